"""Step-size controllers injected into the integration driver (:mod:`.driver`).

A controller only turns the error norm of an attempted step into the next step size; it knows
nothing about the stepping formula (the stepper reports the error norm ||e|| in the weighted RMS
norm (Hairer, Norsett & Wanner I, Eq. II.4.11), accepted when ||e|| <= 1, and the exponent k with which
the local error behaves like h^k). The driver owns the rest (landing on t_end, max/min step,
underflow, Newton failures). Controllers:

* :class:`IController`: the elementary controller h_new = h safety ||e||^(-1/k) (Hairer, Norsett
  & Wanner I, Eq. II.4.13), the factor clipped to [min_factor, max_factor]; optionally a
  ``deadband``: an accepted step keeps h unless the factor reaches ``deadband`` (multistep
  methods, whose history must be re-spaced at every change);
* :class:`PIController`: Gustafsson's PI controller
  h_new = h safety ||e_n||^(-alpha) ||e_(n-1)||^beta, alpha = 1/k - 0.75 beta (Hairer & Wanner
  II, Sec. IV.2; beta = 0.04 as in Hairer's DOPRI5);
* :class:`FixedStepController`: a constant step h (s); with ``land_on_outputs`` the steps restart
  at every output time and the last one of each output interval lands on it exactly (the
  fixed-step one-step methods: every output is a step point).

Every controller has ``adaptive`` (whether the driver runs the error test) and ``reset()``.
The factors themselves are the compiled rules of :mod:`.controller` (:func:`.controller.pi_factor`,
:func:`.controller.rejected_factor`) that the compiled driver (:mod:`.adaptive_driver`) runs
too: one controller, called from Python here.
"""
from __future__ import annotations

from .controller import pi_factor, positive, rejected_factor


class IController:
    """Elementary (integral) controller; see the module docstring.

    safety (0, 1), min_factor (0, 1), max_factor > 1; deadband >= 1 (1: no deadband).
    """

    adaptive = True
    land_on_outputs = False
    #: beta of the PI term (0: the elementary controller)
    beta = 0.0

    def __init__(self, safety: float = 0.9, min_factor: float = 0.2, max_factor: float = 10.0,
                 deadband: float = 1.0):
        if not 0.0 < safety < 1.0:
            raise ValueError(f"option safety={safety!r} must lie in (0, 1)")
        if not 0.0 < min_factor < 1.0:
            raise ValueError(f"option min_factor={min_factor!r} must lie in (0, 1)")
        if not max_factor > 1.0:
            raise ValueError(f"option max_factor={max_factor!r} must be > 1")
        if not deadband >= 1.0:
            raise ValueError(f"option deadband={deadband!r} must be >= 1")
        self.safety = float(safety)
        self.min_factor = float(min_factor)
        self.max_factor = float(max_factor)
        self.deadband = float(deadband)
        self.reset()

    def reset(self) -> None:
        self.err_prev = 1e-4

    def accept(self, h: float, err: float, k: int, after_reject: bool, hold: bool = False) -> float:
        """Next step size after an accepted step of size h with error norm err <= 1.

        after_reject: the step followed a rejection (then h does not grow). hold: the stepper
        asks for a constant step (a multistep start-up); h may then only shrink.
        """
        alpha = 1.0 / k - 0.75 * self.beta
        fac, self.err_prev = pi_factor(float(err), self.err_prev, alpha, self.beta, self.safety,
                                       self.min_factor, self.max_factor,
                                       bool(after_reject or hold))
        if self.deadband > 1.0 and fac < self.deadband:
            fac = 1.0
        return h * fac

    def reject(self, h: float, err: float, k: int) -> float:
        """Step size (< h) for retrying a step rejected with error norm err (> 1 or NaN)."""
        return h * rejected_factor(float(err), 1.0 / k, self.safety, self.min_factor)

    def failed(self, h: float) -> float:
        """Step size after a failure of the stepper's nonlinear solve (Newton): h / 2."""
        return 0.5 * h


class PIController(IController):
    """Gustafsson's PI controller (beta = 0.04 by default); see the module docstring."""

    def __init__(self, safety: float = 0.9, min_factor: float = 0.2, max_factor: float = 10.0,
                 beta: float = 0.04, deadband: float = 1.0):
        self.beta = float(beta)
        super().__init__(safety, min_factor, max_factor, deadband)


class FixedStepController:
    """A constant step h (s); see the module docstring for ``land_on_outputs``."""

    adaptive = False

    def __init__(self, step: float, land_on_outputs: bool = False):
        self.step = positive(step, "step")
        self.land_on_outputs = bool(land_on_outputs)

    def reset(self) -> None:
        pass

    def accept(self, h, err, k, after_reject, hold=False) -> float:
        return self.step

    def reject(self, h, err, k) -> float:          # never called: no error test
        return self.step

    def failed(self, h: float) -> float:
        return self.step


def make_controller(kind: str, **options):
    """A controller by name: "pi", "standard" (= "i") or "fixed" (option step)."""
    kind = str(kind).lower()
    if kind == "pi":
        return PIController(**options)
    if kind in ("standard", "i"):
        options.pop("beta", None)
        return IController(**options)
    if kind == "fixed":
        return FixedStepController(**options)
    raise ValueError(f"option controller={kind!r} must be 'pi', 'standard' or 'fixed'")
