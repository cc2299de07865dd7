"""Adaptive embedded Runge-Kutta 5(4) of Dormand and Prince (the text's ode45, ch. 13).

Seven stages with FSAL ("first same as last"): the last stage k7 = f(t_(n+1), y_(n+1)) is the
first stage of the next step, so an accepted step costs 6 function evaluations. The fifth-order
solution is propagated (local extrapolation); the difference with the embedded fourth-order
solution estimates the local error, measured in the weighted RMS norm with
scale_i = atol_i + rtol max(|y_n,i|, |y_(n+1),i|). Dense output uses the fourth-order continuous
extension of Dormand-Prince (Shampine 1986, the same coefficients as MATLAB's ode45 and SciPy's
RK45); it reproduces both end points of a step.

Projection (done by the driver, :mod:`.driver`): when ``problem.project`` changes the accepted
y_(n+1), the FSAL derivative is recomputed at the projected state (1 extra evaluation, counted in
nfev; not when the problem declares ``project_keeps_rhs``); the driver gives the interpolant the
linear correction theta (y_proj - y_raw) so it still passes through both (projected) end points.

The arithmetic of a step (stages, error norm, continuous extension) is compiled
(:func:`.explicit.rk_combine` with the tableau :data:`DOPRI_TABLEAU`, :func:`dopri_error`,
:func:`dopri_interpolate`); the step-size control is the compiled rules of :mod:`.controller`
called from Python (:mod:`.controllers`, :func:`.controller.initial_step`), the same as the
compiled driver's (:mod:`.adaptive_driver`). When the problem offers
``stages`` (a compiled evaluation of a run of stages, see :class:`.base.ODEProblem`), the six
stages of an attempt are one call.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..jit import njit
from .base import Integrator, register
from .explicit import rk_stages
from .controller import (atol_vector, default_max_step, initial_step, non_negative, positive,
                         raise_if_nonfinite, validate_tolerances)
from .controllers import make_controller
from .driver import Step, Stepper

# Dormand-Prince 5(4) tableau (Dormand & Prince 1980). Names: nodes c_i, tableau rows a_ij,
# weights b_i, slopes k_i (the stage derivatives) -- not A / K, which are the rotation matrix
# and M + alpha D^T D in the text.
DOPRI_NODES = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_DOPRI_ROWS = [
    np.array([]),
    np.array([1 / 5]),
    np.array([3 / 40, 9 / 40]),
    np.array([44 / 45, -56 / 15, 32 / 9]),
    np.array([19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729]),
    np.array([9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]),
]
DOPRI_WEIGHTS = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
# E = b(5th order) - b_hat(4th order), including the FSAL stage k7.
DOPRI_ERROR_WEIGHTS = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525,
                    -1 / 40])
# Continuous extension of order 4 (Shampine 1986): y(t_n + theta h) =
#   y_n + h sum_i k_i (P[i] . [theta, theta^2, theta^3, theta^4]); row sums equal b.
DOPRI_DENSE = np.array([
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
#: "stage" 6 is y_(n+1) and k_7 = f(t_(n+1), y_(n+1)) the FSAL derivative.
DOPRI_TABLEAU = np.zeros((7, 7))
for _s in range(1, 6):
    DOPRI_TABLEAU[_s, :_s] = _DOPRI_ROWS[_s]
DOPRI_TABLEAU[6, :6] = DOPRI_WEIGHTS


@njit
def dopri_error(y, y_new, slopes, hs, atol, rtol):
    """Weighted RMS norm of the local error estimate hs sum_j e_j k_j, scale
    atol + rtol max(|y|, |y_new|)."""
    n = y.size
    acc = 0.0
    for i in range(n):
        e = 0.0
        for j in range(7):
            e += DOPRI_ERROR_WEIGHTS[j] * slopes[j, i]
        scale = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        e *= hs / scale
        acc += e * e
    return math.sqrt(acc / n)


@njit
def dopri_interpolate(y, hs, slopes, theta, delta, out):
    """Dormand-Prince continuous extension: out = y + hs sum_j (P[j] . [theta, .., theta^4]) k_j
    (+ theta delta when delta is not empty: the correction for a projected end point)."""
    t2 = theta * theta
    t3 = t2 * theta
    t4 = t3 * theta
    w = np.empty(7)
    for j in range(7):
        w[j] = (DOPRI_DENSE[j, 0] * theta + DOPRI_DENSE[j, 1] * t2 + DOPRI_DENSE[j, 2] * t3
                + DOPRI_DENSE[j, 3] * t4)
    for i in range(y.size):
        acc = 0.0
        for j in range(7):
            acc += w[j] * slopes[j, i]
        out[i] = y[i] + hs * acc
    if delta.size:
        for i in range(y.size):
            out[i] += theta * delta[i]


_NO_DELTA = np.zeros(0)


def dopri_dense(y_old: np.ndarray, h: float, slopes: np.ndarray, theta: float) -> np.ndarray:
    """Dormand-Prince continuous extension at t_n + theta h (theta in [0, 1]).

    y_old: (n,), slopes: (7, n) stage derivatives of the step, h: step size (s). Order 4.
    """
    slopes = np.ascontiguousarray(slopes, dtype=float)
    out = np.empty(slopes.shape[1])
    dopri_interpolate(np.ascontiguousarray(y_old, dtype=float), float(h), slopes, float(theta),
                      _NO_DELTA, out)
    return out


class DormandPrinceStepper(Stepper):
    """The Dormand-Prince 5(4) stepping formula (FSAL); see the module docstring."""

    name = "rk45"
    #: rows of ``slopes`` (the stages with the FSAL derivative, and any stages of the dense
    #: output), the row of the FSAL derivative, and the order of the error estimate that the
    #: starting step uses
    slope_rows, fsal_row, start_order = 7, 6, 4
    #: the pair: tableau (with the weights as the FSAL row), nodes, the controller's exponent k
    tableau, nodes, k = DOPRI_TABLEAU, DOPRI_NODES, 5

    def __init__(self, rtol, atol, first_step, max_step):
        self.rtol, self.atol_opt = rtol, atol
        self.first_step, self.max_step = first_step, max_step

    def start(self, problem, t0, y0, t_end, counters):
        f = problem.rhs
        self.f, self.counters = f, counters
        self.stages = problem.stages
        self.project_keeps_rhs = problem.project_keeps_rhs
        n = y0.size
        self.atol = atol_vector(self.atol_opt, n)
        self.slopes = np.empty((self.slope_rows, n))          # the stage derivatives k_j
        self.slopes[0] = f(t0, y0)
        self.fsal = False
        counters.nfev += 1
        raise_if_nonfinite(t0, self.slopes[0], "derivative")
        span = t_end - t0
        if self.first_step is not None:
            return min(self.first_step, self.max_step, span)
        return initial_step(f, t0, y0, self.slopes[0], self.start_order, self.rtol, self.atol,
                            self.max_step, span, counters)

    def step(self, t, y, t_new):
        hs = t_new - t
        slopes = self.slopes
        stages = self.fsal_row + 1                    # with the FSAL derivative
        if self.fsal:
            slopes[0] = slopes[self.fsal_row]         # FSAL (kept until now for the dense output)
            self.fsal = False
        y_new = np.empty(y.size)
        done = 1 if self.stages is None else self.stages(t, y, hs, self.tableau, self.nodes,
                                                         slopes, 1, stages, y_new, t_new)
        if done < stages:                             # (the rest of) the stages in Python
            rk_stages(self.f, t, y, hs, self.tableau, self.nodes, slopes, done, stages, y_new,
                      t_new)
        self.counters.nfev += stages - 1
        err = self.error(y, y_new, slopes, hs)
        return Step(t_new, y_new, err, self.k, self.dense_output(y, y_new, hs, t, slopes))

    def error(self, y, y_new, slopes, hs):
        """The weighted norm of the step's local error estimate."""
        return dopri_error(y, y_new, slopes, hs, self.atol, self.rtol)

    def dense_output(self, y, y_new, hs, t, slopes):
        """The dense output of the step (a callable of the time)."""
        return _DopriDense(y, hs, t, slopes)

    def accept(self, step, y_final):
        slopes = self.slopes
        if y_final is not step.y_new and not self.project_keeps_rhs \
                and not np.array_equal(y_final, step.y_new):
            step.dense.own_slopes()                   # before the FSAL slope changes
            slopes[self.fsal_row] = self.f(step.t_new, y_final)   # at the projected state
            self.counters.nfev += 1
        self.fsal = True


class _DopriDense:
    """Shampine's continuous extension of one step, as a callable of the time (s)."""

    __slots__ = ("y", "hs", "t", "slopes", "owned")

    def __init__(self, y, hs, t, slopes):
        self.y, self.hs, self.t, self.slopes = y, hs, t, slopes
        self.owned = False

    def own_slopes(self):
        if not self.owned:
            self.slopes = self.slopes.copy()
            self.owned = True

    def __call__(self, s):
        out = np.empty(self.y.size)
        dopri_interpolate(self.y, self.hs, self.slopes, (s - self.t) / self.hs, _NO_DELTA, out)
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
        if controller not in ("pi", "standard"):
            raise ValueError(f"option controller={controller!r} must be 'standard' or 'pi'")
        self._ctrl = (controller, dict(safety=float(safety), min_factor=float(min_factor),
                                       max_factor=float(max_factor), beta=float(beta)))
        self.make_controller()                 # validate now

    def __repr__(self) -> str:
        return f"DormandPrince45(rtol={self.rtol!r}, atol={self.atol!r})"

    def make_stepper(self):
        return DormandPrinceStepper(self.rtol, self.atol, self.first_step, self.max_step)

    def make_controller(self):
        kind, opts = self._ctrl
        return make_controller(kind, **dict(opts))
