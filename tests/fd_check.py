"""Shared finite-difference checks of constraint kernels (STYLE: testing habit 1).

Along the motion r(t) = r0 + rdot t, A(t) = exp(omega~ t) A0 (constant v, so vdot = 0):
    dPhi/dt   = D v - nu          (7.3)-(7.4)
    d2Phi/dt2 = -gamma            (7.5)-(7.6), gamma including the time terms of drivers
The derivatives are taken by 4th-order central differences.
"""
from __future__ import annotations

import numpy as np

from spatialmbd.constraints import JointGeometry
from spatialmbd.rotations import normalize_p, p_from_rotation_vector, quat_multiply
from spatialmbd.state import BodyState


def random_triads(rng, n):
    Q, _ = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    Q[:, :, 2] = np.cross(Q[:, :, 0], Q[:, :, 1])     # right-handed [u, a, b]
    return Q


def random_geometry(rng, n, n_param=1):
    """Random local geometry of n instances; parameters uniform in [0.5, 2] (n, n_param)."""
    return JointGeometry(s_i=rng.normal(size=(n, 3)), s_j=rng.normal(size=(n, 3)),
                         R_i=random_triads(rng, n), R_j=random_triads(rng, n),
                         param=rng.uniform(0.5, 2.0, size=(n, n_param)))


def random_state(rng, nb):
    q = np.concatenate([rng.normal(size=(nb, 3)), normalize_p(rng.normal(size=(nb, 4)))], axis=1)
    v = rng.normal(size=(nb, 6))
    return q, v


def q_along(q0, v, t):
    """Exact state at time t of the motion with constant rdot and constant global omega."""
    q = q0.copy()
    q[:, :3] += v[:, :3] * t
    q[:, 3:] = quat_multiply(p_from_rotation_vector(v[:, 3:] * t), q0[:, 3:])
    return q


class WrapJump(Exception):
    """The stencil straddles the wrap of a wrapped equation (an angle driver, a screw thread):
    the caller draws another state."""


def derivative_errors(group, q0, v, t0, h=1e-3):
    """(max |Phidot_fd - (D v - nu)|, max |Phiddot_fd + gamma|, scale) over all instances."""
    def phi(dt):
        s = BodyState.from_qv(q_along(q0, v, dt), v, t0 + dt)
        return group.evaluate(s, t0 + dt).phi

    def unwrap(x, ref):   # angle drivers wrap to (-pi, pi]; keep differences continuous
        return ref + np.remainder(x - ref + np.pi, 2 * np.pi) - np.pi

    p0 = phi(0.0)
    pm2, pm1, pp1, pp2 = (unwrap(phi(k * h), p0) for k in (-2, -1, 1, 2))
    steps = np.sort(np.abs(np.diff([pm2, pm1, p0, pp1, pp2], axis=0)), axis=0)
    if np.any(steps[-1] > 10 * steps[1] + 1e-3):   # one step much larger than the others
        raise WrapJump
    d1 = (pm2 - 8 * pm1 + 8 * pp1 - pp2) / (12 * h)
    d2 = (-pm2 + 16 * pm1 - 30 * p0 + 16 * pp1 - pp2) / (12 * h * h)
    state = BodyState.from_qv(q0, v, t0)
    ev = group.evaluate(state, t0)
    vij = np.concatenate([state.rdot[group.body_i], state.omega[group.body_i],
                          state.rdot[group.body_j], state.omega[group.body_j]], axis=1)
    Dv = np.einsum("nmk,nk->nm", ev.D, vij)
    e1 = np.abs(d1 - (Dv - ev.nu)).max()
    e2 = np.abs(d2 + ev.gamma).max()
    scale = max(1.0, np.abs(d2).max())
    return e1, e2, scale
