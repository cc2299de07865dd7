"""Forward dynamics: :func:`simulate`, the run from set-up to results."""
from __future__ import annotations

import math
import time
import warnings
from typing import Optional, Sequence

import numpy as np

from .. import guards
from ..budget import Budget, BudgetGuard
from ..dynamics import EquationsOfMotion
from ..assembly import advance_couplers, coupler_slices, reset_couplers
from ..dynamics import reaction_friction
from ..dynamics import system as cs
from ..dynamics.correction import correct_initial_conditions, hold_mask
from ..errors import ModelError
from ..integrators.adaptive_driver import SINGULAR_STOP, STATUS_TEXT
from ..integrators.base import ODEProblem
from ..results import Results
from ..state import normalize_q
from . import compiled as compiled_runs
from .assembly import _AtTime, _contact_memory, _counters, _state_events, _stateful
from .progress import _progress
from .rhs import _compiled_rhs, _driver_rows, _python_rhs
from .setup import (RedundantConstraintsWarning, _check_fixed_steps, _guarded, _integrator_options,
                    _make_integrator, _recursive_applies, _start_mobility, output_times)


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
    from ..outputs import parse_outputs
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
        from ..dynamics.recursive import JointTree
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
    meth = reaction_friction.install(meth, eom)      # joint friction from the reactions

    from ..forces.actuators.controller import control_run
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
        and hasattr(meth, "project_y") and hasattr(meth, "tolerance_for")
    ptol = meth.tolerance_for(integ, q) if hasattr(meth, "tolerance_for") else None

    guard_length, guard = _singular_guard(model, eom, meth, q, redundant_rows, t0)

    def project(t, y):
        y = y.copy()
        cs.normalize_y(y, nb)
        if guard is not None:
            guard(t, y)
        if tight:
            y = meth.project_y(eom.system, t, y, meth.tolerance_for(integ, y[:n_q], 1e-3),
                               multistep=True)
        elif meth.projects and hasattr(meth, "project_y"):
            y = meth.project_y(eom.system, t, y, ptol)
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
        from ..integrators import Event
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
        return compiled_runs._joint_run(
            model, meth, integ, joint_tree, t0, t_out, callback, chunk_results, stream,
            dict(events=integ_events, budget=limits.active, force_states=n_z,
                 couplers=bool(couplers), time_laws=eom.system.table.has_drivers), eom)

    def sink(times, outputs):                      # streamed chunks (stream given)
        stream.add(chunk_results(times, np.array(outputs), "running", "", {}, 0.0))

    def emit(times, states, acc):
        stream.add(chunk_results(times, states, "running", "", {}, 0.0, acc))
    streaming = stream is not None
    fused = None
    if control is None and compiled_runs._fused_eligible(
            eom, meth, integ, compiled, couplers, integ_events, limits, callback, n_z):
        try:
            fused = compiled_runs._fused_run(eom, meth, integ, t0, y0, t_out, project,
                                             emit if streaming else None,
                                             getattr(stream, "chunk_rows", 0), callback,
                                             guard_length)
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
        if guard is not None and STOP_TEXT in res.message:    # the singular-position guard
            diagnosis = guards.branch_diagnosis(model, meth.name, last, float(t_last), rank0)
        else:
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


#: the message of a run the singular-position guard stopped
STOP_TEXT = STATUS_TEXT[SINGULAR_STOP]


def _singular_guard(model, eom, meth, q, redundant_rows, t0):
    """(the model's size, a check of accepted states) of the singular-position guard
    (:mod:`..dynamics.singular_guard`) for a method that follows its drift with option
    singular="stop"; (None, None) otherwise. The check raises SimulationError (the run stops
    with its outputs so far, status "failed") where the drift decides the branch; the compiled
    drivers run the same rule (:func:`..dynamics.fused.projection_params`)."""
    from ..dynamics.fused import guarded
    from ..dynamics.singular_guard import GUARD_FACTOR, passes_guard
    from ..dynamics.system import System
    from ..errors import SimulationError
    if not (guarded(meth) and model.n_eq) or eom.system.python_groups:
        return None, None
    length = guards.guard_length(model, q)
    keep = None
    if redundant_rows is not None and len(redundant_rows):
        keep = np.setdiff1d(np.arange(model.n_eq), redundant_rows)
    system = System.for_model(model, keep)       # its own work arrays: the run's stay as set
    gp = np.array([1.0, GUARD_FACTOR, length, 0.0])

    last = [t0]

    def check(t, y):
        if t <= last[0]:        # the start (corrected, its rank decided), an output between
            return              # steps (the project hook also maps the dense outputs)
        last[0] = t
        if system.table.has_drivers:
            system.table.set_time(t)
        if not passes_guard(t, y, system.F, system.I, system.W, gp):
            err = SimulationError(f"t = {t:.6g} s: {meth.name} method {STOP_TEXT}")
            err.t = t
            raise err
    return length, check

