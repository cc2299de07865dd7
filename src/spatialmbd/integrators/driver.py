"""The one integration loop: a stepper, an injected step-size controller, and everything else.

The shape of SciPy's ``OdeSolver._step_impl`` driven by ``solve_ivp`` (or diffrax's solver /
step-size controller / saving split): a *stepper* (:class:`Stepper`) knows only its stepping
formula -- ``step(t, y, t_new)`` returns a :class:`Step` (y at t_new, the weighted RMS norm of its
local error estimate, a dense interpolant on [t, t_new]) -- and the *controller*
(:mod:`.controllers`) only turns error norms into step sizes. :func:`run` owns:

* the step-size bookkeeping: landing on t_end (or on every output time for fixed-step one-step
  methods), max_step, the underflow test h < max(min_step, 16 eps |t|), rejections and
  nonlinear-solver (Newton) failures;
* the post-step projection (``ODEProblem.project``) of every accepted state; the dense output
  gets the linear correction theta (y_proj - y_raw) so it passes through the projected end point;
* output sampling at ``t_eval`` through the stepper's dense output (projected too);
* counters (steps, rejected; the stepper counts nfev, njev, nlu), the progress callback;
* **events**: zero crossings of g(t, y) (an :class:`Event`), located by bracketing on the
  accepted step and Brent's method on the dense output to ``event_tol`` (s); a terminal event
  stops the run at the located time, with the state there as the last output;
* partial results on failure (the exceptions carry the time ``.t``; ``Integrator.integrate``
  turns them into a "failed" result with every output computed before).

* **breakpoints** (``problem.breaks``): times the steps land on exactly (shortened like the
  last step onto t_end), an action run there and the stepper restarted -- the sample times of
  zero-order-hold commands, so no step with error control spans their jumps;
* **restart events**: an event with a ``restart`` action (a callable (t, y)) ends the accepted
  step at its located time (outputs up to there come from the dense output), calls the action
  (which may change the right-hand side from then on, e.g. record an impact velocity), and
  restarts the stepper from that state (its FSAL derivative or history is stale). The located
  time is taken on the far side of the crossing, so the event does not fire again there.

Event convention: a crossing is a strict sign change between the ends of an accepted step
(g_old < 0 <= g_new rising, g_old > 0 >= g_new falling), so a zero at the start of the run (e.g.
a restart from a terminal event) does not fire again. ``direction`` > 0 keeps rising crossings
only, < 0 falling ones, 0 both.
"""
from __future__ import annotations

import abc

import math
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

from ..errors import SimulationError
from .controller import (EPS, end_step, landing_time, min_step_size, raise_if_nonfinite,
                         underflow_error)


# ----------------------------------------------------------------------------- step contract
@dataclass
class Step:
    """What a stepper returns for one attempted step from (t, y).

    t_new: end of the step (s; normally the requested one; a multistep start-up may cover more).
    y_new: (n,) state at t_new (before projection), None when ``failed``.
    err: weighted RMS norm of the local error estimate (accept when <= 1); None: no estimate.
    k: the local error behaves like h^k (the controller's exponent).
    dense: callable t -> y (n,) on [t, t_new] (None: not available, see ``Stepper.dense``).
    hold: the stepper asks the controller to keep h (a multistep start-up).
    failed: cause when the nonlinear (Newton) solve failed (the step is retried smaller).
    n_steps: internal steps this step stands for (a multistep start-up); progress_times their ends.
    h: the step size the controller scales (default t_new - t; a start-up's internal step).
    k_retry: the exponent for a retry after a rejection when it differs from k (a multistep
        method whose error at a shorter step is set by its history, see ``gear``).
    """

    t_new: float
    y_new: Optional[np.ndarray]
    err: Optional[float] = None
    k: int = 1
    dense: Optional[Callable[[float], np.ndarray]] = None
    hold: bool = False
    failed: Optional[str] = None
    n_steps: int = 1
    progress_times: Optional[list] = None
    h: Optional[float] = None
    k_retry: Optional[float] = None


class Stepper(abc.ABC):
    """One stepping formula. Subclasses implement ``start`` and ``step`` (and ``accept`` when
    they carry state from step to step: FSAL derivatives, a multistep history, a Jacobian).

    Attributes: ``name``; ``self_controlled`` (True: the stepper chooses its own steps, e.g. a
    SciPy solver; the driver then passes t_new = None); ``projects_state`` (False: the stepper
    owns its state, so projection can only be applied to outputs).
    """

    name = ""
    self_controlled = False
    projects_state = True

    @abc.abstractmethod
    def start(self, problem, t0: float, y0: np.ndarray, t_end: float, counters) -> Optional[float]:
        """Prepare from (t0, y0); return the first step size (s) or None (the controller's)."""

    @abc.abstractmethod
    def step(self, t: float, y: np.ndarray, t_new: Optional[float]) -> Step:
        """Attempt one step from (t, y) to t_new; return a :class:`Step` (raise on errors)."""

    def accept(self, step: Step, y_final: np.ndarray) -> None:
        """The driver accepted ``step``; ``y_final`` is its (projected) end state."""


# ----------------------------------------------------------------------------- events
class Event:
    """A zero crossing g(t, y) = 0 to locate.

    function: (t, y) -> float. terminal: stop the run at the first crossing. direction: > 0
    rising crossings only, < 0 falling only, 0 both. name: for messages and results.
    restart: None, or an action (t, y) -> None run at the crossing, after which the step ends
    there and the stepper restarts (see the module docstring). record: False keeps the event
    out of the located-events list (bookkeeping events).
    """

    def __init__(self, function: Callable, terminal: bool = False, direction: float = 0.0,
                 name: Optional[str] = None, restart: Optional[Callable] = None,
                 record: bool = True):
        if not callable(function):
            raise ValueError(f"event function {function!r} is not callable")
        if restart is not None and not callable(restart):
            raise ValueError(f"event restart action {restart!r} is not callable")
        self.function = function
        self.terminal = bool(terminal)
        self.direction = float(direction)
        self.name = name or getattr(function, "__name__", "event")
        self.restart = restart
        self.record = bool(record)

    @classmethod
    def coerce(cls, spec, index: int) -> "Event":
        """An Event from an Event, an object with ``.function`` (and optional ``.terminal``,
        ``.direction``, ``.name``) or a callable with optional such attributes (SciPy style)."""
        if isinstance(spec, Event):
            return spec
        fun = getattr(spec, "function", None)
        if fun is None:
            fun = spec
        if not callable(fun):
            raise ValueError(f"events[{index}] = {spec!r} is neither callable nor has a callable "
                             "'function' attribute")
        name = getattr(spec, "name", None) or getattr(fun, "__name__", None)
        if not name or name == "<lambda>":
            name = f"event{index}"
        return cls(fun, terminal=getattr(spec, "terminal", False),
                   direction=getattr(spec, "direction", 0.0), name=name,
                   restart=getattr(spec, "restart", None))


@dataclass
class EventRecord:
    """A located event: time t (s), state y (n,), index into the events list, name, terminal."""

    t: float
    y: np.ndarray
    index: int
    name: str
    terminal: bool


def _crossed(g_old: float, g_new: float, direction: float) -> bool:
    rising = g_old < 0.0 <= g_new
    falling = g_old > 0.0 >= g_new
    if direction > 0:
        return rising
    if direction < 0:
        return falling
    return rising or falling


def _brent(fun, a: float, b: float, fa: float, fb: float, xtol: float) -> float:
    """Root of fun in [a, b] with fa, fb of opposite signs (or fb == 0): Brent's method
    (scipy.optimize.brentq) to |error| <= xtol + 4 eps |root|; b itself when fb == 0 and the
    interval holds no earlier sign change of the bracket."""
    if fb == 0.0:
        return b
    from scipy.optimize import brentq
    return float(brentq(fun, a, b, xtol=xtol, rtol=4.0 * EPS))


# ----------------------------------------------------------------------------- the loop
@dataclass
class RunState:
    """Where the driver is: shared with ``Integrator.integrate`` to build partial results."""

    times: list = field(default_factory=list)
    outputs: list = field(default_factory=list)
    events: List[EventRecord] = field(default_factory=list)
    terminated: Optional[EventRecord] = None
    last: Optional[tuple] = None          # (t, y) of the last accepted step (diagnostics)
    #: streaming: sink(times, outputs) receives the outputs every ``chunk`` rows, after which
    #: the lists are emptied, so a long run holds at most ``chunk`` outputs in memory
    sink: Optional[Callable] = None
    chunk: int = 0
    drained: int = 0                      # outputs handed to the sink so far
    t_last_out: Optional[float] = None    # time of the last output (drained or not)

    def emit(self, t: float, y: np.ndarray) -> None:
        """Record the output y(t); hand a full chunk to the sink."""
        self.times.append(t)
        self.outputs.append(y)
        self.t_last_out = t
        if self.sink is not None and len(self.outputs) >= self.chunk:
            self.drain()

    def drain(self) -> None:
        """Hand the outputs held so far to the sink and forget them."""
        if self.sink is None or not self.outputs:
            return
        times, outputs = list(self.times), list(self.outputs)
        del self.times[:], self.outputs[:]
        self.drained += len(times)
        self.sink(times, outputs)

    @property
    def n_outputs(self) -> int:
        """Outputs recorded so far, drained or held."""
        return self.drained + len(self.outputs)


def step_events(evs, g_old, t, t_new, y_new, dense, event_tol, project, project_steps,
                state, name):
    """The events of an accepted step from t to t_new (y_new: its projected end state; dense:
    its dense output, a callable of the time; g_old: each event function at t): every
    crossing located by Brent's method on the dense output, recorded in ``state.events`` in
    time order up to the first terminal or restart event, which sets ``state.terminated`` or
    is returned. Returns (t_stop, restart record or None, the event functions at t_new)."""
    g_new = [float(e.function(t_new, y_new)) for e in evs]
    found = []
    for i, e in enumerate(evs):
        if _crossed(g_old[i], g_new[i], e.direction):
            if dense is None:
                raise SimulationError(f"{name} has no dense output to locate event {e.name!r}")
            fun = e.function
            te = _brent(lambda s, fun=fun: fun(s, dense(s)), t, t_new, g_old[i], g_new[i],
                        event_tol)
            found.append((te, i))
    found.sort()
    for te, i in found:
        if evs[i].restart is not None:
            te = _far_side(evs[i], dense, te, t_new, g_old[i], event_tol)
        ye = y_new if te == t_new else dense(te)
        if project is not None and (te != t_new or not project_steps):
            ye = project(te, ye)
        rec = EventRecord(te, ye, i, evs[i].name, evs[i].terminal)
        if evs[i].record:
            state.events.append(rec)
        if rec.terminal:
            state.terminated = rec
            return te, None, g_new
        if evs[i].restart is not None:
            return te, rec, g_new
    return t_new, None, g_new


def run(stepper: Stepper, controller, problem, t0: float, y0: np.ndarray, t_eval: np.ndarray,
        counters, state: RunState, progress=None, events=None, event_tol: float = 1e-12,
        max_step: float = math.inf, min_step: float = 0.0, t_end: Optional[float] = None) -> None:
    """Integrate y' = problem.rhs from (t0, y0) to t_end (default t_eval[-1]).

    Appends (t_eval[k], y(t_eval[k])) to state.times / state.outputs in order, located events to
    state.events; a terminal event sets state.terminated and ends the run after appending its
    state as the last output. Raises SpatialMBDError subclasses with ``.t`` on failure.
    """
    project = problem.project
    project_steps = project is not None and stepper.projects_state
    touts = t_eval.tolist()
    n_out = len(touts)
    t_end = touts[-1] if t_end is None else float(t_end)
    span = t_end - t0
    k_out, evs = begin(state, touts, t0, y0, events)
    if k_out == n_out and not evs:
        return
    selfc = stepper.self_controlled or controller is None
    adaptive = not selfc and controller.adaptive
    land = not selfc and getattr(controller, "land_on_outputs", False)
    g_old = [float(e.function(t0, y0)) for e in evs]
    breaks = getattr(problem, "breaks", None)
    bps = [] if breaks is None else [float(tb) for tb in breaks.times if t0 < tb < t_end]
    if bps and selfc:
        raise SimulationError(f"{stepper.name} chooses its own steps and cannot land on the "
                              "sample times of sampled controllers or time series; use an "
                              "integrator of the package (rk45, dop853, rk4, ...)")
    i_bp = 0
    t, y = t0, y0
    def horizon():              # a stepper's start-up must not step over the next breakpoint
        return bps[i_bp] if i_bp < len(bps) else t_end
    try:
        h = stepper.start(problem, t0, y0, horizon(), counters)
        if not adaptive and not selfc:
            h = controller.step
        elif h is not None:
            h = min(h, max_step)
        anchor, n_anchor = t0, 0        # fixed steps landing on outputs: t = anchor + i h
        after_reject = False
        last_cause = "error test failed repeatedly"
        while t < t_end:
            # ---------------------------------------------------------- attempt a step
            if selfc:
                st = stepper.step(t, y, None)
            else:
                t_lim = bps[i_bp] if i_bp < len(bps) else t_end
                if land:
                    t_target = touts[k_out] if k_out < n_out else t_end
                    n_anchor += 1
                    t_new = landing_time(anchor, min(t_target, t_lim), h, n_anchor)
                else:
                    hs = end_step(t, h, t_lim)
                    if adaptive and hs < min_step_size(t, span, min_step):
                        raise underflow_error(stepper.name, t, hs, last_cause)
                    t_new = t_lim if hs == t_lim - t else t + hs
                st = stepper.step(t, y, t_new)
                hs = st.h if st.h is not None else st.t_new - t
                if st.failed is not None:
                    counters.rejected += st.n_steps
                    if not adaptive:
                        err = SimulationError(
                            f"t = {t:.6g} s: {stepper.name}: Newton iteration did not converge "
                            f"with step size h = {hs:.3g} s ({st.failed}); reduce the step size")
                        err.t = t
                        raise err
                    h = controller.failed(hs)
                    after_reject = True
                    last_cause = "Newton iteration failed: " + st.failed
                    continue
                if adaptive and st.err is not None and not st.err <= 1.0:
                    counters.rejected += st.n_steps
                    h = controller.reject(hs, st.err, st.k_retry or st.k)
                    after_reject = True
                    last_cause = ("error test failed repeatedly" if math.isfinite(st.err) else
                                  "error estimate not finite; the derivative is not finite")
                    continue
            # ---------------------------------------------------------- accept
            t_new, y_raw = st.t_new, st.y_new
            y_new = project(t_new, y_raw) if project_steps else y_raw
            raise_if_nonfinite(t_new, y_new)
            stepper.accept(st, y_new)
            counters.steps += st.n_steps
            state.last = (t_new, y_new)
            dense = _corrected_dense(st.dense, t, t_new, y_raw, y_new)
            # ---------------------------------------------------------- events
            t_stop, restart = t_new, None
            if evs:
                g_at_t = g_old
                t_stop, restart, g_old = step_events(evs, g_old, t, t_new, y_new, dense,
                                                     event_tol, project, project_steps, state,
                                                     stepper.name)
            # ---------------------------------------------------------- outputs in (t, t_stop]
            while k_out < n_out and touts[k_out] <= t_stop:
                to = touts[k_out]
                if to == t_new:
                    yo = y_new
                    if project is not None and not project_steps:
                        yo = project(to, yo)
                else:
                    yo = dense(to)
                    if project is not None:
                        yo = project(to, yo)
                state.emit(to, yo)
                k_out += 1
            if terminated(state, t_stop, progress):
                return
            if restart is not None:
                if not selfc and t < restart.t < t_new:
                    restart = _restep(stepper, problem, t, y, restart, t_end, counters,
                                      project if project_steps else None, evs[restart.index],
                                      g_at_t[restart.index], t_new, event_tol)
                    if evs[restart.index].record:
                        state.events[-1] = restart
                evs[restart.index].restart(restart.t, restart.y)
                # later crossings are found again from there
                g_old = [float(e.function(restart.t, restart.y)) for e in evs]
                # the step ends there; the controller's next step size still comes from the
                # error of the whole step
                t_new, y_new = restart.t, restart.y
                stepper.start(problem, t_new, y_new, horizon(), counters)
                if land:
                    anchor, n_anchor = t_new, 0
            if i_bp < len(bps) and t_new == bps[i_bp]:      # a breakpoint: act, restart
                breaks.action(t_new, y_new)
                i_bp += 1
                stepper.start(problem, t_new, y_new, horizon(), counters)
                if land:
                    anchor, n_anchor = t_new, 0
            if progress is not None:
                for tp in (st.progress_times or (t_new,)):
                    progress(tp)
            if land and t_new == (touts[k_out - 1] if k_out else None):
                anchor, n_anchor = t_new, 0
            t, y = t_new, y_new
            if not selfc:
                if adaptive and st.err is not None:
                    h = min(controller.accept(hs, st.err, st.k, after_reject, st.hold), max_step)
                elif adaptive:
                    h = min(hs, max_step)
                after_reject = False
    except Exception as exc:
        tag_time(exc, t)
        raise


def terminated(state, t_stop, progress) -> bool:
    """Whether a terminal event stopped the run (at t_stop): then its state is the last
    output and the progress is told."""
    if state.terminated is None:
        return False
    if state.t_last_out != t_stop:
        state.emit(t_stop, state.terminated.y)
    if progress is not None:
        progress(t_stop)
    return True


def begin(state, touts, t0, y0, events):
    """The start of a run: the outputs at t0 emitted; (their number, the events as
    :class:`Event`)."""
    k = 0
    while k < len(touts) and touts[k] == t0:
        state.emit(t0, y0)
        k += 1
    return k, [Event.coerce(e, i) for i, e in enumerate(events or ())]


def tag_time(exc, t):
    """Give an exception without a time the time t where the run stopped (``exc.t``)."""
    if getattr(exc, "t", None) is None:
        try:
            exc.t = t
        except AttributeError:
            pass


def _restep(stepper, problem, t, y, rec, t_end, counters, project, event, g_old, t_new, xtol):
    """:func:`restep` by a step of the stepper (accepted when it succeeds); rec itself (the
    dense output's state) if that fails."""
    last = []

    def step_to(te):
        stepper.start(problem, t, y, t_end, counters)
        st = stepper.step(t, y, te)
        if st.failed is not None or st.y_new is None or st.t_new != te:
            return None
        last[:] = [st]
        return project(te, st.y_new) if project is not None else st.y_new

    found = restep(step_to, rec, event, g_old, t_new, xtol)
    if found is None:
        stepper.start(problem, rec.t, rec.y, t_end, counters)
        return rec
    stepper.accept(last[0], found.y)
    counters.steps += last[0].n_steps
    return found


def restep(step_to, rec, event, g_old, t_new, xtol):
    """The state at a restart event by one step from the accepted step's start to the event
    time (``step_to(te)``: the projected state there, or None when the step failed), shorter
    than the accepted step, so at least as accurate: the dense output can be an order less
    accurate than the step, and the run continues from this state. The time moves on by xtol,
    2 xtol, ... until the stepped state has crossed (so the event does not fire again from
    there). The new record, or None if that fails."""
    te, step = rec.t, max(xtol, 4.0 * EPS * abs(rec.t))
    for _ in range(60):
        y_new = step_to(te)
        if y_new is None or not np.all(np.isfinite(y_new)):
            break
        if _crossed(g_old, float(event.function(te, y_new)), event.direction):
            return EventRecord(te, y_new, rec.index, rec.name, rec.terminal)
        te = min(te + step, t_new)
        step *= 2.0
        if te >= t_new:
            break
    return None


def _far_side(event, dense, te, t_new, g_old, xtol):
    """The first time from te on (steps xtol, 2 xtol, 4 xtol, ...) where g has crossed, so a
    restart there does not see the same crossing again; t_new at the latest."""
    step = max(xtol, 4.0 * EPS * abs(te))
    while te < t_new:
        if _crossed(g_old, float(event.function(te, dense(te))), event.direction):
            return te
        te = min(te + step, t_new)
        step *= 2.0
    return t_new


def _corrected_dense(dense, t0, t1, y_raw, y_proj):
    """dense(s) + theta (y_proj - y_raw), theta = (s - t0) / (t1 - t0): passes through the
    projected end point (the raw interpolant when the projection did nothing)."""
    if dense is None or y_proj is y_raw:
        return dense
    delta = y_proj - y_raw
    if not np.any(delta):
        return dense
    h = t1 - t0

    def corrected(s):
        return dense(s) + ((s - t0) / h) * delta
    return corrected
