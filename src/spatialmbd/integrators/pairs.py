"""The embedded Runge-Kutta pairs of the compiled adaptive driver (:mod:`.adaptive_driver`,
run on the body coordinates by :mod:`..dynamics.fused`, on the joint coordinates by
:mod:`..dynamics.recursive`, and by :mod:`..sweep.batch`) as data, so that one compiled loop
runs either: Dormand-Prince 5(4) (``rk45``, :mod:`.runge_kutta_adaptive`) and 8(5,3)
(``dop853``, :mod:`.dop853`).

A pair is the tuple (kind, tableau, nodes, control):

* kind: :data:`DP5` or :data:`DP8` (the error norm and the dense output differ);
* tableau (R, R) and nodes (R,): the stages 1 .. S-1 (row S-1 the weights b, so that stage
  S-1 is y_(n+1) and slope S-1 the FSAL derivative), then for DP8 the dense output's three
  extra stages (R = S + 3); S = :func:`pair_stages`;
* control: [1/k, beta, safety, min_factor, max_factor, 1/k of the starting step, min_step]:
  the step-size controller's exponents and factors (:mod:`.controller`) and the minimum step
  (s; 0: only the round-off floor).

:func:`make_pair` builds a pair from an integrator's options (:mod:`.dormand_prince`).
"""
from __future__ import annotations

import numpy as np

from ..jit import njit
from .dop853 import (DOP853_NODES, DOP853_TABLEAU, STAGES as DP8_STAGES, dop853_dense,
                     dop853_error, dop853_interpolate)
from .runge_kutta_adaptive import DOPRI_NODES, DOPRI_TABLEAU, dopri_error, dopri_interpolate

DP5, DP8 = 0, 1
#: the order k of each kind's error estimate (the error behaves like h^k) and of its starting
#: step's estimate
_ORDERS = {DP5: (5, 5), DP8: (8, 8)}


def make_pair(kind: int, safety: float, min_factor: float, max_factor: float, beta: float,
              min_step: float = 0.0):
    """The pair ``kind`` (:data:`DP5` or :data:`DP8`) with a PI controller of these factors
    (beta = 0: the elementary controller) and minimum step."""
    k, k_start = _ORDERS[kind]
    tableau, nodes = (DOPRI_TABLEAU, DOPRI_NODES) if kind == DP5 else (DOP853_TABLEAU,
                                                                       DOP853_NODES)
    return (kind, tableau, nodes, np.array([1 / k, float(beta), float(safety),
                                            float(min_factor), float(max_factor), 1 / k_start,
                                            float(min_step)]))


#: Dormand-Prince 5(4) with rk45's defaults (PI, beta 0.04, factors 0.2 .. 10)
PAIR_DP5 = make_pair(DP5, 0.9, 0.2, 10.0, 0.04)
#: DOP853 with dop853's defaults (beta 0, factors 0.333 .. 6)
PAIR_DP8 = make_pair(DP8, 0.9, 0.333, 6.0, 0.0)


def pair_of(integ):
    """The pair of an rk45 / dop853 integrator (any controller options) when the compiled
    whole-run drivers (:mod:`..dynamics.fused`, :mod:`..dynamics.recursive`) can run it:
    scalar atol and no first_step; else None."""
    pair = getattr(integ, "pair", None)
    if pair is None or np.ndim(integ.atol) != 0 or integ.first_step is not None:
        return None
    return pair()


def pair_by_name(name: str):
    """The pair of integrator ``name`` ("rk45" or "dop853") with its defaults, else None."""
    return {"rk45": PAIR_DP5, "dop853": PAIR_DP8}.get(name)


@njit(inline="always")
def pair_stages(kind):
    """S: the stages of a step including the FSAL derivative (7 or 13)."""
    return 7 if kind == DP5 else DP8_STAGES


@njit
def pair_error(kind, y, y_new, slopes, hs, atol, rtol):
    """The pair's weighted error norm of a step (accept when <= 1)."""
    if kind == DP5:
        return dopri_error(y, y_new, slopes, hs, atol, rtol)
    return dop853_error(y, y_new, slopes, hs, atol, rtol)


@njit
def pair_dense(kind, y, y_new, slopes, hs, coef):
    """coef (7, n): what :func:`pair_interpolate` needs of a step from y to the unprojected
    y_new: DP5 the slopes k_1 .. k_7 (copied, before the FSAL slope is re-evaluated at a
    projected state), DP8 the polynomial's coefficients (its extra stages already in slopes)."""
    if kind == DP5:
        for j in range(7):
            for i in range(y.size):
                coef[j, i] = slopes[j, i]
    else:
        dop853_dense(y, y_new, slopes, hs, coef)


@njit
def pair_interpolate(kind, y, hs, coef, theta, delta, out):
    """The dense output at t_n + theta h (+ theta delta when delta is not empty)."""
    if kind == DP5:
        dopri_interpolate(y, hs, coef, theta, delta, out)
    else:
        dop853_interpolate(y, coef, theta, delta, out)
