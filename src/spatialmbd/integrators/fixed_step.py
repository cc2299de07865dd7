"""Fixed-step explicit integrators of text ch. 13: forward Euler, Heun (RK2) and classic RK4.

All three advance y' = f(t, y), y: (n,), with a constant step h (option ``step``, in s). The step
is shortened only to land exactly on each output time, so every output is a step point (no
interpolation). Within an output interval [t_a, t_b] the step points are t_a + i h, and the last
step ends exactly at t_b (it is at most h (1 + 1e-9) long). ``project`` is applied after every step.

Function evaluations per step: Euler 1, Heun 2, RK4 4.
"""
from __future__ import annotations

import abc

import math

import numpy as np

from ..errors import SpatialMBDError
from .base import Integrator, register
from .controller import positive, raise_if_nonfinite


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

    def _integrate(self, problem, t0, y0, t_eval, counters, outputs, progress) -> None:
        f = problem.rhs
        project = problem.project
        advance = self._advance
        stages = self.stages
        h = self.step
        t, y = t0, y0
        try:
            for t_out in t_eval.tolist():
                if t_out > t:
                    # number of steps to t_out; the last one lands exactly on it
                    m = max(1, math.ceil((t_out - t) / h - 1e-9))
                    t_start = t
                    for i in range(1, m + 1):
                        t_new = t_out if i == m else t_start + i * h
                        y = advance(f, t, y, t_new - t)
                        counters.nfev += stages
                        if project is not None:
                            y = project(t_new, y)
                        raise_if_nonfinite(t_new, y)
                        t = t_new
                        counters.steps += 1
                        if progress is not None:
                            progress(t)
                outputs.append(y)
        except (SpatialMBDError, np.linalg.LinAlgError, FloatingPointError) as exc:
            if getattr(exc, "t", None) is None:
                exc.t = t
            raise


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


def rk4_step(f, t: float, y: np.ndarray, h: float, k1: np.ndarray) -> np.ndarray:
    """One classic RK4 step, Eqs. (13.14)-(13.19), given k1 = f(t, y) (3 new evaluations)."""
    hh = 0.5 * h
    th = t + hh
    k2 = f(th, y + hh * k1)                        # Eq. (13.16)
    k3 = f(th, y + hh * k2)                        # Eq. (13.17)
    k4 = f(t + h, y + h * k3)                      # Eq. (13.18)
    return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)   # Eq. (13.14), (13.19)
