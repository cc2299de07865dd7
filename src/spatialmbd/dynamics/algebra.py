"""The compiled algebra of one right-hand-side evaluation in body coordinates, shared by the
methods: the body terms (10.4, 10.6, 11.1), the stage that evaluates the state, forces and
constraint groups, the block-diagonal mass products, the rows of D as 12-blocks, the Schur
complement S = D M^-1 D^T (12.5) assembled into its fixed sparse pattern with its factorisation
and solves (regularised at singular positions, :mod:`.sparse`), the multiplier solve (12.4,
12.5), Baumgarte's right-hand side (12.8) and the ydot writer. :mod:`.system` packs a model
into the flat arrays these functions take (:class:`.system.System`).
"""
from __future__ import annotations

import math

import numpy as np

from ..constraints.kernels import JointRows, evaluate_instances
from ..forces.armature import armature_rows
from ..forces.kernels import STATE_WIDTH, evaluate_forces
from ..jit import array_view, njit
from ..state import qdot_into, state_into
from . import sparse as spc


# --------------------------------------------------------------------------------- layout
# The packed buffers and their compiled views are declared once, in :mod:`.layout`.
from .layout import (FIELDS, KFIELDS, body_views, cons_views, field_view, force_views,  # noqa: F401
                     pack, schur_views)


# --------------------------------------------------------------------------------- helpers
# Only the entry points (called from Python) make the views bo, co, sc (Body, Cons, Schur); the
# helpers take the arrays they need, in small tuples:  M = (mass, J, Jinv),  R = (D, row_bi,
# row_bj) -- the rows of D as 12-blocks over the columns of their two bodies --, and P, the
# pattern and work arrays of S (see :func:`_P`). (Numba passes a tuple as all of its fields, so
# big tuples make calls slow and compilation slower.)
@njit(inline="always")
def fill(a, value):
    for k in range(a.size):
        a[k] = value


@njit(inline="always")
def copy(dst, src):
    for k in range(src.size):
        dst[k] = src[k]


@njit(inline="always")
def finite(x):
    for k in range(x.size):
        if not math.isfinite(x[k]):
            return False
    return True


@njit(inline="always")
def _M(bo):
    return (bo.mass, bo.J, bo.Jinv)


@njit(inline="always")
def _R(co):
    """The rows of the solves: the constraint rows, then the armature rows (their number is
    that of P[12]); a loop over lam, gamma or rg of the model sees the constraint rows only."""
    return (co.D_all, co.row_bi_all, co.row_bj_all)


@njit(inline="always")
def _P(sc):
    return (sc.keep, sc.inc_ptr, sc.inc_row, sc.inc_side, sc.pair_ptr, sc.pair_pos, sc.wk, sc.Cx,
            sc.Lx, sc.xs, sc.ys,
            (sc.S_Cp, sc.S_Ci, sc.S_Lp, sc.S_Li, sc.S_Rp, sc.S_Rj, sc.S_Rpos, sc.S_perm),
            sc.arm_diag, sc.armature)


# --------------------------------------------------------------------------------- bodies
@njit(inline="always")
def congruence(A, X, b, out):
    """out[b] = A[b] X[b] A[b]^T for 3 x 3 blocks (X symmetric)."""
    for a in range(3):
        t0 = A[b, a, 0] * X[b, 0, 0] + A[b, a, 1] * X[b, 1, 0] + A[b, a, 2] * X[b, 2, 0]
        t1 = A[b, a, 0] * X[b, 0, 1] + A[b, a, 1] * X[b, 1, 1] + A[b, a, 2] * X[b, 2, 1]
        t2 = A[b, a, 0] * X[b, 0, 2] + A[b, a, 1] * X[b, 1, 2] + A[b, a, 2] * X[b, 2, 2]
        for c in range(3):
            out[b, a, c] = t0 * A[b, c, 0] + t1 * A[b, c, 1] + t2 * A[b, c, 2]


@njit
def body_terms(A, omega, Jl, Jl_inv, weight, J, Jinv, g, inverse=True):
    """J = A J' A^T and (inverse) its inverse (10.6); g = [m gravity (11.1), -omega~ J omega
    (10.4)]."""
    for b in range(J.shape[0]):
        congruence(A, Jl, b, J)
        if inverse:
            congruence(A, Jl_inv, b, Jinv)
        w0, w1, w2 = omega[b, 0], omega[b, 1], omega[b, 2]
        h0 = J[b, 0, 0] * w0 + J[b, 0, 1] * w1 + J[b, 0, 2] * w2
        h1 = J[b, 1, 0] * w0 + J[b, 1, 1] * w1 + J[b, 1, 2] * w2
        h2 = J[b, 2, 0] * w0 + J[b, 2, 1] * w1 + J[b, 2, 2] * w2
        o = 6 * b
        g[o], g[o + 1], g[o + 2] = weight[b, 0], weight[b, 1], weight[b, 2]
        g[o + 3] = -(w1 * h2 - w2 * h1)
        g[o + 4] = -(w2 * h0 - w0 * h2)
        g[o + 5] = -(w0 * h1 - w1 * h0)


@njit
def stage_state(t, y, normalize, F, I, W):
    """State, mass matrix, g and the compiled constraints at (t, y) (y = [q (7 nb), v, ...]).

    normalize (a float, 1.0 or 0.0): use p / |p|. Returns False if g is not finite."""
    bo = body_views(F, I, W)
    fo = force_views(F, I, W)
    co = cons_views(F, I, W)
    _state(t, y, normalize, bo, co)
    _force_states_in(y, bo.mass.size, fo)
    _forces(bo, fo)
    if co.arm_k.size:                     # the armature rows B, gamma_B (forces.armature)
        armature_rows((bo.r, bo.A, bo.rdot, bo.omega, bo.p),
                      JointRows(fo.fbi, fo.fbj, fo.fs_i, fo.fs_j, fo.fR_i, fo.fR_j, fo.fparam,
                                fo.flaw, fo.fcoord),
                      co.arm_k, co.D_all, co.gamma_all, co.rg_all, co.phi.size)
    return finite(bo.g)


@njit(inline="always")
def _force_states_in(y, nb, fo):
    """The force elements' internal states z (y = [q, v, z, work]) into their law columns 3:
    (forces.kernels); a y without them (13 nb long: an evaluation at a given q, v) leaves what
    was set there (:meth:`System.set_force_states`)."""
    base = 13 * nb
    for k in range(fo.fcoord.size):
        o = fo.fcoord[k]
        if o >= 0 and base + o + STATE_WIDTH < y.size:
            for c in range(STATE_WIDTH):
                fo.flaw[k, 3 + c] = y[base + o + c]


@njit(inline="always")
def _force_states_out(nb, fo, ydot):
    """Their rates z', which the kernels left in the same columns, into ydot."""
    base = 13 * nb
    for k in range(fo.fcoord.size):
        o = fo.fcoord[k]
        if o >= 0 and base + o + STATE_WIDTH < ydot.size:
            for c in range(STATE_WIDTH):
                ydot[base + o + c] = fo.flaw[k, 3 + c]


@njit(inline="always")
def _forces(bo, fo):
    """The compiled force elements into g, with the total power of their non-conservative
    parts into g_power (one evaluation gives force, energy and power)."""
    bo.g_power[0] = 0.0
    if fo.fkind.size:
        S = (bo.r, bo.A, bo.rdot, bo.omega, bo.p)
        G = JointRows(fo.fbi, fo.fbj, fo.fs_i, fo.fs_j, fo.fR_i, fo.fR_j, fo.fparam, fo.flaw,
                      fo.fcoord)
        evaluate_forces(fo.fkind, S, G, bo.g, fo.fenergy, fo.fpower, fo.fscratch)
        total = 0.0
        for k in range(fo.fpower.size):
            total += fo.fpower[k]
        bo.g_power[0] = total


@njit(inline="always")
def _state(t, y, normalize, bo, co):
    nb = bo.mass.size
    q = array_view(y, 0, (nb, 7))
    v = array_view(y, 7 * nb, (nb, 6))
    state_into(q, v, normalize != 0.0, bo.r, bo.A, bo.rdot, bo.omega, bo.p)
    body_terms(bo.A, bo.omega, bo.Jl, bo.Jl_inv, bo.weight, bo.J, bo.Jinv, bo.g)
    S = (bo.r, bo.A, bo.rdot, bo.omega, bo.p)
    G = JointRows(co.bi, co.bj, co.s_i, co.s_j, co.R_i, co.R_j, co.param, co.law, co.coord)
    evaluate_instances(co.kind, S, G, co.rows, (co.phi, co.D, co.nu, co.gamma))


@njit(inline="always")
def block_apply(m, J, b, f, fo, out, oo, inverse):
    """out[oo:oo+6] = M_b f[fo:fo+6] = [m f_r, J f_w], or M_b^-1 f = [f_r / m, J^-1 f_w] with
    ``inverse`` (J then holds the inverse inertia J^-1 = A J'^-1 A^T): M is block diagonal,
    blocks diag(m I, J) (10.6), and is never formed."""
    for a in range(3):
        out[oo + a] = f[fo + a] / m[b] if inverse else f[fo + a] * m[b]
    for a in range(3):
        out[oo + 3 + a] = J[b, a, 0] * f[fo + 3] + J[b, a, 1] * f[fo + 4] + J[b, a, 2] * f[fo + 5]


@njit(inline="always")
def minv_all(M, f, out):
    """out = M^-1 f (6 nb,)."""
    mass, J, Jinv = M
    for b in range(mass.size):
        block_apply(mass, Jinv, b, f, 6 * b, out, 6 * b, True)


@njit(inline="always")
def m_all(M, f, out):
    """out = M f (6 nb,)."""
    mass, J, Jinv = M
    for b in range(mass.size):
        block_apply(mass, J, b, f, 6 * b, out, 6 * b, False)


@njit
def mass_apply(mass, J, x, out, inverse):
    """out[:, k] = M x[:, k] (or M^-1 x[:, k]) for x (6 nb, ncol)."""
    for k in range(x.shape[1]):
        col = np.ascontiguousarray(x[:, k])
        res = np.empty_like(col)
        for b in range(mass.size):
            block_apply(mass, J, b, col, 6 * b, res, 6 * b, inverse)
        out[:, k] = res


@njit(inline="always")
def row_times(R, a, x):
    """(D x)[a] for x in velocity space (6 nb,)."""
    D, row_bi, row_bj = R
    nb = x.size // 6
    acc = 0.0
    bi, bj = row_bi[a], row_bj[a]
    if bi < nb:
        for c in range(6):
            acc += D[a, c] * x[6 * bi + c]
    if bj < nb:
        for c in range(6):
            acc += D[a, 6 + c] * x[6 * bj + c]
    return acc


@njit(inline="always")
def add_transpose_times(R, lam, out):
    """out += D^T lam (lam over all m rows)."""
    D, row_bi, row_bj = R
    nb = out.size // 6
    for a in range(lam.size):
        la = lam[a]
        if la == 0.0:
            continue
        bi, bj = row_bi[a], row_bj[a]
        if bi < nb:
            for c in range(6):
                out[6 * bi + c] += D[a, c] * la
        if bj < nb:
            for c in range(6):
                out[6 * bj + c] += D[a, 6 + c] * la


# --------------------------------------------------------------------------------- S = D W D^T
@njit(inline="always")
def assemble_schur(M, R, P, use_mass, rows_only=False):
    """Cx = values of S = D M^-1 D^T (use_mass) or D D^T over the kept rows, body by body:
    S = sum_b D_b W_b D_b^T with D_b the columns of body b. wk (rows incident to the body,
    12): the row of D_b (columns 6..11) and of D_b M_b^-1 (0..5), gathered once per body so
    that the pairs below are 6-term products of contiguous rows.

    The armature rows (the last P[12].size rows of D, forces.armature) add their compliance
    1 / J to their diagonal in S; D D^T (the projections, the rank decisions) and, with
    ``rows_only``, D M^-1 D^T (the projection in the mass metric) leave them out: their rows
    count as zero there, with 1 on their diagonal."""
    mass, J, Jinv = M
    D = R[0]
    keep, inc_ptr, inc_row, inc_side, pair_ptr, pair_pos, wk, Cx = P[:8]
    arm_diag, armature = P[12], P[13]
    m_con = D.shape[0] - arm_diag.size
    fill(Cx, 0.0)
    for b in range(mass.size):
        p0, p1 = inc_ptr[b], inc_ptr[b + 1]
        for t in range(p0, p1):
            a = keep[inc_row[t]]
            c0 = 6 * inc_side[t]
            w = wk[t - p0]
            scale = 0.0 if a >= m_con and (rows_only or not use_mass) else 1.0
            for c in range(6):
                w[6 + c] = scale * D[a, c0 + c]
            if use_mass:                        # a row of D M^-1 (M^-1 is symmetric)
                block_apply(mass, Jinv, b, w, 6, w, 0, True)
            else:
                for c in range(6):
                    w[c] = w[6 + c]
        q = pair_ptr[b]
        for ta in range(p1 - p0):
            wa = wk[ta]
            for tc in range(ta, p1 - p0):
                wc = wk[tc]
                Cx[pair_pos[q]] += (wa[0] * wc[6] + wa[1] * wc[7] + wa[2] * wc[8]
                                    + wa[3] * wc[9] + wa[4] * wc[10] + wa[5] * wc[11])
                q += 1
    for a in range(arm_diag.size):
        if use_mass and not rows_only:
            Cx[arm_diag[a]] += 1.0 / armature[a]        # B M^-1 B^T + 1 / J
        else:
            Cx[arm_diag[a]] = 1.0


@njit(inline="always")
def schur_factor_solve(M, R, P, use_mass, b, pivot=spc.SINGULAR_PIVOT,
                       shift=spc.TIKHONOV_SHIFT, rows_only=False):
    """b <- S^-1 b (or (D D^T)^-1 b): assemble, factorise and solve. Where S is nearly singular
    (a pivot below ``pivot`` of its diagonal, default :data:`.sparse.SINGULAR_PIVOT`: a
    singular position) the regularised solve of :func:`.sparse.solve_regularised` (relative
    shift ``shift``) is used instead -- bounded, minimum-norm-like multipliers, and
    accelerations continuous through the singular position, decided by compiled arithmetic that
    is the same on every processor. False if S has no positive definite shift either."""
    assemble_schur(M, R, P, use_mass, rows_only)
    ratio = spc.numeric_ratio(P[11], P[7], P[8], P[9])
    if ratio > pivot:
        spc.solve(P[11], P[8], b, P[10])
        return True
    return spc.solve_regularised(P[11], P[7], P[8], P[9], P[10], b, shift)


@njit(inline="always")
def finish(M, R, g, lam, t6, vdot):
    """vdot = M^-1 (g + D^T lam), Eq. (12.4)."""
    copy(t6, g)
    add_transpose_times(R, lam, t6)
    minv_all(M, t6, vdot)


@njit(inline="always")
def baumgarte_rhs(R, gamma, phi, nu, v, mode, alpha, beta, rg):
    """rg = gamma (mode 0) or gamma - 2 alpha Phidot - beta^2 Phi (mode 1, Eq. 12.8),
    Phidot = D v - nu."""
    if mode == 0:
        copy(rg, gamma)
        return
    for a in range(gamma.size):
        phidot = row_times(R, a, v) - nu[a]
        rg[a] = gamma[a] - 2.0 * alpha * phidot - beta * beta * phi[a]


@njit(inline="always")
def solve_multipliers(M, R, P, g, rg, lam, bs, t6, u6, vdot, pivot=spc.SINGULAR_PIVOT,
                      shift=spc.TIKHONOV_SHIFT):
    """lam = S^-1 (rg - D M^-1 g) over the kept rows (12.5) and vdot (12.4), regularised below
    the pivot ratio ``pivot`` (:func:`schur_factor_solve`); False if S is singular (bs then
    holds the right-hand side and Cx the values of S for a fallback).

    rg, lam: over all rows of R (co.rg_all, co.lam_all): with armatures, the rows B v' +
    mu / J = gamma_B follow the constraint rows and vdot = M^-1 (g + D^T lam + B^T mu)."""
    keep = P[0]
    fill(lam, 0.0)
    if keep.size:
        minv_all(M, g, u6)
        for k in range(keep.size):
            bs[k] = rg[keep[k]] - row_times(R, keep[k], u6)
        if not schur_factor_solve(M, R, P, True, bs, pivot, shift):
            return False
        for k in range(keep.size):
            lam[keep[k]] = bs[k]
    finish(M, R, g, lam, t6, vdot)
    return True


@njit(inline="always")
def copy_v(y, v):
    for k in range(v.size):
        v[k] = y[7 * (v.size // 6) + k]


@njit(inline="always")
def write_ydot(p, omega, rdot, vdot, lam, nu, drv, g_power, ydot):
    """ydot = [qdot (5.12), vdot, (the force states' rates, written by _write_ydot), power of
    the drivers lam^T nu and of the compiled force elements' non-conservative parts (last)]."""
    nb = vdot.size // 6
    qdot_into(p, omega, rdot, array_view(ydot, 0, (nb, 7)))
    for j in range(6 * nb):
        ydot[7 * nb + j] = vdot[j]
    power = g_power[0]
    for k in range(drv.size):
        power += lam[drv[k]] * nu[drv[k]]
    if ydot.size > 13 * nb:
        ydot[ydot.size - 1] = power


@njit(inline="always")
def _write_ydot(bo, co, fo, ydot):
    write_ydot(bo.p, bo.omega, bo.rdot, bo.vdot, co.lam, co.nu, co.drv, bo.g_power, ydot)
    _force_states_out(bo.mass.size, fo, ydot)


#: status codes of the compiled right-hand sides (>= 0: success; the augmented Lagrangian
#: returns its number of iterations)
OK, SINGULAR, NOT_FINITE, NOT_CONVERGED = 0, -1, -2, -3

#: the parameter array ``mp`` of the standard / Baumgarte right-hand side
MP_STANDARD = ("normalize", "mode", "alpha", "beta", "singular_pivot", "tikhonov_shift")


#: the parameter array ``mp`` of the penalty / augmented Lagrangian right-hand side
MP_PENALTY = ("normalize", "alpha", "omega", "mu", "iterate", "tolerance", "max_iterations",
              "floor")


# --------------------------------------------------------------------------------- projection


@njit
def normalize_y(y, nb):
    """Every body's Euler parameters in y = [q, ...] scaled to unit length, in place."""
    for b in range(nb):
        o = 7 * b + 3
        n = math.sqrt(y[o] ** 2 + y[o + 1] ** 2 + y[o + 2] ** 2 + y[o + 3] ** 2)
        for c in range(4):
            y[o + c] /= n


@njit
def dependent_rows(F, I, W, drop_tol, dropped):
    """Factorise D D^T (kept rows) of the evaluation in W leaving out the rows that depend on
    earlier ones (:func:`.sparse.factor`); dropped[k] = 1 marks them (in elimination order).
    Returns their number."""
    bo, co, sc = body_views(F, I, W), cons_views(F, I, W), schur_views(F, I, W)
    if sc.keep.size == 0:
        return 0
    P = _P(sc)
    assemble_schur(_M(bo), _R(co), P, False)
    return spc.factor(P[11], sc.Cx, sc.Lx, sc.xs, drop_tol, dropped)
