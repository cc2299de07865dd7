"""The members of a sweep run as batches: :func:`run_members_batched`."""
from __future__ import annotations

import numpy as np

from .direct import _run_direct
from .reduce import _integrate_reduce
from .setup import BatchSetup, _check_analysis


def run_members_batched(job, members: list) -> list:
    """The batch engine of a sweep chunk: build every member, integrate those that build in
    one compiled call, reduce the outputs. Same (status, message, outputs, t) rows as
    :meth:`.core.SweepJob.run_member`."""
    from ..status import FAILED, _describe
    rows = [None] * len(members)
    left = _run_direct(job, members, rows)
    built = []
    for k in left:
        member = members[k]
        try:
            model, analysis = job.build(member)
            built.append((k, model, analysis))
        except Exception as exc:
            rows[k] = (FAILED, _describe(exc), job.empty(), None)
    # members are grouped by analysis (a swept analysis setting gives several groups)
    groups: dict = {}
    for k, model, analysis in built:
        key = repr(analysis.to_dict())
        groups.setdefault(key, []).append((k, model, analysis))
    for items in groups.values():
        analysis = items[0][2]
        try:
            _check_analysis(analysis)
            setup = BatchSetup(items[0][1], analysis.method, analysis.method_options,
                               analysis.integrator)
        except Exception as exc:
            for k, _, _ in items:
                rows[k] = (FAILED, _describe(exc), job.empty(), None)
            continue
        from ...simulate import output_times
        t_out = output_times(analysis.t_end, analysis.output_step, analysis.t_eval, 0.0)
        good, Fs, Y0, starts = [], [], [], []
        for k, model, _ in items:
            try:
                F = setup.pack_F(model)
                y0 = setup.initial_state(model, F, analysis)
                if setup.recursive:
                    starts.append(setup.joint_start(model, y0))
                Y0.append(y0)
                Fs.append(F)
                good.append((k, model))
            except Exception as exc:
                rows[k] = (FAILED, _describe(exc), job.empty(), None)
        if good:
            _integrate_reduce(job, setup, analysis, t_out, good, np.stack(Fs), np.stack(Y0),
                              starts or None, rows)
    return rows
