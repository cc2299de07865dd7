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
:func:`dop853_interpolate`) and shared by the Python stepper below and the compiled drivers
(:mod:`.pairs`).
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np
from scipy.integrate import DOP853 as _COEFFICIENTS

from ..jit import njit
from .base import register
from .explicit import rk_stages
from .runge_kutta_adaptive import DormandPrince45, DormandPrinceStepper

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


_NO_DELTA = np.zeros(0)


class Dop853Stepper(DormandPrinceStepper):
    """The DOP853 stepping formula (FSAL, 12 evaluations per step); see the module docstring."""

    name = "dop853"
    slope_rows, fsal_row, start_order = 16, STAGES - 1, 7
    tableau, nodes, k = DOP853_TABLEAU, DOP853_NODES, 8

    def error(self, y, y_new, slopes, hs):
        return dop853_error(y, y_new, slopes, hs, self.atol, self.rtol)

    def dense_output(self, y, y_new, hs, t, slopes):
        return _Dop853Dense(self, y, y_new, hs, t, slopes)


class _Dop853Dense:
    """DOP853's dense output of one step, as a callable of the time (s); the three extra stages
    are evaluated at the first call (counted in nfev)."""

    __slots__ = ("stepper", "y", "y_new", "hs", "t", "slopes", "owned", "coef")

    def __init__(self, stepper, y, y_new, hs, t, slopes):
        self.stepper, self.y, self.y_new, self.hs, self.t = stepper, y, y_new, hs, t
        self.slopes, self.owned, self.coef = slopes, False, None

    def own_slopes(self):
        if not self.owned:
            self.slopes = self.slopes.copy()
            self.owned = True

    def _coefficients(self):
        st, slopes, hs = self.stepper, self.slopes, self.hs
        out = np.empty(self.y.size)
        t_last = self.t + DOP853_NODES[15] * hs
        done = STAGES if st.stages is None else st.stages(
            self.t, self.y, hs, DOP853_TABLEAU, DOP853_NODES, slopes, STAGES, 16, out, t_last)
        if done < 16:
            rk_stages(st.f, self.t, self.y, hs, DOP853_TABLEAU, DOP853_NODES, slopes, done, 16,
                      out, t_last)
        st.counters.nfev += 3
        coef = np.empty((7, self.y.size))
        dop853_dense(self.y, self.y_new, slopes, hs, coef)
        return coef

    def __call__(self, s):
        if self.coef is None:
            self.coef = self._coefficients()
        out = np.empty(self.y.size)
        dop853_interpolate(self.y, self.coef, (s - self.t) / self.hs, _NO_DELTA, out)
        return out


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

    def __init__(self, rtol: float = 1e-6, atol=1e-9, max_step: Optional[float] = None,
                 min_step: float = 0.0, first_step: Optional[float] = None,
                 safety: float = 0.9, min_factor: float = 0.333, max_factor: float = 6.0,
                 controller: str = "pi", beta: float = 0.0):
        super().__init__(rtol, atol, max_step, min_step, first_step, safety, min_factor,
                         max_factor, controller, beta)

    def __repr__(self) -> str:
        return f"DormandPrince853(rtol={self.rtol!r}, atol={self.atol!r})"

    def make_stepper(self):
        return Dop853Stepper(self.rtol, self.atol, self.first_step, self.max_step)

    #: the controller of the compiled drivers (:mod:`.pairs`)
    DEFAULT_CONTROLLER = ("pi", dict(safety=0.9, min_factor=0.333, max_factor=6.0, beta=0.0))
