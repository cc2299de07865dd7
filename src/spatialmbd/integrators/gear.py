"""Gear's fourth-order backward differentiation formula (BDF4), text ch. 13, Eq. (13.26).

    y_(n+1) = (48 y_n - 36 y_(n-1) + 16 y_(n-2) - 3 y_(n-3)) / 25 + (12/25) h f(t_(n+1), y_(n+1))

An implicit, stiffly stable multistep method. Each step solves G(y) = y - (12/25) h f(t, y) - psi
= 0 by simplified Newton iterations with the iteration matrix M = I - (12/25) h J, J = df/dy from
``problem.jac`` or forward finite differences of ``rhs`` (n + 1 evaluations, counted in nfev).
J and the LU factorisation of M are reused across steps: J is re-evaluated only when Newton fails
(then the step is retried with the fresh J) or converged slowly (> 3 iterations; J is refreshed
before the next step); M is re-factorised only when J or the step size changes. Newton stops when
the estimated remaining error rate/(1 - rate) ||dy|| < newton_tol (weighted RMS norm, scale
atol + rtol |y|), the rate being carried over between solves (Hairer & Wanner, Sec. IV.8).

Start-up: BDF4 needs y_n .. y_(n-3); the first four steps use the L-stable, stiffly accurate
4th-order SDIRK method of Hairer & Wanner (Solving ODEs II, Table IV.6.5, gamma = 1/4) at the same
constant step, so the start is 4th order and stable on stiff problems (its stages are solved with
the same Newton machinery, iteration matrix I - h/4 J). Its embedded 3rd-order solution provides
the error estimate during an adaptive start-up (filtered by M^-1, Shampine's device).

Adaptive mode: the predictor is the quartic extrapolation through y_n .. y_(n-4),
y^p = 5 y_n - 10 y_(n-1) + 10 y_(n-2) - 5 y_(n-3) + y_(n-4); with the BDF4 error constant
-12/125 the local error is about (12/137) (y_(n+1) - y^p). When the step changes the history
y_n .. y_(n-4) is re-spaced by evaluating its interpolating quartic at t_n - k h'
(:func:`controller.resample_matrix`). Step growth needs a factor >= 1.25 (capped at 2); a
rejected step or a Newton failure with a fresh J shrinks it.

Dense output: the quartic through the five latest history points (BDF steps) or the cubic
Hermite interpolant (start-up steps); projected when ``problem.project`` is given.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np
from scipy.linalg import lapack

from ..errors import SpatialMBDError
from .base import Integrator, register
from .controller import (EPS, StepController, atol_vector, default_max_step, end_step, hermite,
                         initial_step, lagrange_weights, min_step_size, newton_error,
                         non_negative, positive, raise_if_nonfinite, resample_matrix,
                         underflow_error, validate_tolerances)

BDF4_ALPHA = np.array([48.0, -36.0, 16.0, -3.0]) / 25.0    # Eq. (13.26), on y_n .. y_(n-3)
BDF4_BETA = 12.0 / 25.0                                    # Eq. (13.26), on h f_(n+1)
BDF4_ERR = 12.0 / 137.0                                    # local error / (y_c - y_p)
EXTRAPOLATE5 = np.array([5.0, -10.0, 10.0, -5.0, 1.0])     # quartic predictor

# SDIRK4, Hairer & Wanner II, Table IV.6.5 (L-stable, stiffly accurate, gamma = 1/4).
SD_GAMMA = 0.25
SD_C = (0.25, 0.75, 11.0 / 20.0, 0.5, 1.0)
SD_A = (
    np.zeros(0),
    np.array([1.0 / 2.0]),
    np.array([17.0 / 50.0, -1.0 / 25.0]),
    np.array([371.0 / 1360.0, -137.0 / 2720.0, 15.0 / 544.0]),
    np.array([25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0]),
)
SD_B = np.array([25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0, 1.0 / 4.0])
SD_BHAT = np.array([59.0 / 48.0, -17.0 / 96.0, 225.0 / 32.0, -85.0 / 12.0, 0.0])
SD_E = SD_B - SD_BHAT

_getrf, _getrs = lapack.get_lapack_funcs(("getrf", "getrs"), (np.empty(1),))


@register
class GearBDF4(Integrator):
    """Gear's BDF4 with Jacobian/LU reuse, SDIRK4 start-up, constant or variable step.

    Options: step (s; the constant step when not adaptive, else the first step), adaptive (True),
    fixed_step (False; True is the same as adaptive=False), rtol, atol (scalar or (n,); they set
    the Newton convergence scale in both modes and the error test in adaptive mode), max_step,
    min_step (s), newton_tol (default max(10 eps / rtol, min(0.03, sqrt(rtol)))), max_newton (5).

    Raises SimulationError (with ``.t``) when Newton does not converge at a constant step, or the
    step size underflows in adaptive mode.
    """

    name = "bdf4"
    order = 4
    adaptive = True

    def __init__(self, step: Optional[float] = None, adaptive: bool = True,
                 fixed_step: bool = False, rtol: float = 1e-6, atol=1e-9,
                 max_step: Optional[float] = None, min_step: float = 0.0,
                 newton_tol: Optional[float] = None, max_newton: int = 5,
                 safety: float = 0.9):
        self.adaptive = bool(adaptive) and not fixed_step
        self.step = None if step is None else positive(step, "step")
        if not self.adaptive and self.step is None:
            raise ValueError("bdf4 at a constant step needs the option step=h > 0 (got None)")
        self.rtol, self.atol = validate_tolerances(rtol, atol)
        self.max_step = default_max_step(max_step)
        self.min_step = non_negative(min_step, "min_step")
        if newton_tol is None:
            newton_tol = max(10.0 * EPS / self.rtol, min(0.03, self.rtol ** 0.5))
        self.newton_tol = positive(newton_tol, "newton_tol")
        if int(max_newton) != max_newton or max_newton < 1:
            raise ValueError(f"option max_newton={max_newton!r} must be an integer >= 1")
        self.max_newton = int(max_newton)
        self.safety = float(safety)
        StepController(5, safety=self.safety)

    def __repr__(self) -> str:
        mode = "adaptive" if self.adaptive else "fixed"
        return f"GearBDF4({mode}, step={self.step!r}, rtol={self.rtol!r})"

    def _integrate(self, problem, t0, y0, t_eval, counters, outputs, progress) -> None:
        f = problem.rhs
        jac = problem.jac
        project = problem.project
        n = y0.size
        adaptive = self.adaptive
        rtol = self.rtol
        atol = atol_vector(self.atol, n)
        newton_tol = self.newton_tol
        max_newton = self.max_newton
        ctrl5 = StepController(5, safety=self.safety, max_factor=2.0)   # BDF4 error ~ h^5
        ctrl4 = StepController(4, safety=self.safety, max_factor=2.0)   # SDIRK embedded ~ h^4
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
        name = self.name

        # ---------------------------------------------------------------- Jacobian and LU
        J = np.empty((n, n))
        lu_cache: dict = {}
        state = {"rate": None}

        def refresh_jacobian(t, y):
            """J = df/dy at (t, y) from problem.jac or forward differences; drops the LUs."""
            nonlocal J
            if jac is not None:
                J = np.array(jac(t, y), dtype=float).reshape(n, n)
            else:
                f0 = f(t, y)
                counters.nfev += 1
                typical = atol / rtol
                for j in range(n):
                    yj = y.copy()
                    d = math.sqrt(EPS) * max(abs(y[j]), typical[j])
                    yj[j] += d
                    d = yj[j] - y[j]                 # the exactly representable increment
                    J[:, j] = (f(t, yj) - f0) / d
                counters.nfev += n
            counters.njev += 1
            if not np.all(np.isfinite(J)):
                raise_if_nonfinite(t, J.ravel(), "Jacobian")
            lu_cache.clear()

        def factor(gh):
            """LU of M = I - gh J (cached per gh); None when M is singular."""
            lu = lu_cache.get(gh)
            if lu is None:
                for key, val in lu_cache.items():      # a round-off different step: reuse
                    if abs(key - gh) <= 1e-9 * gh:
                        return val
                if len(lu_cache) >= 2:
                    lu_cache.clear()
                M = -gh * J
                M.flat[::n + 1] += 1.0
                lu_, piv, info = _getrf(M, overwrite_a=True)
                counters.nlu += 1
                lu = (lu_, piv) if info == 0 else False
                lu_cache[gh] = lu
            return lu

        def newton(t_new, psi, gh, y, scale):
            """Solve y = psi + gh f(t_new, y). Returns (y, iterations) or (None, cause)."""
            lu = factor(gh)
            if lu is False:
                return None, "singular iteration matrix I - gh J"
            lu_, piv = lu
            rate = state["rate"]
            if rate is not None:
                rate = max(rate, 1e-3)          # remembered contraction rate, floored
            dn_old = 0.0
            for it in range(max_newton):
                fy = f(t_new, y)
                counters.nfev += 1
                if not math.isfinite(fy.dot(fy)) and not np.all(np.isfinite(fy)):
                    return None, "non-finite derivative"
                dy, _ = _getrs(lu_, piv, psi + gh * fy - y)
                e = dy / scale
                dn = math.sqrt(float(np.dot(e, e)) / n)
                if it > 0:
                    rate = dn / dn_old
                    if rate >= 1.0:
                        state["rate"] = None
                        return None, f"diverging, contraction rate {rate:.3g}"
                    if rate ** (max_newton - it) / (1.0 - rate) * dn > newton_tol:
                        state["rate"] = None
                        return None, f"too slow, contraction rate {rate:.3g}"
                y = y + dy
                if dn == 0.0 or (rate is not None and rate < 1.0
                                 and rate / (1.0 - rate) * dn < newton_tol):
                    if it > 0:
                        state["rate"] = rate
                    return y, it + 1
                dn_old = dn
            state["rate"] = None
            return None, f"no convergence in {max_newton} iterations"

        # ---------------------------------------------------------------- SDIRK4 start-up step
        Kst = np.empty((5, n))

        def sdirk(t, y, fy, hs, scale):
            """One SDIRK4 step; returns (y_new, f_new, error vector, iterations) or None, cause."""
            gh = SD_GAMMA * hs
            guess = y + gh * fy
            iters = 0
            Y = y
            for i in range(5):
                psi = y + hs * np.dot(SD_A[i], Kst[:i]) if i else y
                if i:
                    guess = psi + gh * Kst[i - 1]
                Y, it = newton(t + SD_C[i] * hs, psi, gh, guess, scale)
                if Y is None:
                    return None, it
                iters = max(iters, it)
                Kst[i] = (Y - psi) * (1.0 / gh)
            err = None
            if adaptive:
                lu_, piv = factor(gh)
                err, _ = _getrs(lu_, piv, hs * np.dot(SD_E, Kst))   # filtered estimate
            return (Y, Kst[4].copy(), err, iters), None

        # ---------------------------------------------------------------- main loop
        t, y = t0, y0
        try:
            fy = f(t0, y0)
            counters.nfev += 1
            raise_if_nonfinite(t0, fy, "derivative")
            if adaptive:
                h = self.step if self.step is not None else initial_step(
                    f, t0, y0, fy, 3, rtol, atol, self.max_step, span, counters)
                h = min(h, self.max_step, span / 4.0)
            else:
                h = self.step
            Y = np.empty((5, n))          # y_n, y_(n-1), .., y_(n-4) spaced by hY
            Y[0] = y0
            n_hist = 1
            hY = h
            J_current = False
            refresh = True
            after_reject = False
            last_cause = "error test failed"
            while t < t_end:
                hs = end_step(t, h, t_end)
                t_new = t_end if hs == t_end - t else t + hs
                if adaptive and hs < min_step_size(t, span, self.min_step):
                    raise underflow_error(name, t, hs, last_cause)
                if refresh:
                    refresh_jacobian(t, y)
                    J_current = True
                    refresh = False
                scale = atol + rtol * np.abs(y)
                startup = n_hist < 5
                if startup:
                    if n_hist > 1 and hs != hY:
                        n_hist = 1                     # restart the uniform start-up
                        Y[0] = y
                    out, cause = sdirk(t, y, fy, hs, scale)
                    if out is not None:
                        y_new, f_new, err_vec, iters = out
                else:
                    if hs != hY:
                        Y = resample_matrix(5, hs / hY) @ Y
                        hY = hs
                    y_p = np.dot(EXTRAPOLATE5, Y)                      # predictor
                    psi = np.dot(BDF4_ALPHA, Y[:4])                   # Eq. (13.26)
                    y_new, cause = newton(t_new, psi, BDF4_BETA * hs, y_p, scale)
                    out = y_new
                    if y_new is not None:
                        iters = cause
                        err_vec = (y_new - y_p) * BDF4_ERR
                if out is None:                        # Newton failure
                    counters.rejected += 1
                    if not J_current:
                        refresh = True                 # retry with a fresh Jacobian
                        continue
                    if not adaptive:
                        raise newton_error(name, t, hs, cause)
                    h = 0.5 * hs
                    after_reject = True
                    last_cause = "Newton iteration failed: " + cause
                    continue
                if adaptive:
                    sc = atol + rtol * np.maximum(np.abs(y), np.abs(y_new))
                    e = err_vec / sc
                    err = math.sqrt(float(np.dot(e, e)) / n)
                    ctrl = ctrl4 if startup else ctrl5
                    if not err <= 1.0:
                        counters.rejected += 1
                        h = hs * ctrl.reject(err)
                        after_reject = True
                        last_cause = ("error test failed" if math.isfinite(err) else
                                      "error estimate not finite")
                        continue
                if project is not None:
                    y_new = project(t_new, y_new)
                raise_if_nonfinite(t_new, y_new)
                Y[1:] = Y[:-1]
                Y[0] = y_new
                hY = hs
                J_current = False
                if iters > 3:
                    refresh = True                     # slow convergence: new J next step
                # ---- accept: outputs in (t, t_new]
                counters.steps += 1
                while k_out < n_out and touts[k_out] <= t_new:
                    to = touts[k_out]
                    if to == t_new:
                        outputs.append(y_new)
                    else:
                        if startup:
                            yo = hermite((to - t) / hs, hs, y, fy, y_new, f_new)
                        else:
                            yo = np.dot(lagrange_weights((to - t_new) / hs, 5), Y)
                        outputs.append(yo if project is None else project(to, yo))
                    k_out += 1
                n_hist = min(n_hist + 1, 5)
                t, y = t_new, y_new
                if startup:
                    fy = f_new
                if progress is not None:
                    progress(t)
                if adaptive:
                    fac = ctrl.accept(err, after_reject)
                    after_reject = False
                    if fac >= 1.25 and n_hist == 5:
                        h = min(hs * fac, self.max_step)
        except (SpatialMBDError, np.linalg.LinAlgError, FloatingPointError) as exc:
            if getattr(exc, "t", None) is None:
                exc.t = t
            raise
