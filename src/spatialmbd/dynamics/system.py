"""The compiled equations of motion of a model: one call per right-hand-side evaluation.

:class:`System` packs everything an evaluation needs into three flat arrays -- ``F`` (model
floats), ``I`` (integers: the header, topology, sparsity patterns) and ``W`` (the work arrays
of one evaluation) -- because a compiled call pays about 0.1 us per array argument; inside
the compiled code :func:`unpack` turns them back into named views (the namedtuple
:data:`Sys`). Per evaluation, with no Python loop over bodies or joints:

* :func:`stage_state`: p / |p|, A(p) (4.13), J = A J' A^T and its inverse (10.6), gravity and
  the gyroscopic term -omega~ J omega (10.4), and every compiled constraint group
  (:func:`..constraints.kernels.evaluate_instances`) into Phi, D (m, 12 blocks), nu, gamma;
* the method's linear algebra, all O(N) for tree topologies (a chain):
  :func:`solve_multipliers` -- S = D M^-1 D^T (12.5) assembled body by body into a fixed
  sparse pattern, sparse Cholesky with a fill-reducing ordering (:mod:`.sparse`), then
  vdot = M^-1 (g + D^T lam) (12.4); :func:`solve_penalty` -- M + alpha D^T D (12.14) and the
  augmented Lagrangian iteration (12.17); :func:`project` -- the corrections of chapter 14
  with D D^T;
* :func:`rhs_standard` / :func:`rhs_penalty` fuse it all with qdot = T(q) v (5.12).

Force elements and constraint types without a compiled kernel are evaluated in Python between
the two stages (they see the state through :attr:`System.state`).

The matrix D never exists as such: row a of D holds 12 numbers, the columns of its bodies
body_i = row_bi[a] and body_j = row_bj[a] (the ground, index nb, is skipped).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..constraints.kernels import JointTable, evaluate_instances
from ..jit import array_view, njit
from ..rotations import rotate_p_scalar
from ..state import BodyState, qdot_into, state_into
from . import sparse as spc

# --------------------------------------------------------------------------------- layout
#: (name, buffer, ndim) of every field, in the order of :data:`Sys`
FIELDS = (
    # model (F)
    ("mass", "F", 1), ("Jl", "F", 3), ("Jl_inv", "F", 3), ("weight", "F", 2),
    ("s_i", "F", 2), ("s_j", "F", 2), ("R_i", "F", 3), ("R_j", "F", 3), ("length", "F", 1),
    # topology (I)
    ("kind", "I", 1), ("rows", "I", 1), ("bi", "I", 1), ("bj", "I", 1), ("coord", "I", 1),
    ("row_bi", "I", 1), ("row_bj", "I", 1), ("keep", "I", 1), ("drv", "I", 1),
    ("inc_ptr", "I", 1), ("inc_row", "I", 1), ("inc_side", "I", 1),
    ("pair_ptr", "I", 1), ("pair_pos", "I", 1),
    ("S_Cp", "I", 1), ("S_Ci", "I", 1), ("S_Lp", "I", 1), ("S_Li", "I", 1), ("S_Rp", "I", 1),
    ("S_Rj", "I", 1), ("S_Rpos", "I", 1), ("S_perm", "I", 1),
    # one evaluation (W)
    ("r", "W", 2), ("A", "W", 3), ("rdot", "W", 2), ("omega", "W", 2), ("p", "W", 2),
    ("J", "W", 3), ("Jinv", "W", 3), ("g", "W", 1),
    ("phi", "W", 1), ("D", "W", 2), ("nu", "W", 1), ("gamma", "W", 1), ("law", "W", 2),
    ("lam", "W", 1), ("vdot", "W", 1), ("rg", "W", 1), ("t6", "W", 1), ("u6", "W", 1),
    ("wk", "W", 2), ("Cx", "W", 1), ("Lx", "W", 1), ("xs", "W", 1), ("ys", "W", 1),
    ("bs", "W", 1), ("q", "W", 2), ("v", "W", 1),
)
Sys = namedtuple("Sys", [f[0] for f in FIELDS])

#: fields of the penalty pack (K = M + alpha D^T D), kept apart so it can be added later
KFIELDS = (("blkpos", "I", 3), ("rowblk", "I", 2), ("K_Cp", "I", 1), ("K_Ci", "I", 1),
           ("K_Lp", "I", 1), ("K_Li", "I", 1), ("K_Rp", "I", 1), ("K_Rj", "I", 1),
           ("K_Rpos", "I", 1), ("K_perm", "I", 1),
           ("Kx", "W", 1), ("KLx", "W", 1), ("xk", "W", 1), ("yk", "W", 1), ("ck", "W", 1),
           ("dtc", "W", 1), ("old", "W", 1))
KSys = namedtuple("KSys", [f[0] for f in KFIELDS])


def pack(fields, arrays: dict):
    """(F, I, W): the arrays of ``fields`` in three flat buffers; I starts with the header
    (offset and three dimensions per field)."""
    nf = len(fields)
    header = np.zeros(4 * nf, dtype=np.int64)
    chunks = {"F": [], "I": [], "W": []}
    sizes = {"F": 0, "I": 4 * nf, "W": 0}
    for k, (name, buf, ndim) in enumerate(fields):
        a = np.asarray(arrays[name])
        if a.ndim != ndim:
            raise ValueError(f"field {name}: expected {ndim} dimensions, got shape {a.shape}")
        header[4 * k] = sizes[buf]
        header[4 * k + 1:4 * k + 1 + ndim] = a.shape
        chunks[buf].append(a.ravel())
        sizes[buf] += a.size
    F = np.concatenate(chunks["F"]).astype(float) if chunks["F"] else np.zeros(0)
    I = np.concatenate([header] + chunks["I"]).astype(np.int64)
    W = np.concatenate(chunks["W"]).astype(float) if chunks["W"] else np.zeros(0)
    return np.ascontiguousarray(F), np.ascontiguousarray(I), np.ascontiguousarray(W)


def field_view(fields, F, I, W, name):
    """A NumPy view of one field (Python side)."""
    k = [f[0] for f in fields].index(name)
    _, buf, ndim = fields[k]
    o = I[4 * k]
    shape = tuple(int(x) for x in I[4 * k + 1:4 * k + 1 + ndim])
    B = {"F": F, "I": I, "W": W}[buf]
    return B[o:o + int(np.prod(shape))].reshape(shape)


@njit
def _v1(B, I, k):
    return array_view(B, I[4 * k], (I[4 * k + 1],))


@njit
def _v2(B, I, k):
    return array_view(B, I[4 * k], (I[4 * k + 1], I[4 * k + 2]))


@njit
def _v3(B, I, k):
    return array_view(B, I[4 * k], (I[4 * k + 1], I[4 * k + 2], I[4 * k + 3]))


@njit
def bare(B):
    """B itself, without reference counting (so passing it around costs no atomic updates)."""
    return array_view(B, 0, (B.size,))


@njit(inline="always")
def unpack(F, I, W):
    """The named views of a System (the field order of FIELDS)."""
    F, I, W = bare(F), bare(I), bare(W)
    return Sys(
        _v1(F, I, 0), _v3(F, I, 1), _v3(F, I, 2), _v2(F, I, 3),
        _v2(F, I, 4), _v2(F, I, 5), _v3(F, I, 6), _v3(F, I, 7), _v1(F, I, 8),
        _v1(I, I, 9), _v1(I, I, 10), _v1(I, I, 11), _v1(I, I, 12), _v1(I, I, 13),
        _v1(I, I, 14), _v1(I, I, 15), _v1(I, I, 16), _v1(I, I, 17),
        _v1(I, I, 18), _v1(I, I, 19), _v1(I, I, 20),
        _v1(I, I, 21), _v1(I, I, 22),
        _v1(I, I, 23), _v1(I, I, 24), _v1(I, I, 25), _v1(I, I, 26), _v1(I, I, 27),
        _v1(I, I, 28), _v1(I, I, 29), _v1(I, I, 30),
        _v2(W, I, 31), _v3(W, I, 32), _v2(W, I, 33), _v2(W, I, 34), _v2(W, I, 35),
        _v3(W, I, 36), _v3(W, I, 37), _v1(W, I, 38),
        _v1(W, I, 39), _v2(W, I, 40), _v1(W, I, 41), _v1(W, I, 42), _v2(W, I, 43),
        _v1(W, I, 44), _v1(W, I, 45), _v1(W, I, 46), _v1(W, I, 47), _v1(W, I, 48),
        _v2(W, I, 49), _v1(W, I, 50), _v1(W, I, 51), _v1(W, I, 52), _v1(W, I, 53),
        _v1(W, I, 54), _v2(W, I, 55), _v1(W, I, 56),
    )


@njit(inline="always")
def unpack_k(KI, KW):
    KI, KW = bare(KI), bare(KW)
    return KSys(_v3(KI, KI, 0), _v2(KI, KI, 1), _v1(KI, KI, 2), _v1(KI, KI, 3),
                _v1(KI, KI, 4), _v1(KI, KI, 5), _v1(KI, KI, 6), _v1(KI, KI, 7),
                _v1(KI, KI, 8), _v1(KI, KI, 9),
                _v1(KW, KI, 10), _v1(KW, KI, 11), _v1(KW, KI, 12), _v1(KW, KI, 13),
                _v1(KW, KI, 14), _v1(KW, KI, 15), _v1(KW, KI, 16))


def _check_layout():
    """unpack() lists the fields by position: keep it in step with FIELDS."""
    assert len(FIELDS) == 57 and len(KFIELDS) == 17


_check_layout()


# --------------------------------------------------------------------------------- helpers
# The functions that take the views ``s`` (a namedtuple of some 60 arrays, which Numba would pass
# as several hundred scalar arguments) are inlined into their callers (``inline="always"``).
@njit
def fill(a, value):
    for k in range(a.size):
        a[k] = value


@njit
def copy(dst, src):
    for k in range(src.size):
        dst[k] = src[k]


# --------------------------------------------------------------------------------- bodies
@njit
def congruence(A, X, b, out):
    """out[b] = A[b] X[b] A[b]^T for 3 x 3 blocks (X symmetric)."""
    for a in range(3):
        t0 = A[b, a, 0] * X[b, 0, 0] + A[b, a, 1] * X[b, 1, 0] + A[b, a, 2] * X[b, 2, 0]
        t1 = A[b, a, 0] * X[b, 0, 1] + A[b, a, 1] * X[b, 1, 1] + A[b, a, 2] * X[b, 2, 1]
        t2 = A[b, a, 0] * X[b, 0, 2] + A[b, a, 1] * X[b, 1, 2] + A[b, a, 2] * X[b, 2, 2]
        for c in range(3):
            out[b, a, c] = t0 * A[b, c, 0] + t1 * A[b, c, 1] + t2 * A[b, c, 2]


@njit
def stage_state(t, y, normalize, F, I, W):
    """State, mass matrix, g and the compiled constraints at (t, y) (y = [q (7 nb), v, ...])."""
    s = unpack(F, I, W)
    nb = s.mass.size
    q = array_view(y, 0, (nb, 7))
    v = array_view(y, 7 * nb, (nb, 6))
    state_into(q, v, normalize, s.r, s.A, s.rdot, s.omega, s.p)
    for b in range(nb):
        congruence(s.A, s.Jl, b, s.J)                                  # J = A J' A^T (10.6)
        congruence(s.A, s.Jl_inv, b, s.Jinv)
        w0, w1, w2 = s.omega[b, 0], s.omega[b, 1], s.omega[b, 2]
        h0 = s.J[b, 0, 0] * w0 + s.J[b, 0, 1] * w1 + s.J[b, 0, 2] * w2
        h1 = s.J[b, 1, 0] * w0 + s.J[b, 1, 1] * w1 + s.J[b, 1, 2] * w2
        h2 = s.J[b, 2, 0] * w0 + s.J[b, 2, 1] * w1 + s.J[b, 2, 2] * w2
        g = s.g[6 * b:6 * b + 6]
        g[0], g[1], g[2] = s.weight[b, 0], s.weight[b, 1], s.weight[b, 2]     # (11.1)
        g[3] = -(w1 * h2 - w2 * h1)                                    # -omega~ J omega (10.4)
        g[4] = -(w2 * h0 - w0 * h2)
        g[5] = -(w0 * h1 - w1 * h0)
    S = (s.r, s.A, s.rdot, s.omega, s.p)
    G = (s.bi, s.bj, s.s_i, s.s_j, s.R_i, s.R_j, s.length, s.law, s.coord)
    evaluate_instances(s.kind, S, G, s.rows, (s.phi, s.D, s.nu, s.gamma))


@njit
def block_apply(m, J, b, f, fo, out, oo, inverse):
    """out[oo:oo+6] = M_b f[fo:fo+6] = [m f_r, J f_w], or M_b^-1 f = [f_r / m, J^-1 f_w] with
    ``inverse`` (J then holds the inverse inertia J^-1 = A J'^-1 A^T): M is block diagonal,
    blocks diag(m I, J) (10.6), and is never formed."""
    for a in range(3):
        out[oo + a] = f[fo + a] / m[b] if inverse else f[fo + a] * m[b]
    for a in range(3):
        out[oo + 3 + a] = J[b, a, 0] * f[fo + 3] + J[b, a, 1] * f[fo + 4] + J[b, a, 2] * f[fo + 5]


@njit(inline="always")
def minv_body(s, b, f, out):
    """out[6b:6b+6] = M_b^-1 f[6b:6b+6]."""
    block_apply(s.mass, s.Jinv, b, f, 6 * b, out, 6 * b, True)


@njit(inline="always")
def m_body(s, b, f, out):
    """out[6b:6b+6] = M_b f[6b:6b+6]."""
    block_apply(s.mass, s.J, b, f, 6 * b, out, 6 * b, False)


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
def row_times(s, a, x):
    """(D x)[a] for x in velocity space (6 nb,)."""
    nb = s.mass.size
    acc = 0.0
    bi, bj = s.row_bi[a], s.row_bj[a]
    if bi < nb:
        for c in range(6):
            acc += s.D[a, c] * x[6 * bi + c]
    if bj < nb:
        for c in range(6):
            acc += s.D[a, 6 + c] * x[6 * bj + c]
    return acc


@njit(inline="always")
def add_transpose_times(s, lam, out):
    """out += D^T lam (lam over all m rows)."""
    nb = s.mass.size
    for a in range(lam.size):
        la = lam[a]
        if la == 0.0:
            continue
        bi, bj = s.row_bi[a], s.row_bj[a]
        if bi < nb:
            for c in range(6):
                out[6 * bi + c] += s.D[a, c] * la
        if bj < nb:
            for c in range(6):
                out[6 * bj + c] += s.D[a, 6 + c] * la


# --------------------------------------------------------------------------------- S = D W D^T
@njit(inline="always")
def assemble_schur(s, use_mass):
    """Cx = values of S = D M^-1 D^T (use_mass) or D D^T over the kept rows."""
    nb = s.mass.size
    fill(s.Cx, 0.0)
    for b in range(nb):
        p0, p1 = s.inc_ptr[b], s.inc_ptr[b + 1]
        for t in range(p0, p1):
            a = s.keep[s.inc_row[t]]
            c0 = 6 * s.inc_side[t]
            if use_mass:                        # a row of D M^-1 (M^-1 is symmetric)
                block_apply(s.mass, s.Jinv, b, s.D[a], c0, s.wk[t - p0], 0, True)
            else:
                for c in range(6):
                    s.wk[t - p0, c] = s.D[a, c0 + c]
        q = s.pair_ptr[b]
        for ta in range(p0, p1):
            for tc in range(ta, p1):
                a = s.keep[s.inc_row[tc]]
                c0 = 6 * s.inc_side[tc]
                val = 0.0
                for c in range(6):
                    val += s.wk[ta - p0, c] * s.D[a, c0 + c]
                s.Cx[s.pair_pos[q]] += val
                q += 1


@njit(inline="always")
def schur_factor(s, use_mass):
    """Assemble and factorise S (or D D^T); False if it is not positive definite."""
    assemble_schur(s, use_mass)
    sym = (s.S_Cp, s.S_Ci, s.S_Lp, s.S_Li, s.S_Rp, s.S_Rj, s.S_Rpos, s.S_perm)
    return spc.numeric(sym, s.Cx, s.Lx, s.xs)


@njit(inline="always")
def schur_solve(s, b):
    sym = (s.S_Cp, s.S_Ci, s.S_Lp, s.S_Li, s.S_Rp, s.S_Rj, s.S_Rpos, s.S_perm)
    spc.solve(sym, s.Lx, b, s.ys)


@njit(inline="always")
def finish(s):
    """vdot = M^-1 (g + D^T lam), Eq. (12.4)."""
    nb = s.mass.size
    copy(s.t6, s.g)
    add_transpose_times(s, s.lam, s.t6)
    for b in range(nb):
        minv_body(s, b, s.t6, s.vdot)


@njit(inline="always")
def multiplier_rhs(s):
    """bs = rg - D M^-1 g over the kept rows (the right-hand side of S lam = ...)."""
    nb = s.mass.size
    for b in range(nb):
        minv_body(s, b, s.g, s.u6)
    for k in range(s.keep.size):
        a = s.keep[k]
        s.bs[k] = s.rg[a] - row_times(s, a, s.u6)


@njit(inline="always")
def baumgarte_rhs(s, mode, alpha, beta):
    """rg = gamma (mode 0) or gamma - 2 alpha Phidot - beta^2 Phi (mode 1, Eq. 12.8)."""
    nb = s.mass.size
    if mode == 0:
        copy(s.rg, s.gamma)
        return
    for a in range(s.gamma.size):
        phidot = -s.nu[a]
        bi, bj = s.row_bi[a], s.row_bj[a]
        if bi < nb:
            for c in range(6):
                phidot += s.D[a, c] * s.v[6 * bi + c]
        if bj < nb:
            for c in range(6):
                phidot += s.D[a, 6 + c] * s.v[6 * bj + c]
        s.rg[a] = s.gamma[a] - 2.0 * alpha * phidot - beta * beta * s.phi[a]


@njit
def rhs_gamma_into(y, F, I, W, mp):
    """rg of :func:`baumgarte_rhs` at the evaluation in W (v read from y)."""
    s = unpack(F, I, W)
    copy_v(s, y)
    baumgarte_rhs(s, int(mp[1]), mp[2], mp[3])


@njit(inline="always")
def solve_multipliers(s, mode, alpha, beta):
    """lam and vdot of the (Baumgarte-modified) standard method; False if S is singular
    (s.bs then holds the right-hand side and s.Cx the values of S for a fallback)."""
    baumgarte_rhs(s, mode, alpha, beta)
    fill(s.lam, 0.0)
    if s.keep.size == 0:
        finish(s)
        return True
    multiplier_rhs(s)
    if not schur_factor(s, True):
        return False
    schur_solve(s, s.bs)
    for k in range(s.keep.size):
        s.lam[s.keep[k]] = s.bs[k]
    finish(s)
    return True


@njit(inline="always")
def copy_v(s, y):
    nb = s.mass.size
    for k in range(6 * nb):
        s.v[k] = y[7 * nb + k]


@njit(inline="always")
def write_ydot(s, ydot):
    """ydot = [qdot (5.12), vdot, power of the drivers lam^T nu]."""
    nb = s.mass.size
    qdot_into(s.p, s.omega, s.rdot, array_view(ydot, 0, (nb, 7)))
    for j in range(6 * nb):
        ydot[7 * nb + j] = s.vdot[j]
    power = 0.0
    for k in range(s.drv.size):
        a = s.drv[k]
        power += s.lam[a] * s.nu[a]
    if ydot.size > 13 * nb:
        ydot[13 * nb] = power


@njit
def finite(x):
    for k in range(x.size):
        if not math.isfinite(x[k]):
            return False
    return True


#: status codes of the compiled right-hand sides (>= 0: success; the augmented Lagrangian
#: returns its number of iterations)
OK, SINGULAR, NOT_FINITE, NOT_CONVERGED = 0, -1, -2, -3

#: the parameter array ``mp`` of the standard / Baumgarte right-hand side
MP_STANDARD = ("normalize", "mode", "alpha", "beta")


@njit
def rhs_standard(t, y, ydot, F, I, W, mp):
    """The whole right-hand side of the standard / Baumgarte methods (no Python parts)."""
    stage_state(t, y, mp[0] != 0.0, F, I, W)
    return after_state_standard(y, ydot, F, I, W, mp)


@njit
def after_state_standard(y, ydot, F, I, W, mp):
    s = unpack(F, I, W)
    copy_v(s, y)
    if not solve_multipliers(s, int(mp[1]), mp[2], mp[3]):
        return SINGULAR
    write_ydot(s, ydot)
    return OK if finite(ydot) else NOT_FINITE


@njit
def fallback_finish(y, ydot, F, I, W):
    """vdot and ydot after a fallback solve that has put lam into s.lam."""
    s = unpack(F, I, W)
    finish(s)
    write_ydot(s, ydot)
    return OK if finite(ydot) else NOT_FINITE


# --------------------------------------------------------------------------------- penalty
@njit(inline="always")
def assemble_penalty(s, k, alpha):
    """Kx = values of M + alpha D^T D (12.14)."""
    nb = s.mass.size
    fill(k.Kx, 0.0)
    for b in range(nb):
        for a in range(6):
            for c in range(6):
                pos = k.blkpos[b, a, c]
                if pos < 0:
                    continue
                if a < 3 and c < 3:
                    if a == c:
                        k.Kx[pos] += s.mass[b]
                elif a >= 3 and c >= 3:
                    k.Kx[pos] += s.J[b, a - 3, c - 3]
    for r in range(s.D.shape[0]):
        bii, bjj, bij, flip = k.rowblk[r, 0], k.rowblk[r, 1], k.rowblk[r, 2], k.rowblk[r, 3]
        for a in range(6):
            da_i = alpha * s.D[r, a]
            da_j = alpha * s.D[r, 6 + a]
            for c in range(6):
                if bii >= 0:
                    pos = k.blkpos[bii, a, c]
                    if pos >= 0:
                        k.Kx[pos] += da_i * s.D[r, c]
                if bjj >= 0:
                    pos = k.blkpos[bjj, a, c]
                    if pos >= 0:
                        k.Kx[pos] += da_j * s.D[r, 6 + c]
                if bij >= 0:
                    pos = k.blkpos[bij, c, a] if flip else k.blkpos[bij, a, c]
                    k.Kx[pos] += da_i * s.D[r, 6 + c]


#: the parameter array ``mp`` of the penalty / augmented Lagrangian right-hand side
MP_PENALTY = ("normalize", "alpha", "omega", "mu", "iterate", "tolerance", "max_iterations",
              "floor")


@njit
def solve_penalty(y, F, I, W, KI, KW, mp):
    """Penalty (12.14) or augmented Lagrangian (12.16)-(12.18) accelerations and lam.

    Returns the number of iterations (1 for the penalty method), SINGULAR if
    M + alpha D^T D is not positive definite, NOT_CONVERGED if the augmented Lagrangian
    iteration did not converge."""
    alpha, omega, mu, al = mp[1], mp[2], mp[3], mp[4] != 0.0
    tol, max_it, floor = mp[5], int(mp[6]), mp[7]
    s = unpack(F, I, W)
    k = unpack_k(KI, KW)
    nb = s.mass.size
    m = s.phi.size
    copy_v(s, y)
    assemble_penalty(s, k, alpha)
    sym = (k.K_Cp, k.K_Ci, k.K_Lp, k.K_Li, k.K_Rp, k.K_Rj, k.K_Rpos, k.K_perm)
    if not spc.numeric(sym, k.Kx, k.KLx, k.xk):
        return SINGULAR
    # constraint dynamics term of (12.14): c = -gamma + 2 mu omega Phidot + omega^2 Phi
    for a in range(m):
        phidot = row_times(s, a, s.v) - s.nu[a]
        k.ck[a] = -s.gamma[a] + 2.0 * mu * omega * phidot + omega * omega * s.phi[a]
    fill(k.dtc, 0.0)
    add_transpose_times(s, k.ck, k.dtc)
    if not al:
        for j in range(6 * nb):
            s.vdot[j] = s.g[j] - alpha * k.dtc[j]
        spc.solve(sym, k.KLx, s.vdot, k.yk)
        for a in range(m):
            s.lam[a] = -alpha * (row_times(s, a, s.vdot) + k.ck[a])
        return 1
    for b in range(nb):                                               # (12.16)
        minv_body(s, b, s.g, s.vdot)
    fill(s.lam, 0.0)
    previous = np.inf
    for it in range(1, max_it + 1):
        copy(k.old, s.vdot)
        for b in range(nb):
            m_body(s, b, k.old, s.t6)
        for j in range(6 * nb):
            s.vdot[j] = s.t6[j] - alpha * k.dtc[j]
        spc.solve(sym, k.KLx, s.vdot, k.yk)                          # (12.17)
        for a in range(m):
            s.lam[a] += -alpha * (row_times(s, a, s.vdot) + k.ck[a])
        change = 0.0
        big = 1.0
        for j in range(6 * nb):
            change += (s.vdot[j] - k.old[j]) ** 2
            big = max(big, abs(s.vdot[j]))
        change = math.sqrt(change)
        at_floor = change <= floor * big and change > 0.5 * previous
        if change <= tol * big or at_floor:                           # (12.18)
            return it
        previous = change
    return NOT_CONVERGED


@njit
def rhs_penalty(t, y, ydot, F, I, W, KI, KW, mp):
    stage_state(t, y, mp[0] != 0.0, F, I, W)
    return after_state_penalty(y, ydot, F, I, W, KI, KW, mp)


@njit
def after_state_penalty(y, ydot, F, I, W, KI, KW, mp):
    it = solve_penalty(y, F, I, W, KI, KW, mp)
    if it < 0:
        return it
    s = unpack(F, I, W)
    write_ydot(s, ydot)
    return it if finite(ydot) else NOT_FINITE


# --------------------------------------------------------------------------------- projection
@njit
def project_positions(t, y, F, I, W, tol, max_it, dx_total):
    """Positions onto Phi(q, t) = 0 by Newton-Raphson, dx = -D^T (D D^T)^-1 Phi (14.12) over
    the kept rows, rotations applied exactly (p <- quat(dpi) (x) p); in place on y[:7 nb].

    dx_total (6 nb,) accumulates the corrections. Returns (iterations, max |Phi| before, after);
    iterations = -1 if D D^T is singular, -2 if Newton did not converge in max_it."""
    s = unpack(F, I, W)
    nb = s.mass.size
    m = s.phi.size
    q = array_view(y, 0, (nb, 7))
    it = 0
    phi0 = -1.0
    while True:
        stage_state(t, y, False, F, I, W)
        err = 0.0
        for a in range(m):
            err = max(err, abs(s.phi[a]))
        if phi0 < 0.0:
            phi0 = err
        if err <= tol:
            return it, phi0, err
        if it == max_it or not math.isfinite(err):
            return -2, phi0, err
        if not schur_factor(s, False):
            return -1, phi0, err
        for k in range(s.keep.size):
            s.bs[k] = s.phi[s.keep[k]]
        schur_solve(s, s.bs)
        fill(s.lam, 0.0)
        for k in range(s.keep.size):
            s.lam[s.keep[k]] = -s.bs[k]
        fill(s.t6, 0.0)
        add_transpose_times(s, s.lam, s.t6)                            # dx = -D^T y
        for b in range(nb):
            for c in range(3):
                q[b, c] += s.t6[6 * b + c]
            pn = _rot(q, b, s.t6[6 * b + 3], s.t6[6 * b + 4], s.t6[6 * b + 5])
            for c in range(4):
                q[b, 3 + c] = pn[c]
        for j in range(6 * nb):
            dx_total[j] += s.t6[j]
        it += 1


@njit
def project_velocities(t, y, F, I, W):
    """v <- v - D^T (D D^T)^-1 (D v - nu) (14.19) over the kept rows, in place on y.

    Returns (ok, max |D v - nu| before, after) (all rows); ok False if D D^T is singular."""
    s = unpack(F, I, W)
    nb = s.mass.size
    m = s.phi.size
    stage_state(t, y, False, F, I, W)
    copy_v(s, y)
    before = 0.0
    for a in range(m):
        before = max(before, abs(row_times(s, a, s.v) - s.nu[a]))
    if m == 0:
        return True, 0.0, 0.0
    if not schur_factor(s, False):
        return False, before, before
    for k in range(s.keep.size):
        a = s.keep[k]
        s.bs[k] = row_times(s, a, s.v) - s.nu[a]
    schur_solve(s, s.bs)
    fill(s.lam, 0.0)
    for k in range(s.keep.size):
        s.lam[s.keep[k]] = -s.bs[k]
    fill(s.t6, 0.0)
    add_transpose_times(s, s.lam, s.t6)
    for j in range(6 * nb):
        y[7 * nb + j] += s.t6[j]
    copy_v(s, y)
    after = 0.0
    for a in range(m):
        after = max(after, abs(row_times(s, a, s.v) - s.nu[a]))
    return True, before, after


@njit
def project(t, y, F, I, W, tol, max_it, dx_total):
    """Both projections (the projection method's step); returns the position iterations, -1
    if D D^T is singular, -2 if Newton did not converge."""
    it, phi0, err = project_positions(t, y, F, I, W, tol, max_it, dx_total)
    if it < 0:
        return it
    ok, before, after = project_velocities(t, y, F, I, W)
    return it if ok else -1


@njit
def _rot(q, b, t0, t1, t2):
    return rotate_p_scalar((q[b, 3], q[b, 4], q[b, 5], q[b, 6]), t0, t1, t2)


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
        arrays = dict(
            mass=model.mass, Jl=model.inertia, Jl_inv=model.inertia_inverse,
            weight=model.mass[:, None] * model.gravity[None, :],
            s_i=G[2], s_j=G[3], R_i=G[4], R_j=G[5], length=G[6],
            kind=table.kind, rows=table.rows, bi=G[0], bj=G[1], coord=G[8],
            row_bi=row_bi, row_bj=row_bj, keep=keep, drv=self.driver_rows, **inc,
            S_Cp=self.S.Cp, S_Ci=self.S.Ci, S_Lp=self.S.Lp, S_Li=self.S.Li, S_Rp=self.S.Rp,
            S_Rj=self.S.Rj, S_Rpos=self.S.Rpos, S_perm=self.S.perm,
            r=np.zeros((nb + 1, 3)), A=np.zeros((nb + 1, 3, 3)), rdot=np.zeros((nb + 1, 3)),
            omega=np.zeros((nb + 1, 3)), p=np.zeros((nb + 1, 4)), J=np.zeros((nb, 3, 3)),
            Jinv=np.zeros((nb, 3, 3)), g=np.zeros(6 * nb), phi=np.zeros(m),
            D=np.zeros((m, 12)), nu=np.zeros(m), gamma=np.zeros(m), law=np.zeros((G[0].size, 3)),
            lam=np.zeros(m), vdot=np.zeros(6 * nb), rg=np.zeros(m), t6=np.zeros(6 * nb),
            u6=np.zeros(6 * nb), wk=np.zeros((max(1, int(np.diff(inc["inc_ptr"]).max(initial=0))), 6)),
            Cx=np.zeros(self.S.Ci.size), Lx=np.zeros(self.S.nnz_L), xs=np.zeros(keep.size),
            ys=np.zeros(keep.size), bs=np.zeros(keep.size), q=np.zeros((nb, 7)),
            v=np.zeros(6 * nb))
        self.F, self.I, self.W = pack(FIELDS, arrays)
        self._layout = {name: (int(self.I[4 * k]), int(np.asarray(arrays[name]).size),
                               np.asarray(arrays[name]).shape)
                        for k, (name, buf, _) in enumerate(FIELDS) if buf == "W"}
        self._kpack = None
        # views used from Python
        w = lambda name: field_view(FIELDS, self.F, self.I, self.W, name)  # noqa: E731
        self.law = w("law")
        table.law = self.law                  # drivers write their (f, f', f'') here
        table.G = table.G[:7] + (self.law,) + table.G[8:]
        self.state = BodyState(r=w("r"), A=w("A"), rdot=w("rdot"), omega=w("omega"),
                               p=w("p"))
        self.g = w("g")
        self.phi, self.D, self.nu, self.gamma = w("phi"), w("D"), w("nu"), w("gamma")
        self.lam, self.vdot, self.bs, self.Cx = w("lam"), w("vdot"), w("bs"), w("Cx")
        self.fused = not self.python_groups and not model.force_groups

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
        self.S = spc.SparseCholesky(rk, pa, pc)
        pair_pos = self.S.positions(pa, pc) if pa.size else np.zeros(0, np.int64)
        return dict(inc_ptr=inc_ptr, inc_row=red.astype(np.int64),
                    inc_side=side.astype(np.int64), pair_ptr=pair_ptr, pair_pos=pair_pos)

    def penalty_pack(self):
        """(KI, KW) of K = M + alpha D^T D (built on first use)."""
        if self._kpack is None:
            self._kpack = self._build_penalty()
        return self._kpack

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
        K = spc.SparseCholesky(6 * nb, R.ravel(), C.ravel())
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
        if self.model.force_groups:
            gen = np.zeros((self.nb + 1, 6))
            for group in self.model.force_groups:
                group.evaluate(state, t, gen)
            g = self.g if W is None else self.fields(W, "g")
            g += gen[:self.nb].ravel()
            if not np.all(np.isfinite(g)):
                return False
        return True

    def rows_independent(self, q, t: float, tol: float = 1e-10) -> bool:
        """True when the kept rows of D(q, t) are clearly independent: D D^T has a Cholesky
        factor whose smallest pivot^2 exceeds tol times its largest diagonal entry (an exactly
        redundant row gives a pivot at round-off level)."""
        y = np.concatenate([np.asarray(q, dtype=float).ravel(), np.zeros(6 * self.nb)])
        self.evaluate(t, y, False)
        ok, ratio = factor_dd(self.F, self.I, self.W)
        return bool(ok and ratio > tol)

    def fields(self, W, name):
        """A view of field ``name`` of the work array W (default the system's own)."""
        if W is None:
            W = self.W
        o, size, shape = self._layout[name]
        return W[o:o + size].reshape(shape)

    def state_of(self, W) -> BodyState:
        f = lambda name: self.fields(W, name)  # noqa: E731
        return BodyState(r=f("r"), A=f("A"), rdot=f("rdot"), omega=f("omega"), p=f("p"))

    def evaluate(self, t: float, y: np.ndarray, normalize: bool, W=None) -> bool:
        """Both stages at (t, y) into W (default the system's own); False if g is not finite."""
        if self.table.has_drivers:
            self.table.set_time(t)
        W = self.W if W is None else W
        if W is not self.W and self.table.has_drivers:
            self.fields(W, "law")[:] = self.law
        stage_state(t, y, normalize, self.F, self.I, W)
        if not (self.python_groups or self.model.force_groups):
            return True
        return self.python_stage(t, None if W is self.W else W)


@njit
def normalize_y(y, nb):
    """Every body's Euler parameters in y = [q, ...] scaled to unit length, in place."""
    for b in range(nb):
        o = 7 * b + 3
        n = math.sqrt(y[o] ** 2 + y[o + 1] ** 2 + y[o + 2] ** 2 + y[o + 3] ** 2)
        for c in range(4):
            y[o + c] /= n


@njit
def factor_dd(F, I, W):
    """Factorise D D^T (kept rows) of the evaluation in W; (ok, min pivot^2 / max diagonal)."""
    s = unpack(F, I, W)
    if s.keep.size == 0:
        return True, 1.0
    ok = schur_factor(s, False)
    if not ok:
        return False, 0.0
    big = 0.0
    for j in range(s.keep.size):
        big = max(big, s.Cx[s.S_Cp[j + 1] - 1])                # diagonal: last in column j
    small = np.inf
    for j in range(s.keep.size):
        small = min(small, s.Lx[s.S_Lp[j]] ** 2)
    return True, small / big


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
