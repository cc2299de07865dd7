"""Adaptive explicit Runge-Kutta 8(5,3) of Dormand and Prince (Hairer's DOP853).

For tight tolerances an eighth-order method takes far fewer evaluations than Dormand-Prince
5(4): on a closed-loop mechanism at rtol 1e-8 about a third. A step has twelve stages, the last
of which (k_13 = f(t_(n+1), y_(n+1))) is the first of the next step (FSAL): 12 function
evaluations per accepted step.

* Error (Hairer, Norsett & Wanner I, Sec. II.10, and their code DOP853): the fifth- and
  third-order estimates err5 = h sum e5_j k_j, err3 = h sum e3_j k_j, scaled by
  atol + rtol max(|y_n|, |y_(n+1)|), combined as
  ||e|| = |h| ||err5||^2 / sqrt(n (||err5||^2 + 0.01 ||err3||^2)) (sums of squares),
  accept when ||e|| <= 1; the controller's exponent is 1/8.
* Step control (DOP853's defaults): safety 0.9, the new step within [1/3, 6] times the old,
  no PI term (beta = 0), at most the old step right after a rejection.
* Dense output of order 7: three extra stages (k_14 .. k_16) evaluated only for steps that hold
  an output time, and the polynomial
  y(t_n + theta h) = y_n + theta (F_0 + (1 - theta) (F_1 + theta (F_2 + (1 - theta) (F_3 + ...))))
  with F_0 = y_(n+1) - y_n, F_1 = h k_1 - F_0, F_2 = 2 F_0 - h (k_13 + k_1), F_(3..6) = h D k.

The coefficients (nodes, tableau, weights, error weights, dense-output matrix) are those
published by Dormand and Prince and Hairer; they are read from SciPy's ``DOP853`` class, which
carries them, instead of being retyped here.

The arithmetic is compiled (:func:`dop853_error`, :func:`dop853_dense`,
:func:`dop853_interpolate`) and run by the one compiled adaptive driver (:mod:`.pairs`,
:mod:`.adaptive_driver`) for the integrator ``dop853``
(:class:`.dormand_prince.DormandPrince853`).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import DOP853 as _COEFFICIENTS

from ..jit import njit

#: stages of a step including the FSAL derivative at its end (k_1 .. k_13)
STAGES = 13
#: the tableau as one (16, 16) array: rows 1..11 the stages, row 12 the weights b (so "stage"
#: 12 is y_(n+1) and k_13 = f(t_(n+1), y_(n+1))), rows 13..15 the dense output's extra stages
DOP853_TABLEAU = np.zeros((16, 16))
DOP853_TABLEAU[:12, :12] = _COEFFICIENTS.A
DOP853_TABLEAU[12, :12] = _COEFFICIENTS.B
DOP853_TABLEAU[13:, :] = _COEFFICIENTS.A_EXTRA
DOP853_NODES = np.concatenate([_COEFFICIENTS.C, [1.0], _COEFFICIENTS.C_EXTRA])
#: rows: the fifth-order and third-order error weights over k_1 .. k_13
DOP853_ERROR = np.ascontiguousarray(np.vstack([_COEFFICIENTS.E5, _COEFFICIENTS.E3]))
#: (4, 16): F_(3..6) = h D k of the dense output
DOP853_DENSE = np.ascontiguousarray(_COEFFICIENTS.D)


@njit
def dop853_error(y, y_new, slopes, hs, atol, rtol):
    """DOP853's error norm of a step (module docstring), scale atol + rtol max(|y|, |y_new|)."""
    n = y.size
    e5 = 0.0
    e3 = 0.0
    for i in range(n):
        a = 0.0
        b = 0.0
        for j in range(STAGES):
            a += DOP853_ERROR[0, j] * slopes[j, i]
            b += DOP853_ERROR[1, j] * slopes[j, i]
        scale = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        a /= scale
        b /= scale
        e5 += a * a
        e3 += b * b
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(hs) * e5 / math.sqrt((e5 + 0.01 * e3) * n)


@njit
def dop853_dense(y, y_new, slopes, hs, coef):
    """The dense output's coefficients coef (7, n) of a step from y to y_new (unprojected) with
    all 16 slopes (the three extra stages evaluated)."""
    for i in range(y.size):
        dy = y_new[i] - y[i]
        coef[0, i] = dy
        coef[1, i] = hs * slopes[0, i] - dy
        coef[2, i] = 2.0 * dy - hs * (slopes[STAGES - 1, i] + slopes[0, i])
        for r in range(4):
            acc = 0.0
            for j in range(16):
                acc += DOP853_DENSE[r, j] * slopes[j, i]
            coef[3 + r, i] = hs * acc


@njit
def dop853_interpolate(y, coef, theta, delta, out):
    """out = y(t_n + theta h) of the dense output (+ theta delta when delta is not empty: the
    correction for a projected end point)."""
    u = 1.0 - theta
    for i in range(y.size):
        acc = 0.0
        for r in range(6, -1, -1):
            acc += coef[r, i]
            acc *= theta if (6 - r) % 2 == 0 else u
        out[i] = y[i] + acc
    if delta.size:
        for i in range(y.size):
            out[i] += theta * delta[i]
