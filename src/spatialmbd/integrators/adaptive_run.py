"""Runs of any :class:`.base.ODEProblem` (a right-hand side written in Python or compiled
stages called from Python, a projection, events, breakpoints, progress) through the one
compiled adaptive driver :func:`.adaptive_driver.rk_steps`.

The problem's callables reach the compiled driver through a *callback problem*
(:class:`CallbackProblem`): its compiled hooks leave compiled code (Numba's object mode) to
call them, and an exception raised there (a singular matrix, a budget, Ctrl-C) is kept and
stops the driver, which this module raises again. Everything the driver does not do itself
happens here between its accepted steps, one step a call:

* **events**: each accepted step's dense output is kept (``rk_steps``' ``keep``) and the zero
  crossings are located on it (:func:`.driver.step_events`, Brent's method), the outputs of the
  step up to a terminal or restart event recorded, the state at a restart event taken by one
  step of the pair from the step's start (:func:`.driver.restep`, :func:`.adaptive_driver.rk_step`);
* **breakpoints** (``problem.breaks``): the steps land on each time (the driver's t_end of a
  segment), where the action runs and the FSAL derivative is evaluated again;
* progress (and the step budget counted by it) after every accepted step; per-component atol,
  ``first_step``, ``min_step`` and any controller factors (the pair's control row).

So a run with events, budgets or Python forces takes the steps of the compiled whole-run
drivers (:mod:`..dynamics.fused`, :mod:`..dynamics.recursive`): one stepper, one controller.
"""
from __future__ import annotations

import itertools
from collections import namedtuple

import numpy as np

from ..errors import SimulationError
from ..jit import ENABLED, njit
from .adaptive_driver import (CORRECTS_DENSE, NEW_DERIVATIVE, NO_KEEP, NOT_FINITE_STATE, OK,
                              STATUS_TEXT, UNDERFLOW, kept_dense, register_problem, rk_start,
                              rk_step, rk_steps)
from .controller import (atol_vector, check_finite, raise_if_nonfinite, underflow_error)
from .driver import begin, restep, step_events, tag_time, terminated
from .explicit import rk_stages
from .pairs import pair_interpolate, pair_stages

__all__ = ["CallbackProblem", "run_adaptive"]

#: a problem of :func:`.adaptive_driver.rk_steps` whose hooks call the Python callables of
#: the run in slot ``slot`` (:class:`_Run`)
CallbackProblem = namedtuple("CallbackProblem", ["slot"])

_RUNS: dict = {}
_SLOTS = itertools.count()


class _Run:
    """The Python side of one run: the problem's callables, the exception that stopped the
    driver, the outputs of the step being taken."""

    def __init__(self, problem):
        self.f, self.stages, self.project = problem.rhs, problem.stages, problem.project
        self.flags = 0 if self.project is None else CORRECTS_DENSE | (
            0 if problem.project_keeps_rhs else NEW_DERIVATIVE)
        self.error = None
        self.nonfinite = False     # the last stages gave a non-finite derivative
        self.pending = []          # (t, y) of the outputs of the current step
        self.n_real = 0            # rows of the segment's output times that are outputs

    def fail(self, exc):
        self.error = exc


# ----------------------------------------------------------------------------- the hooks
def _rhs_call(slot, t, y, out):
    run = _RUNS[slot]
    try:
        out[:] = run.f(t, y.copy())
        return True
    except BaseException as exc:  # noqa: BLE001 - kept, raised again by run_adaptive
        run.fail(exc)
        return False


def _stages_call(slot, t, y, hs, tableau, nodes, K, s0, s1, out, t_last):
    run = _RUNS[slot]
    try:
        done = s0 if run.stages is None else run.stages(t, y, hs, tableau, nodes, K, s0, s1,
                                                        out, t_last)
        if done < s1:                # the rest (or all) of the stages with rhs
            rk_stages(run.f, t, y, hs, tableau, nodes, K, done, s1, out, t_last)
        run.nonfinite = not np.isfinite(K[s0:s1]).all()
        return s1
    except BaseException as exc:  # noqa: BLE001
        run.fail(exc)
        return -1


def _project_call(slot, t, y):
    run = _RUNS[slot]
    if run.project is None:
        return 0
    try:
        y[:] = run.project(t, y.copy())
        return run.flags
    except BaseException as exc:  # noqa: BLE001
        run.fail(exc)
        return -1


def _output_call(slot, t, row, y, interpolated):
    run = _RUNS[slot]
    if row >= run.n_real:            # a breakpoint's landing, not an output time
        return True
    try:
        yo = y.copy()
        if interpolated and run.project is not None:
            yo = run.project(t, yo)
        run.pending.append((t, yo))
        return True
    except BaseException as exc:  # noqa: BLE001
        run.fail(exc)
        return False


if ENABLED:
    from numba import objmode

    # compiled without nogil (Numba warns of object mode inside a nogil function); the
    # object-mode blocks take the GIL for their Python calls

    @njit(nogil=False)
    def _rhs(p, t, y, out):
        with objmode(ok="boolean"):
            ok = _rhs_call(p.slot, t, y, out)
        return ok

    @njit(nogil=False)
    def _stages(p, t, y, hs, tableau, nodes, K, s0, s1, out, t_last):
        with objmode(done="int64"):
            done = _stages_call(p.slot, t, y, hs, tableau, nodes, K, s0, s1, out, t_last)
        return done

    @njit(nogil=False)
    def _project(p, t, y):
        with objmode(flags="int64"):
            flags = _project_call(p.slot, t, y)
        return flags

    @njit(nogil=False)
    def _output(p, t, row, y, interpolated):
        with objmode(ok="boolean"):
            ok = _output_call(p.slot, t, row, y, interpolated)
        return ok
else:                                            # pragma: no cover - without Numba
    def _rhs(p, t, y, out):
        return _rhs_call(p.slot, t, y, out)

    def _stages(p, t, y, hs, tableau, nodes, K, s0, s1, out, t_last):
        return _stages_call(p.slot, t, y, hs, tableau, nodes, K, s0, s1, out, t_last)

    def _project(p, t, y):
        return _project_call(p.slot, t, y)

    def _output(p, t, row, y, interpolated):
        return _output_call(p.slot, t, row, y, interpolated)


register_problem(CallbackProblem, _rhs, _stages, _project, _output)


# ----------------------------------------------------------------------------- the run
class _KeptDense:
    """The dense output of the step that rk_steps kept, as a callable of the time (s); DOP853's
    extra stages are evaluated at the first call (counted in nfev)."""

    def __init__(self, run, problem, pair, t, keep, cnt):
        self.run, self.problem, self.pair, self.t, self.keep, self.cnt = (run, problem, pair,
                                                                          t, keep, cnt)
        R = pair[1].shape[0]
        self.y, self.delta, self.hs = keep[R], keep[R + 2], float(keep[R + 3, 0])
        self.coef = None

    def __call__(self, s):
        if self.coef is None:
            coef = np.empty((7, self.y.size))
            if not kept_dense(self.problem, self.pair, self.t, self.keep, coef, self.cnt):
                raise self.run.error or SimulationError("the right-hand side failed")
            self.coef = coef
        out = np.empty(self.y.size)
        pair_interpolate(self.pair[0], self.y, self.hs, self.coef, (s - self.t) / self.hs,
                         self.delta, out)
        return out


def _failure(run, code, name, t, h, y):
    """The exception of a driver status other than OK."""
    if run.error is not None:
        return run.error
    if code == UNDERFLOW:
        return underflow_error(name, t, h, "error estimate not finite; the derivative is not "
                               "finite" if run.nonfinite else "error test failed repeatedly")
    if code == NOT_FINITE_STATE:
        try:
            check_finite(t, y)
        except SimulationError as exc:
            return exc
    err = SimulationError(f"t = {t:.6g} s: {name}: {STATUS_TEXT.get(code, code)}")
    err.t = t
    return err


def run_adaptive(name, pair, rtol, atol, max_step, first_step, problem, t0, y0, t_eval,
                 counters, state, progress=None, events=None, event_tol=1e-12):
    """Integrate ``problem`` (an :class:`.base.ODEProblem`) from (t0, y0) with the embedded
    pair ``pair`` (:mod:`.pairs`) through the compiled driver: the outputs at t_eval (and
    located events, a terminal event's state) into ``state`` (:class:`.driver.RunState`), the
    work into ``counters``, as :func:`.driver.run` does for the other integrators; raises the
    project's errors with ``.t`` on failure."""
    touts = np.ascontiguousarray(t_eval, dtype=float)
    n_out, t_end = touts.size, float(touts[-1])
    k, evs = begin(state, touts, t0, y0, events)
    if k == n_out and not evs:
        return
    n = y0.size
    atol = atol_vector(atol, n)
    g_old = [float(e.function(t0, y0)) for e in evs]
    breaks = getattr(problem, "breaks", None)
    bps = [] if breaks is None else [float(tb) for tb in breaks.times if t0 < tb < t_end]
    run = _Run(problem)
    slot = next(_SLOTS)
    _RUNS[slot] = run
    p = CallbackProblem(slot)
    R, S = pair[1].shape[0], pair_stages(pair[0])
    keep = np.zeros((R + 5, n)) if evs else NO_KEEP
    cnt = np.zeros(3, dtype=np.int64)                    # nfev, steps, rejected
    y = np.array(y0, dtype=float)
    K0 = np.empty(n)
    t, h = t0, 0.0

    def sync():
        counters.nfev, counters.steps, counters.rejected = (int(c) for c in cnt)

    def derivative(t, y):                                # K0 = f(t, y) after a restart
        K0[:] = problem.rhs(t, y.copy())
        cnt[0] += 1
        raise_if_nonfinite(t, K0, "derivative")

    try:
        if t0 >= t_end:
            return
        horizon = bps[0] if bps else t_end
        if first_step is not None:
            derivative(t0, y)
            h = min(first_step, max_step, horizon - t0)
        else:
            code, h = rk_start(p, t0, y, K0, pair[3][5], rtol, atol, max_step, horizon - t0,
                               cnt)
            if code != OK:
                raise _failure(run, code, name, t0, 0.0, y)
            raise_if_nonfinite(t0, K0, "derivative")
        err_prev, i_bp = 1e-4, 0
        while t < t_end:
            seg_end = bps[i_bp] if i_bp < len(bps) else t_end
            k1 = int(np.searchsorted(touts, seg_end, side="right"))
            t_seg, run.n_real = touts[k:k1], k1 - k
            if not t_seg.size or t_seg[-1] != seg_end:   # land on a breakpoint
                t_seg = np.append(t_seg, seg_end)
            ks = 0
            while t < seg_end:
                t_prev, y_prev, K_prev = t, y.copy(), K0.copy()
                run.pending = []
                code, t, h, err_prev, ks = rk_steps(p, t, y, K0, h, err_prev, pair, t0, t_seg,
                                                    ks, 0, t_seg.size, rtol, atol, max_step, 1,
                                                    cnt, keep)
                sync()
                if code != OK:
                    raise _failure(run, code, name, t, h, y)
                y_new = y.copy()
                state.last = (t, y_new)
                t_stop, restart = t, None
                if evs:
                    g_at_t = g_old
                    dense = _KeptDense(run, p, pair, t_prev, keep, cnt)
                    t_stop, restart, g_old = step_events(evs, g_old, t_prev, t, y_new, dense,
                                                         event_tol, problem.project, True,
                                                         state, name)
                    sync()
                for to, yo in run.pending:
                    if to <= t_stop:
                        state.emit(to, yo)
                if terminated(state, t_stop, progress):
                    return
                if restart is not None:
                    ev = evs[restart.index]
                    if t_prev < restart.t < t:
                        found = restep(lambda te: _step_to(run, p, pair, t_prev, y_prev, K_prev,
                                                           te, cnt, R, problem.project),
                                       restart, ev, g_at_t[restart.index], t, event_tol)
                        if found is not None:
                            restart = found
                            cnt[1] += 1
                            if ev.record:
                                state.events[-1] = restart
                        sync()
                    ev.restart(restart.t, restart.y)
                    g_old = [float(e.function(restart.t, restart.y)) for e in evs]
                    # the step ends there; the next step size still comes from the error
                    # of the whole step
                    t = restart.t
                    y[:] = restart.y
                    state.last = (t, y.copy())
                    ks = int(np.searchsorted(t_seg, t, side="right"))
                    derivative(t, y)
                    sync()
                if progress is not None:
                    progress(t)
            k = k1
            if i_bp < len(bps) and t == bps[i_bp]:       # a breakpoint: act, restart
                breaks.action(t, y.copy())
                i_bp += 1
                derivative(t, y)
                sync()
    except Exception as exc:
        tag_time(exc, t)
        raise
    finally:
        sync()
        del _RUNS[slot]


def _step_to(run, p, pair, t, y, K0, te, cnt, R, project):
    """The projected state at te by one step of the pair from (t, y) (K0 = f(t, y)), or None
    when the right-hand side failed."""
    K = np.empty((R, y.size))
    K[0] = K0
    y_new = np.empty(y.size)
    if rk_step(p, pair, t, y, K, te, y_new, cnt) < pair_stages(pair[0]):
        if isinstance(run.error, (KeyboardInterrupt, SystemExit)):
            raise run.error
        run.error = None
        return None
    return project(te, y_new) if project is not None else y_new
