"""The one rank decision: which constraint equations are independent, which depend on others,
and which multipliers (reactions) are therefore not unique.

Every analysis that needs a rank -- mobility and the redundant equations left out of the
multiplier solve, the determinacy of reactions in inverse dynamics, statics and quasi-statics,
the null spaces of linearization -- takes it from here, so they all agree.

**Why not the SVD or QR with column pivoting.** The number of singular values above a
tolerance is well defined when there is a gap, but *which* rows a pivoted QR leaves out is
decided by comparing column norms: the equations of a symmetric mechanism (the N-four-bar's
identical loops) tie exactly, and the tie is broken by the last bits of round-off, which differ
between BLAS kernels. The rows left out then differ from machine to machine, and so does every
later result that depends on them.

**The rule used here.** The rows are taken in the model's own order (joints as declared, each
joint's equations in their documented order); a row is *dependent* when its distance to the span
of the independent rows before it is at most ``RANK_RTOL`` times its own length. The
orthogonalisation is a modified Gram--Schmidt with one re-orthogonalisation, compiled, with no
BLAS call, so its arithmetic is the same on every processor. Exactly redundant rows have
relative distances of 1e-15 or so (round-off); independent rows of any mechanism that is not at
a singular position have distances many orders above ``RANK_RTOL``, so the decision sits in the
gap and does not hang on round-off. A mechanism placed within about ``RANK_RTOL`` of a singular
position (``sigma_min / sigma_max`` below 1e-9) is treated as being at it.

The dependent rows give the self-stress states directly: row k = sum_j c_kj (independent row
j), so ``w = e_k - sum_j c_kj e_j`` satisfies D^T w = 0. The multiplier of a row is unique
exactly when every self-stress vanishes on it, so :func:`nonunique_rows` is the support of
these vectors -- all the rows of a redundant loop, not only the one left out.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .jit import njit

#: a row whose distance to the span of the independent rows before it is at most this fraction
#: of its length depends on them
RANK_RTOL = 1e-9
#: a self-stress coefficient below this (relative to the largest of its vector) is round-off
SUPPORT_RTOL = 1e-7


class RowRank(NamedTuple):
    """The rank decision of a matrix D (m x n).

    rank: number of independent rows. independent, dependent: row indices (ascending).
    coefficients: (len(dependent), len(independent)): dependent row k = coefficients[k] @
    D[independent] (to round-off). distance: (m,) the relative distance of each row to the span
    of the independent rows before it (1 for the first nonzero row; 0 for a zero row)."""

    rank: int
    independent: np.ndarray
    dependent: np.ndarray
    coefficients: np.ndarray
    distance: np.ndarray


@njit
def _greedy_rows(D, rtol, Q, R, distance, keep):
    """Modified Gram-Schmidt over the rows of D in order (twice, for orthogonality): Q (r, n)
    the orthonormal basis of the independent rows, R (m, r) the coefficients of each row in it,
    keep[k] = 1 for independent rows. Returns r."""
    m, n = D.shape
    r = 0
    w = np.empty(n)
    for k in range(m):
        norm = 0.0
        for c in range(n):
            w[c] = D[k, c]
            norm += w[c] * w[c]
        norm = math.sqrt(norm)
        for sweep in range(2):
            for j in range(r):
                s = 0.0
                for c in range(n):
                    s += Q[j, c] * w[c]
                R[k, j] += s
                for c in range(n):
                    w[c] -= s * Q[j, c]
        rest = 0.0
        for c in range(n):
            rest += w[c] * w[c]
        rest = math.sqrt(rest)
        distance[k] = rest / norm if norm > 0.0 else 0.0
        if norm > 0.0 and rest > rtol * norm:
            for c in range(n):
                Q[r, c] = w[c] / rest
            R[k, r] = rest
            keep[k] = 1
            r += 1
    return r


def row_rank(D, rtol: float = RANK_RTOL) -> RowRank:
    """The independent and dependent rows of D (dense or sparse, m x n): see the module doc."""
    D = np.ascontiguousarray(D.toarray() if hasattr(D, "toarray") else D, dtype=float)
    if D.ndim != 2:
        raise ValueError(f"row_rank: D must be a matrix, got shape {D.shape}")
    m, n = D.shape
    if m == 0:
        e = np.zeros(0, dtype=np.int64)
        return RowRank(0, e, e, np.zeros((0, 0)), np.zeros(0))
    Q = np.zeros((min(m, n), n))
    R = np.zeros((m, min(m, n)))
    distance = np.zeros(m)
    keep = np.zeros(m, dtype=np.int8)
    r = int(_greedy_rows(D, float(rtol), Q, R, distance, keep))
    independent = np.flatnonzero(keep).astype(np.int64)
    dependent = np.flatnonzero(keep == 0).astype(np.int64)
    # dependent row k = R[k, :r] @ Q[:r] and D[independent] = R[independent, :r] @ Q[:r]
    # (lower triangular, nonsingular): coefficients c_k = R[k] R_ind^-1
    if dependent.size and r:
        L = R[independent, :r]
        coefficients = np.linalg.solve(L.T, R[dependent, :r].T).T
    else:
        coefficients = np.zeros((dependent.size, r))
    return RowRank(r, independent, dependent, coefficients, distance)


def self_stresses(D, rank: RowRank | None = None) -> np.ndarray:
    """(m, number of dependent rows): a basis of {w : D^T w = 0}, one column per dependent row
    (that row with coefficient 1, the independent rows it depends on with -c)."""
    rank = row_rank(D) if rank is None else rank
    m = rank.distance.size
    W = np.zeros((m, rank.dependent.size))
    for col, k in enumerate(rank.dependent):
        W[k, col] = 1.0
        W[rank.independent, col] = -rank.coefficients[col]
    return W


def nonunique_rows(D, rank: RowRank | None = None) -> np.ndarray:
    """Rows whose multipliers are not unique: the support of the self-stress states (every
    row of a redundant loop). Sorted indices."""
    W = self_stresses(D, rank)
    if W.shape[1] == 0:
        return np.zeros(0, dtype=np.int64)
    big = np.abs(W).max(axis=0)
    return np.flatnonzero((np.abs(W) > SUPPORT_RTOL * big[None, :]).any(axis=1)).astype(np.int64)


def left_null_space(D, rank: RowRank | None = None) -> np.ndarray:
    """Orthonormal basis (m, m - rank) of {w : D^T w = 0}, the span of the self-stresses."""
    W = self_stresses(D, rank)
    if W.shape[1] == 0:
        return W
    Qw, _ = np.linalg.qr(W)
    return Qw


def null_space(D, rank: RowRank | None = None):
    """(orthonormal basis (n, n - rank) of {x : D x = 0}, rank), with the rank of
    :func:`row_rank`."""
    D = np.asarray(D.toarray() if hasattr(D, "toarray") else D, dtype=float)
    n = D.shape[1]
    if D.shape[0] == 0:
        return np.eye(n), 0
    rank = row_rank(D) if rank is None else rank
    Di = D[rank.independent]
    if Di.shape[0] == 0:
        return np.eye(n), 0
    # complete QR of the independent rows' transpose: the last n - r columns span the null
    # space (D's dependent rows add nothing to it)
    Qf, _ = np.linalg.qr(Di.T, mode="complete")
    return Qf[:, rank.rank:].copy(), rank.rank
