"""Adams-Bashforth-Moulton fourth-order predictor-corrector (PECE), text ch. 13.

Predictor, Adams-Bashforth, Eq. (13.20):
    y^p_(n+1) = y_n + h/24 (55 f_n - 59 f_(n-1) + 37 f_(n-2) - 9 f_(n-3))
Corrector, Adams-Moulton, Eq. (13.23):
    y_(n+1) = y_n + h/24 (9 f^p_(n+1) + 19 f_n - 5 f_(n-1) + f_(n-2)),  f^p_(n+1) = f(t_(n+1), y^p)
then f_(n+1) = f(t_(n+1), y_(n+1)) (PECE: 2 evaluations per step).

Local error (Milne's device): the predictor and corrector errors are (251/720) h^5 y^(5) and
-(19/720) h^5 y^(5), so the corrector's local error is about -(19/270) (y_(n+1) - y^p_(n+1)).

Start-up: the first three steps are classic RK4, Eqs. (13.14)-(13.19), at the same step size.
In adaptive mode the start-up is validated by the first predictor-corrector step: if that step
fails the error test, the RK4 start-up steps are discarded (counted as rejected) and the start-up
is redone from the initial point with the reduced step; outputs are only emitted once validated.
(The stepper, :class:`AdamsStepper`, takes the start-up as one step of four internal steps, so
the driver accepts or rejects it as a whole.)

Variable step (design choice): the method keeps the uniform-spacing formulas above and, when the
step changes from h to h', re-spaces the derivative history f_n, ..., f_(n-3) by evaluating the
cubic that interpolates it at t_n - k h', k = 1, 2, 3 (:func:`controller.resample_matrix`; exact
for polynomial f of degree <= 3, so the method stays fourth order and no extra evaluations are
needed). To limit re-spacing, the step grows only when the error allows a factor >= 1.25 (at most
x2) and shrinks only on rejection (factor >= 0.2).

Dense output: cubic Hermite interpolation between accepted steps from (y_n, f_n) and
(y_(n+1), f_(n+1)); outputs are projected when ``problem.project`` is given.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .base import Integrator, register
from .controller import (atol_vector, default_max_step, hermite, initial_step, non_negative,
                         positive, raise_if_nonfinite, resample_matrix, validate_tolerances)
from .controllers import FixedStepController, IController
from .driver import Step, Stepper

AB4 = np.array([55.0, -59.0, 37.0, -9.0]) / 24.0     # Eq. (13.20), on f_n .. f_(n-3)
AM4 = np.array([19.0, -5.0, 1.0]) / 24.0             # Eq. (13.23), on f_n .. f_(n-2)
AM4_NEW = 9.0 / 24.0                                 # Eq. (13.23), on f^p_(n+1)
MILNE = 19.0 / 270.0                                 # corrector error / (y_c - y_p)


def _rk4(f, t, y, h, k1):
    hh = 0.5 * h
    k2 = f(t + hh, y + hh * k1)                       # Eq. (13.16)
    k3 = f(t + hh, y + hh * k2)                       # Eq. (13.17)
    k4 = f(t + h, y + h * k3)                         # Eq. (13.18)
    return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


class PiecewiseHermite:
    """Cubic Hermite interpolation through nodes (t_i, y_i, f_i); the last derivative may be
    supplied later (``last``: a callable returning it, read on first use)."""

    def __init__(self, ts, ys, fs, last=None):
        self.ts, self.ys, self.fs, self.last = ts, ys, fs, last

    def __call__(self, s):
        ts = self.ts
        i = 0
        while i < len(ts) - 2 and s > ts[i + 1]:
            i += 1
        f1 = self.fs[i + 1] if i + 1 < len(self.fs) else self.last()
        h = ts[i + 1] - ts[i]
        return hermite((s - ts[i]) / h, h, self.ys[i], self.fs[i], self.ys[i + 1], f1)


class AdamsStepper(Stepper):
    """ABM4 PECE stepping formula with an RK4 start-up taken as one step of four (the first
    call covers t .. t + 4h: three RK4 steps, Eqs. (13.14)-(13.19), and the first PECE step,
    whose error test validates the whole start-up; a rejection redoes all four)."""

    name = "abm4"

    def __init__(self, rtol, atol, first_step, max_step, adaptive):
        self.rtol, self.atol_opt = rtol, atol
        self.first_step, self.max_step = first_step, max_step
        self.adaptive = adaptive

    def start(self, problem, t0, y0, t_end, counters):
        f = problem.rhs
        self.f, self.counters, self.project = f, counters, problem.project
        self.t_end = t_end
        n = y0.size
        self.atol = atol_vector(self.atol_opt, n)
        self.fy = f(t0, y0)
        counters.nfev += 1
        raise_if_nonfinite(t0, self.fy, "derivative")
        self.F = np.empty((4, n))       # f_n, f_(n-1), f_(n-2), f_(n-3) spaced by hF
        self.n_hist = 1
        self.hF = 0.0
        self.f_new = None
        span = t_end - t0
        if not self.adaptive:
            return None
        h = self.first_step if self.first_step is not None else initial_step(
            f, t0, y0, self.fy, 4, self.rtol, self.atol, self.max_step, span, self.counters)
        return min(h, self.max_step, span / 4.0)

    def _pece(self, t, y, hs):
        """Predictor, Eq. (13.20), and corrector, Eq. (13.23); F spaced by hs."""
        F = self.F
        t_new = t + hs
        y_p = y + hs * np.dot(AB4, F)                              # Eq. (13.20)
        f_p = self.f(t_new, y_p)
        self.counters.nfev += 1
        y_c = y + hs * (AM4_NEW * f_p + np.dot(AM4, F[:3]))        # Eq. (13.23)
        err = None
        if self.adaptive:
            scale = self.atol + self.rtol * np.maximum(np.abs(y), np.abs(y_c))
            e = (y_c - y_p) * (MILNE / scale)
            err = math.sqrt(float(np.dot(e, e)) / y.size)
        return y_c, err

    def step(self, t, y, t_new):
        f, counters, F = self.f, self.counters, self.F
        hs = t_new - t
        if self.n_hist < 4:
            # ---- start-up: three RK4 steps at constant step, then the first PECE step
            if t + 4.0 * hs > self.t_end:
                hs = (self.t_end - t) / 4.0
            ts, ys, fs = [t], [y], [self.fy]
            F[0] = self.fy
            yk, fk, tk = y, self.fy, t
            for i in range(1, 4):
                tk = t + i * hs
                yk = _rk4(f, ts[-1], yk, hs, fk)
                counters.nfev += 3
                if self.project is not None:
                    yk = self.project(tk, yk)
                raise_if_nonfinite(tk, yk)
                fk = f(tk, yk)
                counters.nfev += 1
                F[1:] = F[:-1]
                F[0] = fk
                ts.append(tk)
                ys.append(yk)
                fs.append(fk)
            self.n_hist = 4
            self.hF = hs
            t_end4 = self.t_end if t + 4.0 * hs >= self.t_end else t + 4.0 * hs
            y_c, err = self._pece(tk, yk, t_end4 - tk)
            ts.append(t_end4)
            ys.append(y_c)
            dense = PiecewiseHermite(ts, ys, fs, last=lambda: self.f_new)
            if err is not None and not err <= 1.0:
                self.n_hist = 1                      # redo the start-up at a smaller step
            return Step(t_end4, y_c, err, 5, dense, n_steps=4, h=hs,
                        progress_times=ts[1:])
        # ---- predictor-corrector step
        if hs != self.hF:
            self.F = F = resample_matrix(4, hs / self.hF) @ F
            self.hF = hs
        y_c, err = self._pece(t, y, hs)
        dense = PiecewiseHermite([t, t_new], [y, y_c], [self.fy], last=lambda: self.f_new)
        return Step(t_new, y_c, err, 5, dense)

    def accept(self, step, y_final):
        f_new = self.f(step.t_new, y_final)                       # final E of PECE
        self.counters.nfev += 1
        F = self.F
        F[1:] = F[:-1]
        F[0] = f_new
        self.fy = self.f_new = f_new


@register
class AdamsBashforthMoulton4(Integrator):
    """Fourth-order Adams-Bashforth-Moulton PECE, variable or constant step.

    Options: step (s; the constant step when not adaptive, else the first step), adaptive (True),
    fixed_step (False; True is the same as adaptive=False), rtol, atol (scalar or (n,)),
    max_step (s), min_step (s), safety (0.9).

    Raises SimulationError (with ``.t``) on step-size underflow.
    """

    name = "abm4"
    order = 4
    adaptive = True
    multistep = True

    def __init__(self, step: Optional[float] = None, adaptive: bool = True,
                 fixed_step: bool = False, rtol: float = 1e-6, atol=1e-9,
                 max_step: Optional[float] = None, min_step: float = 0.0, safety: float = 0.9):
        self.adaptive = bool(adaptive) and not fixed_step
        self.step = None if step is None else positive(step, "step")
        if not self.adaptive and self.step is None:
            raise ValueError("abm4 at a constant step needs the option step=h > 0 (got None)")
        self.rtol, self.atol = validate_tolerances(rtol, atol)
        self.max_step = default_max_step(max_step)
        self.min_step = non_negative(min_step, "min_step")
        self.safety = float(safety)
        self.make_controller()

    def __repr__(self) -> str:
        mode = "adaptive" if self.adaptive else "fixed"
        return f"AdamsBashforthMoulton4({mode}, step={self.step!r}, rtol={self.rtol!r})"

    def make_stepper(self):
        return AdamsStepper(self.rtol, self.atol, self.step, self.max_step, self.adaptive)

    def make_controller(self):
        if not self.adaptive:
            return FixedStepController(self.step)
        # the history is re-spaced at every change: grow only by >= 1.25 (at most x2)
        return IController(safety=self.safety, max_factor=2.0, deadband=1.25)
