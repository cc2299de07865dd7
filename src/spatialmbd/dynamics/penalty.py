"""Penalty method, Eqs. (12.9)-(12.15):

    (M + alpha D^T D) vdot = g - alpha D^T (-gamma + 2 mu omega Phidot + omega^2 Phi)   (12.14)

The constraint forces are D^T lam with lam = -alpha (D vdot - gamma + 2 mu omega Phidot +
omega^2 Phi) (the convention of eom.py). Redundant constraints need no special treatment: the
leading matrix stays positive definite. Defaults alpha = 1e7, omega = 10, mu = 1 (text); with
option ``project`` omega = mu = 0 (:class:`_PenaltyBase`).

M + alpha D^T D has the block pattern of the bodies connected by joints; it is assembled into
that fixed pattern and factorised by a sparse Cholesky (compiled: :func:`penalty_solve`).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import ModelError, SingularMatrixError
from . import system as cs
from .base import Method, MethodOutput, check_positive, check_singular, register
from .step_projection import ProjectsState
from .standard import _y_of


#: the projection of the penalty methods with option ``project``: max |Phi| (m; never coarser
#: than the run's atol, :meth:`.projection.ProjectsState.tolerance_for`) and Newton iterations
PROJECTION_TOLERANCE = 1e-10
PROJECTION_ITERATIONS = 10


class _PenaltyBase(ProjectsState, Method):
    """Option ``project`` (default True): after every accepted step the positions and
    velocities are projected onto Phi = 0 and D v = nu in the metric of the mass matrix, as the
    projection method does -- the penalty and augmented Lagrangian formulations with
    projections (Bayo and Ledesma 1996). The run then stays on the constraint manifold instead
    of the drifted one the penalty's compliance holds it on, and passes singular positions
    straight (docs/choosing.md). project=False: the text's formulation (12.14) alone, whose
    drift decides the branch at a singular position -- there option ``singular`` applies
    (:mod:`.singular_guard`)."""
    #: augmented Lagrangian iterations (12.17) instead of one penalty solve (False here)
    iterate = False

    def __init__(self, alpha: float = 1e7, omega: Optional[float] = None,
                 mu: Optional[float] = None, singular: str = "stop", project: bool = False):
        self.singular = check_singular(self.name, singular)
        if not isinstance(project, (bool, np.bool_)):
            raise ModelError(f"{self.name} project: expected true or false, got {project!r} "
                             "(true: project the positions and velocities onto the constraints "
                             "after every step; false: the text's formulation alone)")
        self.project_steps = bool(project)
        self.projects = self.project_steps        # the run projects after every step
        self.follows_drift = not self.project_steps
        # the stabilisation terms of (12.14) by default only without the projection, which
        # removes the drift itself: with both, the terms 2 mu omega Phidot + omega^2 Phi act on
        # what the step left before the projection, and the N-four-bar's augmented Lagrangian
        # run (rk45, rtol 1e-6) took 389 steps to 171 and ended 2.5e-4 m off the exact path to
        # 4.5e-5 m (docs/choosing.md)
        if omega is None:
            omega = 0.0 if self.project_steps else 10.0
        if mu is None:
            mu = 0.0 if self.project_steps else 1.0
        self.alpha = check_positive(f"{self.name} alpha", alpha)
        self.omega = check_positive(f"{self.name} omega", omega, allow_zero=True)
        self.mu = check_positive(f"{self.name} mu", mu, allow_zero=True)

    def _singular(self, t):
        err = SingularMatrixError(f"t = {t:.6g} s: M + alpha D^T D is not positive definite "
                                  "(a body has a singular mass matrix?)")
        err.t = t
        return err

    def params(self) -> np.ndarray:
        """mp of the compiled solve (:data:`.system.MP_PENALTY`)."""
        return np.array([1.0, self.alpha, self.omega, self.mu, float(self.iterate),
                         getattr(self, "tolerance", 0.0), getattr(self, "max_iterations", 1),
                         getattr(self, "floor", 0.0)])

    def kernels(self, system, W=None):
        KI, KW = system.penalty_pack()
        self._mp = self.params()
        return (rhs_penalty, after_state_penalty,
                (system.F, system.I, system.W if W is None else W, KI, KW, self._mp))

    def stages(self, system):
        """The compiled ``ODEProblem.stages`` hook (see Standard.stages)."""
        if not system.fused or system.table.has_drivers:
            return None
        KI, KW = system.penalty_pack()
        F, I, W, mp = system.F, system.I, system.W, self._mp
        kernel = stages_penalty
        count = np.zeros(1, dtype=np.int64)
        method = self

        def stages(t, y, h, A, C, K, s0, s1, out, t_last):
            done = kernel(t, y, h, A, C, K, s0, s1, out, t_last, F, I, W, KI, KW, mp, count)
            if method.iterate:
                method.total_iterations += int(count[0])
                count[0] = 0
            return done
        return stages

    def status(self, code, system, t, y, ydot, W=None):
        if code == cs.SINGULAR:
            raise self._singular(t)
        if code == cs.NOT_CONVERGED:
            raise self._not_converged(t)
        return code

    def accelerations(self, ev, t):
        sys_ = ev.system
        mp = self.__dict__.get("_mp")
        if mp is None:
            mp = self._mp = self.params()
        KI, KW = sys_.penalty_pack()
        y = _y_of(ev)
        code = after_state_penalty(y, np.empty(y.size), sys_.F, sys_.I, ev.W, KI, KW, mp)
        if code < 0:
            self.status(code, sys_, t, y, None, ev.W)
        it = max(code, 0)
        if self.iterate:
            self.total_iterations += it
        return MethodOutput(sys_.fields(ev.W, "vdot").copy(), sys_.fields(ev.W, "lam").copy(),
                            it)

    def _projection_settings(self):
        return PROJECTION_TOLERANCE, PROJECTION_ITERATIONS

    def _projection_advice(self, iterations, tol) -> str:
        return (f"the {self.name} method's projection ({iterations} iterations, tolerance "
                f"{tol:.3g}) failed here; run with method option project: false, or method "
                "projection")

    def parameters(self):
        return {"alpha": self.alpha, "omega": self.omega, "mu": self.mu,
                "singular": self.singular, "project": self.project_steps}


@register
class Penalty(_PenaltyBase):
    """The penalty method (12.14). With option ``project`` its step projection is in the
    metric of its own leading matrix K = M + alpha D^T D (Bayo and Ledesma 1996):

        q <- q - K^-1 alpha D^T Phi (iterated),    v <- v - K^-1 alpha D^T (D v - nu)

    Along a direction in which D keeps a singular value sigma this removes the violation as the
    mass metric does where alpha sigma^2 >> m, and leaves it where the penalty's own stiffness
    alpha sigma^2 is small -- near a singular position, where the penalty delivers only part of
    the constraint force along the near-dependent rows. Removing the velocity that part left
    (the mass metric) is a plastic impact: the 2-loop N-four-bar lost 0.5 J of its 35.8 J at
    its first flat position (rk45, rtol 1e-8), against 4e-6 J over 10 s in this metric
    (docs/choosing.md). The augmented Lagrangian, whose iterations deliver the whole force,
    projects in the mass metric."""
    name = "penalty"

    def project_y(self, system, t, y, tolerance=None, multistep=False):
        if system.python_groups:             # no compiled constraints: the mass metric
            return super().project_y(system, t, y, tolerance, multistep)
        y = y.copy()
        tol = PROJECTION_TOLERANCE if tolerance is None else float(tolerance)
        if system.table.has_drivers:
            system.table.set_time(t)
        KI, KW = system.penalty_pack()
        mp = self.__dict__.get("_mp")
        if mp is None:
            mp = self._mp = self.params()
        if penalty_project(t, y, system.F, system.I, system.W, KI, KW, mp, tol,
                           PROJECTION_ITERATIONS) < 0:
            err = SingularMatrixError(
                f"t = {t:.6g} s: the penalty method's projection failed: M + alpha D^T D is "
                "not positive definite or the positions are not finite; run with method "
                "option project: false, or method projection")
            err.t = t
            raise err
        return y


# -------------------- Compiled solve of the penalty and augmented Lagrangian methods, Eq. (12.14)
import math
from ..integrators.explicit import rk_combine
from .layout import unpack_k
from . import sparse as spc
from ..jit import njit
from ..jit import array_view
from .projection_kernels import move_positions
from .system import (NOT_CONVERGED, NOT_FINITE, OK, SINGULAR, _M, _R, _write_ydot,
                     add_transpose_times, body_views, cons_views, copy, copy_v, fill, finite,
                     force_views, m_all, minv_all, row_times, stage_state)  # noqa: E402


@njit
def assemble_penalty(M, R, blkpos, rowblk, alpha, armature, Kx):
    """Kx = values of M + alpha D^T D (12.14): the body blocks of M, and alpha D_r^T D_r of
    every row r into the blocks of its bodies; an armature row (the last armature.size rows,
    forces.armature) adds J B^T B instead (M + J B^T B is the mass matrix with the rotor)."""
    mass, J, Jinv = M
    D = R[0]
    m_con = D.shape[0] - armature.size
    fill(Kx, 0.0)
    for b in range(mass.size):
        for a in range(6):
            for c in range(6):
                pos = blkpos[b, a, c]
                if pos < 0:
                    continue
                if a < 3 and c < 3:
                    if a == c:
                        Kx[pos] += mass[b]
                elif a >= 3 and c >= 3:
                    Kx[pos] += J[b, a - 3, c - 3]
    for r in range(D.shape[0]):
        bii, bjj, bij, flip = rowblk[r, 0], rowblk[r, 1], rowblk[r, 2], rowblk[r, 3]
        if flip < 0:                          # a redundant row left out (drop_penalty_rows)
            continue
        weight = alpha if r < m_con else armature[r - m_con]
        for a in range(6):
            da_i = weight * D[r, a]
            da_j = weight * D[r, 6 + a]
            for c in range(6):
                if bii >= 0:
                    pos = blkpos[bii, a, c]
                    if pos >= 0:
                        Kx[pos] += da_i * D[r, c]
                if bjj >= 0:
                    pos = blkpos[bjj, a, c]
                    if pos >= 0:
                        Kx[pos] += da_j * D[r, 6 + c]
                if bij >= 0:
                    pos = blkpos[bij, c, a] if flip else blkpos[bij, a, c]
                    Kx[pos] += da_i * D[r, 6 + c]


@njit
def penalty_solve(M, R, phi, nu, gamma, g, v, k, mp, lam, vdot, t6, armature):
    """Penalty (12.14) or augmented Lagrangian (12.16)-(12.18) accelerations and lam.

    gamma, lam: over all rows of R, the constraint rows (as many as phi) and then the armature
    rows, whose J (armature) puts J B^T B into the leading matrix and J B^T gamma_B into the
    right-hand side, exactly (their lam is the rotor's mu = -J theta'').

    Returns the number of iterations (0 for the penalty method), SINGULAR if
    M + alpha D^T D is not positive definite, NOT_CONVERGED if the augmented Lagrangian
    iteration did not converge."""
    alpha, omega, mu, al = mp[1], mp[2], mp[3], mp[4] != 0.0
    tol, max_it, floor = mp[5], int(mp[6]), mp[7]
    n = vdot.size
    m = phi.size
    na = armature.size
    assemble_penalty(M, R, k.blkpos, k.rowblk, alpha, armature, k.Kx)
    sym = (k.K_Cp, k.K_Ci, k.K_Lp, k.K_Li, k.K_Rp, k.K_Rj, k.K_Rpos, k.K_perm)
    if not spc.numeric(sym, k.Kx, k.KLx, k.xk):
        return SINGULAR
    # constraint dynamics term of (12.14): c = -gamma + 2 mu omega Phidot + omega^2 Phi
    for a in range(m):
        if k.rowblk[a, 3] < 0:                # a redundant row left out
            k.ck[a] = 0.0
            continue
        phidot = row_times(R, a, v) - nu[a]
        k.ck[a] = -gamma[a] + 2.0 * mu * omega * phidot + omega * omega * phi[a]
    for a in range(m, m + na):                # alpha c = -J gamma_B: g + J B^T gamma_B
        k.ck[a] = -gamma[a] * (armature[a - m] / alpha)
    fill(k.dtc, 0.0)
    add_transpose_times(R, k.ck, k.dtc)
    if not al:
        for j in range(n):
            vdot[j] = g[j] - alpha * k.dtc[j]
        spc.solve(sym, k.KLx, vdot, k.yk)
        # one step of iterative refinement: with a large alpha and light bodies M + alpha D^T D
        # is ill-conditioned (cond ~ alpha |D|^2 / m_min), and the round-off of one solve,
        # cond eps relative, is noise in the right-hand side that implicit integrators'
        # Newton iterations cannot converge through; the residual of the solve, corrected
        # once, brings it to the level of the data
        m_all(M, vdot, t6)                                            # M x
        for a in range(m):
            lam[a] = alpha * row_times(R, a, vdot) if k.rowblk[a, 3] >= 0 else 0.0
        for a in range(m, m + na):
            lam[a] = armature[a - m] * row_times(R, a, vdot)
        add_transpose_times(R, lam, t6)                               # + alpha D^T D x
        for j in range(n):
            t6[j] = g[j] - alpha * k.dtc[j] - t6[j]                   # residual
        spc.solve(sym, k.KLx, t6, k.yk)
        for j in range(n):
            vdot[j] += t6[j]
        for a in range(m):
            lam[a] = (-alpha * (row_times(R, a, vdot) + k.ck[a]) if k.rowblk[a, 3] >= 0
                      else 0.0)
        _rotor_mu(R, gamma, armature, m, vdot, lam)
        return OK
    minv_all(M, g, vdot)                                              # (12.16)
    fill(lam, 0.0)
    previous = np.inf
    for it in range(1, max_it + 1):
        copy(k.old, vdot)
        m_all(M, k.old, t6)
        if it > 1:                # the rotors' (M + J B^T B) vdot_i - J B^T gamma_B (M vdot_0 = g)
            for a in range(m, m + na):
                _add_row(R, a, armature[a - m] * (row_times(R, a, k.old) - gamma[a]), t6)
        for j in range(n):
            vdot[j] = t6[j] - alpha * k.dtc[j]
        spc.solve(sym, k.KLx, vdot, k.yk)                            # (12.17)
        for a in range(m):
            if k.rowblk[a, 3] >= 0:
                lam[a] += -alpha * (row_times(R, a, vdot) + k.ck[a])
        change = 0.0
        big = 1.0
        for j in range(n):
            change += (vdot[j] - k.old[j]) ** 2
            big = max(big, abs(vdot[j]))
        change = math.sqrt(change)
        at_floor = change <= floor * big and change > 0.5 * previous
        if change <= tol * big or at_floor:                           # (12.18)
            _rotor_mu(R, gamma, armature, m, vdot, lam)
            return it
        previous = change
    return NOT_CONVERGED


@njit(inline="always")
def _add_row(R, a, w, out):
    """out += w D[a]^T (row a of R over the columns of its two bodies)."""
    D, row_bi, row_bj = R
    nb = out.size // 6
    bi, bj = row_bi[a], row_bj[a]
    if bi < nb:
        for c in range(6):
            out[6 * bi + c] += D[a, c] * w
    if bj < nb:
        for c in range(6):
            out[6 * bj + c] += D[a, 6 + c] * w


@njit(inline="always")
def _rotor_mu(R, gamma, armature, m, vdot, lam):
    """lam of the armature rows m, m + 1, ...: mu = -J (B vdot - gamma_B) = -J theta''."""
    for a in range(m, m + armature.size):
        lam[a] = -armature[a - m] * (row_times(R, a, vdot) - gamma[a])


@njit
def rhs_penalty(t, y, ydot, F, I, W, KI, KW, mp):
    stage_state(t, y, mp[0], F, I, W)
    return after_state_penalty(y, ydot, F, I, W, KI, KW, mp)


@njit
def after_state_penalty(y, ydot, F, I, W, KI, KW, mp):
    return _after_penalty(y, ydot, body_views(F, I, W), cons_views(F, I, W),
                          force_views(F, I, W), unpack_k(KI, KW), mp)


@njit
def stages_penalty(t, y, h, A, C, K, s0, s1, out, t_last, F, I, W, KI, KW, mp, iterations):
    """:func:`stages_standard` for the penalty / augmented Lagrangian methods; adds the inner
    iterations to iterations[0]."""
    for s in range(s0, s1):
        rk_combine(y, h, A, K, s, out)
        stage_state(t_last if s == s1 - 1 else t + C[s] * h, out, mp[0], F, I, W)
        it = after_state_penalty(out, K[s], F, I, W, KI, KW, mp)
        if it < 0:
            return s
        iterations[0] += it
    return s1


@njit(inline="always")
def _after_penalty(y, ydot, bo, co, fo, k, mp):
    copy_v(y, bo.v)
    it = penalty_solve(_M(bo), _R(co), co.phi, co.nu, co.gamma_all, bo.g, bo.v, k, mp,
                       co.lam_all, bo.vdot, bo.t6, k.rotor)
    if it < 0:
        return it
    _write_ydot(bo, co, fo, ydot)
    return it if finite(ydot) else NOT_FINITE


@njit
def penalty_project(t, y, F, I, W, KI, KW, mp, tol, max_it):
    """The penalty method's step projection (:class:`Penalty`), in place on y: Newton-like
    iterations q <- q - K^-1 alpha D^T Phi until max |Phi| <= tol or ``max_it`` of them (along
    a near-dependent direction it converges only by the factor m / (m + alpha sigma^2) per
    iteration, and that is meant), rotations applied exactly, then v <- v - K^-1 alpha D^T
    (D v - nu) at the final positions; K = M + alpha D^T D (12.14) factorised at each
    position. Returns the iterations, SINGULAR if K is not positive definite, NOT_FINITE if
    the positions are not finite."""
    bo, co, k = body_views(F, I, W), cons_views(F, I, W), unpack_k(KI, KW)
    nb = bo.mass.size
    m = co.phi.size
    q = array_view(y, 0, (nb, 7))
    M, R = _M(bo), _R(co)
    sym = (k.K_Cp, k.K_Ci, k.K_Lp, k.K_Li, k.K_Rp, k.K_Rj, k.K_Rpos, k.K_perm)
    alpha = mp[1]
    it = 0
    while True:
        stage_state(t, y, 0.0, F, I, W)
        err = 0.0
        for a in range(m):
            if k.rowblk[a, 3] >= 0:
                err = max(err, abs(co.phi[a]))
        if not math.isfinite(err):
            return NOT_FINITE
        assemble_penalty(M, R, k.blkpos, k.rowblk, alpha, k.rotor, k.Kx)
        if not spc.numeric(sym, k.Kx, k.KLx, k.xk):
            return SINGULAR
        if err <= tol or it == max_it:
            break
        _k_correction(M, R, co.phi, k, sym, alpha, m, bo.t6, bo.u6, co.lam_all)
        move_positions(q, bo.t6)
        it += 1
    copy_v(y, bo.v)
    for a in range(m):
        co.rg[a] = row_times(R, a, bo.v) - co.nu[a]
    _k_correction(M, R, co.rg, k, sym, alpha, m, bo.t6, bo.u6, co.lam_all)
    for j in range(6 * nb):
        y[7 * nb + j] += bo.t6[j]
    return it


@njit
def _k_correction(M, R, r, k, sym, alpha, m, out, res, lam):
    """out = -K^-1 alpha D^T r over the kept constraint rows (r: (>= m,); the armature rows
    beyond m carry no violation), K factorised in k.KLx, with one step of iterative refinement
    as in :func:`penalty_solve` (K's condition number is about alpha |D|^2 / m_min). res (6 nb,)
    and lam (the rows) are scratch."""
    for a in range(k.ck.size):
        k.ck[a] = r[a] if a < m and k.rowblk[a, 3] >= 0 else 0.0
    fill(k.dtc, 0.0)
    add_transpose_times(R, k.ck, k.dtc)
    for j in range(out.size):
        out[j] = -alpha * k.dtc[j]
    spc.solve(sym, k.KLx, out, k.yk)
    m_all(M, out, res)                                                # K out
    for a in range(lam.size):
        if a >= m:
            lam[a] = k.rotor[a - m] * row_times(R, a, out)
        else:
            lam[a] = alpha * row_times(R, a, out) if k.rowblk[a, 3] >= 0 else 0.0
    add_transpose_times(R, lam, res)
    for j in range(out.size):
        res[j] = -alpha * k.dtc[j] - res[j]                           # residual
    spc.solve(sym, k.KLx, res, k.yk)
    for j in range(out.size):
        out[j] += res[j]
