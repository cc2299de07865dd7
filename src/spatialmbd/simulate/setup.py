"""The set-up of a run: output times, the choice of method and integrator, the mobility and
redundancy analysis at the start, the checks of fixed steps and budgets."""
from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from .. import guards
from ..assembly import SPARSE_THRESHOLD
from ..budget import check_fixed_steps, check_outputs
from ..dynamics import EquationsOfMotion
from ..errors import ModelError, SpatialMBDError
from ..integrators import get_integrator
from ..kinematics import mobility
from ..state import normalize_q, qdot_from_v


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


def _recursive_applies(model, integrator, integrator_options, step, atol, events, budget,
                       max_steps, max_wall_time) -> bool:
    """Whether method "auto" takes the recursive method: an open tree of revolute,
    translational and spherical joints (free roots allowed, at least one joint;
    :class:`.dynamics.recursive.JointTree`), integrated by rk45 (the default) or dop853 with
    nothing the recursive run does not support (events, budgets, force states, time laws)."""
    from ..dynamics.recursive import JointTree
    if integrator not in ("rk45", "dop853") or step is not None or events \
            or budget is not None or max_steps is not None or max_wall_time is not None \
            or np.ndim(atol) != 0:
        return False
    if integrator_options and set(integrator_options) - {"rtol", "atol", "max_step"}:
        return False
    if integrator_options and np.ndim(integrator_options.get("atol", 0.0)) != 0:
        return False
    from ..forces.contact.memory import impact_groups
    if impact_groups(model):                  # impact memory: restart events at every touch
        return False
    from ..dynamics.recursive import FREE
    try:
        tree = JointTree(model, model.q0, model.v0)
    except (ModelError, ValueError, ZeroDivisionError, FloatingPointError):
        return False
    if not set(tree.kind.tolist()) - {FREE}:   # free bodies alone: no constraints to save
        return False
    table = EquationsOfMotion(model).system.force_table
    return not table.n_states and not table.has_laws


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
    from ..kinematics import Mobility
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


def _check_fixed_steps(integ, rhs, t0, y0, t_out, limits, n_eq=0) -> None:
    """Before the run starts: refuse a fixed-step run of more steps than
    budget.MAX_FIXED_STEPS without a step budget, and estimate the work of a long run (steps
    known in advance: fixed steps, or an adaptive integrator's max_step; output rows) from
    one timed evaluation, announced or refused by budget.check_work."""
    from ..budget import (OUTPUT_EVALUATIONS, STEP_EVALUATIONS, check_work, estimate_work,
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
    from ..integrators import INTEGRATORS, Integrator
    if isinstance(integrator, str) and integrator.lower() in INTEGRATORS and options:
        cls = INTEGRATORS[integrator.lower()]
        accepted = set(guards._signature_options(cls))
        wrong = sorted(set(options) - accepted, key=str)
        if wrong:
            from ..suggest import closest_first, suggest
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


def _integrator_options(integ) -> dict:
    out = {}
    for key in ("step", "rtol", "atol", "max_step", "adaptive"):
        if hasattr(integ, key):
            value = getattr(integ, key)
            if isinstance(value, np.ndarray):
                value = value.tolist()
            out[key] = value
    return out
