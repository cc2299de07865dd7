"""Step-size control and helpers shared by the integrators of text ch. 13.

* option validation (:func:`positive`, :func:`validate_tolerances`, :func:`atol_vector`);
* the weighted RMS error norm ||e|| = sqrt(mean((e_i / (atol_i + rtol |y_i|))^2)) (Hairer,
  Norsett & Wanner, *Solving ODEs I*, Eq. II.4.11; of a step: each pair's compiled error
  function): a step is accepted when ||e|| <= 1;
* the initial step-size selection of Hairer et al. (Sec. II.4, "starting step size"): the
  compiled rules :func:`start_first_guess` and :func:`start_step`, with the weighted norms and
  the right-hand side's evaluation left to the caller (:func:`initial_step` for a Python
  right-hand side);
* the step-size rules, compiled and shared by every adaptive path (the controllers of
  :mod:`.controllers` and the compiled driver :mod:`.adaptive_driver`): after a rejection
  h_new = h safety ||e||^(-1/k) (:func:`rejected_factor`), after an accepted step Gustafsson's
  PI controller h_new = h safety ||e_n||^(-alpha) ||e_(n-1)||^beta (Hairer & Wanner II,
  Sec. IV.2; beta = 0: the elementary controller) (:func:`pi_factor`), both within bounds;
* :func:`resample_matrix`: the Lagrange matrix that re-spaces the uniform history of a multistep
  method (derivatives for Adams, states for Gear/BDF) to a new step size, and
  :func:`lagrange_weights` for the dense output of the BDF history polynomial;
* :func:`underflow_error` / :func:`raise_if_nonfinite`: the :class:`SimulationError` raised on
  step-size underflow or NaN, with its ``.t`` attribute set.

Times are in seconds (any consistent unit works); every state is a 1-D array of shape (n,).
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..errors import SimulationError
from ..jit import njit

EPS = float(np.finfo(float).eps)


def check_finite(t: float, y: np.ndarray, what: str = "state") -> None:
    """Raise SimulationError naming the time if ``y`` holds NaN or inf."""
    if not np.all(np.isfinite(y)):
        err = SimulationError(f"t = {t:.6g} s: non-finite {what} (NaN or inf); the motion "
                              "became unbounded or a force law returned NaN")
        err.t = t
        raise err


# ----------------------------------------------------------------------------- options
def positive(value, name: str, allow_inf: bool = False) -> float:
    """``value`` as a float, or ValueError naming the option when it is not > 0 (and finite)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"option {name}={value!r} must be a positive number") from None
    if not v > 0.0 or (math.isinf(v) and not allow_inf) or math.isnan(v):
        raise ValueError(f"option {name}={value!r} must be a positive"
                         + (" number" if allow_inf else " finite number"))
    return v


def non_negative(value, name: str) -> float:
    """``value`` as a float >= 0, or ValueError naming the option."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"option {name}={value!r} must be a number >= 0") from None
    if not v >= 0.0 or math.isinf(v):
        raise ValueError(f"option {name}={value!r} must be a finite number >= 0")
    return v


def validate_tolerances(rtol, atol):
    """Check rtol (scalar > 100 eps) and atol (scalar or (n,) array, every entry > 0).

    Returns (rtol: float, atol: float or (n,) float array). ValueError names option and value.
    """
    rtol = positive(rtol, "rtol")
    if rtol < 100 * EPS:
        raise ValueError(f"option rtol={rtol!r} is below the round-off limit "
                         f"100*eps = {100 * EPS:.3g}")
    a = np.asarray(atol, dtype=float) if not isinstance(atol, (int, float)) else None
    if a is None:
        return rtol, positive(atol, "atol")
    if a.ndim == 0:
        return rtol, positive(float(a), "atol")
    if a.ndim != 1 or not np.all(a > 0) or not np.all(np.isfinite(a)):
        raise ValueError(f"option atol={atol!r} must be a positive number or a 1-D array of "
                         "positive numbers (one per state component)")
    return rtol, a.copy()


def atol_vector(atol, n: int) -> np.ndarray:
    """atol broadcast to shape (n,); ValueError if a per-component atol has the wrong length."""
    if isinstance(atol, float):
        return np.full(n, atol)
    if atol.shape != (n,):
        raise ValueError(f"option atol has {atol.size} components but the state has {n}")
    return atol


# ----------------------------------------------------------------------------- norms, errors
def rms_norm(x: np.ndarray) -> float:
    """Root-mean-square norm of a (n,) array (a Python float)."""
    return math.sqrt(float(np.dot(x, x)) / x.size)


def raise_if_nonfinite(t: float, y: np.ndarray, what: str = "state") -> None:
    """Cheap NaN/inf test for a 1-D float array: one dot product (y . y is NaN or inf when a
    component is); only on a hit is the full :func:`check_finite` run (which ignores overflow
    of a finite y . y)."""
    if not math.isfinite(y.dot(y)):
        check_finite(t, y, what)


def underflow_error(name: str, t: float, h: float, cause: str) -> SimulationError:
    """SimulationError for a step size that fell below the minimum, with ``.t`` set."""
    err = SimulationError(f"t = {t:.6g} s: {name}: step size h = {h:.3g} s underflow "
                          f"({cause}); the solution may be singular or the tolerances too tight")
    err.t = t
    return err


def newton_error(name: str, t: float, h: float, cause: str) -> SimulationError:
    """SimulationError for a Newton iteration that did not converge, with ``.t`` set."""
    err = SimulationError(f"t = {t:.6g} s: {name}: Newton iteration did not converge with step "
                          f"size h = {h:.3g} s ({cause}); reduce the step size")
    err.t = t
    return err


# The rules below are shared by the Python controllers (.controllers) and the compiled driver
# (.adaptive_driver), compiled and callable from both, so both take the same steps.
@njit(inline="always")
def start_first_guess(d0: float, d1: float, max_step: float, span: float) -> float:
    """Hairer's first guess of the starting step, h0 = 0.01 d0 / d1 (1e-6 when either norm is
    below 1e-5), within max_step and the span (d0 = ||y0||, d1 = ||f(t0, y0)||, weighted)."""
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    return min(h0, max_step, abs(span))


@njit(inline="always")
def start_step(h0: float, d1: float, d2: float, k_inv: float, max_step: float,
               span: float) -> float:
    """Hairer's starting step from h0 and d2 = ||f(t0 + h0, y0 + h0 f0) - f0|| / h0:
    h1 = (0.01 / max(d1, d2))^(1/k) (max(1e-6, 1e-3 h0) when both are below 1e-15), then
    min(100 h0, h1, max_step, span); h0 itself when d2 is not finite."""
    if not math.isfinite(d2):
        return h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** k_inv
    return min(100.0 * h0, h1, max_step, abs(span))


@njit(inline="always")
def rejected_factor(err: float, k_inv: float, safety: float, min_factor: float) -> float:
    """Step factor after a rejected step: safety err^(-1/k) within [min_factor, 0.9]
    (min_factor for a non-finite error)."""
    if not math.isfinite(err):
        return min_factor
    return max(min_factor, min(0.9, safety * err ** (-k_inv)))


@njit(inline="always")
def pi_factor(err: float, err_prev: float, alpha: float, beta: float, safety: float,
              min_factor: float, max_factor: float, after_reject: bool):
    """(factor, err_prev for the next step) after an accepted step, the PI controller:
    safety err^(-alpha) err_prev^beta within [min_factor, max_factor] (max_factor for a zero
    error), at most 1 right after a rejection; err_prev is kept at least 1e-4."""
    fac = max_factor if err == 0.0 else safety * err ** (-alpha) * err_prev ** beta
    fac = min(max_factor, max(min_factor, fac))
    if after_reject:
        fac = min(fac, 1.0)
    return fac, max(err, 1e-4)


@njit
def min_step_size(t: float, span: float, min_step: float) -> float:
    """Smallest admissible step near time t: max(min_step, 16 eps max(|t|, |span|))."""
    return max(min_step, 16.0 * EPS * max(abs(t), abs(span)))


@njit
def end_step(t: float, h: float, t_end: float) -> float:
    """Step from t of nominal size h, lengthened by at most 1 % or shortened to land on t_end.

    Avoids a tiny last step (and a spurious step-size underflow) just before t_end.
    """
    if t + 1.01 * h >= t_end:
        return t_end - t
    return h


@njit
def landing_steps(anchor: float, target: float, h: float) -> int:
    """Number of fixed steps of size h from anchor to the output time target, the last one
    landing on it (shortened, or lengthened by less than 1e-9 h)."""
    return max(1, math.ceil((target - anchor) / h - 1e-9))


@njit
def landing_time(anchor: float, target: float, h: float, i: int) -> float:
    """End of the i-th (from 1) of those steps: anchor + i h, the last one target itself."""
    return target if i >= landing_steps(anchor, target, h) else anchor + i * h


# ----------------------------------------------------------------------------- initial step
def initial_step(rhs, t0: float, y0: np.ndarray, f0: np.ndarray, order: int, rtol: float,
                 atol: np.ndarray, max_step: float, span: float, counters) -> float:
    """Starting step size by the algorithm of Hairer, Norsett & Wanner (Sec. II.4): the
    compiled rules :func:`start_first_guess` and :func:`start_step` (those of the compiled
    driver, :func:`.adaptive_driver.rk_start`) on the weighted norms of y0, f0 and of the
    difference of f at one more point, evaluated by the Python ``rhs``.

    order: order of the local error estimate (the error behaves like h^(order+1)).
    One extra right-hand-side evaluation (counted in ``counters.nfev``).
    """
    scale = atol + np.abs(y0) * rtol
    d1 = rms_norm(f0 / scale)
    h0 = start_first_guess(rms_norm(y0 / scale), d1, float(max_step), float(span))
    f1 = rhs(t0 + h0, y0 + h0 * f0)
    counters.nfev += 1
    d2 = rms_norm((f1 - f0) / scale) / h0
    return start_step(h0, d1, d2, 1.0 / (order + 1), float(max_step), float(span))


# ----------------------------------------------------------------------------- multistep history
def resample_matrix(m: int, r: float) -> np.ndarray:
    """(m, m) matrix L re-spacing a uniform history to a step ratio r = h_new / h_old.

    The history rows z_j = z(t_n - j h_old), j = 0..m-1, define the degree m-1 interpolating
    polynomial; ``L @ Z`` evaluates it at t_n - k h_new, k = 0..m-1 (row 0 is unchanged).
    """
    s = [-float(j) for j in range(m)]
    L = np.empty((m, m))
    for k in range(m):
        x = -k * r
        for j in range(m):
            w = 1.0
            for i in range(m):
                if i != j:
                    w *= (x - s[i]) / (s[j] - s[i])
            L[k, j] = w
    return L


def lagrange_weights(x: float, m: int) -> np.ndarray:
    """(m,) weights w_j = l_j(x) of the Lagrange basis on the nodes 0, -1, ..., -(m-1)."""
    w = np.empty(m)
    for j in range(m):
        v = 1.0
        for i in range(m):
            if i != j:
                v *= (x + i) / (i - j)
        w[j] = v
    return w


def hermite(theta: float, h: float, y0: np.ndarray, f0: np.ndarray, y1: np.ndarray,
            f1: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolant at t0 + theta h from (y0, f0 = y0') and (y1, f1 = y1').

    Exact at theta = 0 and 1; error O(h^4). Shapes (n,), h in s.
    """
    t2 = theta * theta
    t3 = t2 * theta
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = (t3 - 2.0 * t2 + theta) * h
    h01 = 1.0 - h00
    h11 = (t3 - t2) * h
    return h00 * y0 + h01 * y1 + h10 * f0 + h11 * f1


def default_max_step(max_step: Optional[float]) -> float:
    """max_step option: None or inf means unbounded."""
    if max_step is None:
        return math.inf
    return positive(max_step, "max_step", allow_inf=True)
