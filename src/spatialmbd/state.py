"""Kinematic state of all bodies, computed once per evaluation and shared by every kernel.

Coordinates (text ch. 6):
    q: (nb, 7) per body [r (3), p (4)]  -- r: centre-of-mass position (m), p: Euler parameters
    v: (nb, 6) per body [rdot (3), omega (3)] -- omega in global components (rad/s)
Flattened forms q (7 nb,) and v (6 nb,) are used by the solvers.

The ground is appended as an extra body with index ``nb`` (r = 0, A = I, v = 0), so that kernels
can gather ``body_i``/``body_j`` indices without branching; its Jacobian columns are dropped at
assembly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .jit import njit
from .rotations import A_into, pdot_scalar

#: the names of a body's seven coordinates (q) and six velocity components (v), in the order of
#: the arrays: model files, drivers, result columns and sensitivities all use these
#: (:mod:`spatialmbd.outputs.vocabulary` adds what they are and their units)
POSITION_NAMES = ("x", "y", "z", "e0", "e1", "e2", "e3")
VELOCITY_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")


@dataclass
class BodyState:
    """Positions, rotation matrices and velocities of the bodies plus the ground (last row).

    r: (nb+1, 3) m; A: (nb+1, 3, 3); rdot: (nb+1, 3) m/s; omega: (nb+1, 3) rad/s (global);
    p: (nb+1, 4) Euler parameters.
    """

    r: np.ndarray
    A: np.ndarray
    rdot: np.ndarray
    omega: np.ndarray
    p: np.ndarray
    t: float = 0.0

    @classmethod
    def empty(cls, nb: int) -> "BodyState":
        return cls(r=np.empty((nb + 1, 3)), A=np.empty((nb + 1, 3, 3)),
                   rdot=np.empty((nb + 1, 3)), omega=np.empty((nb + 1, 3)),
                   p=np.empty((nb + 1, 4)))

    @classmethod
    def from_qv(cls, q: np.ndarray, v: np.ndarray | None, t: float = 0.0) -> "BodyState":
        """q: (nb, 7) or (7 nb,); v: (nb, 6) or (6 nb,) or None (zero velocities)."""
        q = np.ascontiguousarray(q, dtype=float).reshape(-1, 7)
        nb = q.shape[0]
        v = (np.zeros((nb, 6)) if v is None
             else np.ascontiguousarray(v, dtype=float).reshape(nb, 6))
        state = cls.empty(nb)
        state_into(q, v, False, state.r, state.A, state.rdot, state.omega, state.p)
        state.t = t
        return state

    def arrays(self):
        """(r, A, rdot, omega, p): the tuple the compiled kernels take."""
        return (self.r, self.A, self.rdot, self.omega, self.p)


@njit
def state_into(q, v, normalize, r, A, rdot, omega, p):
    """Fill the state arrays (ground appended: r = 0, p = (1, 0, 0, 0), v = 0) from q (nb, 7)
    and v (nb, 6); with ``normalize`` every p is divided by its length first."""
    nb = q.shape[0]
    for b in range(nb + 1):
        if b < nb:
            e0, e1, e2, e3 = q[b, 3], q[b, 4], q[b, 5], q[b, 6]
            if normalize:
                n = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
                e0, e1, e2, e3 = e0 / n, e1 / n, e2 / n, e3 / n
            for c in range(3):
                r[b, c] = q[b, c]
                rdot[b, c] = v[b, c]
                omega[b, c] = v[b, 3 + c]
        else:
            e0, e1, e2, e3 = 1.0, 0.0, 0.0, 0.0
            for c in range(3):
                r[b, c] = 0.0
                rdot[b, c] = 0.0
                omega[b, c] = 0.0
        p[b, 0], p[b, 1], p[b, 2], p[b, 3] = e0, e1, e2, e3
        A_into(p, b, A)


@njit
def qdot_into(p, omega, rdot, qd):
    """qdot = T(q) v for the bodies (not the ground): rdot as is, pdot = 1/2 G^T omega (5.12)."""
    for b in range(qd.shape[0]):
        pd = pdot_scalar((p[b, 0], p[b, 1], p[b, 2], p[b, 3]),
                         (omega[b, 0], omega[b, 1], omega[b, 2]))
        for c in range(3):
            qd[b, c] = rdot[b, c]
        for c in range(4):
            qd[b, 3 + c] = pd[c]


def qdot_from_v(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """qdot = T(q) v: rdot as is and pdot = 1/2 G^T omega, Eq. (5.12).

    q: (nb, 7) or flat, v: (nb, 6) or flat -> same layout as q.
    """
    shape = np.shape(q)
    q = np.ascontiguousarray(q, dtype=float).reshape(-1, 7)
    v = np.ascontiguousarray(v, dtype=float).reshape(-1, 6)
    qd = np.empty_like(q)
    qdot_into(np.ascontiguousarray(q[:, 3:]), np.ascontiguousarray(v[:, 3:]),
              np.ascontiguousarray(v[:, :3]), qd)
    return qd.reshape(shape)


def normalize_q(q: np.ndarray) -> np.ndarray:
    """A copy of q with every body's Euler parameters scaled to unit length."""
    shape = np.shape(q)
    q = np.array(q, dtype=float).reshape(-1, 7)
    q[:, 3:] /= np.linalg.norm(q[:, 3:], axis=1, keepdims=True)
    return q.reshape(shape)
