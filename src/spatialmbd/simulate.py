"""Forward dynamics driver: initial-condition correction, the time loop, saving and counters.

Data flows one way (STYLE.md): model -> state (t, q, v) -> assembly -> method (vdot, lam) ->
integrator -> results. The integrator advances y = [q (7 nb), v (6 nb), W] with
    qdot = T(q) v (rdot as is, pdot = 1/2 G^T omega, Eq. 5.12),  vdot from the method,
    Wdot = power of non-conservative forces and drivers (for the energy balance).
Euler parameters: the right-hand side uses p / |p| (so A(p) is always a rotation) and every
accepted step renormalises p; since p^T pdot = 0 exactly, this only removes integration error
(a projection onto the unit sphere, which does not lower the integrator's order).

The right-hand side of the built-in methods is compiled (:mod:`.dynamics.system`): one call per
evaluation when the model has no force elements and only compiled joint types, otherwise two
compiled stages around the Python force elements. Methods without a compiled path run through
``Method.accelerations``. Large models skip the dense rank analysis of D when a sparse Cholesky
factorisation of D D^T shows that its rows are independent.
"""
from __future__ import annotations

import time
import warnings
from typing import Optional, Sequence

import numpy as np

from .assembly import SPARSE_THRESHOLD
from .dynamics import EquationsOfMotion, get_method
from .dynamics import system as cs
from .dynamics.correction import correct_initial_conditions, hold_mask
from .errors import ModelError, SimulationError, SpatialMBDError
from .integrators import get_integrator
from .integrators.base import ODEProblem, check_finite
from .kinematics import mobility
from .results import Results
from .state import normalize_q, qdot_from_v


class RedundantConstraintsWarning(UserWarning):
    """The model has redundant constraint equations (reactions not uniquely determined)."""


def output_times(t_end: float, output_step: Optional[float], t_eval, t0: float = 0.0):
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float)
        if t_eval.ndim != 1 or t_eval.size == 0 or np.any(np.diff(t_eval) <= 0):
            raise ModelError("t_eval must be a strictly increasing 1-D array of times")
        return t_eval
    if not (np.isfinite(t_end) and t_end > t0):
        raise ModelError(f"t_end must be greater than the start time {t0}, got {t_end}")
    if output_step is None:
        output_step = (t_end - t0) / 500.0
    if not output_step > 0:
        raise ModelError(f"output_step must be positive, got {output_step}")
    n = int(np.floor((t_end - t0) / output_step + 1e-9))
    t = t0 + output_step * np.arange(n + 1)
    if t[-1] < t_end - 1e-12 * max(1.0, t_end):
        t = np.append(t, t_end)
    return t


def simulate(model, t_end: float = 1.0, *, method="standard", integrator="rk45",
             output_step: Optional[float] = None, t_eval: Optional[Sequence[float]] = None,
             step: Optional[float] = None, rtol: Optional[float] = None,
             atol: Optional[float] = None, method_options: Optional[dict] = None,
             integrator_options: Optional[dict] = None, q0=None, v0=None,
             correct_initial: bool = True, hold=None, sparse: Optional[bool] = None,
             progress=False, t0: float = 0.0, events=None, event_tol: float = 1e-12) -> Results:
    """Forward dynamics of ``model`` from t0 to t_end.

    method: "standard", "baumgarte", "penalty", "augmented_lagrangian", "projection" or a
        Method instance (method_options: its parameters, e.g. alpha, beta).
    integrator: "euler", "heun", "rk4", "abm4", "bdf4", "rk45", "scipy-..." or an Integrator
        (step: fixed step size in s; rtol/atol for adaptive ones; integrator_options: others).
    output_step / t_eval: the output times (dense output; default 500 intervals).
    q0, v0: initial state (nb, 7) and (nb, 6); default the model's. correct_initial: apply the
        chapter 14 corrections first (hold: coordinates kept fixed, {"body": ["x", ...]}).
    progress: True for a progress bar on runs longer than about a second, or a callable(t).
    events: zero crossings to locate (docs/events.md): each a callable g(t, state) -> float
        (state: a :class:`.state.BodyState` of the bodies, ground last) or an object with
        ``function`` and optional ``terminal`` (stop the run there), ``direction`` (> 0 rising
        only, < 0 falling only), ``name``; located to ``event_tol`` (s) on the dense output.

    Returns Results (status "success", "event" when a terminal event stopped the run -- its
    state is the last output -- or "failed" with everything computed up to the failure);
    ``results.events`` lists the located events (t, name, index, terminal).
    """
    nb = model.nb
    t_out = output_times(t_end, output_step, t_eval, t0)
    meth = get_method(method, **(method_options or {}))
    integ_opts = dict(integrator_options or {})
    for key, value in (("step", step), ("rtol", rtol), ("atol", atol)):
        if value is not None:
            integ_opts[key] = value
    integ = _make_integrator(integrator, integ_opts)
    eom = EquationsOfMotion(model, sparse=sparse)

    q = np.array(model.q0 if q0 is None else q0, dtype=float).reshape(nb, 7)
    v = np.array(model.v0 if v0 is None else v0, dtype=float).reshape(nb, 6)
    q = normalize_q(q)
    correction = None
    if correct_initial and model.n_eq:
        q, v, correction = correct_initial_conditions(model, q, v, t0, hold_mask(model, hold),
                                                      system=eom.system)

    mob = _redundancy(model, eom, q, t0)
    if mob is not None and mob.redundant:
        mob = _structural_redundancy(model, eom, q, v, t0, mob)
    redundant_rows = np.array([r[0] for r in mob.redundant], dtype=int) if mob else None
    redundant_joints = sorted({r[1] for r in mob.redundant}) if mob else []
    messages = []
    if redundant_joints:
        text = (f"{len(redundant_rows)} redundant constraint equation(s) in joint(s) "
                f"{', '.join(redundant_joints)} (Gruebler DoF {mob.grubler}, actual DoF "
                f"{mob.dof}); they are left out of the multiplier solve, so the reactions of "
                "these joints are not uniquely determined")
        warnings.warn(text, RedundantConstraintsWarning, stacklevel=2)
        messages.append(text)
    meth.setup(eom, redundant_rows)

    n_q, n_v = 7 * nb, 6 * nb
    driver_rows = _driver_rows(model)
    track_work = bool(model.force_groups) or driver_rows.size > 0
    rhs = _compiled_rhs(model, eom, meth, track_work)
    compiled = rhs is not None
    if rhs is None:
        rhs = _python_rhs(model, eom, meth, track_work, driver_rows)

    def project(t, y):
        y = y.copy()
        cs.normalize_y(y, nb)
        if meth.projects and hasattr(meth, "project_y"):
            return meth.project_y(eom.system, t, y)
        if meth.projects:
            qq, vv = meth.project(eom, t, y[:n_q].reshape(nb, 7), y[n_q:n_q + n_v])
            y[n_q:n_q + n_v] = vv
            y[:n_q] = np.asarray(qq).reshape(-1)
        return y

    y0 = np.concatenate([q.reshape(-1), v.reshape(-1), [0.0]])
    callback = _progress(progress, t0, t_out[-1])
    start = time.perf_counter()
    try:
        # rhs uses p / |p|, so the normalisation alone never changes it
        problem = ODEProblem(rhs=rhs, project=project, project_keeps_rhs=not meth.projects,
                             stages=meth.stages(eom.system) if compiled else None,
                             n_quadrature=1)           # W does not enter the rhs
        res = integ.integrate(problem, t0, y0, t_out, progress=callback,
                              events=_state_events(events, nb), event_tol=event_tol)
    finally:
        if hasattr(callback, "close"):
            callback.close()
    wall = time.perf_counter() - start
    if res.status == "failed" and model.n_eq and res.last is not None:
        diagnosis = _singular_diagnosis(model, res.last, mob, meth.name)
        if diagnosis:
            res.message = f"{res.message}. Diagnosis: {diagnosis}"
    for t_a, alpha, iters in getattr(meth, "adaptations", ()):
        messages.append(f"t = {t_a:.6g} s: {meth.name} did not converge with its settings; "
                        f"continued with alpha = {alpha:.3g}, max_iterations = {iters}")
    if res.status != "success":
        messages.append(res.message)
    out = Results.from_integration(
        model=model, eom=eom, method=meth, integrator=integ, t=res.t, y=res.y, status=res.status,
        message=res.message, counters=res.counters.as_dict(), wall_time=wall,
        correction=correction, redundant_joints=redundant_joints, messages=messages,
        settings=dict(t0=t0, t_end=float(t_out[-1]), n_output=int(t_out.size),
                      method=meth.name, method_options=meth.parameters(),
                      integrator=integ.name, integrator_options=_integrator_options(integ),
                      correct_initial=correct_initial))
    out.events = [dict(t=e.t, name=e.name, index=e.index, terminal=e.terminal)
                  for e in res.events]
    return out


def _singular_diagnosis(model, last, mob0, method_name, rel: float = 1e-3):
    """Why a run failed, if the mechanism is at a singular position: the rank of D at the last
    accepted state against the start, the joints whose equations became dependent, and the
    setting to change. None when D has full (start) rank there."""
    import scipy.linalg as la
    from .kinematics import _dense
    t, y = last
    nb = model.nb
    q = normalize_q(np.asarray(y[:7 * nb], dtype=float)).reshape(nb, 7)
    try:
        D = _dense(model.assembler.evaluate(q, None, t).D)
    except SpatialMBDError:
        return None
    m = D.shape[0]
    s = np.linalg.svd(D, compute_uv=False)
    if s.size == 0 or s[0] == 0.0:
        return None
    rank_start = mob0.rank if mob0 is not None else m
    s0 = None if mob0 is None else mob0.singular_values
    if s0 is not None and rank_start > 0 and len(s0) >= rank_start:
        # far below the smallest singular value of the start: (nearly) dependent now
        threshold = rel * float(s0[rank_start - 1])
    else:
        threshold = rel * 1e-1 * float(s[0])
    near = int(np.sum(s > threshold))
    if near >= rank_start:
        return None
    start_rows = {r[0] for r in mob0.redundant} if mob0 is not None else set()
    _, _, piv = la.qr(D.T, pivoting=True, mode="economic")
    rows = [int(r) for r in piv[near:] if int(r) not in start_rows]
    joints = sorted({model.equation_labels[r][0] for r in rows})
    small = ", ".join(f"{v:.2g}" for v in s[near:rank_start])
    text = (f"at t = {t:.6g} s the constraint Jacobian D has numerical rank {near} of {m} "
            f"equations (rank {rank_start} at the start; singular value(s) {small} below "
            f"{threshold:.3g}, {rel:g} x the smallest of the start): the equations of joint(s) "
            f"{', '.join(joints) or '?'} became dependent, so the mechanism is at a singular "
            "(dead-centre / bifurcation) position")
    if method_name in ("standard", "baumgarte", "projection"):
        text += (f", where the multipliers of the {method_name} method are not unique and its "
                 "accelerations blow up; use method 'penalty' (its "
                 "M + alpha D^T D stays positive definite through singular positions), or end "
                 f"the run before t = {t:.6g} s")
    else:
        text += ("; raise alpha (and, for augmented_lagrangian, max_iterations), or end the "
                 f"run before t = {t:.6g} s")
    return text


def _state_events(events, nb):
    """The simulate-level events (functions of (t, BodyState)) as integrator events (functions
    of (t, y)); None when there are none."""
    if not events:
        return None
    from .integrators import Event
    from .state import BodyState
    n_q, n_v = 7 * nb, 6 * nb
    out = []
    for i, spec in enumerate(events):
        ev = Event.coerce(spec, i)
        user = ev.function

        def g(t, y, user=user):
            state = BodyState.from_qv(normalize_q(y[:n_q]).reshape(nb, 7),
                                      y[n_q:n_q + n_v].reshape(nb, 6), t)
            return float(user(t, state))
        out.append(Event(g, terminal=ev.terminal, direction=ev.direction, name=ev.name))
    return out


#: above this many entries of D the dense rank analysis (SVD) is not attempted
DENSE_MOBILITY_MAX = 4_000_000


def _redundancy(model, eom, q, t0):
    """The mobility analysis that names redundant constraint rows (None: none).

    Small models: the SVD / pivoted-QR analysis of :func:`.kinematics.mobility`, as always.
    Large ones (a dense D would not fit): a sparse Cholesky factorisation of D D^T that
    leaves out dependent rows; only if it finds some and D is small enough for the dense
    analysis is that run to name them."""
    if not model.n_eq:
        return None
    nb = model.nb
    if 6 * nb <= SPARSE_THRESHOLD:
        return mobility(model, q, t0)
    rows = eom.system.dependent_rows(q, t0)
    if rows.size == 0:
        return None
    if model.n_eq * 6 * nb <= DENSE_MOBILITY_MAX:
        return mobility(model, q, t0)
    from .kinematics import Mobility
    m = model.n_eq
    labels = model.equation_labels
    return Mobility(grubler=6 * nb - m, rank=m - rows.size, dof=6 * nb - (m - rows.size),
                    n_equations=m, redundant=[(int(r),) + tuple(labels[r]) for r in rows],
                    singular_values=None)


def _structural_redundancy(model, eom, q, v, t0, mob):
    """The redundancy analysis a short way along the motion when the start has dependent rows.

    A mechanism started at a singular position (e.g. a four-bar at dead centre) has rows that
    are dependent only there; leaving them out for the whole run would drop constraints that
    are independent a moment later. The rows are taken from the configuration reached after
    moving about 1e-4 m along the initial velocity (the rank test ignores the O(1e-8) constraint
    violation of that step); with zero velocity the start's analysis stands."""
    qdot = qdot_from_v(q, v).reshape(model.nb, 7)
    speed = float(np.abs(qdot).max()) if qdot.size else 0.0
    if not speed > 0.0 or 6 * model.nb > SPARSE_THRESHOLD:
        return mob
    dt = 1e-4 / speed
    q1 = normalize_q(q + dt * qdot)
    try:
        mob1 = mobility(model, q1, t0 + dt)
    except SpatialMBDError:
        return mob
    return mob1 if len(mob1.redundant) < len(mob.redundant) else mob


def right_hand_side(model, method="standard", method_options: Optional[dict] = None):
    """The y' = f(t, y) that :func:`simulate` integrates, and its initial state y0.

    y = [q (7 nb), v (6 nb), W] (see the module docstring). For benchmarks and for driving the
    equations of motion with an integrator of one's own (W is a quadrature: the rhs does not
    depend on it; declare it with ``ODEProblem(rhs, n_quadrature=1)`` for the implicit ones). No initial-condition correction and
    no redundancy analysis: every constraint row enters the multiplier solve.
    """
    meth = get_method(method, **(method_options or {}))
    eom = EquationsOfMotion(model)
    meth.setup(eom, None)
    driver_rows = _driver_rows(model)
    track_work = bool(model.force_groups) or driver_rows.size > 0
    rhs = _compiled_rhs(model, eom, meth, track_work)
    if rhs is None:
        rhs = _python_rhs(model, eom, meth, track_work, driver_rows)
    y0 = np.concatenate([normalize_q(np.asarray(model.q0, dtype=float)).reshape(-1),
                         np.asarray(model.v0, dtype=float).reshape(-1), [0.0]])
    return rhs, y0


def _compiled_rhs(model, eom, meth, track_work):
    """y' = f(t, y) through the method's compiled kernels (None if it has none)."""
    system = eom.system
    kernels = meth.kernels(system)
    if kernels is None:
        return None
    full, after, args = kernels
    table = system.table
    drivers = table.has_drivers
    iterate = meth.iterate
    status = meth.status

    def finish(t, y, ydot, code):
        if code < 0:
            code = status(code, system, t, y, ydot)
        if code < 0:
            check_finite(t, ydot, "accelerations")
        elif iterate:
            meth.total_iterations += code

    if system.fused:
        def rhs(t, y):
            if not y.flags.c_contiguous:          # e.g. a column of SciPy's Jacobian
                y = np.ascontiguousarray(y)
            if drivers:
                table.set_time(t)
            ydot = np.empty_like(y)
            code = full(t, y, ydot, *args)
            if code:
                finish(t, y, ydot, code)
            return ydot
        return rhs

    F, I, W = system.F, system.I, system.W
    forces = model.force_groups
    state = system.state

    def rhs(t, y):
        if not y.flags.c_contiguous:
            y = np.ascontiguousarray(y)
        if drivers:
            table.set_time(t)
        cs.stage_state(t, y, 1.0, F, I, W)
        if not system.python_stage(t):
            eom._raise_non_finite(state, t)
        ydot = np.empty_like(y)
        code = after(y, ydot, *args)
        if code:                                  # (a method may redo the solve here)
            finish(t, y, ydot, code)
        if forces and track_work:
            ydot[-1] += sum(g.nonconservative_power(state, t) for g in forces)
        return ydot
    return rhs


def _python_rhs(model, eom, meth, track_work, driver_rows):
    """y' = f(t, y) through Method.accelerations (methods without a compiled path)."""
    nb = model.nb
    n_q, n_v = 7 * nb, 6 * nb

    def rhs(t, y):
        qq = normalize_q(y[:n_q]).reshape(nb, 7)
        vv = y[n_q:n_q + n_v]
        ev = eom.evaluate(t, qq, vv)
        out = meth.accelerations(ev, t)
        ydot = np.empty_like(y)
        ydot[:n_q] = qdot_from_v(qq, vv.reshape(nb, 6)).reshape(-1)
        ydot[n_q:n_q + n_v] = out.vdot
        if track_work:
            ydot[-1] = _nonconservative_power(model, ev, out.lam, driver_rows, t)
        else:
            ydot[-1] = 0.0
        check_finite(t, ydot, "accelerations")
        return ydot
    return rhs


def _make_integrator(integrator, options: dict):
    """get_integrator with a clear error for options the integrator does not take."""
    import inspect
    from .integrators import INTEGRATORS, Integrator
    if isinstance(integrator, str) and integrator.lower() in INTEGRATORS and options:
        cls = INTEGRATORS[integrator.lower()]
        accepted = set(inspect.signature(cls.__init__).parameters) - {"self"}
        wrong = sorted(set(options) - accepted)
        if wrong:
            raise ModelError(f"integrator {integrator!r} takes no {', '.join(wrong)}; its "
                             f"options are {', '.join(sorted(accepted)) or 'none'} (fixed-step "
                             "integrators take step, adaptive ones rtol and atol)")
    if isinstance(integrator, Integrator) and options:
        raise ModelError("step/rtol/atol cannot be combined with an Integrator instance; set "
                         "them on the instance")
    return get_integrator(integrator, **options)


def _driver_rows(model) -> np.ndarray:
    rows = []
    for g, off in zip(model.constraint_groups, model.group_offsets):
        if g.rheonomic:
            rows.extend(range(off, off + g.size))
    return np.array(rows, dtype=int)


def _nonconservative_power(model, ev, lam, driver_rows, t) -> float:
    """Power of the non-conservative force elements and of the drivers' reactions (lam^T nu)."""
    p = sum(g.nonconservative_power(ev.state, t) for g in model.force_groups)
    if driver_rows.size:
        p += float(lam[driver_rows] @ ev.cv.nu[driver_rows])
    return p


def _integrator_options(integ) -> dict:
    out = {}
    for key in ("step", "rtol", "atol", "max_step", "adaptive"):
        if hasattr(integ, key):
            value = getattr(integ, key)
            if isinstance(value, np.ndarray):
                value = value.tolist()
            out[key] = value
    return out


class _Progress:
    """A tqdm bar that appears only when the run has taken more than about a second."""

    def __init__(self, t0, t1):
        self.t0, self.t1 = t0, t1
        self.start = time.perf_counter()
        self.bar = None
        self.last = t0

    def __call__(self, t):
        if self.bar is None:
            if time.perf_counter() - self.start < 1.0:
                return
            from tqdm import tqdm
            self.bar = tqdm(total=self.t1 - self.t0, unit="s(sim)", leave=False,
                            bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")
        self.bar.update(t - self.last)
        self.last = t

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _progress(progress, t0, t1):
    if callable(progress):
        return progress
    if progress:
        return _Progress(t0, t1)
    return None
