"""Runs in compiled code from start to end: the one compiled adaptive driver
(:mod:`..integrators.adaptive_driver`) on the body coordinates (:mod:`..dynamics.fused`, with its
RK4 driver) or on the joint coordinates of the recursive method (:mod:`..dynamics.recursive`),
called in slices (progress and Ctrl-C between them)."""
from __future__ import annotations

import time

import numpy as np

from ..errors import ModelError, SpatialMBDError


def _joint_run(model, meth, integ, tree, t0, t_out, callback, chunk_results, stream, refuse,
               eom):
    """The run of method "recursive" from its :class:`.dynamics.recursive.JointTree` (the
    initial state checked): joint coordinates by :mod:`.dynamics.recursive`, in
    compiled slices of about :data:`FUSED_SLICE_SECONDS` (progress and Ctrl-C between them),
    then the bodies' coordinates at the outputs, handed to the Results as any run's."""
    from ..dynamics import recursive as rc
    from ..integrators.base import Counters
    from ..integrators.pairs import pair_of
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
                         f"driver: scalar atol, no first_step); got integrator "
                         f"{integ.name!r} with those options")
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
                                         "(an articulated inertia is singular)"}.get(
                                             code, rc.STATUS_TEXT.get(code, f"status {code}")))
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
    rk45 or dop853 (scalar atol, no first_step; :func:`.integrators.pairs.pair_of`)
    or rk4, and none of what the Python driver does between steps (events and contact memory,
    drivers' and force laws' times, couplers, budgets, force-element states)."""
    from ..integrators.fixed_step import RungeKutta4
    from ..integrators.pairs import pair_of
    system = eom.system
    if not (FUSED_RUNS and compiled and system.fused) or system.python_groups:
        return False
    if couplers or events or limits.active or n_z or system.table.has_drivers:
        return False
    if getattr(meth, "reaction_friction", None):       # its loop: per right-hand side
        return False
    if meth.name not in ("standard", "baumgarte", "projection") or \
            getattr(meth, "solver", "schur") == "kkt":
        return False
    if type(integ) is RungeKutta4:
        return True
    return pair_of(integ) is not None


def _fused_run(eom, meth, integ, t0, y0, t_out, project, emit=None, chunk=0, progress=None,
               guard_length=None):
    """(IntegrationResult, (vdot, lam)) of the run by :mod:`.dynamics.fused`, in calls of
    about :data:`FUSED_SLICE_SECONDS` each (between them Ctrl-C gives status "interrupted"
    with the outputs so far, and ``progress(t)`` is called); None if it failed (the Python
    driver then reruns it and says why).

    emit / chunk (streaming): every ``chunk`` outputs go to ``emit(times, states, (vdot,
    lam))`` and are forgotten (a window of about ``chunk`` rows is kept); the result then
    holds the outputs after the last full chunk, as the Python driver's does."""
    from ..dynamics import fused as fz
    from ..integrators.base import Counters, IntegrationResult
    from ..integrators.controller import underflow_error
    from ..integrators.pairs import pair_of
    system = eom.system
    pair = pair_of(integ)
    F, I, W, mp = system.F, system.I, system.W, meth._mp
    nb, m = system.nb, system.model.n_eq
    lam_off = system._layout["lam"][0]
    pp = fz.projection_params(meth, meth.tolerance_for(integ, y0[:7 * nb])
                              if hasattr(meth, "tolerance_for") else None, guard_length)
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
        if k_base == 0 and code not in (fz.UNDERFLOW, fz.SINGULAR_STOP):
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
    elif code == fz.SINGULAR_STOP:                       # the state where the guard stopped
        t_fail, last = float(t), (float(t), y.copy())
        message = f"t = {t_fail:.6g} s: {meth.name} method {fz.STATUS_TEXT[code]}"
    res = IntegrationResult(
        t=np.array(times), y=states, status=status, message=message, t_fail=t_fail,
        counters=Counters(steps=int(counters[1]), rejected=int(counters[2]),
                          nfev=int(counters[0]), wall_time=wall), last=last)
    return res, acc
