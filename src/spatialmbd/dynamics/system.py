"""The compiled equations of motion of a model: one call per right-hand-side evaluation.

:class:`System` packs everything an evaluation needs into three flat arrays -- ``F`` (model
floats), ``I`` (integers: the header, topology, sparsity patterns) and ``W`` (the work arrays
of one evaluation) -- because a compiled call pays about 0.1 us per array argument; inside
the compiled code :func:`body_views`, :func:`cons_views` and :func:`schur_views` turn them back
into named views (the namedtuples :data:`Body`, :data:`Cons`, :data:`Schur`). Per evaluation,
with no Python loop over bodies or joints:

* :func:`stage_state`: p / |p|, A(p) (4.13), J = A J' A^T and its inverse (10.6), gravity and
  the gyroscopic term -omega~ J omega (10.4), and every compiled constraint group
  (:func:`..constraints.kernels.evaluate_instances`) into Phi, D (m, 12 blocks), nu, gamma;
* the method's linear algebra, all O(N) for tree topologies (a chain):
  :func:`solve_multipliers` -- S = D M^-1 D^T (12.5) assembled body by body into a fixed
  sparse pattern, sparse Cholesky with a fill-reducing ordering (:mod:`.sparse`), then
  vdot = M^-1 (g + D^T lam) (12.4); the penalty solve -- M + alpha D^T D (12.14) and the
  augmented Lagrangian iteration (12.17); the projection -- the corrections of chapter 14
  with D D^T;
* each method's compiled right-hand side fuses it all with qdot = T(q) v (5.12): it lives next
  to the method's class (``standard.rhs_standard`` / ``stages_standard``,
  ``penalty.rhs_penalty`` / ``stages_penalty``, ``projection.project``); this module holds
  what they share (the stage, the structured solves, the packed buffers, :class:`System`).

Force elements and constraint types without a compiled kernel are evaluated in Python between
the two stages (they see the state through :attr:`System.state`).

The matrix D never exists as such: row a of D holds 12 numbers, the columns of its bodies
body_i = row_bi[a] and body_j = row_bj[a] (the ground, index nb, is skipped).
"""
from __future__ import annotations

import copy as copy_module
import math

import numpy as np

from ..constraints.kernels import JointRows, JointTable, evaluate_instances
from ..forces.kernels import ForceTable, evaluate_forces
from ..jit import array_view, njit
from ..state import BodyState, qdot_into, state_into
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
    return (co.D, co.row_bi, co.row_bj)


@njit(inline="always")
def _P(sc):
    return (sc.keep, sc.inc_ptr, sc.inc_row, sc.inc_side, sc.pair_ptr, sc.pair_pos, sc.wk, sc.Cx,
            sc.Lx, sc.xs, sc.ys,
            (sc.S_Cp, sc.S_Ci, sc.S_Lp, sc.S_Li, sc.S_Rp, sc.S_Rj, sc.S_Rpos, sc.S_perm))


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
    _state(t, y, normalize, bo, cons_views(F, I, W))
    _force_states_in(y, bo.mass.size, fo)
    _forces(bo, fo)
    return finite(bo.g)


@njit(inline="always")
def _force_states_in(y, nb, fo):
    """The force elements' internal states z (y = [q, v, z, work]) into their law columns 3:
    (forces.kernels); a y without them (13 nb long: an evaluation at a given q, v) leaves what
    was set there (:meth:`System.set_force_states`)."""
    base = 13 * nb
    for k in range(fo.fcoord.size):
        o = fo.fcoord[k]
        if o >= 0 and base + o + 3 < y.size:
            for c in range(3):
                fo.flaw[k, 3 + c] = y[base + o + c]


@njit(inline="always")
def _force_states_out(nb, fo, ydot):
    """Their rates z', which the kernels left in the same columns, into ydot."""
    base = 13 * nb
    for k in range(fo.fcoord.size):
        o = fo.fcoord[k]
        if o >= 0 and base + o + 3 < ydot.size:
            for c in range(3):
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
def assemble_schur(M, R, P, use_mass):
    """Cx = values of S = D M^-1 D^T (use_mass) or D D^T over the kept rows, body by body:
    S = sum_b D_b W_b D_b^T with D_b the columns of body b. wk (rows incident to the body,
    12): the row of D_b (columns 6..11) and of D_b M_b^-1 (0..5), gathered once per body so
    that the pairs below are 6-term products of contiguous rows."""
    mass, J, Jinv = M
    D = R[0]
    keep, inc_ptr, inc_row, inc_side, pair_ptr, pair_pos, wk, Cx = P[:8]
    fill(Cx, 0.0)
    for b in range(mass.size):
        p0, p1 = inc_ptr[b], inc_ptr[b + 1]
        for t in range(p0, p1):
            a = keep[inc_row[t]]
            c0 = 6 * inc_side[t]
            w = wk[t - p0]
            for c in range(6):
                w[6 + c] = D[a, c0 + c]
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


@njit(inline="always")
def schur_factor(M, R, P, use_mass):
    """Assemble and factorise S (or D D^T); False if it is not positive definite."""
    assemble_schur(M, R, P, use_mass)
    return spc.numeric(P[11], P[7], P[8], P[9])


@njit(inline="always")
def schur_factor_solve(M, R, P, use_mass, b):
    """b <- S^-1 b (or (D D^T)^-1 b): assemble, factorise and solve. Where S is nearly singular
    (a pivot below :data:`.sparse.SINGULAR_PIVOT` of its diagonal: a singular position) the
    regularised solve of :func:`.sparse.solve_regularised` is used instead -- bounded, minimum-
    norm-like multipliers, and accelerations continuous through the singular position, decided
    by compiled arithmetic that is the same on every processor. False if S has no positive
    definite shift either."""
    assemble_schur(M, R, P, use_mass)
    ratio = spc.numeric_ratio(P[11], P[7], P[8], P[9])
    if ratio > spc.SINGULAR_PIVOT:
        spc.solve(P[11], P[8], b, P[10])
        return True
    return spc.solve_regularised(P[11], P[7], P[8], P[9], P[10], b)


@njit(inline="always")
def schur_solve(P, b):
    """b <- S^-1 b with the factor of :func:`schur_factor`."""
    spc.solve(P[11], P[8], b, P[10])


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
def solve_multipliers(M, R, P, g, rg, lam, bs, t6, u6, vdot):
    """lam = S^-1 (rg - D M^-1 g) over the kept rows (12.5) and vdot (12.4); False if S is
    singular (bs then holds the right-hand side and Cx the values of S for a fallback)."""
    keep = P[0]
    fill(lam, 0.0)
    if keep.size:
        minv_all(M, g, u6)
        for k in range(keep.size):
            bs[k] = rg[keep[k]] - row_times(R, keep[k], u6)
        if not schur_factor_solve(M, R, P, True, bs):
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
MP_STANDARD = ("normalize", "mode", "alpha", "beta")


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


# --------------------------------------------------------------------------------- Python side
class System:
    """Packed model, topology, sparsity patterns and work arrays of one model.

    keep: the constraint rows used in the multiplier and projection solves (default all; the
    redundant rows found by the mobility analysis are left out).
    """

    def __init__(self, model, keep=None):
        self.model = model
        nb = self.nb = model.nb
        m = self.m = model.n_eq
        groups, offsets = model.constraint_groups, model.group_offsets
        self.table = table = JointTable(groups, offsets)
        self.python_groups = [(g, off) for g, off in zip(groups, offsets) if not g.compiled]
        row_bi = np.empty(m, dtype=np.int64)
        row_bj = np.empty(m, dtype=np.int64)
        drv = []
        for g, off in zip(groups, offsets):
            row_bi[off:off + g.size] = np.repeat(g.body_i, g.n_eq)
            row_bj[off:off + g.size] = np.repeat(g.body_j, g.n_eq)
            if g.rheonomic:
                drv.extend(range(off, off + g.size))
        self.row_bi, self.row_bj = row_bi, row_bj
        self.driver_rows = np.array(drv, dtype=np.int64)
        keep = np.arange(m, dtype=np.int64) if keep is None else np.asarray(keep, np.int64)
        self.keep = keep
        inc = self._incidence(keep)
        G = table.G
        self.force_table = ft = ForceTable(model.force_groups)
        self.python_forces = [g for g in model.force_groups if not g.compiled]
        Gf = ft.G
        arrays = dict(
            fkind=ft.kind, fbi=Gf.bi, fbj=Gf.bj, fs_i=Gf.s_i, fs_j=Gf.s_j, fR_i=Gf.R_i,
            fR_j=Gf.R_j, fparam=Gf.param, fcoord=Gf.coord, flaw=ft.law, fenergy=np.zeros(ft.n),
            fpower=np.zeros(ft.n), fscratch=np.zeros((1, 12)), g_power=np.zeros(1),
            mass=model.mass, Jl=model.inertia, Jl_inv=model.inertia_inverse,
            weight=model.mass[:, None] * model.gravity[None, :],
            s_i=G.s_i, s_j=G.s_j, R_i=G.R_i, R_j=G.R_j, param=G.param,
            kind=table.kind, rows=table.rows, bi=G[0], bj=G[1], coord=G[8],
            row_bi=row_bi, row_bj=row_bj, keep=keep, drv=self.driver_rows, **inc,
            S_Cp=self.S.Cp, S_Ci=self.S.Ci, S_Lp=self.S.Lp, S_Li=self.S.Li, S_Rp=self.S.Rp,
            S_Rj=self.S.Rj, S_Rpos=self.S.Rpos, S_perm=self.S.perm,
            r=np.zeros((nb + 1, 3)), A=np.zeros((nb + 1, 3, 3)), rdot=np.zeros((nb + 1, 3)),
            omega=np.zeros((nb + 1, 3)), p=np.zeros((nb + 1, 4)), J=np.zeros((nb, 3, 3)),
            Jinv=np.zeros((nb, 3, 3)), g=np.zeros(6 * nb), phi=np.zeros(m),
            D=np.zeros((m, 12)), nu=np.zeros(m), gamma=np.zeros(m), law=np.zeros((G[0].size, 3)),
            lam=np.zeros(m), vdot=np.zeros(6 * nb), rg=np.zeros(m), t6=np.zeros(6 * nb),
            u6=np.zeros(6 * nb),
            wk=np.zeros((max(1, int(np.diff(inc["inc_ptr"]).max(initial=0))), 12)),
            Cx=np.zeros(self.S.Ci.size), Lx=np.zeros(self.S.nnz_L), xs=np.zeros(keep.size),
            ys=np.zeros(keep.size), bs=np.zeros(keep.size), q=np.zeros((nb, 7)),
            v=np.zeros(6 * nb))
        self.F, self.I, self.W = pack(FIELDS, arrays)
        self._layout = {name: (int(self.I[4 * k]), int(np.asarray(arrays[name]).size),
                               np.asarray(arrays[name]).shape)
                        for k, (name, buf, _) in enumerate(FIELDS) if buf == "W"}
        self._kpack = None
        self._kshared = [None]                # the penalty pack, shared with the clones
        self.fused = not self.python_groups and not self.python_forces
        self._bind()

    def _bind(self):
        """The Python-side views of W (and the drivers' law table into W)."""
        w = lambda name: self.fields(None, name)  # noqa: E731
        self.law = w("law")
        table = copy_module.copy(self.table)
        table.law = self.law                  # drivers write their (f, f', f'') here
        table.G = table.G._replace(law=self.law)
        self.flaw = w("flaw")                 # the force elements' laws, likewise
        if self.force_table.has_laws:
            flaw, forces = self.flaw, self.force_table
            table.also_set = [lambda t: forces.set_time(t, flaw)]
            table.has_drivers = True
        self.table = table
        self.state = BodyState(r=w("r"), A=w("A"), rdot=w("rdot"), omega=w("omega"),
                               p=w("p"))
        self.g = w("g")
        self.phi, self.D, self.nu, self.gamma = w("phi"), w("D"), w("nu"), w("gamma")
        self.lam, self.vdot, self.bs, self.Cx = w("lam"), w("vdot"), w("bs"), w("Cx")

    @classmethod
    def for_model(cls, model, keep=None) -> "System":
        """A System of the model with its own work arrays; the static part (packed model,
        patterns, symbolic factorisations) is built once per model and kept rows."""
        from ..model.data import thread_data
        cache = thread_data(model).systems
        key = None if keep is None else tuple(np.asarray(keep).tolist())
        proto = cache.get(key)
        if proto is None:
            proto = cache[key] = cls(model, keep)
        return proto.clone()

    def clone(self) -> "System":
        """The same static data with fresh work arrays."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.W = self.W.copy()
        if self._kpack is not None:
            new._kpack = (self._kpack[0], self._kpack[1].copy())
        new._bind()
        return new

    # ---------------------------------------------------------------- patterns
    def _incidence(self, keep):
        """Rows incident to each body and the positions of their products in S."""
        nb = self.nb
        rk = keep.size
        full_bi, full_bj = self.row_bi[keep], self.row_bj[keep]
        body = np.concatenate([full_bi, full_bj])
        side = np.concatenate([np.zeros(rk, np.int64), np.ones(rk, np.int64)])
        red = np.concatenate([np.arange(rk), np.arange(rk)])
        real = body < nb
        body, side, red = body[real], side[real], red[real]
        order = np.lexsort((red, body))
        body, side, red = body[order], side[order], red[order]
        inc_ptr = np.zeros(nb + 1, dtype=np.int64)
        np.cumsum(np.bincount(body, minlength=nb), out=inc_ptr[1:])
        # every pair (ta <= tc) of rows incident to a body
        counts = np.diff(inc_ptr)
        npair = counts * (counts + 1) // 2
        pair_ptr = np.zeros(nb + 1, dtype=np.int64)
        np.cumsum(npair, out=pair_ptr[1:])
        pa, pc = _pairs(inc_ptr, red, int(pair_ptr[-1]))
        self.S = spc.symbolic(rk, pa, pc)
        pair_pos = self.S.positions(pa, pc) if pa.size else np.zeros(0, np.int64)
        return dict(inc_ptr=inc_ptr, inc_row=red.astype(np.int64),
                    inc_side=side.astype(np.int64), pair_ptr=pair_ptr, pair_pos=pair_pos)

    def penalty_pack(self):
        """(KI, KW) of K = M + alpha D^T D (built on first use, static part shared by the
        clones of a System)."""
        if self._kpack is None:
            if self._kshared[0] is None:
                self._kshared[0] = self._build_penalty()
            KI, KW = self._kshared[0]
            self._kpack = (KI, KW.copy())
        return self._kpack

    def drop_penalty_rows(self, rows) -> None:
        """Leave the constraint rows ``rows`` (redundant ones) out of M + alpha D^T D and of
        the penalty term (their multipliers are 0), as the standard method leaves them out of
        its multiplier solve. None or empty: use every row."""
        KI, KW = self.penalty_pack()
        off, nr, nc = int(KI[4]), int(KI[5]), int(KI[6])        # KFIELDS[1] = rowblk
        rowblk = KI[off:off + nr * nc].reshape(nr, nc)
        bi, bj = self.row_bi, self.row_bj
        rowblk[:, 3] = (bi > bj).astype(np.int64)
        if rows is not None and len(rows):
            rowblk[np.asarray(rows, dtype=np.int64), 3] = -1

    def _build_penalty(self):
        nb, m = self.nb, self.m
        bi, bj = self.row_bi, self.row_bj
        both = (bi < nb) & (bj < nb)
        lo, hi = np.minimum(bi[both], bj[both]), np.maximum(bi[both], bj[both])
        pairs = np.unique(lo * (nb + 1) + hi)
        blk_b1 = np.concatenate([np.arange(nb), pairs // (nb + 1)])
        blk_b2 = np.concatenate([np.arange(nb), pairs % (nb + 1)])
        nblk = blk_b1.size
        a6 = np.arange(6)
        R = (6 * blk_b1[:, None, None] + a6[None, :, None]) * np.ones((1, 1, 6), np.int64)
        C = (6 * blk_b2[:, None, None] + a6[None, None, :]) * np.ones((1, 6, 1), np.int64)
        K = spc.symbolic(6 * nb, R.ravel(), C.ravel())
        blkpos = K.positions(R.ravel(), C.ravel()).reshape(nblk, 6, 6)
        diag = np.arange(nblk) < nb
        lower = K.pinv[R] > K.pinv[C]               # the duplicate of an upper entry
        blkpos[diag[:, None, None] & lower] = -1
        rowblk = np.full((m, 4), -1, dtype=np.int64)
        rowblk[bi < nb, 0] = bi[bi < nb]
        rowblk[bj < nb, 1] = bj[bj < nb]
        key = np.minimum(bi, bj) * (nb + 1) + np.maximum(bi, bj)
        rowblk[both, 2] = nb + np.searchsorted(pairs, key[both])
        rowblk[:, 3] = (bi > bj).astype(np.int64)
        arrays = dict(blkpos=blkpos, rowblk=rowblk, K_Cp=K.Cp, K_Ci=K.Ci, K_Lp=K.Lp,
                      K_Li=K.Li, K_Rp=K.Rp, K_Rj=K.Rj, K_Rpos=K.Rpos, K_perm=K.perm,
                      Kx=np.zeros(K.Ci.size), KLx=np.zeros(K.nnz_L), xk=np.zeros(6 * nb),
                      yk=np.zeros(6 * nb), ck=np.zeros(m), dtc=np.zeros(6 * nb),
                      old=np.zeros(6 * nb))
        _, KI, KW = pack(KFIELDS, arrays)
        self.K = K
        return KI, KW

    # ---------------------------------------------------------------- evaluation
    def python_stage(self, t: float, W=None):
        """Constraint groups without a compiled kernel and the force elements, in Python."""
        state = self.state if W is None else self.state_of(W)
        state.t = t
        if self.python_groups:
            phi, D, nu, gamma = (self.fields(W, n) for n in ("phi", "D", "nu", "gamma"))
            for g, off in self.python_groups:
                e = g.evaluate(state, t)
                sl = slice(off, off + g.size)
                phi[sl], nu[sl], gamma[sl] = e.phi.ravel(), e.nu.ravel(), e.gamma.ravel()
                D[sl] = e.D.reshape(-1, 12)
        if self.python_forces:
            gen = np.zeros((self.nb + 1, 6))
            for group in self.python_forces:
                group.evaluate(state, t, gen)
            g = self.g if W is None else self.fields(W, "g")
            g += gen[:self.nb].ravel()
            if not np.all(np.isfinite(g)):
                return False
        return True

    def dependent_rows(self, q, t: float, tol: float = 1e-13) -> np.ndarray:
        """Constraint rows of D(q, t) that depend on others: the Cholesky factorisation of
        D D^T leaves out every row whose pivot is <= tol times its diagonal entry (an exactly
        redundant row gives a pivot at round-off level, about 1e-16; a merely ill-conditioned
        one stays far above: 1e-11 for the 10 000-link revolute chain). Sorted row indices
        (among the kept rows) -- empty when the rows are independent."""
        y = np.concatenate([np.asarray(q, dtype=float).ravel(), np.zeros(6 * self.nb)])
        self.evaluate(t, y, False)
        dropped = np.zeros(self.keep.size, dtype=np.int64)
        if dependent_rows(self.F, self.I, self.W, tol, dropped) == 0:
            return np.zeros(0, dtype=np.int64)
        return np.sort(self.keep[self.S.perm[dropped == 1]])

    def fields(self, W, name):
        """A view of field ``name`` of the work array W (default the system's own)."""
        if W is None:
            W = self.W
        o, size, shape = self._layout[name]
        if len(shape) == 1:
            return W[o:o + size]
        return W[o:o + size].reshape(shape)

    def set_force_states(self, z, W=None) -> None:
        """The force elements' internal states (``force_table.n_states``, in the order of y)
        for evaluations at a given q, v (whose y does not carry them)."""
        flaw = self.fields(self.W if W is None else W, "flaw")
        coord = self.force_table.G.coord
        for k in np.flatnonzero(coord >= 0):
            flaw[k, 3:6] = z[coord[k]:coord[k] + 3]

    def state_of(self, W) -> BodyState:
        f = lambda name: self.fields(W, name)  # noqa: E731
        return BodyState(r=f("r"), A=f("A"), rdot=f("rdot"), omega=f("omega"), p=f("p"))

    def evaluate(self, t: float, y: np.ndarray, normalize: bool, W=None) -> bool:
        """Both stages at (t, y) into W (default the system's own); False if g is not finite."""
        own = W is None or W is self.W
        if self.table.has_drivers:
            self.table.set_time(t)
            if not own:
                self.fields(W, "law")[:] = self.law
                self.fields(W, "flaw")[:] = self.flaw
        ok = stage_state(t, y, 1.0 if normalize else 0.0, self.F, self.I, self.W if own else W)
        if self.python_groups or self.python_forces:
            ok = self.python_stage(t, None if own else W) and ok
        return ok


@njit
def _pairs(inc_ptr, red, total):
    pa = np.empty(total, dtype=np.int64)
    pc = np.empty(total, dtype=np.int64)
    q = 0
    for b in range(inc_ptr.size - 1):
        for ta in range(inc_ptr[b], inc_ptr[b + 1]):
            for tc in range(ta, inc_ptr[b + 1]):
                pa[q] = red[ta]
                pc[q] = red[tc]
                q += 1
    return pa, pc
