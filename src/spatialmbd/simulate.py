"""Forward dynamics driver: initial-condition correction, the time loop, saving and counters.

Data flows one way (STYLE.md): model -> state (t, q, v) -> assembly -> method (vdot, lam) ->
integrator -> results. The integrator advances y = [q (7 nb), v (6 nb), z, W] with
    qdot = T(q) v (rdot as is, pdot = 1/2 G^T omega, Eq. 5.12),  vdot from the method,
    zdot = the rates of the force elements' internal states (LuGre bristles; usually none),
    Wdot = power of non-conservative forces and drivers (for the energy balance; last).
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

import math
import time
import warnings
from typing import Optional, Sequence

import numpy as np

from . import guards
from .assembly import SPARSE_THRESHOLD
from .budget import Budget, BudgetGuard, check_fixed_steps, check_outputs
from .dynamics import EquationsOfMotion, get_method
from .assembly import advance_couplers, coupler_slices, reset_couplers
from .dynamics import system as cs
from .dynamics.correction import correct_initial_conditions, hold_mask
from .errors import ModelError, SpatialMBDError
from .integrators import get_integrator
from .integrators.base import ODEProblem, check_finite
from .kinematics import mobility
from .results import Results
from .state import normalize_q, qdot_from_v


class RedundantConstraintsWarning(UserWarning):
    """The model has redundant constraint equations (reactions not uniquely determined)."""


def output_times(t_end: float, output_step: Optional[float], t_eval, t0: float = 0.0,
                 max_outputs: Optional[int] = None, n_state: int = 14, n_eq: int = 0):
    """The output times (s): t_eval as given, or t0, t0 + output_step, ... up to t_end.
    Refuses more than max_outputs samples (default budget.MAX_OUTPUT_SAMPLES) before any
    array is allocated (n_state, n_eq: sizes for the memory estimate in the message)."""
    t0 = guards.check_time("t0", t0)
    if t_eval is not None:
        try:
            t_eval = np.asarray(t_eval, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ModelError("t_eval must be a strictly increasing 1-D array of times (s), "
                             f"got {type(t_eval).__name__}") from None
        if t_eval.ndim != 1 or t_eval.size == 0 or not np.all(np.isfinite(t_eval)) \
                or np.any(np.diff(t_eval) <= 0):
            raise ModelError("t_eval must be a strictly increasing 1-D array of finite times")
        if t_eval[0] < t0:
            raise ModelError(f"t_eval starts at {t_eval[0]:g} s, before the start time t0 = "
                             f"{t0:g} s; give output times from t0 on (or an earlier t0)")
        check_outputs(t_eval.size, float(t_eval[-1] - t_eval[0]), None, max_outputs,
                      n_state, n_eq)
        return t_eval
    t_end = guards.check_time("t_end", t_end)
    if not (np.isfinite(t_end) and t_end > t0):
        raise ModelError(f"t_end must be greater than the start time {t0}, got {t_end}")
    if output_step is None:
        output_step = (t_end - t0) / 500.0
    output_step = guards.check_time("output_step", output_step, positive=True)
    n_float = (t_end - t0) / output_step
    check_outputs(n_float + 1, t_end - t0, output_step, max_outputs, n_state, n_eq)
    n = int(np.floor(n_float + 1e-9))
    t = t0 + output_step * np.arange(n + 1)
    if abs(t[-1] - t_end) <= max(1e-9 * output_step, 1e-12 * max(1.0, abs(t_end))):
        t[-1] = t_end                  # the last step of the grid ends on t_end, not an ulp off
    elif t[-1] < t_end:
        t = np.append(t, t_end)
    return t


def simulate(model, t_end: float = 1.0, *, method="auto", integrator="rk45",
             output_step: Optional[float] = None, t_eval: Optional[Sequence[float]] = None,
             step: Optional[float] = None, rtol: Optional[float] = None,
             atol: Optional[float] = None, method_options: Optional[dict] = None,
             integrator_options: Optional[dict] = None, q0=None, v0=None,
             correct_initial: bool = True, hold=None, sparse: Optional[bool] = None,
             progress=False, t0: float = 0.0, outputs=None, budget=None,
             max_steps: Optional[int] = None, max_wall_time: Optional[float] = None,
             events=None, event_tol: float = 1e-12, stream=None,
             controllers=None) -> Results:
    """Forward dynamics of ``model`` from t0 to t_end.

    method: "auto" (default: "recursive" for an open tree of revolute, translational and
        spherical joints with rk45 (the default) or dop853 and no events or budgets -- faster than
        projection, no drift --, else
        "projection", the recommendation of docs/choosing.md: no gains, the constraint
        violation stays at round-off), "projection", "standard", "baumgarte", "penalty",
        "augmented_lagrangian", "recursive" (joint coordinates of open trees of revolute,
        translational and spherical joints and free bodies, rk45 or dop853:
        :mod:`.dynamics.recursive`) or a Method instance
        (method_options: its parameters, e.g. alpha, beta).
    integrator: "euler", "heun", "rk4", "abm4", "bdf4", "rk45", "dop853" (Dormand-Prince
        8(5,3), for tight tolerances), "scipy-..." or an Integrator
        (step: fixed step size in s; rtol/atol for adaptive ones; integrator_options: others).
        rk45, dop853 and rk4 runs of a fully compiled model with the standard, Baumgarte or
        projection method go through the compiled drivers of :mod:`.dynamics.fused` (same steps and
        results, no Python per step; docs/integrators.md).
    output_step / t_eval: the output times (dense output; default 500 intervals).
    q0, v0: initial state (nb, 7) and (nb, 6); default the model's. correct_initial: apply the
        chapter 14 corrections first (hold: coordinates kept fixed, {"body": ["x", ...]}).
    progress: True for a progress bar on runs longer than about a second (on a terminal; when
        stderr is not a terminal, e.g. a log file, one plain line at most every 5 s), or a
        callable(t).
    outputs: what to record besides the standard columns (:mod:`spatialmbd.outputs`): Output
        requests, dicts or shorthands ("joints", "drivers", "forces", "bodies", "all");
        checked before the run, kept as ``results.output_requests``.
    budget / max_steps / max_wall_time: caps on the run (a :class:`~.budget.Budget` or a dict;
        max_steps: accepted steps, max_wall_time: s); a run that reaches one stops with status
        "budget" and its results so far. Limits checked before the run: the number of output
        samples and of fixed steps (see :mod:`.budget`).

    events: zero crossings to locate (docs/integrators.md): each a callable g(t, state) -> float
        (state: a :class:`.state.BodyState` of the bodies, ground last) or an object with
        ``function`` and optional ``terminal`` (stop the run there), ``direction`` (> 0 rising
        only, < 0 falling only), ``name``; located to ``event_tol`` (s) on the dense output;
        listed in ``results.events`` (t, name, index, terminal), the state at each in
        ``results.event_states`` ((q (nb, 7), v (nb, 6)) per event, located, not sampled).

    stream: a :class:`.io.stream.ResultsWriter`: every ``stream.chunk_rows`` outputs are
        handed to it as Results (``stream.add``) and forgotten, so memory stays bounded; the
        returned Results then hold only the rows after the last full chunk (with the whole
        run's status and counters), for ``stream.finish`` -- or use
        :func:`.io.stream.simulate_to_file`, which does both.

    controllers: sampled controllers (:class:`.forces.actuators.controller.SampledController`:
        a Python function of t and joint coordinates, sampled at a fixed rate, whose commands
        the actuators hold; docs/actuators.md). Their sample times and the samples of
        time-series commands are breakpoints the steps land on; results.control_log maps
        each controlled actuator to its samples [t, command].

    Returns Results: status "success"; "event" (a terminal event stopped the run; its state is
    the last output); "failed" (with the cause, and a diagnosis at a singular
    position), "budget" or "interrupted" (Ctrl-C), each with everything computed until then.
    Bad arguments raise ModelError naming the argument, the value and the valid choices.
    """
    from .outputs import parse_outputs
    model = guards.compiled_model(model)
    nb = model.nb
    limits = Budget.make(budget, max_steps, max_wall_time)
    t_out = output_times(t_end, output_step, t_eval, t0, limits.max_outputs, 13 * nb + 1,
                         model.n_eq)
    requests = parse_outputs(model, outputs)
    guards.check_integrator_name(integrator)
    auto = isinstance(method, str) and method.lower() == "auto"
    if auto:
        method = "projection"
        if not method_options and not controllers and _recursive_applies(model, integrator, integrator_options, step,
                                                     atol, events, budget, max_steps,
                                                     max_wall_time):
            method = "recursive"
    meth = guards.make_method(method, method_options)
    if integrator_options is not None and not isinstance(integrator_options, dict):
        raise ModelError(f"integrator_options: expected a dict of options, got "
                         f"{type(integrator_options).__name__}")
    integ_opts = dict(integrator_options or {})
    for key, value in (("step", step), ("rtol", rtol), ("atol", atol)):
        if value is not None:
            integ_opts[key] = value
    integ = _make_integrator(integrator, integ_opts)
    q, v = guards.initial_state(model, q0, v0)
    hold = guards.check_hold(model, hold)
    guards.warn(guards.unit_warnings(model))
    eom = EquationsOfMotion(model, sparse=sparse)

    q = normalize_q(q)
    correction = None
    if correct_initial and model.n_eq:
        q_given = q
        q, v, correction = correct_initial_conditions(model, q, v, t0, hold_mask(model, hold),
                                                      system=eom.system)
        guards.warn([guards.correction_warning(model, correction, q_given)])

    joint_tree = None
    if getattr(meth, "joint_coordinates", False):
        # the joint coordinates of the (corrected) initial state, built once for the run; under
        # "auto" an initial state the joints cannot place (correct_initial=False from an
        # unassembled start) is left to the projection method, which projects it
        from .dynamics.recursive import JointTree
        joint_tree = JointTree(model, q, v)
        try:
            joint_tree.check_initial(q)
        except ModelError:
            if not auto:
                raise
            meth, joint_tree = guards.make_method("projection", None), None
    mob = _start_mobility(model, eom, q, v, t0)
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

    from .forces.actuators.controller import control_run
    control = control_run(model, eom.system, controllers, t0, float(t_out[-1]), meth)
    n_q, n_v = 7 * nb, 6 * nb
    driver_rows = _driver_rows(model)
    track_work = bool(model.force_groups) or driver_rows.size > 0
    rhs = _compiled_rhs(model, eom, meth, track_work)
    compiled = rhs is not None
    n_z = eom.system.force_table.n_states
    if rhs is None:
        if n_z:
            raise ModelError(f"{_stateful(model)}: LuGre friction integrates its bristle "
                             "states in the compiled right-hand sides only; use a built-in "
                             "method without solver='kkt'")
        rhs = _python_rhs(model, eom, meth, track_work, driver_rows)

    couplers = coupler_slices(model.constraint_groups)
    reset_couplers(couplers, eom.system.law)       # gear angles from the assembled zero

    # a multistep integrator's history needs a smooth projection (Integrator.multistep):
    # converged to 1e-3 of its atol (down to a round-off floor of the positions' size)
    tight = getattr(integ, "multistep", False) and meth.projects \
        and hasattr(meth, "project_y")
    atol_min = float(np.min(getattr(integ, "atol", 1e-9))) if tight else 0.0

    def project(t, y):
        y = y.copy()
        cs.normalize_y(y, nb)
        if tight:
            floor = 64.0 * np.finfo(float).eps * max(1.0, float(np.abs(
                y[:n_q].reshape(nb, 7)[:, :3]).max()))
            y = meth.project_y(eom.system, t, y, min(meth.tolerance, max(1e-3 * atol_min,
                                                                          floor)))
        elif meth.projects and hasattr(meth, "project_y"):
            y = meth.project_y(eom.system, t, y)
        elif meth.projects:
            qq, vv = meth.project(eom, t, y[:n_q].reshape(nb, 7), y[n_q:n_q + n_v])
            y[n_q:n_q + n_v] = vv
            y[:n_q] = np.asarray(qq).reshape(-1)
        if couplers:             # every accepted step: the couplers' angles, unwrapped
            advance_couplers(couplers, eom.system.law, y[:n_q], nb)
        return y

    y0 = np.concatenate([q.reshape(-1), v.reshape(-1), np.zeros(n_z), [0.0]])  # [q, v, z, W]
    if control is not None:
        control.start(t0, y0)                      # the first samples of the controllers
    _check_fixed_steps(integ, rhs, t0, y0, t_out, limits, model.n_eq)
    last_state = guards.LastState()
    rhs = last_state.wrap(rhs)
    callback = _progress(progress, t0, t_out[-1])
    stages = last_state.wrap_stages(meth.stages(eom.system) if compiled else None)
    if limits.active:
        callback = BudgetGuard(limits, callback)
        rhs, stages = _guarded(rhs, stages, callback)
    integ_events = _state_events(events, nb)
    contact_memory = _contact_memory(model, eom, compiled, t0, y0)
    if contact_memory is not None:
        from .integrators import Event
        integ_events = (integ_events or []) + [
            Event(gap, direction=-1.0, name=name, restart=touch, record=False)
            for name, gap, touch in contact_memory.triggers()]
    def settings():             # after the run: the method's options as adapted in it
        return dict(t0=t0, t_end=float(t_out[-1]), n_output=int(t_out.size),
                    method=meth.name, method_options=meth.parameters(),
                    integrator=integ.name, integrator_options=_integrator_options(integ),
                    correct_initial=correct_initial)
    eval_eom = eom if contact_memory is None else _AtTime(eom, contact_memory)
    if control is not None:
        eval_eom = _AtTime(eval_eom, control)

    def chunk_results(times, outputs, status, message, counters, wall, accelerations=None):
        out = Results.from_integration(
            model=model, eom=eval_eom, method=meth, integrator=integ, t=np.asarray(times),
            y=np.asarray(outputs), status=status, message=message, counters=counters,
            wall_time=wall, correction=correction, redundant_joints=redundant_joints,
            messages=messages, settings=settings(), accelerations=accelerations)
        out.output_requests = requests
        out.contact_log = contact_memory.log if contact_memory is not None else []
        out.control_log = control.commands() if control is not None else {}
        if contact_memory is not None:            # evaluating the outputs rewound the memory
            contact_memory.restore(math.inf)
        return out

    if getattr(meth, "joint_coordinates", False):      # method "recursive"
        return _joint_run(model, meth, integ, joint_tree, t0, t_out, callback, chunk_results,
                          stream, dict(events=integ_events, budget=limits.active,
                                       force_states=n_z, couplers=bool(couplers),
                                       time_laws=eom.system.table.has_drivers), eom)

    def sink(times, outputs):                      # streamed chunks (stream given)
        stream.add(chunk_results(times, np.array(outputs), "running", "", {}, 0.0))

    def emit(times, states, acc):
        stream.add(chunk_results(times, states, "running", "", {}, 0.0, acc))
    streaming = stream is not None
    fused = None
    if control is None and _fused_eligible(eom, meth, integ, compiled, couplers, integ_events,
                                           limits, callback, n_z):
        try:
            fused = _fused_run(eom, meth, integ, t0, y0, t_out, project,
                               emit if streaming else None,
                               getattr(stream, "chunk_rows", 0), callback)
        finally:
            if fused is not None and hasattr(callback, "close"):
                callback.close()
    accelerations = None
    if fused is not None:                  # the whole run in compiled code (dynamics.fused)
        res, accelerations = fused
        wall = res.counters.wall_time
    else:
        start = time.perf_counter()
        try:
            # rhs uses p / |p|, so the normalisation alone never changes it
            problem = ODEProblem(rhs=rhs, project=project, project_keeps_rhs=not meth.projects,
                                 stages=stages, n_quadrature=1,   # W does not enter the rhs
                                 breaks=control)
            res = integ.integrate(problem, t0, y0, t_out, progress=callback,
                                  events=integ_events, event_tol=event_tol,
                                  sink=sink if streaming else None,
                                  chunk=getattr(stream, "chunk_rows", 0))
        finally:
            if hasattr(callback, "close"):
                callback.close()
        wall = time.perf_counter() - start
    if res.status == "failed":
        if last_state.y is not None and np.all(np.isfinite(last_state.y[:7 * nb])):
            last, t_last = normalize_q(last_state.y[:7 * nb].reshape(nb, 7)), last_state.t
        elif res.last is not None and np.all(np.isfinite(res.last[1][:7 * nb])):
            # the compiled driver's last accepted state (where its steps stalled)
            last, t_last = normalize_q(res.last[1][:7 * nb].reshape(nb, 7)), res.last[0]
        else:
            last = res.y[-1, :7 * nb].reshape(nb, 7) if len(res.t) else q
            t_last = float(res.t[-1]) if len(res.t) else t0
        rank0 = mob.rank if mob is not None else model.n_eq
        sv = getattr(mob, "singular_values", None)
        ratio0 = float(sv[rank0 - 1] / sv[0]) if sv is not None and rank0 and sv[0] else None
        # a fixed step can make an explicit integration unstable; an adaptive one shrinks its
        # step instead (its trial states near a singular position are not a blow-up)
        v_last = last_state.y[7 * nb:13 * nb] if last_state.y is not None and not getattr(
            integ, "adaptive", False) else None
        diagnosis = guards.blow_up_diagnosis(model, v, v_last, t0, float(t_last)) or \
            guards.singular_diagnosis(model, last, float(t_last), rank0, ratio0,
                                      t_fail=res.t_fail)
        if diagnosis:
            res.message = f"{res.message}; {diagnosis}"
    for t_a, alpha, iters in getattr(meth, "adaptations", ()):
        messages.append(f"t = {t_a:.6g} s: {meth.name} did not converge with its settings; "
                        f"continued with alpha = {alpha:.3g}, max_iterations = {iters}")
    if res.status not in ("success", "event"):
        messages.append(res.message)
    results = chunk_results(res.t, res.y, res.status, res.message, _counters(res, meth), wall,
                            accelerations)
    results.events = [dict(t=e.t, name=e.name, index=e.index, terminal=e.terminal)
                      for e in res.events]
    results.event_states = [(np.asarray(e.y[:7 * nb], dtype=float).reshape(nb, 7),
                             np.asarray(e.y[7 * nb:13 * nb], dtype=float).reshape(nb, 6))
                            for e in res.events]
    return results


def _recursive_applies(model, integrator, integrator_options, step, atol, events, budget,
                       max_steps, max_wall_time) -> bool:
    """Whether method "auto" takes the recursive method: an open tree of revolute,
    translational and spherical joints (free roots allowed, at least one joint;
    :class:`.dynamics.recursive.JointTree`), integrated by rk45 (the default) or dop853 with
    nothing the recursive run does not support (events, budgets, force states, time laws)."""
    from .dynamics.recursive import JointTree
    if integrator not in ("rk45", "dop853") or step is not None or events \
            or budget is not None or max_steps is not None or max_wall_time is not None \
            or np.ndim(atol) != 0:
        return False
    if integrator_options and set(integrator_options) - {"rtol", "atol", "max_step"}:
        return False
    if integrator_options and np.ndim(integrator_options.get("atol", 0.0)) != 0:
        return False
    from .forces.contact.memory import impact_groups
    if impact_groups(model):                  # impact memory: restart events at every touch
        return False
    from .dynamics.recursive import FREE
    try:
        tree = JointTree(model, model.q0, model.v0)
    except (ModelError, ValueError, ZeroDivisionError, FloatingPointError):
        return False
    if not set(tree.kind.tolist()) - {FREE}:   # free bodies alone: no constraints to save
        return False
    table = EquationsOfMotion(model).system.force_table
    return not table.n_states and not table.has_laws


def _joint_run(model, meth, integ, tree, t0, t_out, callback, chunk_results, stream, refuse,
               eom):
    """The run of method "recursive" from its :class:`.dynamics.recursive.JointTree` (the
    initial state checked): joint coordinates by :mod:`.dynamics.recursive`, in
    compiled slices of about :data:`FUSED_SLICE_SECONDS` (progress and Ctrl-C between them),
    then the bodies' coordinates at the outputs, handed to the Results as any run's."""
    from .dynamics import recursive as rc
    from .integrators.base import Counters
    from .integrators.pairs import pair_of
    for what, present in (("events", refuse["events"]), ("budgets", refuse["budget"]),
                          ("force-element states (LuGre)", refuse["force_states"]),
                          ("couplers", refuse["couplers"]),
                          ("time-dependent force laws or drivers", refuse["time_laws"])):
        if present:
            raise ModelError(f"method 'recursive' does not support {what} yet; use method "
                             "'standard' or 'projection'")
    pair = pair_of(integ)
    if pair is None:
        raise ModelError(f"method 'recursive' integrates with rk45 or dop853 (its compiled "
                         f"driver: scalar atol, the default controller, no min_step or "
                         f"first_step); got integrator {integ.name!r} with those options")
    T = tree.arrays()
    system = eom.system
    nb = model.nb
    x = tree.x0.copy()
    X = np.empty((t_out.size, x.size))
    K0 = np.empty(x.size)
    counters = np.zeros(3, dtype=np.int64)
    rtol, atol, max_step = float(integ.rtol), float(integ.atol), float(integ.max_step)
    # load the compiled driver (from the cache, on a process's first run) before the clock
    # starts: a call that takes no step (h > 0, max_steps = 0) and writes nothing
    rc.dopri_joint(t0, x.copy(), K0, 1.0, 1e-4, T, system.F, system.I, system.W, pair, t0,
                   t_out, 0, rtol, atol, max_step, 0, X, counters.copy())
    start = time.perf_counter()
    t, h, err_prev, done, code = t0, 0.0, 1e-4, 0, rc.OK
    status, message, slice_steps = "success", "", FUSED_FIRST_SLICE
    try:
        while code == rc.OK and (h == 0.0 or t < t_out[-1]):
            began, before = time.perf_counter(), int(counters[1])
            code, t, h, err_prev, done = rc.dopri_joint(
                t, x, K0, h, err_prev, T, system.F, system.I, system.W, pair, t0, t_out, done,
                rtol, atol, max_step, slice_steps, X, counters)
            if callback is not None:
                callback(t)
            took, steps = time.perf_counter() - began, int(counters[1]) - before
            if steps > 0:
                slice_steps = int(min(1_000_000, max(1, FUSED_SLICE_SECONDS * steps
                                                     / max(took, 1e-6))))
            if h == 0.0 and code == rc.OK:
                break
    except KeyboardInterrupt:
        status, message = "interrupted", f"interrupted (Ctrl-C) at t = {t:.6g} s"
    finally:
        if hasattr(callback, "close"):
            callback.close()
    if code != rc.OK:
        status = "failed"
        message = (f"t = {t:.6g} s: " + {rc.RHS_FAILED: "the accelerations are not finite "
                                         "(an articulated inertia is singular)",
                                         rc.UNDERFLOW: "step size underflow (error test "
                                         "failed repeatedly)"}.get(code, f"status {code}"))
    wall = time.perf_counter() - start
    Y = np.empty((done, 13 * nb + 1))
    rc.body_rows(X[:done], T, nb, tree.nq, Y)
    # vdot and lambda at the outputs, compiled (as the compiled drivers give them)
    Yd, Lam = np.empty((done, 6 * nb)), np.empty((done, model.n_eq))
    rc.output_accelerations(t_out[:done], Y, system.F, system.I, system.W, meth.params(),
                            system._layout["lam"][0], Yd, Lam)
    acc = (Yd.reshape(done, nb, 6), Lam)
    cnt = Counters(steps=int(counters[1]), rejected=int(counters[2]), nfev=int(counters[0]),
                   wall_time=wall).as_dict()
    times = t_out[:done]
    first = 0
    if stream is not None and getattr(stream, "chunk_rows", 0) > 0:
        chunk = stream.chunk_rows
        while done - first >= chunk:
            part = slice(first, first + chunk)
            stream.add(chunk_results(times[part], Y[part], "running", "", {}, 0.0,
                                     (acc[0][part], acc[1][part])))
            first += chunk
    results = chunk_results(times[first:], Y[first:], status, message, cnt, wall,
                            (acc[0][first:], acc[1][first:]))
    results.events, results.event_states = [], []
    return results


#: run eligible simulations through the compiled drivers of :mod:`.dynamics.fused` (tests
#: compare both paths by switching this off)
FUSED_RUNS = True
#: wall time (s) of one compiled call: between calls Ctrl-C is seen and the progress shown;
#: the number of steps per call is adapted to it (the first call takes FUSED_FIRST_SLICE)
FUSED_SLICE_SECONDS = 0.1
FUSED_FIRST_SLICE = 64


def _fused_eligible(eom, meth, integ, compiled, couplers, events, limits, callback,
                    n_z) -> bool:
    """Whether this run can go through :mod:`.dynamics.fused` with the arithmetic of the Python
    driver: a fully compiled right-hand side of the standard / Baumgarte / projection method,
    rk45 or dop853 with its default controller (scalar atol; :func:`.integrators.pairs.pair_of`)
    or rk4, and none of what the Python driver does between steps (events and contact memory,
    drivers' and force laws' times, couplers, budgets, force-element states)."""
    from .integrators.fixed_step import RungeKutta4
    from .integrators.pairs import pair_of
    system = eom.system
    if not (FUSED_RUNS and compiled and system.fused) or system.python_groups:
        return False
    if couplers or events or limits.active or n_z or system.table.has_drivers:
        return False
    if meth.name not in ("standard", "baumgarte", "projection") or \
            getattr(meth, "solver", "schur") == "kkt":
        return False
    if type(integ) is RungeKutta4:
        return True
    return pair_of(integ) is not None


def _fused_run(eom, meth, integ, t0, y0, t_out, project, emit=None, chunk=0, progress=None):
    """(IntegrationResult, (vdot, lam)) of the run by :mod:`.dynamics.fused`, in calls of
    about :data:`FUSED_SLICE_SECONDS` each (between them Ctrl-C gives status "interrupted"
    with the outputs so far, and ``progress(t)`` is called); None if it failed (the Python
    driver then reruns it and says why).

    emit / chunk (streaming): every ``chunk`` outputs go to ``emit(times, states, (vdot,
    lam))`` and are forgotten (a window of about ``chunk`` rows is kept); the result then
    holds the outputs after the last full chunk, as the Python driver's does."""
    from .dynamics import fused as fz
    from .integrators.base import Counters, IntegrationResult
    from .integrators.controller import underflow_error
    from .integrators.pairs import pair_of
    system = eom.system
    pair = pair_of(integ)
    F, I, W, mp = system.F, system.I, system.W, meth._mp
    nb, m = system.nb, system.model.n_eq
    lam_off = system._layout["lam"][0]
    pp = fz.projection_params(meth)
    y = np.array(y0, dtype=float)
    nt, n = t_out.size, y.size
    streaming = emit is not None and chunk > 0
    rows = min(nt, 2 * chunk) if streaming else nt
    # the window of outputs k_base, k_base + 1, ...: states, vdot, lambda
    Y, Yd, Lam = np.empty((rows, n)), np.empty((rows, 6 * nb)), np.empty((rows, m))
    k_base = 0
    counters = np.zeros(3, dtype=np.int64)              # nfev, steps, rejected
    # load the compiled driver and projection (from the cache, on a process's first run)
    # before the clock starts: calls that take no step and write nothing (h > 0 and
    # max_steps = 0; rk4: no output times), a projection of a copy
    project(t0, y.copy())
    if pair is not None:
        fz.dopri_steps(t0, y.copy(), np.empty(n), 1.0, 1e-4, F, I, W, mp, pp, pair, t0, t_out,
                       0, 0, float(integ.rtol), float(integ.atol), float(integ.max_step), 0,
                       nb, Y, Yd, Lam, lam_off, counters.copy())
    else:
        fz.rk4_outputs(t0, y.copy(), F, I, W, mp, pp, t_out, 0, 0, 0, float(integ.step), nb,
                       Y, Yd, Lam, lam_off, counters.copy())

    start = time.perf_counter()
    y = project(t0, y)                                  # as Integrator.integrate does first
    done, code, status, message = 0, fz.OK, "success", ""
    slice_steps = FUSED_FIRST_SLICE

    def window(k0, k1):
        """Outputs k0..k1-1 of the window: (times, states, (vdot, lam)), copies."""
        a, b = k0 - k_base, k1 - k_base
        return (t_out[k0:k1], Y[a:b].copy(),
                (Yd[a:b].reshape(b - a, nb, 6).copy(), Lam[a:b].copy()))

    def next_slice(t, began, steps_before):
        """After a call: progress, and the steps of the next call (about the target time)."""
        nonlocal slice_steps
        if progress is not None:
            progress(t)
        took, steps = time.perf_counter() - began, int(counters[1]) - steps_before
        if steps > 0:
            rate = max(took, 1e-6) / steps
            slice_steps = int(min(1_000_000, max(1, FUSED_SLICE_SECONDS / rate)))

    def flush(need_room):
        """Hand full chunks to emit and slide the window; grow it if it is still full."""
        nonlocal Y, Yd, Lam, k_base
        emitted = False
        while streaming and done - k_base >= chunk:
            emit(*window(k_base, k_base + chunk))
            rest = done - k_base - chunk
            for arr in (Y, Yd, Lam):
                arr[:rest] = arr[chunk:chunk + rest]
            k_base += chunk
            emitted = True
        if need_room and not emitted:       # one step with more outputs than the window
            Y, Yd, Lam = (np.concatenate([arr, np.empty_like(arr)]) for arr in (Y, Yd, Lam))

    try:
        if pair is not None:                             # rk45 or dop853
            K0 = np.empty(n)
            rtol, atol = float(integ.rtol), float(integ.atol)
            max_step = float(integ.max_step)
            t, h, err_prev = t0, 0.0, 1e-4              # h = 0: the first call starts the run
            while code in (fz.OK, fz.NEED_ROOM) and (h == 0.0 or t < t_out[-1]):
                began, before = time.perf_counter(), int(counters[1])
                code, t, h, err_prev, done = fz.dopri_steps(
                    t, y, K0, h, err_prev, F, I, W, mp, pp, pair, t0, t_out, done, k_base, rtol,
                    atol, max_step, slice_steps, nb, Y, Yd, Lam, lam_off, counters)
                flush(code == fz.NEED_ROOM)
                next_slice(t, began, before)
                if h == 0.0 and code == fz.OK:          # only outputs at t0, nothing to step
                    break
        else:                                            # RungeKutta4
            h = float(integ.step)
            per_output = max(1.0, (t_out[-1] - t0) / max(1, nt - 1) / h)   # steps
            t = t0
            while code == fz.OK and done < nt:
                slice_outputs = max(1, int(slice_steps / per_output))
                if streaming:
                    slice_outputs = min(slice_outputs, chunk)
                k1 = min(nt, done + slice_outputs)
                began, before = time.perf_counter(), int(counters[1])
                code, t = fz.rk4_outputs(t, y, F, I, W, mp, pp, t_out, done, k1, k_base, h,
                                         nb, Y, Yd, Lam, lam_off, counters)
                if code == fz.OK:
                    done = k1
                    flush(False)
                    next_slice(t, began, before)
    except KeyboardInterrupt:                            # Ctrl-C: keep what was computed
        status, message, code = "interrupted", "interrupted (Ctrl-C)", fz.OK
    except (SpatialMBDError, FloatingPointError, np.linalg.LinAlgError) as exc:
        # from emit (the stream's files): kept, with the cause, as the Python driver does
        status, message, code = getattr(exc, "status", "failed"), str(exc), fz.OK
    if code != fz.OK:
        if k_base == 0 and code != fz.UNDERFLOW:
            # nothing handed out yet: the Python driver reruns it (its least-squares fallbacks
            # for a singular S or projection may get through) and says why. A stalled step
            # control is not rerun: the rerun would stall too, or (at a singular position,
            # where round-off decides where steps end) elsewhere, with fewer outputs
            return None
        # streamed chunks cannot be taken back: the run stops here, as failed
        status, message = "failed", fz.STATUS_TEXT[code]
    times, states, acc = window(k_base, done)
    wall = time.perf_counter() - start
    t_fail = None
    last = (float(t_out[done - 1]), states[-1].copy()) if len(states) else None
    if status != "success":
        t_fail = float(t_out[done]) if done < nt else float(t_out[-1])
        message = f"t = {t_fail:.6g} s: {message}"
    if code == fz.UNDERFLOW:                             # where the steps stalled, as the
        t_fail, last = float(t), (float(t), y.copy())    # Python driver reports it
        message = str(underflow_error(integ.name, t_fail, h, "error test failed repeatedly"))
    res = IntegrationResult(
        t=np.array(times), y=states, status=status, message=message, t_fail=t_fail,
        counters=Counters(steps=int(counters[1]), rejected=int(counters[2]),
                          nfev=int(counters[0]), wall_time=wall), last=last)
    return res, acc


class _AtTime:
    """The equations of motion with a run-time memory (the contacts' impact velocities, the
    controllers' held commands) set to what it was at each evaluation time (the accelerations
    at the output times, after the run)."""

    def __init__(self, eom, memory):
        self._eom, self._memory = eom, memory

    def evaluate(self, t, q, v):
        self._memory.restore(t)
        return self._eom.evaluate(t, q, v)

    def __getattr__(self, name):
        return getattr(self._eom, name)


def _stateful(model) -> str:
    """The force elements with internal states, for messages ("forces['a'], ...")."""
    names = [g.element[k] if hasattr(g, "element") else g.names[k]
             for g in model.force_groups for k in np.flatnonzero(g.state_rows())]
    return ", ".join(f"forces[{n!r}]" for n in dict.fromkeys(names))


def _contact_memory(model, eom, compiled, t0, y0):
    """The impact-velocity memory of the contact elements for this run (None without
    contacts): restart events at every first touch (:mod:`.forces.contact.memory`)."""
    from .forces.contact.memory import ContactMemory, impact_groups
    if not impact_groups(model):
        return None
    if not compiled:
        from .forces.contact.laws import C_LAW, HERTZ
        hyst = [g.element[k] for g in impact_groups(model) for k in range(g.n)
                if g.param[k, C_LAW] > HERTZ]
        if hyst:
            raise ModelError(f"forces[{hyst[0]!r}]: a hysteresis contact law needs the impact "
                             "velocity, which only the compiled right-hand sides record; use a "
                             "built-in method without solver='kkt'")
        return None
    memory = ContactMemory(model, eom.system)
    memory.start(t0, y0)
    return memory


def _counters(res, meth) -> dict:
    """The integrator's counters, and the inner iterations of an iterative method (the
    augmented Lagrangian): per run, in the results, not on the method."""
    counters = res.counters.as_dict()
    if getattr(meth, "iterate", False):
        counters["method_iterations"] = int(getattr(meth, "total_iterations", 0))
    return counters


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


def _start_mobility(model, eom, q, v, t0):
    """The mobility analysis that decides which rows the multiplier solve leaves out
    (:func:`_redundancy`, moved a short way along the motion when the start has dependent
    rows, :func:`_structural_redundancy`); None without constraints."""
    mob = _redundancy(model, eom, q, t0)
    if mob is not None and mob.redundant:
        mob = _structural_redundancy(model, eom, q, v, t0, mob)
    return mob


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

    y = [q (7 nb), v (6 nb), z, W] (see the module docstring; z: the internal states of force
    elements such as LuGre friction, usually none). For benchmarks and for driving the
    equations of motion with an integrator of one's own (W is a quadrature: the rhs does not
    depend on it; declare it with ``ODEProblem(rhs, n_quadrature=1)`` for the implicit ones). No initial-condition correction. Redundant constraint
    equations (found at the model's initial state, as :func:`simulate` finds them) are left
    out of the multiplier solve, as in :func:`simulate`: with them every evaluation would take
    the least-squares fallback, tens of times slower.
    """
    meth = get_method(method, **(method_options or {}))
    eom = EquationsOfMotion(model)
    mob = _start_mobility(model, eom, normalize_q(np.asarray(model.q0, dtype=float)),
                          np.asarray(model.v0, dtype=float), 0.0)
    meth.setup(eom, np.array([r[0] for r in mob.redundant], dtype=int) if mob else None)
    driver_rows = _driver_rows(model)
    track_work = bool(model.force_groups) or driver_rows.size > 0
    rhs = _compiled_rhs(model, eom, meth, track_work)
    if rhs is None:
        rhs = _python_rhs(model, eom, meth, track_work, driver_rows)
    y0 = np.concatenate([normalize_q(np.asarray(model.q0, dtype=float)).reshape(-1),
                         np.asarray(model.v0, dtype=float).reshape(-1),
                         np.zeros(eom.system.force_table.n_states), [0.0]])
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
        if code < 0 and model.force_groups and not np.all(np.isfinite(system.g)):
            eom._raise_non_finite(system.state, t)     # names the force element
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
    forces = system.python_forces            # the compiled ones are inside the kernels
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


def _check_fixed_steps(integ, rhs, t0, y0, t_out, limits, n_eq=0) -> None:
    """Before the run starts: refuse a fixed-step run of more steps than
    budget.MAX_FIXED_STEPS without a step budget, and estimate the work of a long run (steps
    known in advance: fixed steps, or an adaptive integrator's max_step; output rows) from
    one timed evaluation, announced or refused by budget.check_work."""
    from .budget import (OUTPUT_EVALUATIONS, STEP_EVALUATIONS, check_work, estimate_work,
                         row_bytes)
    span = float(t_out[-1]) - t0
    step = getattr(integ, "step", None)
    stages = getattr(integ, "stages", 1) or 1
    if not integ.adaptive and step:
        n_steps = span / step + len(t_out)
    else:
        max_step = float(getattr(integ, "max_step", math.inf) or math.inf)
        n_steps = span / max_step if 0.0 < max_step < math.inf else 0.0
        step = None
    units = n_steps * (stages + STEP_EVALUATIONS) + len(t_out) * OUTPUT_EVALUATIONS
    per_eval = None
    if units > 1e5 and not limits.active:
        try:
            rhs(t0, y0)
            times = []
            for _ in range(3):
                start = time.perf_counter()
                rhs(t0, y0)
                times.append(time.perf_counter() - start)
            per_eval = min(times)
        except Exception:  # noqa: BLE001 - the run itself reports evaluation failures
            per_eval = None
    if step:
        check_fixed_steps(n_steps, step, span, stages, limits, per_eval,
                          len(t_out) * row_bytes(y0.size, n_eq))
    if per_eval:
        check_work(estimate_work(n_steps, stages, len(t_out), per_eval), limits)


def _guarded(rhs, stages, guard):
    """rhs and the compiled stages hook with the wall-time budget checked on every call."""
    check = guard.check_time

    def guarded_rhs(t, y):
        check(t)
        return rhs(t, y)

    if stages is None:
        return guarded_rhs, None

    def guarded_stages(t, *args):
        check(t)
        return stages(t, *args)
    return guarded_rhs, guarded_stages


def _make_integrator(integrator, options: dict):
    """get_integrator with a clear error for options the integrator does not take."""
    from .integrators import INTEGRATORS, Integrator
    if isinstance(integrator, str) and integrator.lower() in INTEGRATORS and options:
        cls = INTEGRATORS[integrator.lower()]
        accepted = set(guards._signature_options(cls))
        wrong = sorted(set(options) - accepted, key=str)
        if wrong:
            from .suggest import closest_first, suggest
            raise ModelError(f"integrator {integrator!r} takes no {', '.join(map(str, wrong))}"
                             f"{suggest(wrong[0], accepted)}; its options are "
                             f"{', '.join(closest_first(wrong[0], sorted(accepted))) or 'none'}"
                             " (fixed-step integrators take step, adaptive ones rtol and atol)")
    if isinstance(integrator, Integrator) and options:
        raise ModelError("step/rtol/atol cannot be combined with an Integrator instance; set "
                         "them on the instance")
    try:
        return get_integrator(integrator, **options)
    except ModelError:
        raise
    except (TypeError, ValueError, OverflowError) as exc:
        raise ModelError(f"integrator {integrator!r}: {exc}") from None


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
    """Progress of a run that has taken more than about a second.

    On a terminal: a tqdm bar. Otherwise (stderr redirected to a log file or a pipe): a plain
    line ``progress: t = ... of ... s (..%), ... s elapsed`` at most every ``interval`` seconds,
    never a carriage return."""

    def __init__(self, t0, t1, stream=None, interval: float = 5.0):
        import sys
        self.t0, self.t1 = t0, t1
        self.start = time.perf_counter()
        self.bar = None
        self.last = t0
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.terminal = bool(isatty and isatty())
        self.interval = interval
        self.next_line = self.start + 1.0

    def __call__(self, t):
        now = time.perf_counter()
        if not self.terminal:
            if now >= self.next_line:
                span = self.t1 - self.t0
                share = 100.0 * (t - self.t0) / span if span > 0 else 100.0
                print(f"progress: t = {t:.6g} of {self.t1:.6g} s ({share:.0f}%), "
                      f"{now - self.start:.0f} s elapsed", file=self.stream, flush=True)
                self.next_line = now + self.interval
            return
        if self.bar is None:
            if now - self.start < 1.0:
                return
            from tqdm import tqdm
            self.bar = tqdm(total=self.t1 - self.t0, unit="s(sim)", leave=False,
                            file=self.stream,
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
