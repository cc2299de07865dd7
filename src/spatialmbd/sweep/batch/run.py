"""Running a batch: :func:`simulate_batch` (members given as models) and their Results."""
from __future__ import annotations

import math
import time
from types import SimpleNamespace
from typing import Optional, Sequence

import numpy as np

from ...dynamics.fused import OK, STATUS_TEXT, project_state
from ...errors import ModelError
from ...integrators.pairs import PAIR_DP5, pair_by_name
from .kernels import _run_members, integrate_batch_joint
from .setup import BatchMember, BatchSetup, _check_analysis


def simulate_batch(models: Sequence, analysis, setup: Optional[BatchSetup] = None,
                   max_steps: int = 10_000_000, accelerations: bool = True,
                   threads: bool = False) -> list:
    """Integrate the members ``models`` (one topology) with ``analysis`` in one compiled call.

    models: Models that differ only in values (masses, inertias, geometry, gravity, initial
    state). analysis: an Analysis (dynamic; method auto/standard/baumgarte/projection/recursive
    -- "auto" as simulate() chooses it; rk45 or dop853 with rtol/atol/max_step, or rk4 with
    step). Returns one :class:`BatchMember` per model (arrays shaped as in
    :class:`..results.Results`, so the sweep outputs read them alike).
    accelerations: also evaluate vdot and lambda at the output times (one more right-hand
    side per output; False leaves them NaN). threads: spread the members over one thread per
    core (the compiled loop releases the GIL).
    """
    from ...simulate import output_times
    from ...io.modelfile import Analysis
    if isinstance(analysis, dict):
        analysis = Analysis.from_dict(analysis)
    _check_analysis(analysis)
    models = list(models)
    if not models:
        return []
    if setup is None:
        setup = BatchSetup(models[0], analysis.method, analysis.method_options,
                           analysis.integrator)
    t_out = output_times(analysis.t_end, analysis.output_step, analysis.t_eval, 0.0)
    Fs = np.stack([setup.pack_F(m) for m in models])
    Y0 = np.stack([setup.initial_state(m, Fs[k], analysis) for k, m in enumerate(models)])
    return _integrate(setup, models, analysis, t_out, Fs, Y0, max_steps, accelerations,
                      threads)


def _integrate(setup, models, analysis, t_out, Fs, Y0, max_steps, with_outputs=True,
               threads=False, starts=None):
    """Integrate the members (F rows Fs, corrected initial states Y0; for the recursive
    method, optionally their (x0, Tf) joint starts) in one compiled call."""
    if setup.recursive:
        return _integrate_joint(setup, models, analysis, t_out, Fs, Y0, max_steps,
                                with_outputs, threads, starts)
    B, n = Y0.shape
    nb, m = setup.nb, setup.m
    W = np.repeat(setup.system.W[None, :], B, axis=0)
    nt = t_out.size
    Y = np.zeros((B, nt, n))
    rows = nt if with_outputs else 0                # no rows: the drivers skip them
    Yd = np.zeros((B, rows, 6 * nb))
    Lam = np.zeros((B, rows, m))
    status = np.zeros(B, dtype=np.int64)
    t_fail = np.zeros(B)
    counters = np.zeros((B, 3), dtype=np.int64)
    pair = pair_by_name(analysis.integrator)
    adaptive = pair is not None
    rtol = 1e-6 if analysis.rtol is None else float(analysis.rtol)
    atol = 1e-9 if analysis.atol is None else float(analysis.atol)
    max_step = float((analysis.integrator_options or {}).get("max_step") or math.inf)
    step = 1e-3 if analysis.step is None else float(analysis.step)
    pp = setup.pp.copy()
    if adaptive and hasattr(setup.method, "tolerance_for"):   # as simulate(): never above atol
        pp[1] = setup.method.tolerance_for(SimpleNamespace(atol=atol), Y0[:, :7 * nb])
    if pp[0] != 0.0:              # as simulate(): the start projected as every accepted step
        dx = np.zeros(6 * nb)
        for b in range(B):
            if not project_state(0.0, Y0[b], Fs[b], setup.system.I, W[b], pp, nb, dx):
                raise ModelError(f"batch member {b}: the projection of its initial state "
                                 "failed; use engine='simulate' for its diagnosis")
    start = time.perf_counter()
    _run_members((Y0, Fs, setup.system.I, W, setup.mp, pp, t_out, adaptive,
                  pair or PAIR_DP5, rtol, atol, max_step, step, max_steps, nb,
                  setup.lam_off, Y, Yd, Lam, status, t_fail, counters), B, threads)
    wall = time.perf_counter() - start
    return _members(setup, models, t_out, Y, Yd, Lam, status, t_fail, counters, wall,
                    with_outputs)


def _integrate_joint(setup, models, analysis, t_out, Fs, Y0, max_steps, with_outputs,
                     threads, starts=None):
    """_integrate for the recursive method: each member's joint state and tree (from its
    corrected y0 unless given in starts), all members in one compiled call
    (:func:`integrate_batch_joint`)."""
    B = Y0.shape[0]
    nb, m, nt = setup.nb, setup.m, t_out.size
    if starts is None:
        starts = [setup.joint_start(model, Y0[b]) for b, model in enumerate(models)]
    X0 = np.stack([x0 for x0, _ in starts])
    Tf = np.stack([tf for _, tf in starts])
    nq = setup.tree.nq
    W = np.repeat(setup.system.W[None, :], B, axis=0)
    X = np.empty((B, nt, X0.shape[1]))              # (every row is written, NaN past a
    Y = np.empty((B, nt, 13 * nb + 1))             # failure)
    rows = nt if with_outputs else 0
    Yd = np.empty((B, rows, 6 * nb))
    Lam = np.empty((B, rows, m))
    status = np.zeros(B, dtype=np.int64)
    t_fail = np.zeros(B)
    counters = np.zeros((B, 3), dtype=np.int64)
    rtol = 1e-6 if analysis.rtol is None else float(analysis.rtol)
    atol = 1e-9 if analysis.atol is None else float(analysis.atol)
    max_step = float((analysis.integrator_options or {}).get("max_step") or math.inf)
    start = time.perf_counter()
    _run_members((X0, setup.tree.Ti, Tf, Fs, setup.system.I, W, t_out,
                  pair_by_name(analysis.integrator), rtol, atol, max_step,
                  max_steps, nb, nq, setup.mp, setup.lam_off, X, Y, Yd, Lam, status, t_fail,
                  counters), B, threads, integrate_batch_joint)
    wall = time.perf_counter() - start
    return _members(setup, models, t_out, Y, Yd, Lam, status, t_fail, counters, wall,
                    with_outputs)


def _members(setup, models, t_out, Y, Yd, Lam, status, t_fail, counters, wall,
             with_outputs):
    """One BatchMember per model from the stacked outputs."""
    nb, m, nt, B = setup.nb, setup.m, t_out.size, len(models)
    if not with_outputs:                       # one read-only NaN array for all members
        vdot_none, lam_none = np.full((nt, nb, 6), np.nan), np.full((nt, m), np.nan)
        vdot_none.setflags(write=False)
        lam_none.setflags(write=False)
    out = []
    for b, model in enumerate(models):
        ok = status[b] == OK
        msg = "" if ok else f"t = {t_fail[b]:.6g} s: {STATUS_TEXT[int(status[b])]}"
        out.append(BatchMember(
            model=model, t=t_out, q=Y[b, :, :7 * nb].reshape(nt, nb, 7),
            v=Y[b, :, 7 * nb:13 * nb].reshape(nt, nb, 6),
            vdot=Yd[b].reshape(nt, nb, 6) if with_outputs else vdot_none,
            lam=Lam[b] if with_outputs else lam_none, work=Y[b, :, -1],
            status="success" if ok else "failed", message=msg,
            counters=dict(nfev=int(counters[b, 0]), steps=int(counters[b, 1]),
                          rejected=int(counters[b, 2]), wall_time=wall / B)))
    return out


def as_results(member: BatchMember):
    """A :class:`..results.Results` of a batch member (for energies, reactions, tables)."""
    from ...results import Results
    return Results(model=member.model, t=member.t, q=member.q, v=member.v, vdot=member.vdot,
                   lam=member.lam, work=member.work, status=member.status,
                   message=member.message, counters=member.counters,
                   wall_time=member.counters.get("wall_time", 0.0))
