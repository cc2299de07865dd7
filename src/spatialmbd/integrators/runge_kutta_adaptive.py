"""Adaptive embedded Runge-Kutta 5(4) of Dormand and Prince (the text's ode45, ch. 13).

Seven stages with FSAL ("first same as last"): the last stage k7 = f(t_(n+1), y_(n+1)) is the
first stage of the next step, so an accepted step costs 6 function evaluations. The fifth-order
solution is propagated (local extrapolation); the difference with the embedded fourth-order
solution estimates the local error, measured in the weighted RMS norm with
scale_i = atol_i + rtol max(|y_n,i|, |y_(n+1),i|). Dense output uses the fourth-order continuous
extension of Dormand-Prince (Shampine 1986, the same coefficients as MATLAB's ode45 and SciPy's
RK45); it reproduces both end points of a step.

Projection (by the compiled driver, :mod:`.adaptive_driver`): when the problem's projection
changes the accepted y_(n+1), the FSAL derivative is recomputed at the projected state (1 extra
evaluation, counted in nfev; not when the problem keeps its right-hand side,
``project_keeps_rhs``), and the interpolant gets the linear correction theta (y_proj - y_raw)
so it still passes through both (projected) end points.

This module holds the formula as data and compiled arithmetic (the tableau
:data:`DOPRI_TABLEAU`, :func:`dopri_error`, :func:`dopri_interpolate`); the integrator
``rk45`` (:class:`.dormand_prince.DormandPrince45`) runs it through the one compiled adaptive
driver (:mod:`.adaptive_driver`, :mod:`.pairs`).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit

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
