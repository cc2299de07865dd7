"""The second-order part of the initial velocity correction, at a start with dependent rows.

The velocity correction of the text (14.19) makes D v = nu. Away from a singular position
that is all a motion needs. At a start where some rows of D are dependent (a singular
position, e.g. three revolute joints of a loop on one line) D v = nu also admits first-order
*flexes*: velocities that no motion has, because along them the dependent rows turn
independent at once and the constraints are violated at second order. A motion q(t) with
Phi(q(t), t) = 0 needs D a = gamma (the acceleration equation); with the self-stresses w of
D (w^T D = 0, :func:`spatialmbd.rank.self_stresses`) it is solvable only when

    g_k(v) = w_k^T gamma(q, v, t) = 0        for every self-stress w_k,

a condition quadratic in v. A start that violates it is inconsistent: the projection method
removes the flex part at its first projection (an impulse), the multiplier methods withhold
and then apply it over the first moments, and the two describe different motions (6e-3 to
8e-3 m apart after 0.1 s on the regression models of tests/dynamics/data).

This correction removes it once, before any method runs, so that every method starts from the
same consistent state. It keeps D v = nu by moving only within its solutions, v = v_c + N z
(N an orthonormal basis of the null space of D, of the dimension of the mobility plus the
dependent rows: small), and solves g(v_c + N z) = 0 by minimum-norm Newton steps in the metric
of the mass matrix, K = N^T M N: dz = -a K^-1 G^T (G K^-1 G^T)^+ g, G = dg/dz exact from
central differences (gamma is quadratic in v), a in (2, 1, 1/2, ...) the first that reduces
|g| (a = 2 is the projection of v onto the null space of [D; dg/dv], exact for a g homogeneous
in v with a definite form on the flex, e.g. a rigid structure at a singular position; it is
the impulse of a plastic impact with the second-order constraints, which the projection method
applies in the limit of a short first step). Rows that are redundant everywhere (the planar
revolute loops of the N-four-bar) have g = 0 for every D v = nu and leave v unchanged, as does
a velocity along a branch through a bifurcation.
"""
from __future__ import annotations

import numpy as np

from ..rank import null_space, row_rank, self_stresses
from ..state import BodyState

#: |g_k| at most this fraction of the largest size of the terms the g sum (|w_k|^T |gamma|) is
#: round-off
CONSISTENT_RTOL = 1e-12
MAX_ITERATIONS = 30
#: above this many entries of D the analysis (dense rank, null space and mass metric) is not
#: attempted -- the bound of the start's dense mobility analysis (simulate.setup)
DENSE_MAX = 4_000_000


def _dense(D):
    return np.asarray(D.toarray() if hasattr(D, "toarray") else D, dtype=float)


def mass_matrix_inverse(model, q) -> np.ndarray:
    """(6 nb, 6 nb) block-diagonal M^-1 of the velocity coordinates [rdot, omega] (global)."""
    nb = model.nb
    A = BodyState.from_qv(q, None).A[:nb]
    Minv = np.zeros((6 * nb, 6 * nb))
    Jinv = model.inertia_inverse
    for b in range(nb):                # once per run, at the start: not in the per-step path
        Minv[6 * b:6 * b + 3, 6 * b:6 * b + 3] = np.eye(3) / model.mass[b]
        Minv[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = A[b] @ Jinv[b] @ A[b].T
    return Minv


def _inconsistent(asm, q, v, t, W):
    """Columns of W with |w^T gamma| above round-off (|w|^T |gamma| + |w|^T |nu| the size of
    the terms summed). The others -- rows redundant everywhere, whose g vanishes for every
    D v = nu -- are left out of the iteration: their dg/dz is round-off, which the Newton
    steps would otherwise follow."""
    c = asm.evaluate(q, v, t)
    g = W.T @ c.gamma
    size = np.abs(W).T @ np.abs(c.gamma) + np.abs(W).T @ np.abs(c.nu)
    return np.abs(g) > CONSISTENT_RTOL * max(float(size.max()), np.finfo(float).tiny)


def _projection_limit(asm, q, v, t, W, D, keep, Minv, consistent):
    """v projected (mass metric) onto the null space of [D_kept; dg/dv] again and again:
    (v, converged)."""
    w_, U = np.linalg.eigh(Minv)
    Mhalf = (U * np.sqrt(w_)) @ U.T                 # M^-1/2 for the least-squares form
    n = v.size
    for _ in range(MAX_ITERATIONS):
        c = asm.evaluate(q, v, t)
        g = W.T @ c.gamma
        if consistent(g, np.abs(W).T @ np.abs(c.gamma) + np.abs(W).T @ np.abs(c.nu)):
            return v, True
        step = max(float(np.abs(v).max()), 1.0)
        dg = np.empty((W.shape[1], n))
        for j in range(n):             # gamma is quadratic in v: central differences exact
            e = np.zeros(n)
            e[j] = step
            dg[:, j] = (W.T @ (asm.evaluate(q, v + e, t).gamma
                               - asm.evaluate(q, v - e, t).gamma)) / (2.0 * step)
        J = np.vstack([D[keep], dg])
        r = np.concatenate([D[keep] @ v - c.nu[keep], 2.0 * g])
        x = np.linalg.lstsq(J @ Mhalf, r, rcond=1e-10)[0]
        v = v - Mhalf @ x
    return v, False


def remove_flex(model, q, v, t=0.0, hold=None):
    """(v, |g| before, |g| after): v with the second-order inconsistent part removed (see the
    module doc); v unchanged when D has no dependent rows or g(v) is round-off, and for a D
    of more than DENSE_MAX entries (not analysed: such a start keeps D v = nu only).

    q: (nb, 7) assembled; v: (6 nb,) with D v = nu; hold: boolean mask (6 nb,) of
    coordinates not to change, or None."""
    v = np.array(v, dtype=float).reshape(-1)
    asm = model.assembler
    cv = asm.evaluate(q, v, t)
    if cv.D.shape[0] * cv.D.shape[1] > DENSE_MAX:
        return v, 0.0, 0.0          # too large for the dense analysis: D v = nu only
    D = _dense(cv.D)
    if D.size == 0:
        return v, 0.0, 0.0
    rank = row_rank(D)
    if rank.dependent.size == 0:
        return v, 0.0, 0.0
    W = self_stresses(D, rank)                      # (m, k)
    W = W[:, _inconsistent(asm, q, v, t, W)]        # the self-stresses the start violates
    if W.shape[1] == 0:
        return v, 0.0, 0.0

    def residual(vv):
        c = asm.evaluate(q, vv, t)
        g = W.T @ c.gamma
        size = np.abs(W).T @ np.abs(c.gamma) + np.abs(W).T @ np.abs(c.nu)
        return g, size, c

    g, size, _ = residual(v)
    before = float(np.abs(g).max())
    Minv = mass_matrix_inverse(model, q)
    Dn = D if hold is None or not np.any(hold) else np.vstack([D, np.eye(v.size)[hold]])
    N, _ = null_space(Dn)                           # (n, p): v = v_c + N z keeps D v = nu
    if N.shape[1] == 0:
        return v, before, before
    K = N.T @ np.linalg.inv(Minv) @ N                 # the mass metric on z
    Kinv = np.linalg.inv(K)
    tiny = np.finfo(float).tiny

    def consistent(g, size):
        return bool(np.all(np.abs(g) <= CONSISTENT_RTOL * max(float(size.max()), tiny)))

    p = N.shape[1]

    def newton_step(vv, g):
        step = max(float(np.abs(vv).max()), 1.0)
        G = np.empty((g.size, p))
        for j in range(p):             # gamma is quadratic in v: central differences exact
            G[:, j] = (W.T @ (asm.evaluate(q, vv + step * N[:, j], t).gamma
                              - asm.evaluate(q, vv - step * N[:, j], t).gamma)) / (2.0 * step)
        y = np.linalg.lstsq(G @ Kinv @ G.T, g, rcond=1e-12)[0]
        return -N @ (Kinv @ (G.T @ y))

    def iterate(vv, factors):
        for _ in range(MAX_ITERATIONS):
            g, size, _ = residual(vv)
            if consistent(g, size):
                return vv, True
            dv = newton_step(vv, g)
            norm0 = float(np.abs(g).max())
            for a in factors:
                trial = vv + a * dv
                if len(factors) == 1 or float(np.abs(residual(trial)[0]).max()) < norm0:
                    break
            else:
                return vv, False                    # no decrease: the best found
            vv = trial
        return vv, False

    # first the projection method's own limit: v projected onto the null space of [D; dg/dv]
    # again and again (a = 2); where that cycles (on rand2007 it alternates between two
    # residuals), Newton steps shortened until |g| decreases
    v_projected, done = _projection_limit(asm, q, v, t, W, D, rank.independent, Minv,
                                          consistent)
    if done:
        v = v_projected
    else:
        v, _ = iterate(v, (2.0, 1.0, 0.5, 0.25, 0.125))
    g, _, _ = residual(v)
    return v, before, float(np.abs(g).max())
