"""Fixed-step explicit integrators of text ch. 13: forward Euler, Heun (RK2) and classic RK4.

All three advance y' = f(t, y), y: (n,), with a constant step h (option ``step``, in s). The step
is shortened only to land exactly on each output time, so every output is a step point (no
interpolation). Within an output interval [t_a, t_b] the step points are t_a + i h, and the last
step ends exactly at t_b (it is at most h (1 + 1e-9) long). ``project`` is applied after every step.

Function evaluations per step: Euler 1, Heun 2, RK4 4.
"""
from __future__ import annotations

import abc

import numpy as np

from .base import Integrator, register
from .controller import hermite, positive
from .controllers import FixedStepController
from .driver import Step, Stepper


class OneStepStepper(Stepper):
    """The stepping formula of a fixed-step one-step method; ``advance(f, t, y, h, f0)`` gives
    y_(n+1) from f0 = f(t_n, y_n). Dense output (only needed for events): the cubic Hermite
    interpolant from (y_n, f_n) and (y_(n+1), f(t_(n+1), y_(n+1))), the latter evaluated on
    first use (counted in nfev)."""

    def __init__(self, name, advance, evaluations):
        self.name = name
        self.advance = advance
        self.evaluations = evaluations

    def start(self, problem, t0, y0, t_end, counters):
        self.f = problem.rhs
        self.counters = counters
        return None

    def step(self, t, y, t_new):
        f, counters = self.f, self.counters
        h = t_new - t
        f0 = f(t, y)
        y_new = self.advance(f, t, y, h, f0)
        counters.nfev += self.evaluations
        cache = []

        def dense(s):
            if not cache:
                cache.append(f(t_new, y_new))
                counters.nfev += 1
            return hermite((s - t) / h, h, y, f0, y_new, cache[0])
        return Step(t_new, y_new, None, 1, dense)


class FixedStepIntegrator(Integrator):
    """Base class of the one-step fixed-step methods. Option: ``step`` h > 0 (s), default 1e-3."""

    adaptive = False
    stages = 0          # right-hand-side evaluations per step

    def __init__(self, step: float = 1e-3):
        self.step = positive(step, "step")

    def __repr__(self) -> str:
        return f"{type(self).__name__}(step={self.step!r})"

    @abc.abstractmethod
    def _advance(self, f, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """One step of size h from (t, y); returns y_(n+1) (a new array)."""

    def _advance_from(self, f, t, y, h, f0):
        """One step given f0 = f(t, y) (already evaluated)."""
        return self._advance(_Memo(f, t, y, f0), t, y, h)

    def make_stepper(self):
        return OneStepStepper(self.name, self._advance_from, self.stages)

    def make_controller(self):
        return FixedStepController(self.step, land_on_outputs=True)


class _Memo:
    """f with its value at (t, y) known (the first stage of a step is not evaluated twice)."""

    __slots__ = ("f", "t", "y", "f0")

    def __init__(self, f, t, y, f0):
        self.f, self.t, self.y, self.f0 = f, t, y, f0

    def __call__(self, t, y):
        if t == self.t and y is self.y:
            return self.f0
        return self.f(t, y)


@register
class ForwardEuler(FixedStepIntegrator):
    """Forward (explicit) Euler, Eq. (13.6): y_(n+1) = y_n + h f(t_n, y_n). Order 1."""

    name = "euler"
    order = 1
    stages = 1

    def _advance(self, f, t, y, h):
        return y + h * f(t, y)  # Eq. (13.6)


@register
class Heun(FixedStepIntegrator):
    """Heun's method (second-order Runge-Kutta), Eqs. (13.11)-(13.13). Order 2.

    k1 = f(t_n, y_n), k2 = f(t_n + h, y_n + h k1), y_(n+1) = y_n + h (k1 + k2) / 2.
    """

    name = "heun"
    order = 2
    stages = 2

    def _advance(self, f, t, y, h):
        k1 = f(t, y)                               # Eq. (13.12)
        k2 = f(t + h, y + h * k1)                  # Eq. (13.13)
        return y + (0.5 * h) * (k1 + k2)           # Eq. (13.11)


@register
class RungeKutta4(FixedStepIntegrator):
    """Classic fourth-order Runge-Kutta, Eqs. (13.14)-(13.19). Order 4.

    k1 = f(t_n, y_n), k2 = f(t_n + h/2, y_n + h k1/2), k3 = f(t_n + h/2, y_n + h k2/2),
    k4 = f(t_n + h, y_n + h k3), y_(n+1) = y_n + h (k1 + 2 k2 + 2 k3 + k4) / 6.
    """

    name = "rk4"
    order = 4
    stages = 4

    def _advance(self, f, t, y, h):
        return rk4_step(f, t, y, h, f(t, y))

    def _advance_from(self, f, t, y, h, f0):
        return rk4_step(f, t, y, h, f0)


def rk4_step(f, t: float, y: np.ndarray, h: float, k1: np.ndarray) -> np.ndarray:
    """One classic RK4 step, Eqs. (13.14)-(13.19), given k1 = f(t, y) (3 new evaluations)."""
    hh = 0.5 * h
    th = t + hh
    k2 = f(th, y + hh * k1)                        # Eq. (13.16)
    k3 = f(th, y + hh * k2)                        # Eq. (13.17)
    k4 = f(t + h, y + h * k3)                      # Eq. (13.18)
    return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)   # Eq. (13.14), (13.19)
