"""A sweep member's outputs reduced from its arrays in the batch, without a Results."""
from __future__ import annotations

import math

from ...outputs.vocabulary import BODY_POSITION, BODY_VELOCITY
from .run import _integrate, as_results


def _integrate_reduce(job, setup, analysis, t_out, good, Fs, Y0, starts, rows):
    """Integrate the members good = [(row, model)] and reduce each to its sweep row."""
    from ..status import FAILED, _describe
    opts = job.batch_options
    res = _integrate(setup, [m for _, m in good], analysis, t_out, Fs, Y0,
                     int(opts.get("max_steps", 10_000_000)),
                     with_outputs=_needs_accelerations(job.outputs),
                     threads=bool(opts.get("threads", False)), starts=starts)
    plan = _state_plan(job.outputs, setup.model)
    requests = None
    if plan is None and analysis.outputs:        # joint, force, ... columns, as simulate has
        from ...outputs import parse_outputs as parse_requests
        requests = parse_requests(setup.model, analysis.outputs)
    for (k, _), member in zip(good, res):
        try:
            if plan is not None:
                rows[k] = _reduce_states(job, member, plan)
            else:
                results = as_results(member)
                results.output_requests = requests or []
                rows[k] = job.reduce(results)
        except Exception as exc:
            rows[k] = (FAILED, _describe(exc), job.empty(), None)


def _state_plan(outputs, model):
    """[(reduction, "q" or "v", body, column)] when every output is a reduction of a body's
    position, Euler parameter or velocity column (what the member's arrays hold as they
    are); None otherwise (the outputs are then evaluated on a Results, as in a separate run)."""
    plan = []
    for o in outputs:
        if o.function is not None or o.reduction is None:
            return None
        parts = o.column.split(".")
        if len(parts) != 2 or parts[0] not in model.body_names:
            return None
        k = model.body_names.index(parts[0])
        if parts[1] in BODY_POSITION:
            plan.append((o.reduction, "q", k, BODY_POSITION.index(parts[1])))
        elif parts[1] in BODY_VELOCITY:
            plan.append((o.reduction, "v", k, BODY_VELOCITY.index(parts[1])))
        else:
            return None
    return plan


def _reduce_states(job, member, plan):
    """The sweep row of a member whose outputs are all in ``plan``: the values
    :meth:`.core.SweepJob.reduce` gives, read from the member's arrays without a Results."""
    from ..status import FAILED, SUCCESS
    from ..outputs import REDUCTIONS
    if member.status != SUCCESS:
        return FAILED, str(member.message), job.empty(), None
    vals = []
    for red, arr, k, i in plan:
        x = (member.q if arr == "q" else member.v)[:, k, i]
        vals.append(math.nan if x.size == 0 else REDUCTIONS[red](member.t, x))
    return SUCCESS, "", vals, None


# ------------------------------------------------------------------ members set without builds
#: the Model arrays a sweep parameter may set directly, without building the member's model
_STATE_COLUMNS = BODY_POSITION + BODY_VELOCITY


def _needs_accelerations(outputs) -> bool:
    """Whether any output may read vdot or lambda (accelerations, reactions, callables)."""
    for o in outputs:
        if o.function is not None:
            return True
        parts = o.column.split(".")
        if o.column == "t" or parts[0] in ("energy", "violation"):
            continue
        if parts[-1] in _STATE_COLUMNS and not parts[-1].startswith("f"):
            if len(parts) == 2 or parts[-1] in ("x", "y", "z", "vx", "vy", "vz"):
                continue
        return True
    return False
