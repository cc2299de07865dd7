"""Sparse Cholesky factorisation with a fixed pattern (compiled), for the SPD matrices of the
methods: S = D M^-1 D^T (Lagrange multipliers), D D^T (projections) and M + alpha D^T D
(penalty, augmented Lagrangian).

The pattern of these matrices depends only on the topology, so everything symbolic is done
once per model: a fill-reducing ordering (multiple minimum degree on A + A^T, computed by
SuperLU), the elimination tree, the pattern of L and, for every row k, the columns of L(k, :)
in the order the up-looking algorithm visits them. Each evaluation then only fills the values
of the upper triangle of P A P^T (``Cx``, positions from :meth:`SparseCholesky.positions`),
runs :func:`numeric` -- the up-looking Cholesky of CSparse (Davis 2006, ``cs_chol``) with the
row patterns replayed instead of recomputed -- and :func:`solve`. For a tree-structured
mechanism (a chain) the fill is O(N), so factorisation and solve are O(N).

A pivot that is not positive (a singular or indefinite matrix: redundant constraints, a singular
configuration) makes :func:`numeric` return False; the callers then fall back to a
least-squares solve, as LAPACK's potrf failure did before. :func:`factor` with a drop tolerance
instead leaves out the rows that depend on earlier ones (the redundancy test of large models).
"""
from __future__ import annotations

import hashlib
import math
import threading
from collections import OrderedDict

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..jit import njit

#: matrices up to this size keep their natural order (the ordering would not pay)
NATURAL_ORDER_MAX = 12


def fill_reducing_order(n: int, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """perm (new -> old) of a symmetric pattern: multiple minimum degree on A + A^T (SuperLU)."""
    if n <= NATURAL_ORDER_MAX:
        return np.arange(n)
    A = sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n)).tocsc()
    A = (A + A.T).tocsc()
    A.data[:] = 1.0
    A = A + sp.diags(np.asarray(A.sum(axis=0)).ravel() + 1.0)    # diagonally dominant
    lu = spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                   options=dict(SymmetricMode=True))
    # Pr A Pc = L U with Pc[i, perm_c[i]] = 1: perm_c maps an old index to its new one
    return np.argsort(lu.perm_c)


class SparseCholesky:
    """Symbolic analysis of a symmetric n x n pattern given by entries (rows, cols) (either
    triangle, duplicates allowed; the diagonal is always included)."""

    def __init__(self, n: int, rows: np.ndarray, cols: np.ndarray):
        rows = np.concatenate([np.asarray(rows, dtype=np.int64), np.arange(n)])
        cols = np.concatenate([np.asarray(cols, dtype=np.int64), np.arange(n)])
        self.n = n
        self.perm = np.ascontiguousarray(fill_reducing_order(n, rows, cols), dtype=np.int64)
        self.pinv = np.empty(n, dtype=np.int64)
        self.pinv[self.perm] = np.arange(n)
        # upper triangle of C = P A P^T in CSC (column j: rows i <= j, sorted)
        pi, pj = self.pinv[rows], self.pinv[cols]
        lo, hi = np.minimum(pi, pj), np.maximum(pi, pj)
        self._keys = np.unique(hi * n + lo)
        self.Ci = np.ascontiguousarray(self._keys % n, dtype=np.int64)
        col = self._keys // n
        self.Cp = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(col, minlength=n), out=self.Cp[1:])
        parent = np.empty(n, dtype=np.int64)
        _etree(self.Cp, self.Ci, parent)
        counts = np.zeros(n, dtype=np.int64)
        nrow = _row_counts(self.Cp, self.Ci, parent, counts)
        self.Lp = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(counts + 1, out=self.Lp[1:])                      # + the diagonal
        self.Li = np.empty(self.Lp[-1], dtype=np.int64)
        self.Rp = np.zeros(n + 1, dtype=np.int64)
        self.Rj = np.empty(nrow, dtype=np.int64)
        self.Rpos = np.empty(nrow, dtype=np.int64)
        _row_patterns(self.Cp, self.Ci, parent, self.Lp, self.Li, self.Rp, self.Rj, self.Rpos)
        self.parent = parent

    @property
    def nnz_L(self) -> int:
        return int(self.Lp[-1])

    def positions(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Index into the values ``Cx`` of the (symmetric) entries (rows, cols)."""
        pi, pj = self.pinv[np.asarray(rows)], self.pinv[np.asarray(cols)]
        keys = np.maximum(pi, pj) * self.n + np.minimum(pi, pj)
        pos = np.searchsorted(self._keys, keys)
        if np.any(self._keys[np.minimum(pos, self._keys.size - 1)] != keys):
            raise ValueError("entry outside the symbolic pattern")
        return pos.astype(np.int64)

    def arrays(self):
        """(Cp, Ci, Lp, Li, Rp, Rj, Rpos, perm): what the compiled functions take."""
        return (self.Cp, self.Ci, self.Lp, self.Li, self.Rp, self.Rj, self.Rpos, self.perm)

    def to_scipy(self, Cx: np.ndarray) -> sp.csc_matrix:
        """The full symmetric matrix A (original order) of the values Cx."""
        n = self.n
        up = sp.csc_matrix((Cx, self.Ci, self.Cp), shape=(n, n))
        full = (up + sp.triu(up, 1).T).tocsc()
        return full[self.pinv][:, self.pinv].tocsc()


#: patterns whose symbolic analysis is kept for reuse (least recently used dropped first)
SYMBOLIC_CACHE_SIZE = 64
_symbolic_cache: OrderedDict = OrderedDict()
_symbolic_lock = threading.Lock()


def symbolic(n: int, rows, cols) -> SparseCholesky:
    """``SparseCholesky(n, rows, cols)``, shared by equal patterns.

    A sweep, a Monte Carlo study or a sensitivity run builds the same topology many times, and
    the fill-reducing ordering is most of a System's construction (1.3 of its 2.2 ms for the
    17 rows of the free slider-crank). The analysis is read-only once built (its arrays are
    marked so), so one object serves every System of the pattern; a hit is checked entry by
    entry, not by its hash alone."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    cols = np.ascontiguousarray(cols, dtype=np.int64)
    digest = hashlib.blake2b(rows.tobytes() + b"|" + cols.tobytes(), digest_size=16).digest()
    key = (int(n), rows.size, digest)
    with _symbolic_lock:
        hit = _symbolic_cache.get(key)
        if hit is not None and np.array_equal(hit[0], rows) and np.array_equal(hit[1], cols):
            _symbolic_cache.move_to_end(key)
            return hit[2]
    sym = SparseCholesky(n, rows, cols)
    for a in vars(sym).values():
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    rows, cols = rows.copy(), cols.copy()
    rows.setflags(write=False)
    cols.setflags(write=False)
    with _symbolic_lock:
        _symbolic_cache[key] = (rows, cols, sym)
        while len(_symbolic_cache) > SYMBOLIC_CACHE_SIZE:
            _symbolic_cache.popitem(last=False)
    return sym


# ---------------------------------------------------------------------------------- symbolic
@njit
def _etree(Cp, Ci, parent):
    """Elimination tree of the upper triangle (CSparse cs_etree)."""
    n = parent.size
    ancestor = np.empty(n, dtype=np.int64)
    for k in range(n):
        parent[k] = -1
        ancestor[k] = -1
        for p in range(Cp[k], Cp[k + 1]):
            i = Ci[p]
            while i != -1 and i < k:
                inext = ancestor[i]
                ancestor[i] = k
                if inext == -1:
                    parent[i] = k
                i = inext


@njit
def _ereach(Cp, Ci, k, parent, s, w):
    """Pattern of L(k, :) (CSparse cs_ereach): s[top:n], in topological order."""
    n = parent.size
    top = n
    w[k] = k
    for p in range(Cp[k], Cp[k + 1]):
        i = Ci[p]
        if i > k:
            continue
        length = 0
        while w[i] != k:
            s[length] = i
            length += 1
            w[i] = k
            i = parent[i]
        while length > 0:
            top -= 1
            length -= 1
            s[top] = s[length]
    return top


@njit
def _row_counts(Cp, Ci, parent, counts):
    """counts[i] = off-diagonal entries of column i of L; returns their total."""
    n = parent.size
    s = np.empty(n, dtype=np.int64)
    w = np.full(n, -1, dtype=np.int64)
    total = 0
    for k in range(n):
        top = _ereach(Cp, Ci, k, parent, s, w)
        for t in range(top, n):
            counts[s[t]] += 1
        total += n - top
    return total


@njit
def _row_patterns(Cp, Ci, parent, Lp, Li, Rp, Rj, Rpos):
    """Li (rows of each column of L, diagonal first) and, per row k, the columns i of L(k, :)
    in visiting order (Rj) with the position of L(k, i) in Li (Rpos)."""
    n = parent.size
    s = np.empty(n, dtype=np.int64)
    w = np.full(n, -1, dtype=np.int64)
    c = Lp[:-1].copy()
    t_out = 0
    for k in range(n):
        Li[c[k]] = k
        c[k] += 1
    for k in range(n):
        top = _ereach(Cp, Ci, k, parent, s, w)
        Rp[k] = t_out
        for t in range(top, n):
            i = s[t]
            Rj[t_out] = i
            Rpos[t_out] = c[i]
            Li[c[i]] = k
            c[i] += 1
            t_out += 1
    Rp[n] = t_out


# ---------------------------------------------------------------------------------- numeric
@njit
def numeric(sym, Cx, Lx, x):
    """L L^T = C (values Cx of the upper triangle). Returns False on a pivot <= 0 or NaN."""
    return factor(sym, Cx, Lx, x, 0.0, x[:0]) == 0


@njit
def factor(sym, Cx, Lx, x, drop_tol, dropped):
    """The up-looking Cholesky factorisation of C = P A P^T.

    drop_tol = 0: returns 0 on success, -1 on a pivot <= 0 or NaN. drop_tol > 0: a row k whose
    pivot is <= drop_tol times its diagonal entry depends (to that tolerance) on the rows
    before it in the elimination order; it is left out -- L_kk = inf, so it takes no part in
    the other rows and ``solve`` gives it 0 -- and marked dropped[k] = 1 (permuted index).
    Returns the number of rows left out."""
    return factor_shifted(sym, Cx, Lx, x, drop_tol, dropped, 0.0)[0]


@njit
def factor_shifted(sym, Cx, Lx, x, drop_tol, dropped, shift):
    """:func:`factor` of C + shift diag(C) (shift >= 0, relative). Returns (its result, the
    smallest pivot over its diagonal entry): how close C is to singular (0 where a row was
    dropped or the factorisation failed)."""
    Cp, Ci, Lp, Li, Rp, Rj, Rpos, perm = sym
    n = Lp.size - 1
    count = 0
    ratio = 1.0
    for k in range(n):
        for p in range(Cp[k], Cp[k + 1]):
            x[Ci[p]] = Cx[p]
        x[k] *= 1.0 + shift
        d = x[k]
        ckk = d
        x[k] = 0.0
        for t in range(Rp[k], Rp[k + 1]):
            i = Rj[t]
            lki = x[i] / Lx[Lp[i]]
            x[i] = 0.0
            for p in range(Lp[i] + 1, Rpos[t]):
                x[Li[p]] -= Lx[p] * lki
            d -= lki * lki
            Lx[Rpos[t]] = lki
        if drop_tol > 0.0 and not d > drop_tol * abs(ckk):
            dropped[k] = 1
            Lx[Lp[k]] = np.inf
            count += 1
            ratio = 0.0
            continue
        if not d > 0.0:
            for t in range(Rp[k], Rp[k + 1]):      # leave x clean
                x[Rj[t]] = 0.0
            return -1, 0.0
        if d < ratio * ckk:
            ratio = d / ckk
        Lx[Lp[k]] = math.sqrt(d)
    return count, ratio


@njit
def numeric_ratio(sym, Cx, Lx, x):
    """:func:`numeric` returning the smallest pivot over its diagonal entry (-1 on a pivot <= 0
    or NaN)."""
    code, ratio = factor_shifted(sym, Cx, Lx, x, 0.0, x[:0], 0.0)
    return ratio if code == 0 else -1.0


@njit
def multiply(sym, Cx, b, out):
    """out = A b for A = P^T C P with C given by the values Cx of its upper triangle."""
    Cp, Ci, Lp, Li, Rp, Rj, Rpos, perm = sym
    n = Lp.size - 1
    for k in range(n):
        out[k] = 0.0
    for j in range(n):
        bj = b[perm[j]]
        for p in range(Cp[j], Cp[j + 1]):
            i = Ci[p]
            out[perm[i]] += Cx[p] * bj
            if i != j:
                out[perm[j]] += Cx[p] * b[perm[i]]


#: a pivot of the Cholesky factorisation at most this fraction of its diagonal entry marks the
#: matrix as (nearly) singular: a singular position, where the multipliers are no longer unique
#: but the accelerations are; the solve is then regularised (:func:`solve_regularised`). Two
#: windows (docs/choosing.md): the projection method's, wide, with the shift TIKHONOV_SHIFT --
#: the right-hand side near a singular position amplifies the states' error by one over the
#: small singular value of D, and the projection returns the impulse the regularised solve
#: withholds --, and the narrow one of the methods that cannot return it (standard, Baumgarte),
#: where every withheld impulse stays in the velocities as drift
SINGULAR_PIVOT = 1e-6
#: the relative diagonal shift of that regularisation
TIKHONOV_SHIFT = 1e-10
#: the narrow window and its shift (standard and Baumgarte methods)
SINGULAR_PIVOT_NARROW = 1e-8
TIKHONOV_SHIFT_NARROW = 1e-12
#: its iterations (iterated Tikhonov): the bias in a direction of relative eigenvalue s is
#: (shift / (s + shift))^TIKHONOV_ITERATIONS; at the switch (s = pivot) it is (1e-4)^3 = 1e-12
#: in both windows, so the switch is seamless
TIKHONOV_ITERATIONS = 3


@njit
def solve_regularised(sym, Cx, Lx, x, y, b, shift=TIKHONOV_SHIFT):
    """b <- the iterated Tikhonov solution of A lam = b, A = P^T C P (values Cx), for a nearly
    singular A: lam_0 = 0, lam_{i+1} = lam_i + (A + mu diag(A))^-1 (b - A lam_i), i <
    TIKHONOV_ITERATIONS, mu = shift (default TIKHONOV_SHIFT).

    In the eigendirections of A with relative eigenvalue s >> mu this is the exact solution to a
    relative (mu / s)^2; in those with s << mu (the near-dependent rows of a singular position)
    lam stays bounded, of order the residual / mu, instead of amplifying round-off and
    constraint drift by 1 / s. The accelerations are unique where lam is not, and this keeps
    them bounded and continuous through the singular position. Returns False if the shifted
    matrix is not positive definite either (a NaN, a negative diagonal)."""
    n = b.size
    if factor_shifted(sym, Cx, Lx, x, 0.0, x[:0], shift)[0] != 0:
        return False
    lam = np.zeros(n)
    r = b.copy()
    Ar = np.empty(n)
    for it in range(TIKHONOV_ITERATIONS):
        solve(sym, Lx, r, y)                      # r <- (A + mu diag A)^-1 r
        for k in range(n):
            lam[k] += r[k]
        if it + 1 < TIKHONOV_ITERATIONS:
            multiply(sym, Cx, lam, Ar)
            for k in range(n):
                r[k] = b[k] - Ar[k]
    for k in range(n):
        b[k] = lam[k]
    return True


@njit
def solve(sym, Lx, b, y):
    """b <- A^-1 b with A = P^T L L^T P (y: work array of size n)."""
    Cp, Ci, Lp, Li, Rp, Rj, Rpos, perm = sym
    n = Lp.size - 1
    for k in range(n):
        y[k] = b[perm[k]]
    for j in range(n):                              # L y = b
        y[j] /= Lx[Lp[j]]
        yj = y[j]
        for p in range(Lp[j] + 1, Lp[j + 1]):
            y[Li[p]] -= Lx[p] * yj
    for j in range(n - 1, -1, -1):                  # L^T x = y
        s = y[j]
        for p in range(Lp[j] + 1, Lp[j + 1]):
            s -= Lx[p] * y[Li[p]]
        y[j] = s / Lx[Lp[j]]
    for k in range(n):
        b[perm[k]] = y[k]
