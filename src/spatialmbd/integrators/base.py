"""The contract between the dynamics and the time integrators (text ch. 13).

An integrator advances a first-order system y' = f(t, y) (13.1)-(13.3) and knows nothing about
multibody systems: the dynamics hand it an :class:`ODEProblem` whose ``rhs`` solves the equations
of motion once per call (one *function evaluation*, as counted in Table 15.3) and whose optional
``project`` hook maps an accepted state back onto its manifold (unit Euler parameters, or the
constraint manifold for the projection method).

Adding an integrator (after scipy.integrate._ivp and diffrax's solver / controller split):

1. write a :class:`.driver.Stepper` (``start``, ``step(t, y, t_new) -> Step`` with the new
   state, its error norm and a dense interpolant, ``accept`` when it carries state);
2. subclass :class:`Integrator`, set ``name``, ``order`` and ``adaptive`` and implement
   ``make_stepper()`` and ``make_controller()`` (a controller of :mod:`.controllers`) -- or,
   for an embedded Runge-Kutta pair, add its tableau to :mod:`.pairs` and subclass
   :class:`.dormand_prince.DormandPrince45` (the compiled driver runs it);
3. register the class with :func:`register`.

The loop itself (output sampling, projection, counters, progress, events, partial results) is
:func:`.driver.run`, the same for every integrator.

Failures: the right-hand side raises :class:`spatialmbd.errors.SpatialMBDError` (singular matrix,
Newton failure), or produces NaN, or the step size underflows. ``Integrator.integrate`` catches
these and returns an :class:`IntegrationResult` with ``status == "failed"``, a message giving the
time and the cause, and every output computed before the failure. A terminal event ends the run
with ``status == "event"`` (a success: ``result.success`` is True).
"""
from __future__ import annotations

import abc
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from ..errors import SpatialMBDError
from .controller import check_finite  # noqa: F401  (re-exported: simulate)
from .driver import RunState, run

RHS = Callable[[float, np.ndarray], np.ndarray]
Projection = Callable[[float, np.ndarray], np.ndarray]


@dataclass
class ODEProblem:
    """y' = rhs(t, y).

    rhs: (t, y (n,)) -> y' (n,). One call is one function evaluation.
    project: optional (t, y) -> y applied to every accepted step (and to the initial state);
        it must be idempotent on states that already lie on the manifold.
    jac: optional (t, y) -> (n, n) Jacobian dy'/dy; implicit integrators fall back to finite
        differences of ``rhs`` when it is None.
    project_keeps_rhs: True when ``project`` never changes rhs(t, y) (beyond round-off), e.g.
        when it only rescales components that rhs normalises anyway (unit Euler parameters);
        integrators may then keep a derivative computed before the projection (FSAL).
    stages: optional compiled evaluation of explicit Runge-Kutta stages,
        ``stages(t, y, h, tableau, nodes, slopes, s0, s1, out, t_last) -> s``: for
        s = s0 .. s1-1, out = y + h sum_(j<s) tableau[s, j] slopes[j] and
        slopes[s] = rhs(t + nodes[s] h, out) (t_last for the last stage), exactly as
        :func:`.explicit.rk_stages` does with ``rhs``, in one call. Returns the first stage it
        did not complete (s1 when all went well); the integrator evaluates the rest with ``rhs``
        (which then reports the problem, e.g. a singular matrix).
    n_quadrature: the last ``n_quadrature`` components of y are quadratures: rhs does not depend
        on them (e.g. the work W of the non-conservative forces). Implicit integrators leave
        their (zero) Jacobian columns out and keep them out of the Newton convergence test
        (their update is exact once the other components have converged).
    breaks: optional time breakpoints -- an object with ``times`` (increasing, s) and
        ``action(t, y)``: the steps land exactly on each time, where the action runs (it may
        change rhs from then on: a zero-order-hold command) and the stepper restarts, so no
        step with error control spans a jump of rhs (:func:`.driver.run`).
    """

    rhs: RHS
    project: Optional[Projection] = None
    jac: Optional[Callable[[float, np.ndarray], np.ndarray]] = None
    project_keeps_rhs: bool = False
    stages: Optional[Callable] = None
    n_quadrature: int = 0
    breaks: Optional[object] = None


@dataclass
class Counters:
    """Work done by one integration run."""

    steps: int = 0            # accepted steps
    rejected: int = 0         # rejected steps (error test or Newton failure)
    nfev: int = 0             # right-hand-side evaluations = solves of the equations of motion
    njev: int = 0             # Jacobian evaluations (implicit integrators)
    nlu: int = 0              # LU factorisations (implicit integrators)
    wall_time: float = 0.0    # seconds

    def as_dict(self) -> dict:
        return dict(steps=self.steps, rejected=self.rejected, nfev=self.nfev, njev=self.njev,
                    nlu=self.nlu, wall_time=self.wall_time)


@dataclass
class IntegrationResult:
    """Outputs of an integration at the requested times.

    t: (n_out,) the output times actually reached (a prefix of t_eval when failed; after a
        terminal event the prefix before the event followed by the event time).
    y: (n_out, n) the state at those times (dense output, not the internal steps).
    status: "success", "event" (a terminal event stopped the run) or "failed"; message says
        why it failed (time and cause) or which event stopped it.
    events: the located events (:class:`.driver.EventRecord`: t, y, index, name, terminal) in
        time order.
    """

    t: np.ndarray
    y: np.ndarray
    status: str
    message: str
    counters: Counters = field(default_factory=Counters)
    t_fail: Optional[float] = None
    events: list = field(default_factory=list)
    last: Optional[tuple] = None       # (t, y) of the last accepted step

    @property
    def success(self) -> bool:
        return self.status in ("success", "event")


class Integrator(abc.ABC):
    """Base class: the options of a time-stepping strategy; ``make_stepper`` and
    ``make_controller`` give the pieces :func:`.driver.run` drives."""

    name: str = ""
    order: int = 0
    adaptive: bool = False
    max_step: float = math.inf
    min_step: float = 0.0
    #: a multistep method: its steps and error estimates build on the earlier states, so a
    #: projection of every accepted state must be smooth -- converged far below the error
    #: tolerance (simulate asks for 1e-3 atol), not stopped at a threshold near it, whose
    #: on/off corrections of about atol would stay in the history as noise the error test
    #: cannot step below (Andrews' squeezer under bdf4: step size underflow)
    multistep: bool = False

    def integrate(self, problem: ODEProblem, t0: float, y0: np.ndarray, t_eval: np.ndarray,
                  progress: Optional[Callable[[float], None]] = None, events=None,
                  event_tol: float = 1e-12, sink: Optional[Callable] = None,
                  chunk: int = 0) -> IntegrationResult:
        """Integrate from (t0, y0) and return the state at each time of ``t_eval``.

        t_eval: (n_out,) increasing, t_eval[0] >= t0. progress: called with the current time
        after accepted steps (for progress bars). events: zero crossings to locate (see
        :mod:`.driver`: callables g(t, y) or objects with ``function``, ``terminal``,
        ``direction``); event_tol: their time tolerance (s). sink / chunk: streaming -- every
        ``chunk`` outputs are handed to ``sink(times, outputs)`` and forgotten; the result then
        holds only the outputs after the last full chunk.
        """
        t_eval = np.asarray(t_eval, dtype=float)
        if t_eval.ndim != 1 or t_eval.size == 0:
            raise ValueError("t_eval must be a non-empty 1-D array of output times")
        if np.any(np.diff(t_eval) <= 0) or t_eval[0] < t0:
            raise ValueError("t_eval must be strictly increasing and start at or after t0")
        counters = Counters()
        y0 = np.array(y0, dtype=float)
        if problem.project is not None:
            y0 = problem.project(t0, y0)
        if sink is not None and (isinstance(chunk, bool) or not isinstance(chunk, int)
                                 or chunk < 1):
            raise ValueError(f"chunk: expected a positive number of outputs, got {chunk!r}")
        state = RunState(sink=sink, chunk=chunk)
        start = time.perf_counter()
        status, message, t_fail = "success", "", None
        try:
            with np.errstate(all="ignore"):
                self._integrate(problem, float(t0), y0, t_eval, counters, state.outputs, progress,
                                events=events, event_tol=event_tol, state=state)
        except (SpatialMBDError, FloatingPointError, np.linalg.LinAlgError) as exc:
            status = getattr(exc, "status", "failed")     # "budget": stopped by a budget
            t_fail = getattr(exc, "t", None)
            message = str(exc)
        except KeyboardInterrupt:                         # Ctrl-C: keep what was computed
            status, message = "interrupted", "interrupted (Ctrl-C)"
        except Exception as exc:  # noqa: BLE001 - a non-project error mid-run (e.g. LAPACK's
            # ValueError): the outputs computed so far are returned with the cause; before
            # the first evaluation it is a setting the integrator cannot use: raised
            if counters.nfev == 0 and not state.n_outputs:
                raise
            status = "failed"
            t_fail = getattr(exc, "t", None)
            message = f"{type(exc).__name__}: {exc}"
        counters.wall_time = time.perf_counter() - start
        outputs = state.outputs
        n_out = len(outputs)
        y = np.array(outputs) if n_out else np.empty((0, y0.size))
        n_all = state.n_outputs
        if status != "success" and t_fail is None:
            t_fail = float(t_eval[n_all]) if n_all < t_eval.size else float(t_eval[-1])
        if status != "success" and not message.startswith("t ="):
            message = f"t = {t_fail:.6g} s: {message}"
        if status == "success" and state.terminated is not None:
            ev = state.terminated
            status = "event"
            message = f"t = {ev.t:.9g} s: terminal event {ev.name!r} (events[{ev.index}])"
        return IntegrationResult(t=np.array(state.times, dtype=float), y=y, status=status,
                                 message=message, counters=counters, t_fail=t_fail,
                                 events=list(state.events), last=state.last)

    def _integrate(self, problem: ODEProblem, t0: float, y0: np.ndarray, t_eval: np.ndarray,
                   counters: Counters, outputs: list, progress, events=None,
                   event_tol: float = 1e-12, state=None) -> None:
        """Run the driver; append y(t_eval[k]) to ``outputs`` in order; raise on failure."""
        if state is None:
            state = RunState(outputs=outputs)
        run(self.make_stepper(), self.make_controller(), problem, float(t0),
            np.asarray(y0, dtype=float), np.asarray(t_eval, dtype=float), counters, state,
            progress=progress, events=events, event_tol=event_tol, max_step=self.max_step,
            min_step=self.min_step)

    def make_stepper(self):
        """A fresh :class:`.driver.Stepper` for one run (an integrator that overrides
        ``_integrate`` needs none)."""
        raise NotImplementedError(f"{type(self).__name__} has no stepper for driver.run")

    def make_controller(self):
        """A fresh step-size controller (:mod:`.controllers`) for one run."""
        raise NotImplementedError(f"{type(self).__name__} has no controller for driver.run")


INTEGRATORS: dict[str, type[Integrator]] = {}


def register(cls: type[Integrator]) -> type[Integrator]:
    """Class decorator: make an integrator available by name (files, CLI, ``simulate``)."""
    INTEGRATORS[cls.name] = cls
    return cls


def get_integrator(spec, **options) -> Integrator:
    """An integrator from a name (with options) or an Integrator instance."""
    if isinstance(spec, Integrator):
        if options:
            raise ValueError("options can only be given with an integrator name")
        return spec
    if isinstance(spec, str):
        key = spec.lower()
        if key not in INTEGRATORS:
            raise ValueError(f"unknown integrator {spec!r}; valid names: "
                             + ", ".join(sorted(INTEGRATORS)))
        return INTEGRATORS[key](**options)
    raise TypeError(f"integrator must be a name or an Integrator, not {type(spec).__name__}")
