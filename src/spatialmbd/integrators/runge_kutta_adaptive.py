"""Adaptive embedded Runge-Kutta 5(4) of Dormand and Prince (the text's ode45, ch. 13).

Seven stages with FSAL ("first same as last"): the last stage k7 = f(t_(n+1), y_(n+1)) is the
first stage of the next step, so an accepted step costs 6 function evaluations. The fifth-order
solution is propagated (local extrapolation); the difference with the embedded fourth-order
solution estimates the local error, measured in the weighted RMS norm with
scale_i = atol_i + rtol max(|y_n,i|, |y_(n+1),i|). Dense output uses the fourth-order continuous
extension of Dormand-Prince (Shampine 1986, the same coefficients as MATLAB's ode45 and SciPy's
RK45); it reproduces both end points of a step.

Projection: when ``problem.project`` changes the accepted y_(n+1), the FSAL derivative is
recomputed at the projected state (1 extra evaluation, counted in nfev; not when the problem
declares ``project_keeps_rhs``), and the interpolant gets the linear correction
theta (y_proj - y_raw) so it still passes through both (projected) end points; dense outputs
are projected too (the hook is idempotent on the manifold).

The arithmetic of a step (stages, error norm, continuous extension) is compiled
(:func:`.explicit.rk_combine` with the tableau :data:`DOPRI_AB`, :func:`dopri_error`,
:func:`dopri_interpolate`); the step-size control stays in Python. When the problem offers
``stages`` (a compiled evaluation of a run of stages, see :class:`.base.ODEProblem`), the six
stages of an attempt are one call.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..errors import SpatialMBDError
from ..jit import njit
from .base import Integrator, register
from .explicit import rk_stages
from .controller import (StepController, atol_vector, default_max_step, end_step,
                         initial_step, min_step_size, non_negative, positive,
                         raise_if_nonfinite, underflow_error, validate_tolerances)

# Dormand-Prince 5(4) tableau (Dormand & Prince 1980).
DOPRI_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
DOPRI_A = [
    np.array([]),
    np.array([1 / 5]),
    np.array([3 / 40, 9 / 40]),
    np.array([44 / 45, -56 / 15, 32 / 9]),
    np.array([19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729]),
    np.array([9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]),
]
DOPRI_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
# E = b(5th order) - b_hat(4th order), including the FSAL stage k7.
DOPRI_E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525,
                    -1 / 40])
# Continuous extension of order 4 (Shampine 1986): y(t_n + theta h) =
#   y_n + h sum_i k_i (P[i] . [theta, theta^2, theta^3, theta^4]); row sums equal b.
DOPRI_P = np.array([
    [1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0.0, 0.0, 0.0, 0.0],
    [0.0, 131558114200 / 32700410799, -68118460800 / 10900136933,
     87487479700 / 32700410799],
    [0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0.0, 127303824393 / 49829197408, -318862633887 / 49829197408,
     701980252875 / 199316789632],
    [0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])


#: The tableau as one (7, 7) array: row s (1..5) holds a_sj, row 6 the weights b, so that
#: "stage" 6 is y_(n+1) and K_6 = f(t_(n+1), y_(n+1)) the FSAL derivative.
DOPRI_AB = np.zeros((7, 7))
for _s in range(1, 6):
    DOPRI_AB[_s, :_s] = DOPRI_A[_s]
DOPRI_AB[6, :6] = DOPRI_B


@njit
def dopri_error(y, y_new, K, hs, atol, rtol):
    """Weighted RMS norm of the local error estimate hs sum_j e_j K_j, scale
    atol + rtol max(|y|, |y_new|)."""
    n = y.size
    acc = 0.0
    for i in range(n):
        e = 0.0
        for j in range(7):
            e += DOPRI_E[j] * K[j, i]
        scale = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        e *= hs / scale
        acc += e * e
    return math.sqrt(acc / n)


@njit
def dopri_interpolate(y, hs, K, theta, delta, out):
    """Dormand-Prince continuous extension: out = y + hs sum_j (P[j] . [theta, .., theta^4]) K_j
    (+ theta delta when delta is not empty: the correction for a projected end point)."""
    t2 = theta * theta
    t3 = t2 * theta
    t4 = t3 * theta
    w = np.empty(7)
    for j in range(7):
        w[j] = DOPRI_P[j, 0] * theta + DOPRI_P[j, 1] * t2 + DOPRI_P[j, 2] * t3 + DOPRI_P[j, 3] * t4
    for i in range(y.size):
        acc = 0.0
        for j in range(7):
            acc += w[j] * K[j, i]
        out[i] = y[i] + hs * acc
    if delta.size:
        for i in range(y.size):
            out[i] += theta * delta[i]


_NO_DELTA = np.zeros(0)


def dopri_dense(y_old: np.ndarray, h: float, K: np.ndarray, theta: float) -> np.ndarray:
    """Dormand-Prince continuous extension at t_n + theta h (theta in [0, 1]).

    y_old: (n,), K: (7, n) stage derivatives of the step, h: step size (s). Order 4.
    """
    K = np.ascontiguousarray(K, dtype=float)
    out = np.empty(K.shape[1])
    dopri_interpolate(np.ascontiguousarray(y_old, dtype=float), float(h), K, float(theta),
                      _NO_DELTA, out)
    return out


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

    def __init__(self, rtol: float = 1e-6, atol=1e-9, max_step: Optional[float] = None,
                 min_step: float = 0.0, first_step: Optional[float] = None,
                 safety: float = 0.9, min_factor: float = 0.2, max_factor: float = 10.0,
                 controller: str = "pi", beta: float = 0.04):
        self.rtol, self.atol = validate_tolerances(rtol, atol)
        self.max_step = default_max_step(max_step)
        self.min_step = non_negative(min_step, "min_step")
        self.first_step = None if first_step is None else positive(first_step, "first_step")
        self._ctrl_args = (5, float(safety), float(min_factor), float(max_factor),
                           controller, float(beta))
        StepController(*self._ctrl_args)       # validate now

    def __repr__(self) -> str:
        return f"DormandPrince45(rtol={self.rtol!r}, atol={self.atol!r})"

    def _integrate(self, problem, t0, y0, t_eval, counters, outputs, progress) -> None:
        f = problem.rhs
        project = problem.project
        keeps_rhs = problem.project_keeps_rhs
        n = y0.size
        rtol = self.rtol
        atol = atol_vector(self.atol, n)
        max_step = self.max_step
        ctrl = StepController(*self._ctrl_args)
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
        AB, C = DOPRI_AB, DOPRI_C
        stages = problem.stages
        K = np.empty((7, n))
        error = dopri_error
        t, y = t0, y0
        try:
            K[0] = f(t0, y0)
            counters.nfev += 1
            raise_if_nonfinite(t0, K[0], "derivative")
            if self.first_step is not None:
                h = min(self.first_step, max_step, span)
            else:
                h = initial_step(f, t0, y0, K[0], 4, rtol, atol, max_step, span, counters)
            after_reject = False
            not_finite = False
            while t < t_end:
                h_min = min_step_size(t, span, self.min_step)
                # ---- attempt steps until one is accepted
                while True:
                    hs = end_step(t, h, t_end)
                    if hs < h_min:
                        raise underflow_error(
                            self.name, t, hs, "error test failed repeatedly"
                            + ("; the derivative is not finite" if not_finite else ""))
                    t_new = t_end if hs == t_end - t else t + hs
                    y_new = np.empty(n)
                    done = 1 if stages is None else stages(t, y, hs, AB, C, K, 1, 7, y_new,
                                                           t_new)
                    if done < 7:                          # (the rest of) the stages in Python
                        rk_stages(f, t, y, hs, AB, C, K, done, 7, y_new, t_new)
                    counters.nfev += 6
                    err = error(y, y_new, K, hs, atol, rtol)
                    if err <= 1.0:
                        break
                    not_finite = not math.isfinite(err)
                    counters.rejected += 1
                    h = hs * ctrl.reject(err)
                    after_reject = True
                not_finite = False
                # ---- accept
                fac = ctrl.accept(err, after_reject)
                after_reject = False
                Kd = K                                   # the stages of the interpolant
                delta = _NO_DELTA
                if project is not None:
                    y_p = project(t_new, y_new)
                    if keeps_rhs:
                        delta = y_p - y_new
                        y_new = y_p
                    elif y_p is not y_new and not np.array_equal(y_p, y_new):
                        delta = y_p - y_new
                        y_new = y_p
                        if k_out < n_out and touts[k_out] < t_new:
                            Kd = K.copy()                # before K[6] changes
                        K[6] = f(t_new, y_new)           # FSAL derivative at projected state
                        counters.nfev += 1
                raise_if_nonfinite(t_new, y_new)
                # ---- dense output, Shampine's continuous extension
                while k_out < n_out and touts[k_out] <= t_new:
                    to = touts[k_out]
                    if to == t_new:
                        outputs.append(y_new)
                    else:
                        th = (to - t) / hs
                        yo = np.empty(n)
                        dopri_interpolate(y, hs, Kd, th, delta, yo)
                        if project is not None:
                            yo = project(to, yo)
                        outputs.append(yo)
                    k_out += 1
                K[0] = K[6]                               # FSAL
                t, y = t_new, y_new
                counters.steps += 1
                if progress is not None:
                    progress(t)
                h = min(hs * fac, max_step)
        except (SpatialMBDError, np.linalg.LinAlgError, FloatingPointError) as exc:
            if getattr(exc, "t", None) is None:
                exc.t = t
            raise

