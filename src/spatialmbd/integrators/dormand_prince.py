"""The adaptive Dormand-Prince integrators ``rk45`` (5(4), :mod:`.runge_kutta_adaptive`) and
``dop853`` (8(5,3), :mod:`.dop853`): their options, run by the one compiled adaptive driver
(:mod:`.adaptive_driver`; from Python through :mod:`.adaptive_run`) with the one step-size
controller (:mod:`.controller`), whose factors the options set (:func:`.pairs.make_pair`)."""
from __future__ import annotations

from typing import Optional

import numpy as np

from .adaptive_run import run_adaptive
from .base import Integrator, register
from .controller import default_max_step, non_negative, positive, validate_tolerances
from .controllers import make_controller
from .driver import RunState
from .pairs import DP5, DP8, make_pair


@register
class DormandPrince45(Integrator):
    """Adaptive Dormand-Prince 5(4) with FSAL, PI step control and dense output.

    Options: rtol (> 0), atol (> 0, scalar or (n,) per component), max_step (s, default inf),
    min_step (s, default 0: the floor is 16 eps |t|), first_step (s, default: Hairer's
    algorithm), safety (0.9), min_factor (0.2), max_factor (10), controller ("pi" with
    beta = 0.04 as in Hairer's DOPRI5, or "standard").

    Raises SimulationError (with ``.t``) when the step size underflows.
    """

    name = "rk45"
    order = 5
    adaptive = True
    #: the pair's kind (:mod:`.pairs`)
    kind = DP5

    def __init__(self, rtol: float = 1e-6, atol=1e-9, max_step: Optional[float] = None,
                 min_step: float = 0.0, first_step: Optional[float] = None,
                 safety: float = 0.9, min_factor: float = 0.2, max_factor: float = 10.0,
                 controller: str = "pi", beta: float = 0.04):
        self.rtol, self.atol = validate_tolerances(rtol, atol)
        self.max_step = default_max_step(max_step)
        self.min_step = non_negative(min_step, "min_step")
        self.first_step = None if first_step is None else positive(first_step, "first_step")
        if controller not in ("pi", "standard"):
            raise ValueError(f"option controller={controller!r} must be 'standard' or 'pi'")
        self._ctrl = (controller, dict(safety=float(safety), min_factor=float(min_factor),
                                       max_factor=float(max_factor), beta=float(beta)))
        make_controller(controller, **dict(self._ctrl[1]))      # validate the factors now

    def __repr__(self) -> str:
        return f"{type(self).__name__}(rtol={self.rtol!r}, atol={self.atol!r})"

    def pair(self):
        """The embedded pair with this integrator's controller and minimum step
        (:mod:`.pairs`), as the compiled driver runs it."""
        kind, opts = self._ctrl
        return make_pair(self.kind, opts["safety"], opts["min_factor"], opts["max_factor"],
                         opts["beta"] if kind == "pi" else 0.0, self.min_step)

    def _integrate(self, problem, t0: float, y0: np.ndarray, t_eval: np.ndarray, counters,
                   outputs: list, progress, events=None, event_tol: float = 1e-12,
                   state=None) -> None:
        if state is None:
            state = RunState(outputs=outputs)
        run_adaptive(self.name, self.pair(), self.rtol, self.atol, self.max_step,
                     self.first_step, problem, float(t0), np.asarray(y0, dtype=float),
                     np.asarray(t_eval, dtype=float), counters, state, progress=progress,
                     events=events, event_tol=event_tol)


@register
class DormandPrince853(DormandPrince45):
    """Adaptive Dormand-Prince 8(5,3) (Hairer's DOP853) with FSAL and dense output of order 7:
    the integrator for tight tolerances (rtol <= 1e-7) on non-stiff problems.

    Options as rk45's (rtol, atol, max_step, min_step, first_step, controller, safety,
    min_factor, max_factor, beta), with DOP853's defaults: safety 0.9, min_factor 1/3,
    max_factor 6, beta 0 (the elementary controller with exponent 1/8).

    Raises SimulationError (with ``.t``) when the step size underflows.
    """

    name = "dop853"
    order = 8
    kind = DP8

    def __init__(self, rtol: float = 1e-6, atol=1e-9, max_step: Optional[float] = None,
                 min_step: float = 0.0, first_step: Optional[float] = None,
                 safety: float = 0.9, min_factor: float = 0.333, max_factor: float = 6.0,
                 controller: str = "pi", beta: float = 0.0):
        super().__init__(rtol, atol, max_step, min_step, first_step, safety, min_factor,
                         max_factor, controller, beta)
