"""The compiled coordinate projection (14.12, 14.19) that the projection method runs after every
accepted step and the initial-condition correction (:mod:`.correction`) runs once: Newton on
Phi(q, t) = 0 with dx = -D^T (D D^T)^-1 Phi over the kept rows, then the velocities onto
D v = nu, on the sparse Cholesky machinery of the multipliers (:mod:`.algebra`), regularised at
singular positions."""
from __future__ import annotations

import math

from ..jit import array_view, njit
from ..rotations import rotate_p_scalar
from .sparse import SINGULAR_PIVOT, TIKHONOV_SHIFT
from .algebra import (_M, _P, _R, add_transpose_times, body_views, cons_views, copy_v, fill,
                     minv_all, row_times, schur_factor_solve, schur_views, stage_state)  # noqa: E402


@njit
def dd_solve_correction(M, R, P, rhs_rows, bs, lam, dx, use_mass, work):
    """dx = -D^T (D D^T)^-1 r over the kept rows (r = rhs_rows[keep]), or with ``use_mass``
    the correction in the metric of the mass matrix, dx = -M^-1 D^T (D M^-1 D^T)^-1 r;
    regularised at a singular position (:func:`.system.schur_factor_solve`: the components of
    r along the near-dependent rows, which a first-order correction cannot remove, are left
    alone instead of amplified); False if the matrix has no positive definite shift either.
    work: (6 nb,) scratch for the mass-weighted form."""
    keep = P[0]
    for k in range(keep.size):             # the armature rows (keep[k] >= m) are left out
        bs[k] = rhs_rows[keep[k]] if keep[k] < rhs_rows.size else 0.0
    if not schur_factor_solve(M, R, P, use_mass, bs, SINGULAR_PIVOT, TIKHONOV_SHIFT, True):
        return False
    fill(lam, 0.0)
    for k in range(keep.size):
        if keep[k] < lam.size:
            lam[keep[k]] = -bs[k]
    if use_mass:
        fill(work, 0.0)
        add_transpose_times(R, lam, work)
        minv_all(M, work, dx)
    else:
        fill(dx, 0.0)
        add_transpose_times(R, lam, dx)
    return True


@njit(inline="always")
def move_positions(q, dx):
    """q (nb, 7) moved by dx (6 nb: translations, then rotation vectors in global axes), the
    rotations applied exactly (p <- quat(dpi) (x) p)."""
    for b in range(q.shape[0]):
        for c in range(3):
            q[b, c] += dx[6 * b + c]
        pn = rotate_p_scalar((q[b, 3], q[b, 4], q[b, 5], q[b, 6]), dx[6 * b + 3],
                             dx[6 * b + 4], dx[6 * b + 5])
        for c in range(4):
            q[b, 3 + c] = pn[c]


@njit
def project_positions(t, y, F, I, W, tol, max_it, dx_total, use_mass=False):
    """Positions onto Phi(q, t) = 0 by Newton-Raphson, dx = -D^T (D D^T)^-1 Phi (14.12) over
    the kept rows (with ``use_mass`` dx = -M^-1 D^T (D M^-1 D^T)^-1 Phi, the correction of
    least kinetic metric), rotations applied exactly (p <- quat(dpi) (x) p); in place on
    y[:7 nb].

    dx_total (6 nb,) accumulates the corrections. Returns (iterations, max |Phi| before, after);
    iterations = -1 if D D^T is singular, -2 if Newton did not converge in max_it."""
    bo, co, sc = body_views(F, I, W), cons_views(F, I, W), schur_views(F, I, W)
    nb = bo.mass.size
    q = array_view(y, 0, (nb, 7))
    M, R, P = _M(bo), _R(co), _P(sc)
    it = 0
    phi0 = -1.0
    while True:
        stage_state(t, y, 0.0, F, I, W)
        err = 0.0
        for a in range(co.phi.size):
            err = max(err, abs(co.phi[a]))
        if phi0 < 0.0:
            phi0 = err
        if err <= tol:
            return it, phi0, err
        if it == max_it or not math.isfinite(err):
            return -2, phi0, err
        if not dd_solve_correction(M, R, P, co.phi, sc.bs, co.lam, bo.t6, use_mass, bo.u6):
            return -1, phi0, err
        move_positions(q, bo.t6)
        for j in range(6 * nb):
            dx_total[j] += bo.t6[j]
        it += 1


@njit
def _max_residual(R, v, nu):
    out = 0.0
    for a in range(nu.size):
        out = max(out, abs(row_times(R, a, v) - nu[a]))
    return out


@njit
def project_velocities(t, y, F, I, W, use_mass=False):
    """v <- v - D^T (D D^T)^-1 (D v - nu) (14.19) over the kept rows, in place on y (with
    ``use_mass`` v <- v - M^-1 D^T (D M^-1 D^T)^-1 (D v - nu)).

    Returns (ok, max |D v - nu| before, after) (all rows); ok False if D D^T is singular."""
    stage_state(t, y, 0.0, F, I, W)
    return _project_velocities_staged(y, F, I, W, use_mass)


@njit
def _project_velocities_staged(y, F, I, W, use_mass):
    """:func:`project_velocities` with D and nu already evaluated at y's positions (as
    :func:`project_positions` leaves them: its last evaluation is its convergence check)."""
    bo, co, sc = body_views(F, I, W), cons_views(F, I, W), schur_views(F, I, W)
    nb = bo.mass.size
    copy_v(y, bo.v)
    R = _R(co)
    before = _max_residual(R, bo.v, co.nu)
    if co.phi.size == 0:
        return True, 0.0, 0.0
    for a in range(co.rg.size):
        co.rg[a] = row_times(R, a, bo.v) - co.nu[a]
    if not dd_solve_correction(_M(bo), R, _P(sc), co.rg, sc.bs, co.lam, bo.t6, use_mass,
                               bo.u6):
        return False, before, before
    for j in range(6 * nb):
        y[7 * nb + j] += bo.t6[j]
    copy_v(y, bo.v)
    return True, before, _max_residual(R, bo.v, co.nu)


@njit
def project(t, y, F, I, W, tol, max_it, dx_total, use_mass=True):
    """Both projections (the projection method's step), by default in the metric of the mass
    matrix (``use_mass`` False: the text's Euclidean 14.12 and 14.19);
    returns the position iterations, -1 if D M^-1 D^T is singular, -2 if Newton did not
    converge.

    The mass metric (beyond the text's Euclidean 14.12 and 14.19, which the initial-condition
    correction keeps): what the step left inconsistent is removed along M^-1 D^T, the direction
    of a constraint impulse. Where the multipliers were regularised (a singular position), the
    impulse the near-dependent rows did not deliver is exactly of that form, and the projection
    after the position gives it back instead of changing the speed along the mechanism's
    motion -- which in the Euclidean metric put an energy error into every passage."""
    it, phi0, err = project_positions(t, y, F, I, W, tol, max_it, dx_total, use_mass)
    if it < 0:
        return it
    ok, before, after = _project_velocities_staged(y, F, I, W, use_mass)  # D, nu at final q
    return it if ok else -1
