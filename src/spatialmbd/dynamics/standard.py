"""Standard Lagrange multipliers method, Eqs. (12.3)-(12.6).

With M block diagonal the Schur complement is cheap: lam = S^-1 (gamma - D M^-1 g) with
S = D M^-1 D^T (12.5), then vdot = M^-1 (g + D^T lam) (12.4) -- signs for the convention
D^T lam = reaction forces (eom.py). S is assembled body by body into its fixed sparsity pattern
and factorised by a sparse Cholesky with a fill-reducing ordering chosen once (compiled,
:mod:`.system`, :mod:`.sparse`): O(N) for chains and trees. solver="kkt" instead factorises the
whole augmented matrix [M, -D^T; D, 0] with a pivoting LU (12.3), densely.

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
from . import sparse as spc
from . import system as cs
from .base import Method, MethodOutput, check_singular, register

SOLVERS = ("schur", "kkt")
#: S up to this size is solved densely (lstsq) when it is singular, larger ones by LSQR
DENSE_FALLBACK_MAX = 2000


def fallback_multipliers(system, W) -> None:
    """lam of a singular S (minimum norm), from the values the compiled solve left in W."""
    Cx = system.fields(W, "Cx")
    b = system.fields(W, "bs")
    S = system.S.to_scipy(Cx)
    if S.shape[0] <= DENSE_FALLBACK_MAX:
        lam = la.lstsq(S.toarray(), b, check_finite=False)[0]
    else:
        lam = spla.lsqr(S, b, atol=1e-15, btol=1e-15)[0]
    full = system.fields(W, "lam_all")
    full[:] = 0.0
    full[system.keep_all] = lam


def singular_error(t):
    err = SingularMatrixError(f"t = {t:.6g} s: the system matrix D M^-1 D^T is singular "
                              "(singular configuration or redundant constraints)")
    err.t = t
    return err


def solve_kkt(ev, rhs_gamma: np.ndarray, keep=None):
    """vdot, lam of [M, -D^T; D, 0][vdot; lam] = [g; rhs_gamma] (rows ``keep`` of D only) by a
    dense pivoting LU of the whole augmented matrix (12.3): the solver="kkt" option. With
    armatures the rows [B, 0, 1/J] [vdot; lam; mu] = gamma_B join it (M vdot = g + D^T lam +
    B^T mu)."""
    D = ev.cv.D
    m_all = D.shape[0]
    if keep is not None:
        D = D[keep]
        rhs_gamma = rhs_gamma[keep]
    B, J, gamma_B = _armature_rows(ev)
    if B.shape[0]:                        # rows B vdot + mu / J = gamma_B (forces.armature)
        Dd = D.toarray() if sp.issparse(D) else np.asarray(D)
        sol = _kkt(ev, np.vstack([Dd, B]), np.concatenate([rhs_gamma, gamma_B]),
                   np.concatenate([np.zeros(Dd.shape[0]), 1.0 / J]))
        lam, mu = sol[:Dd.shape[0]], sol[Dd.shape[0]:]
        vdot = ev.M.solve(ev.g + Dd.T @ lam + B.T @ mu)
    elif D.shape[0] == 0:
        return ev.M.solve(ev.g), np.zeros(m_all)
    else:
        lam = _kkt(ev, D, rhs_gamma)
        vdot = ev.M.solve(ev.g + D.T @ lam)                       # Eq. (12.4)
    if keep is not None:
        full = np.zeros(m_all)
        full[keep] = lam
        lam = full
    return vdot, lam


def _armature_rows(ev):
    """(B (na, 6 nb) dense, J (na,), gamma_B (na,)) of the armature rows of the evaluation."""
    sys_ = getattr(ev, "system", None)
    na = 0 if sys_ is None else sys_.n_armature
    if not na:
        return np.zeros((0, ev.v.size)), np.zeros(0), np.zeros(0)
    m, nb = sys_.m, sys_.nb
    blocks = sys_.fields(ev.W, "D_all")[m:]
    B = np.zeros((na, 6 * nb + 6))                 # the ground's columns 6 nb.. dropped below
    rows, cols = np.arange(na)[:, None], np.arange(6)[None, :]
    B[rows, 6 * sys_.row_bi_all[m:, None] + cols] += blocks[:, :6]
    B[rows, 6 * sys_.row_bj_all[m:, None] + cols] += blocks[:, 6:]
    J = sys_.field_values("armature")
    return B[:, :6 * nb], J, sys_.fields(ev.W, "gamma_all")[m:].copy()


def _kkt(ev, D, rhs_gamma, compliance=None):
    n = D.shape[1]
    m = D.shape[0]
    Dd = D.toarray() if sp.issparse(D) else D
    K = np.zeros((n + m, n + m))
    K[:n, :n] = ev.M.dense()
    K[:n, n:] = -Dd.T
    K[n:, :n] = Dd
    if compliance is not None:
        K[n:, n:] = np.diag(compliance)
    rhs = np.concatenate([ev.g, rhs_gamma])
    lu, piv = la.lu_factor(K, check_finite=False)
    if np.abs(np.diag(lu)).min() < 1e-14 * np.abs(np.diag(lu)).max():
        sol = la.lstsq(K, rhs, check_finite=False)[0]
    else:
        sol = la.lu_solve((lu, piv), rhs, check_finite=False)
    return sol[n:]


def _y_of(ev):
    """The evaluated state vector [q, v] (the compiled solves read v from y)."""
    y = getattr(ev, "y", None)
    if y is None:
        nb = ev.v.size // 6
        y = np.zeros(13 * nb)
        y[7 * nb:] = ev.v
    return y


@register
class Standard(Method):
    """Lagrange multipliers, index-1 form (12.3); constraint drift is not corrected."""

    name = "standard"
    #: Baumgarte mode of the compiled solve (0: gamma as is)
    mode = 0

    follows_drift = True

    def __init__(self, solver: str = "schur", singular: str = "stop"):
        if solver not in SOLVERS:
            raise ValueError(f"standard method: unknown solver {solver!r}; valid: {SOLVERS}")
        self.solver = solver
        self.singular = check_singular(self.name, singular)

    def setup(self, eom, redundant_rows=None):
        super().setup(eom, redundant_rows)
        self._mp = self.params()
        self.keep = None
        if redundant_rows is not None and len(redundant_rows):
            keep = np.ones(eom.model.n_eq, dtype=bool)
            keep[redundant_rows] = False
            self.keep = np.nonzero(keep)[0]
        eom.set_keep(self.keep)

    def gains(self):
        """(alpha, beta) of the compiled right-hand side gamma - 2 alpha Phidot - beta^2 Phi."""
        return 0.0, 0.0

    #: the regularisation window of the multiplier solve at singular positions (pivot ratio,
    #: relative shift; :mod:`.sparse`): narrow here, since nothing returns the impulse a
    #: regularised solve withholds; the projection method widens it
    regularisation = (spc.SINGULAR_PIVOT_NARROW, spc.TIKHONOV_SHIFT_NARROW)

    def params(self) -> np.ndarray:
        """mp of the compiled solve: normalize, mode, alpha, beta, singular pivot, Tikhonov
        shift (:data:`.system.MP_STANDARD`)."""
        alpha, beta = self.gains()
        pivot, shift = self.regularisation
        return np.array([1.0, float(self.mode), alpha, beta, pivot, shift])

    def rhs_gamma(self, ev):
        """The right-hand side of D vdot = ... (gamma; Baumgarte: (12.8)), from the compiled
        code."""
        if self.mode == 0:
            return ev.cv.gamma
        sys_ = ev.system
        rhs_gamma_into(_y_of(ev), sys_.F, sys_.I, ev.W, self.params())
        return sys_.fields(ev.W, "rg").copy()

    # ---- compiled path: used by accelerations() and by simulate's right-hand side
    def kernels(self, system, W=None):
        if self.solver == "kkt":
            return None
        self._mp = self.params()
        return (rhs_standard, after_state_standard,
                (system.F, system.I, system.W if W is None else W, self._mp))

    def stages(self, system):
        """The compiled ``ODEProblem.stages`` hook (None when the right-hand side needs Python
        between its stages)."""
        if self.solver == "kkt" or not system.fused or system.table.has_drivers:
            return None
        F, I, W, mp = system.F, system.I, system.W, self._mp
        kernel = stages_standard

        def stages(t, y, h, A, C, K, s0, s1, out, t_last):
            return kernel(t, y, h, A, C, K, s0, s1, out, t_last, F, I, W, mp)
        return stages

    def status(self, code, system, t, y, ydot, W=None):
        """A singular S: minimum-norm multipliers for this instant; non-finite vdot: raise."""
        W = system.W if W is None else W
        if code == cs.SINGULAR:
            fallback_multipliers(system, W)
            code = fallback_finish(y, ydot, system.F, system.I, W)
        if code == cs.NOT_FINITE and not np.all(np.isfinite(system.fields(W, "vdot"))):
            raise singular_error(t)
        return code

    def accelerations(self, ev, t):
        if self.solver == "kkt":
            vdot, lam = solve_kkt(ev, self.rhs_gamma(ev), self.keep)
            if not np.all(np.isfinite(vdot)):
                raise singular_error(t)
            return MethodOutput(vdot, lam)
        sys_ = ev.system
        mp = self.__dict__.get("_mp")
        if mp is None:
            mp = self._mp = self.params()
        y = _y_of(ev)
        ydot = np.empty(y.size)
        code = after_state_standard(y, ydot, sys_.F, sys_.I, ev.W, mp)
        if code < 0:
            self.status(code, sys_, t, y, ydot, ev.W)
        return MethodOutput(sys_.fields(ev.W, "vdot").copy(), sys_.fields(ev.W, "lam").copy())

    def parameters(self):
        return {"solver": self.solver, "singular": self.singular}


# -------------------- Compiled right-hand side of the standard and Baumgarte methods
from ..integrators.explicit import rk_combine
from ..jit import njit
from .system import (NOT_FINITE, OK, SINGULAR, _M, _P, _R, _write_ydot, baumgarte_rhs, body_views,
                     cons_views, copy_v, finish, finite, force_views, schur_views,
                     solve_multipliers, stage_state)  # noqa: E402


@njit
def rhs_gamma_into(y, F, I, W, mp):
    """rg of :func:`baumgarte_rhs` at the evaluation in W (v read from y)."""
    bo, co = body_views(F, I, W), cons_views(F, I, W)
    copy_v(y, bo.v)
    baumgarte_rhs(_R(co), co.gamma, co.phi, co.nu, bo.v, int(mp[1]), mp[2], mp[3], co.rg)


@njit
def rhs_standard(t, y, ydot, F, I, W, mp):
    """The whole right-hand side of the standard / Baumgarte methods (no Python parts)."""
    stage_state(t, y, mp[0], F, I, W)
    return after_state_standard(y, ydot, F, I, W, mp)


@njit
def after_state_standard(y, ydot, F, I, W, mp):
    """The standard / Baumgarte solve after :func:`stage_state` (and the Python stage)."""
    return _after_standard(y, ydot, body_views(F, I, W), cons_views(F, I, W),
                           schur_views(F, I, W), force_views(F, I, W), mp)


@njit(inline="always")
def _after_standard(y, ydot, bo, co, sc, fo, mp):
    copy_v(y, bo.v)
    R = _R(co)
    baumgarte_rhs(R, co.gamma, co.phi, co.nu, bo.v, int(mp[1]), mp[2], mp[3], co.rg)
    if not solve_multipliers(_M(bo), R, _P(sc), bo.g, co.rg_all, co.lam_all, sc.bs, bo.t6,
                             bo.u6, bo.vdot, mp[4], mp[5]):
        return SINGULAR
    _write_ydot(bo, co, fo, ydot)
    return OK if finite(ydot) else NOT_FINITE


@njit
def stages_standard(t, y, h, A, C, K, s0, s1, out, t_last, F, I, W, mp):
    """Runge-Kutta stages s0 .. s1-1 with the standard / Baumgarte right-hand side (the
    ``ODEProblem.stages`` hook): out = y + h sum_j A[s, j] K[j], K[s] = f(t + C[s] h, out).
    Returns the first stage that did not succeed (s1 if all did)."""
    for s in range(s0, s1):
        rk_combine(y, h, A, K, s, out)
        stage_state(t_last if s == s1 - 1 else t + C[s] * h, out, mp[0], F, I, W)
        if after_state_standard(out, K[s], F, I, W, mp) != OK:
            return s
    return s1


@njit
def fallback_finish(y, ydot, F, I, W):
    """vdot and ydot after a fallback solve that has put lam into co.lam."""
    bo, co = body_views(F, I, W), cons_views(F, I, W)
    finish(_M(bo), _R(co), bo.g, co.lam_all, bo.t6, bo.vdot)
    _write_ydot(bo, co, force_views(F, I, W), ydot)
    return OK if finite(ydot) else NOT_FINITE
