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

from ..errors import SpatialMBDError
from .base import Integrator, register
from .controller import (StepController, atol_vector, default_max_step, end_step, hermite,
                         initial_step, min_step_size, non_negative, positive,
                         raise_if_nonfinite, resample_matrix, underflow_error,
                         validate_tolerances)

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
        StepController(5, safety=self.safety)

    def __repr__(self) -> str:
        mode = "adaptive" if self.adaptive else "fixed"
        return f"AdamsBashforthMoulton4({mode}, step={self.step!r}, rtol={self.rtol!r})"

    def _integrate(self, problem, t0, y0, t_eval, counters, outputs, progress) -> None:
        f = problem.rhs
        project = problem.project
        n = y0.size
        adaptive = self.adaptive
        rtol = self.rtol
        atol = atol_vector(self.atol, n)
        ctrl = StepController(5, safety=self.safety, max_factor=2.0)
        touts = t_eval.tolist()
        n_out = len(touts)
        t_end = touts[-1]
        span = t_end - t0
        k_out = 0
        if touts[0] == t0:
            outputs.append(y0)
            k_out = 1
        if k_out == n_out:
            return

        def commit(t, y, fy, t_new, y_new, f_new):
            """Accept a step: count it, emit the outputs in (t, t_new], report progress."""
            nonlocal k_out
            counters.steps += 1
            hs = t_new - t
            while k_out < n_out and touts[k_out] <= t_new:
                to = touts[k_out]
                if to == t_new:
                    outputs.append(y_new)
                else:
                    yo = hermite((to - t) / hs, hs, y, fy, y_new, f_new)
                    outputs.append(yo if project is None else project(to, yo))
                k_out += 1
            if progress is not None:
                progress(t_new)

        t, y = t0, y0
        try:
            fy = f(t0, y0)
            counters.nfev += 1
            raise_if_nonfinite(t0, fy, "derivative")
            if adaptive:
                if self.step is not None:
                    h = self.step
                else:
                    h = initial_step(f, t0, y0, fy, 4, rtol, atol, self.max_step, span,
                                     counters)
                h = min(h, self.max_step, span / 4.0)
            else:
                h = self.step
            F = np.empty((4, n))           # f_n, f_(n-1), f_(n-2), f_(n-3) spaced by hF
            F[0] = fy
            n_hist = 1
            hF = h
            pending = []                   # unvalidated start-up steps (adaptive mode)
            origin = (t, y, fy)
            after_reject = False
            while t < t_end:
                hs = end_step(t, h, t_end)
                t_new = t_end if hs == t_end - t else t + hs
                if n_hist < 4:
                    # ---- start-up: classic RK4 at constant step, Eqs. (13.14)-(13.19)
                    if n_hist > 1 and hs != hF:
                        n_hist = 1                 # (only at the very end) restart history
                    if n_hist == 1:
                        origin = (t, y, fy)
                    y_new = _rk4(f, t, y, hs, fy)
                    counters.nfev += 3
                    if project is not None:
                        y_new = project(t_new, y_new)
                    raise_if_nonfinite(t_new, y_new)
                    f_new = f(t_new, y_new)
                    counters.nfev += 1
                    F[1:] = F[:-1]
                    F[0] = f_new
                    n_hist += 1
                    hF = hs
                    if adaptive and t_new < t_end:
                        pending.append((t, y, fy, t_new, y_new, f_new))
                    else:
                        for rec in pending:
                            commit(*rec)
                        pending.clear()
                        commit(t, y, fy, t_new, y_new, f_new)
                    t, y, fy = t_new, y_new, f_new
                    continue
                # ---- predictor-corrector step
                if hs != hF:
                    F = resample_matrix(4, hs / hF) @ F
                    hF = hs
                y_p = y + hs * np.dot(AB4, F)                          # Eq. (13.20)
                f_p = f(t_new, y_p)
                y_c = y + hs * (AM4_NEW * f_p + np.dot(AM4, F[:3]))    # Eq. (13.23)
                counters.nfev += 1
                if adaptive:
                    scale = atol + rtol * np.maximum(np.abs(y), np.abs(y_c))
                    e = (y_c - y_p) * (MILNE / scale)
                    err = math.sqrt(float(np.dot(e, e)) / n)
                    if not err <= 1.0:
                        h = hs * ctrl.reject(err)
                        after_reject = True
                        if pending:
                            # start-up not validated: redo it from its origin at the new step
                            counters.rejected += len(pending) + 1
                            pending.clear()
                            t, y, fy = origin
                            F[0] = fy
                            n_hist = 1
                        else:
                            counters.rejected += 1
                        if h < min_step_size(t, span, self.min_step):
                            raise underflow_error(
                                self.name, t, h, "predictor-corrector error test failed"
                                + ("; the derivative is not finite"
                                   if not math.isfinite(err) else ""))
                        continue
                if project is not None:
                    y_c = project(t_new, y_c)
                raise_if_nonfinite(t_new, y_c)
                f_new = f(t_new, y_c)                                  # final E of PECE
                counters.nfev += 1
                F[1:] = F[:-1]
                F[0] = f_new
                for rec in pending:
                    commit(*rec)
                pending.clear()
                commit(t, y, fy, t_new, y_c, f_new)
                t, y, fy = t_new, y_c, f_new
                if adaptive:
                    fac = ctrl.accept(err, after_reject)
                    after_reject = False
                    if fac >= 1.25:
                        h = min(hs * fac, self.max_step)
        except (SpatialMBDError, np.linalg.LinAlgError, FloatingPointError) as exc:
            if getattr(exc, "t", None) is None:
                exc.t = t
            raise
