"""Kinematic analysis (text ch. 7) and mobility (ch. 2).

Positions: Newton-Raphson on Phi(q, t) = 0 (7.2). D is the Jacobian with respect to the 6-per-body
velocities, while q has 7 coordinates per body (ERRATA for (14.6)); each iteration therefore
solves D [dr; dpi] = -Phi for a translation dr and a small global rotation dpi of every body and
applies the rotation exactly, p <- quat(dpi) (x) p. Because Phi(r + dr, exp(dpi~) A) =
Phi + D [dr; dpi] + O(|d|^2), the iteration converges quadratically and p stays unit length.

Velocities and accelerations: D v = nu (7.4) and D vdot = gamma (7.6), solved with the one
factorisation of D at the converged positions (Nikravesh 1988).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import ConvergenceError, ModelError, SingularMatrixError, SpatialMBDError
from .rank import RANK_RTOL, row_rank
from .rotations import rotate_p
from .state import BodyState


# ------------------------------------------------------------------------------- linear algebra
class JacobianFactor:
    """A factorisation of the square constraint Jacobian D (dense LU or sparse SuperLU), or a
    least-squares solver when D is not square (redundant but consistent constraints)."""

    def __init__(self, D, model, t: float):
        self.m, self.n = D.shape
        self.sparse = sp.issparse(D)
        self.square = self.m == self.n
        self.model = model
        try:
            if self.square and self.sparse:
                self._lu = spla.splu(sp.csc_matrix(D))
            elif self.square:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", la.LinAlgWarning)
                    self._lu = la.lu_factor(D, check_finite=False)
                diag = np.abs(np.diag(self._lu[0]))
                if diag.min() <= 1e-13 * max(diag.max(), 1.0):
                    raise np.linalg.LinAlgError("singular")
            else:
                self._D = D.toarray() if self.sparse else D
        except (RuntimeError, np.linalg.LinAlgError):
            raise singular_jacobian_error(D, model, t) from None

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self.square and self.sparse:
            return self._lu.solve(b)
        if self.square:
            return la.lu_solve(self._lu, b, check_finite=False)
        return np.linalg.lstsq(self._D, b, rcond=None)[0]


def _dense(D) -> np.ndarray:
    return D.toarray() if sp.issparse(D) else np.asarray(D)


def singular_jacobian_error(D, model, t: float) -> SingularMatrixError:
    """A SingularMatrixError naming the joints whose equations are linearly dependent."""
    Dd = _dense(D)
    U, s, _ = np.linalg.svd(Dd)
    tol = max(Dd.shape) * np.finfo(float).eps * (s[0] if s.size else 1.0) * 1e3
    rank = int(np.sum(s > tol))
    null_left = U[:, rank:]
    involved = []
    if null_left.size:
        weight = np.abs(null_left).max(axis=1)
        for row in np.argsort(-weight):
            if weight[row] < 1e-6:
                break
            name = model.equation_labels[row][0]
            if name not in involved:
                involved.append(name)
    names = ", ".join(involved[:8]) or "unknown"
    return SingularMatrixError(
        f"t = {t:.6g} s: the constraint Jacobian is singular (rank {rank} of "
        f"{min(Dd.shape)}); dependent equations belong to: {names}. The mechanism is at a "
        "singular configuration, or these joints impose redundant constraints (check "
        "`spatialmbd info` / spatialmbd.kinematics.mobility).")


# ------------------------------------------------------------------------------- positions
@dataclass
class NewtonInfo:
    iterations: int
    residuals: list      # max |Phi| before each iteration and after the last one
    converged: bool


def apply_correction(q: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """q (nb, 7) moved by dx (6 nb,) = [dr, dpi] per body (dpi a global rotation vector)."""
    q = q.copy()
    dx = dx.reshape(-1, 6)
    q[:, :3] += dx[:, :3]
    q[:, 3:] = rotate_p(q[:, 3:], dx[:, 3:])
    return q


def describe_residual(model, phi: np.ndarray, count: int = 3) -> str:
    order = np.argsort(-np.abs(phi))[:count]
    parts = []
    for k in order:
        name, typ, lab = model.equation_labels[k]
        parts.append(f"{name} ({typ}, {lab}): {phi[k]:.3g}")
    return "; ".join(parts)


def newton_positions(model, q: np.ndarray, t: float = 0.0, tol: float = 1e-10,
                     max_iter: int = 30, solve=None, hold: Optional[np.ndarray] = None,
                     what: str = "position analysis"):
    """The one Newton-Raphson iteration for Phi(q, t) = 0 (kinematics, initial-condition
    correction, projection), in the 6-per-body space with the rotation part applied exactly
    (ERRATA for (14.6)).

    solve(D, b) -> dx: the linear solve of each step (default: LU for a square full-rank D,
    else the minimum-norm correction (14.12)); hold: optional mask (6 nb,) of coordinates not
    to move (then the minimum-norm correction over the others). Returns (q, dx_total,
    NewtonInfo). Raises ConvergenceError naming ``what``, the time, the iterations and the
    largest residuals with their joints."""
    asm = model.assembler
    q = np.array(q, dtype=float).reshape(model.nb, 7)
    total = np.zeros(6 * model.nb)
    residuals = []
    for it in range(max_iter + 1):
        cv = asm.evaluate(q, None, t)
        err = float(np.abs(cv.phi).max()) if cv.phi.size else 0.0
        residuals.append(err)
        if not np.isfinite(err):
            break
        if err <= tol:
            return q, total, NewtonInfo(it, residuals, True)
        if it == max_iter:
            break
        if hold is not None and np.any(hold):
            dx = minimum_norm_solve(cv.D, -cv.phi, hold)
        elif solve is not None:
            dx = solve(cv.D, -cv.phi)
        elif cv.D.shape[0] == cv.D.shape[1]:
            dx = JacobianFactor(cv.D, model, t).solve(-cv.phi)
        else:
            dx = minimum_norm_solve(cv.D, -cv.phi)                     # Eq. (14.12)
        q = apply_correction(q, dx)
        total += dx
    raise ConvergenceError(
        f"t = {t:.6g} s: {what} did not converge in {len(residuals) - 1} Newton "
        f"iterations (max |Phi| = {residuals[-1]:.3g}, tolerance {tol:.1g}); largest "
        f"residuals: {describe_residual(model, cv.phi)}. The mechanism may be unable to "
        "assemble here (drivers beyond its range, a bad initial guess, or inconsistent "
        "joints).")


def solve_positions(model, q: np.ndarray, t: float = 0.0, tol: float = 1e-10,
                    max_iter: int = 30, hold: Optional[np.ndarray] = None):
    """Newton-Raphson for Phi(q, t) = 0 starting at q (nb, 7); returns (q, NewtonInfo).

    Square full-rank D: LU; otherwise the minimum-norm correction (Moore-Penrose, 14.12).
    hold: optional boolean mask (6 nb,) of velocity-space coordinates not to move.
    Raises ConvergenceError (time, iterations, largest residuals and their joints).
    """
    q, _, info = newton_positions(model, q, t, tol, max_iter, hold=hold)
    return q, info


def minimum_norm_solve(D, b: np.ndarray, hold: Optional[np.ndarray] = None) -> np.ndarray:
    """The one minimum-norm solve: x = D^+ b = D^T (D D^T)^+ b, rank-safe, with the columns
    in ``hold`` kept at zero (14.12). Dense: Cholesky of D D^T, least squares when it is
    singular; sparse: SuperLU of D D^T, LSQR when it is singular."""
    n = D.shape[1]
    if hold is not None and np.any(hold):
        x = np.zeros(n)
        x[~hold] = np.linalg.lstsq(_dense(D)[:, ~hold], b, rcond=None)[0]
        return x
    if sp.issparse(D):
        try:
            y = spla.splu((D @ D.T).tocsc(), permc_spec="MMD_AT_PLUS_A").solve(b)
            if np.all(np.isfinite(y)):
                return D.T @ y
        except RuntimeError:
            pass
        return spla.lsqr(D, b, atol=1e-15, btol=1e-15, iter_lim=20 * n)[0]
    try:
        c = la.cho_factor(D @ D.T, check_finite=False)
        x = D.T @ la.cho_solve(c, b, check_finite=False)
        if np.all(np.isfinite(x)) and np.allclose(D @ x, b, rtol=1e-8, atol=1e-12 * (
                1.0 + np.abs(b).max(initial=0.0))):
            return x
    except la.LinAlgError:
        pass
    return np.linalg.lstsq(D, b, rcond=None)[0]


# ------------------------------------------------------------------------------- mobility
@dataclass
class Mobility:
    """Degrees of freedom by counting (2.1) and by the numerical rank of D."""

    grubler: int
    rank: int
    dof: int
    n_equations: int
    redundant: list = field(default_factory=list)   # (row, element, type, label)
    singular_values: np.ndarray = None
    #: max |Phi| of the state given, and how far (max |dx| in the 6-per-body space) it was
    #: moved onto Phi = 0 before the rank was taken (0: it was assembled already)
    violation: float = 0.0
    correction: float = 0.0
    #: equations that constrain velocities only (nonholonomic: rolling without slip); the
    #: DoF above are velocity DoF, the configuration has dof + n_velocity_only
    n_velocity_only: int = 0

    @property
    def n_redundant(self) -> int:
        return len(self.redundant)

    def report(self) -> str:
        lines = [f"Gruebler-Kutzbach DoF (6 nb - m, Eq. 2.1): {self.grubler}",
                 f"constraint equations m: {self.n_equations}, rank of D: {self.rank}",
                 f"actual DoF (6 nb - rank D): {self.dof}",
                 f"redundant equations: {self.n_redundant}"]
        if self.n_velocity_only:
            lines.insert(3, f"  of which velocity-only (nonholonomic) equations: "
                            f"{self.n_velocity_only}, so the configuration has "
                            f"{self.dof + self.n_velocity_only} DoF and the velocities {self.dof}")
        for row, name, typ, lab in self.redundant:
            lines.append(f"  equation {row}: {name} ({typ}, {lab})")
        if self.correction:
            lines.append(f"(the state given violates the constraints by {self.violation:.3g}; "
                         f"the rank is taken at the assembled state {self.correction:.3g} "
                         "away)")
        return "\n".join(lines)


def mobility(model, q: Optional[np.ndarray] = None, t: float = 0.0,
             tol: Optional[float] = None) -> Mobility:
    """Gruebler count next to the numerical rank of D and the redundant equations.

    The rank and the redundant equations come from the one rank decision of the project
    (:func:`spatialmbd.rank.row_rank`): the equations are taken in the model's order, and one
    that depends on those before it (relative distance to their span at most ``tol``, default
    :data:`spatialmbd.rank.RANK_RTOL`) is redundant -- the later equations of a redundant
    loop are the ones left out, on every machine (a pivoted QR breaks the ties of symmetric
    mechanisms by round-off). A state that violates the constraints (max |Phi| > ASSEMBLED)
    is first moved onto Phi = 0 (minimum-norm Newton), because off the manifold the rank is not
    that of the mechanism; the result says how far (``violation``, ``correction``). The
    singular values of D are reported alongside (``singular_values``).
    """
    q = model.q0 if q is None else np.asarray(q).reshape(model.nb, 7)
    cv = model.assembler.evaluate(q, None, t)
    violation = float(np.abs(cv.phi).max()) if cv.phi.size else 0.0
    correction = 0.0
    if violation > ASSEMBLED:
        # D at a state off the constraint manifold has its would-be-zero singular values
        # raised to the size of the violation, so a rank test there miscounts (a Bricard
        # linkage 1e-6 off its manifold looks rigid): take the rank at the nearest assembled
        # state, found by the minimum-norm Newton iteration
        try:
            q_assembled, _ = solve_positions(model, q, t)
        except SpatialMBDError:
            q_assembled = None
        if q_assembled is not None:
            dq = q_assembled - q
            correction = float(max(np.abs(dq[:, :3]).max(), np.abs(dq[:, 3:]).max()))
            cv = model.assembler.evaluate(q_assembled, None, t)
    D = _dense(cv.D)
    m, n = D.shape
    if m == 0:
        return Mobility(6 * model.nb, 0, 6 * model.nb, 0, [], np.zeros(0))
    s = np.linalg.svd(D, compute_uv=False)
    decision = row_rank(D, RANK_RTOL if tol is None else tol)
    rank = decision.rank
    redundant = []
    for row in decision.dependent:
        name, typ, lab = model.equation_labels[row]
        redundant.append((int(row), name, typ, lab))
    return Mobility(grubler=6 * model.nb - m, rank=rank, dof=n - rank, n_equations=m,
                    redundant=redundant, singular_values=s, violation=violation,
                    correction=correction,
                    n_velocity_only=sum(g.n * len(g.velocity_rows)
                                        for g in model.constraint_groups))


#: a state with max |Phi| above this is assembled before its mobility is taken
ASSEMBLED = 1e-9


# ------------------------------------------------------------------------------- analysis
@dataclass
class KinematicResults:
    """Time series of a kinematic analysis.

    t (nt,); q (nt, nb, 7); v (nt, nb, 6); vdot (nt, nb, 6);
    points: name -> dict(r, rdot, rddot) each (nt, 3), for every named point "body.point";
    newton_iterations (nt,); residual (nt,) max |Phi| after convergence.
    """

    model: object
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    vdot: np.ndarray
    points: dict
    newton_iterations: np.ndarray
    residual: np.ndarray
    status: str = "success"
    message: str = ""

    def body(self, name: str) -> dict:
        k = self.model.body_index(name)
        return dict(r=self.q[:, k, :3], p=self.q[:, k, 3:], rdot=self.v[:, k, :3],
                    omega=self.v[:, k, 3:], rddot=self.vdot[:, k, :3],
                    omegadot=self.vdot[:, k, 3:])


def point_kinematics(state: BodyState, vdot: np.ndarray, body: int, local: np.ndarray):
    """Position, velocity and acceleration of a body point (5.8)-(5.9) and its derivative."""
    s = state.A[body] @ local
    w = state.omega[body]
    wd = vdot[body, 3:] if body < vdot.shape[0] else np.zeros(3)
    r = state.r[body] + s
    rd = state.rdot[body] + np.cross(w, s)
    rdd = (vdot[body, :3] if body < vdot.shape[0] else np.zeros(3)) + np.cross(wd, s) \
        + np.cross(w, np.cross(w, s))
    return r, rd, rdd


def kinematic_analysis(model, t: Sequence[float], q_guess: Optional[np.ndarray] = None,
                       tol: float = 1e-10, max_iter: int = 30, *, budget=None,
                       max_steps: Optional[int] = None,
                       max_wall_time: Optional[float] = None) -> KinematicResults:
    """Positions, velocities and accelerations of a fully driven mechanism at the times t.

    budget / max_steps / max_wall_time: the same caps as :func:`spatialmbd.simulate`
    (a :class:`spatialmbd.budget.Budget`, a dict, or the keywords; max_steps counts solved
    instants, max_wall_time is in s and is checked before every Newton solve). A run stopped
    by its budget returns the instants solved so far with ``status == "budget"``.

    The drivers must take up every degree of freedom: rank D = 6 nb (checked at the first
    instant, with the joints named if not). Each instant starts Newton from a second-order
    prediction q + v dt + vdot dt^2 / 2 of the previous solution.
    """
    from .budget import Budget, BudgetExceeded, BudgetGuard
    from .checks import check_times
    t = check_times(t)
    limits = Budget.make(budget, max_steps, max_wall_time)
    guard = BudgetGuard(limits) if limits.active else None
    nb = model.nb
    q = np.array(model.q0 if q_guess is None else q_guess, dtype=float).reshape(nb, 7)
    model.assembler.reset_couplers()           # gear angles measured from the assembled zero
    q, info = solve_positions(model, q, t[0], tol, max_iter)
    mob = mobility(model, q, t[0])
    if mob.dof > 0:
        raise ModelError(
            f"kinematic analysis needs as many drivers as degrees of freedom: the mechanism "
            f"has {mob.dof} free DoF left ({len(model.driver_names)} driver(s) given); add "
            "drivers (angle, translation or coordinate) or run a dynamic analysis")
    if mob.n_equations > mob.rank:
        drivers = set(model.driver_names)
        extra = [r for r in mob.redundant if r[1] in drivers]
        if extra:
            raise ModelError(
                "more drivers than degrees of freedom: the equations of "
                + ", ".join(sorted({r[1] for r in extra}))
                + " depend on the other constraints; remove driver(s) so that their number "
                f"equals the mechanism's DoF ({6 * nb - mob.rank + len(extra)})")
    nt = t.size
    Q = np.empty((nt, nb, 7))
    V = np.empty((nt, nb, 6))
    VD = np.empty((nt, nb, 6))
    iters = np.zeros(nt, dtype=int)
    res = np.zeros(nt)
    pts = {name: dict(r=np.empty((nt, 3)), rdot=np.empty((nt, 3)), rddot=np.empty((nt, 3)))
           for name in model.points}
    asm = model.assembler
    status, message = "success", ""
    done = 0
    try:
        for k, tk in enumerate(t):
            if k > 0:
                if guard is not None:
                    guard(t[k - 1])                    # one solved instant = one step
                asm.advance_couplers(Q[k - 1])   # gear angles unwrapped from instant to instant
                dt = tk - t[k - 1]
                guess = apply_correction(Q[k - 1], (V[k - 1] * dt + 0.5 * VD[k - 1] * dt * dt))
                q, info = solve_positions(model, guess, tk, tol, max_iter)
            cv = asm.evaluate(q, None, tk)
            factor = JacobianFactor(cv.D, model, tk)
            v = factor.solve(cv.nu)                                            # Eq. (7.4)
            cv = asm.evaluate(q, v, tk)
            vdot = factor.solve(cv.gamma)                                      # Eq. (7.6)
            Q[k], V[k], VD[k] = q, v.reshape(nb, 6), vdot.reshape(nb, 6)
            iters[k] = info.iterations
            res[k] = info.residuals[-1]
            if pts:
                state = BodyState.from_qv(q, v, tk)
                for name, (body, local) in model.points.items():
                    r, rd, rdd = point_kinematics(state, VD[k], body, local)
                    pts[name]["r"][k], pts[name]["rdot"][k], pts[name]["rddot"][k] = r, rd, rdd
            done = k + 1
    except BudgetExceeded as exc:
        status, message = exc.status, str(exc)
    except (ConvergenceError, SingularMatrixError) as exc:
        status, message = "failed", str(exc)
    finally:
        asm.reset_couplers()                # the shared assembler left as it was found
    sl = slice(0, done)
    return KinematicResults(model=model, t=t[sl], q=Q[sl], v=V[sl], vdot=VD[sl],
                            points={n: {k: a[sl] for k, a in d.items()} for n, d in pts.items()},
                            newton_iterations=iters[sl], residual=res[sl], status=status,
                            message=message)
