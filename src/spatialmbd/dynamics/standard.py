"""Standard Lagrange multipliers method, Eqs. (12.3)-(12.6).

With M block diagonal the Schur complement is cheap: lam = S^-1 (gamma - D M^-1 g) with
S = D M^-1 D^T (12.5), then vdot = M^-1 (g + D^T lam) (12.4) -- signs for the convention
D^T lam = reaction forces (eom.py). S is factorised by Cholesky (dense) or sparse LU with a
fill-reducing ordering (large systems). solver="kkt" instead factorises the whole augmented
matrix [M, -D^T; D, 0] with a pivoting LU (12.3).

Redundant constraints: rows found dependent at the start (mobility) are left out (reduced
sense, their multipliers are 0 and the reactions of their joints are not unique); if S is
singular at some instant anyway, the minimum-norm multipliers are used for that instant.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SingularMatrixError
from .base import Method, MethodOutput, register

SOLVERS = ("schur", "kkt")


def solve_constrained(ev, rhs_gamma: np.ndarray, keep=None, solver: str = "schur"):
    """vdot, lam of [M, -D^T; D, 0][vdot; lam] = [g; rhs_gamma] (rows ``keep`` of D only)."""
    D = ev.cv.D
    m_all = D.shape[0]
    if keep is not None:
        D = D[keep]
        rhs_gamma = rhs_gamma[keep]
    Minv_g = ev.M.solve(ev.g)
    if D.shape[0] == 0:
        return Minv_g, np.zeros(m_all)
    if solver == "kkt":
        lam = _kkt(ev, D, rhs_gamma)
    elif sp.issparse(D):
        Minv_DT = _sparse_minv_dt(ev.M, D)
        S = (D @ Minv_DT).tocsc()
        b = rhs_gamma - D @ Minv_g
        try:
            lam = spla.splu(S, permc_spec="COLAMD").solve(b)
        except RuntimeError:
            lam = spla.lsqr(S, b, atol=1e-15, btol=1e-15)[0]
        if not np.all(np.isfinite(lam)):
            lam = spla.lsqr(S, b, atol=1e-15, btol=1e-15)[0]
    else:
        Minv_DT = ev.M.solve(D.T)
        S = D @ Minv_DT                                           # Eq. (12.5)
        b = rhs_gamma - D @ Minv_g
        try:
            lam = la.cho_solve(la.cho_factor(S, check_finite=False), b, check_finite=False)
        except la.LinAlgError:
            lam = la.lstsq(S, b, check_finite=False)[0]           # minimum norm, redundant
    vdot = Minv_g + ev.M.solve(D.T @ lam)                         # Eq. (12.4)
    if keep is not None:
        full = np.zeros(m_all)
        full[keep] = lam
        lam = full
    return vdot, lam


def _sparse_minv_dt(M, D):
    """M^-1 D^T as a sparse matrix (block-diagonal M^-1 times sparse D^T)."""
    nb = M.mass.size
    blocks = np.zeros((nb, 6, 6))
    blocks[:, 0, 0] = blocks[:, 1, 1] = blocks[:, 2, 2] = 1.0 / M.mass
    blocks[:, 3:, 3:] = M.J_inv
    rows = (np.arange(nb)[:, None, None] * 6 + np.arange(6)[None, :, None]).repeat(6, axis=2)
    cols = (np.arange(nb)[:, None, None] * 6 + np.arange(6)[None, None, :]).repeat(6, axis=1)
    Minv = sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(6 * nb, 6 * nb))
    return Minv @ D.T.tocsr()


def _kkt(ev, D, rhs_gamma):
    n = D.shape[1]
    m = D.shape[0]
    Dd = D.toarray() if sp.issparse(D) else D
    K = np.zeros((n + m, n + m))
    K[:n, :n] = ev.M.dense()
    K[:n, n:] = -Dd.T
    K[n:, :n] = Dd
    rhs = np.concatenate([ev.g, rhs_gamma])
    lu, piv = la.lu_factor(K, check_finite=False)
    if np.abs(np.diag(lu)).min() < 1e-14 * np.abs(np.diag(lu)).max():
        sol = la.lstsq(K, rhs, check_finite=False)[0]
    else:
        sol = la.lu_solve((lu, piv), rhs, check_finite=False)
    return sol[n:]


@register
class Standard(Method):
    """Lagrange multipliers, index-1 form (12.3); constraint drift is not corrected."""

    name = "standard"

    def __init__(self, solver: str = "schur"):
        if solver not in SOLVERS:
            raise ValueError(f"standard method: unknown solver {solver!r}; valid: {SOLVERS}")
        self.solver = solver

    def setup(self, eom, redundant_rows=None):
        super().setup(eom, redundant_rows)
        self.keep = None
        if redundant_rows is not None and len(redundant_rows):
            keep = np.ones(eom.model.n_eq, dtype=bool)
            keep[redundant_rows] = False
            self.keep = np.nonzero(keep)[0]

    def rhs_gamma(self, ev):
        return ev.cv.gamma

    def accelerations(self, ev, t):
        vdot, lam = solve_constrained(ev, self.rhs_gamma(ev), self.keep, self.solver)
        if not np.all(np.isfinite(vdot)):
            err = SingularMatrixError(f"t = {t:.6g} s: the system matrix D M^-1 D^T is singular "
                                      "(singular configuration or redundant constraints)")
            err.t = t
            raise err
        return MethodOutput(vdot, lam)

    def parameters(self):
        return {"solver": self.solver}
