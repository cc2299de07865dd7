"""Gear's fourth-order backward differentiation formula (BDF4), text ch. 13, Eq. (13.26).

    y_(n+1) = (48 y_n - 36 y_(n-1) + 16 y_(n-2) - 3 y_(n-3)) / 25 + (12/25) h f(t_(n+1), y_(n+1))

An implicit, stiffly stable multistep method. Each step solves G(y) = y - (12/25) h f(t, y) - psi
= 0 by simplified Newton iterations with the iteration matrix M = I - (12/25) h J, J = df/dy from
``problem.jac`` or forward finite differences of ``rhs`` (:func:`.jacobian.fd_jacobian`: one
evaluation per column, except the ``problem.n_quadrature`` trailing quadrature components whose
columns are zero, + 1 for f(y) + 1 measuring f's round-off, which sizes the increments; counted
in nfev), evaluated at the predicted end of the step (t_(n+1), y^p), where Newton works (J can turn
fast along the solution: on the flyball governor the stiff spring directions rotate with the
shaft). J and the LU factorisation of M are reused across iterations and steps: J is
re-evaluated when Newton fails with a reused J (the step is retried with the fresh J, same h) or
converged slowly (> 3 iterations); after a failure of a reused J it is evaluated up front for the
next 1, 2, 4, then 8 steps (reset when a reused J succeeds again). M is re-factorised only when
J or the step size changes. Newton stops when the estimated remaining error
rate/(1 - rate) ||dy|| < newton_tol (weighted RMS norm over the non-quadrature components, scale
atol + rtol |y|), the rate being carried over between solves as rate^0.8 (Hairer & Wanner,
Sec. IV.8, and their RADAU5), or when a correction ||dy|| <= newton_tol no longer shrinks (the
round-off of f reached, see :mod:`.jacobian`).

Structure: :class:`GearStepper` is the stepping formula (:class:`.driver.Stepper`), the step
size comes from an :class:`.controllers.IController` with a deadband (or a constant step), and
:func:`.driver.run` does the rest.

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

from .base import Integrator, register
from .controller import (EPS, atol_vector, default_max_step, hermite,
                         initial_step, lagrange_weights, non_negative, positive,
                         raise_if_nonfinite, resample_matrix, validate_tolerances)
from .controllers import FixedStepController, IController
from .driver import Step, Stepper
from .jacobian import fd_jacobian

BDF4_ALPHA = np.array([48.0, -36.0, 16.0, -3.0]) / 25.0    # Eq. (13.26), on y_n .. y_(n-3)
BDF4_BETA = 12.0 / 25.0                                    # Eq. (13.26), on h f_(n+1)
BDF4_ERR = 12.0 / 137.0                                    # local error / (y_c - y_p)
MAX_GROWTH = 2.0                                           # step growth cap per step
EXTRAPOLATE5 = np.array([5.0, -10.0, 10.0, -5.0, 1.0])     # quartic predictor

# SDIRK4, Hairer & Wanner II, Table IV.6.5 (L-stable, stiffly accurate, gamma = 1/4).
SD_GAMMA = 0.25
SD_NODES = (0.25, 0.75, 11.0 / 20.0, 0.5, 1.0)
SD_COEF = (
    np.zeros(0),
    np.array([1.0 / 2.0]),
    np.array([17.0 / 50.0, -1.0 / 25.0]),
    np.array([371.0 / 1360.0, -137.0 / 2720.0, 15.0 / 544.0]),
    np.array([25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0]),
)
SD_WEIGHTS = np.array([25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0, 1.0 / 4.0])
SD_BHAT = np.array([59.0 / 48.0, -17.0 / 96.0, 225.0 / 32.0, -85.0 / 12.0, 0.0])
SD_ERROR_WEIGHTS = SD_WEIGHTS - SD_BHAT


def retry_exponent(h: float, H: float) -> float:
    """The exponent k with which the BDF4 error estimate falls when a step of size h, taken
    from a history of accepted points spaced H, is retried at h/2: err(h/2) = err(h) 2^(-k).

    The re-spaced history lies on the quartic Q through the accepted points, so the predictor
    is Q(t_n + h) and the estimate is (12/137) (12/25) h (f - Q') ~ h p'(h), p(s) =
    prod_(j=0..4) (s + j H) (the interpolation error of Q): it falls like h^5 only when the
    history is re-spaced too (h = H = everything), but like h^2.4 at h = H and h^1 for
    h << H when only the new step shrinks -- as a retry does. With the exponent 5 a
    rejected step was retried at 0.78 h for an error of 2 and failed again (err ~1.06).
    """
    def g(x):
        terms = [x + j * H for j in range(5)]
        return x * math.prod(terms) * sum(1.0 / v for v in terms)
    k = math.log(g(h) / g(0.5 * h)) / math.log(2.0)
    return min(5.0, max(1.0, k))


_getrf, _getrs = lapack.get_lapack_funcs(("getrf", "getrs"), (np.empty(1),))


class NewtonSolver:
    """Simplified Newton for y = psi + gh f(t, y) with the iteration matrix I - gh J.

    J = df/dy from ``problem.jac`` or forward differences of ``rhs`` (one column per
    non-quadrature component, + 2 evaluations; counted in nfev). J and the LU factorisations of
    I - gh J (kept for the last two values of gh) are reused across iterations and steps; the
    caller refreshes J only when Newton fails with a J that is not current. Convergence:
    rate/(1 - rate) ||dy|| < newton_tol in the weighted RMS norm over the non-quadrature
    components (Hairer & Wanner II, Sec. IV.8), the contraction rate carried between solves.
    """

    def __init__(self, problem, n, rtol, atol, newton_tol, max_newton, counters):
        self.f = problem.rhs
        self.jac = problem.jac
        self.n = n
        self.nd = n - int(problem.n_quadrature or 0)   # components in the convergence test
        self.rtol, self.atol = rtol, atol
        self.newton_tol, self.max_newton = newton_tol, max_newton
        self.counters = counters
        self.J = np.zeros((n, n))
        self.lu_cache: dict = {}
        self.rate = None
        self.current = False            # J evaluated at the current step's start

    def refresh(self, t, y, fy=None):
        """J = df/dy at (t, y); drops the LU factorisations."""
        n, nd, f, counters = self.n, self.nd, self.f, self.counters
        if self.jac is not None:
            self.J = np.array(self.jac(t, y), dtype=float).reshape(n, n)
        else:
            J = self.J
            if fy is None:
                fy = f(t, y)
                counters.nfev += 1
            counters.nfev += fd_jacobian(f, t, y, fy, self.atol / self.rtol, nd, J)
        counters.njev += 1
        if not np.all(np.isfinite(self.J)):
            raise_if_nonfinite(t, self.J.ravel(), "Jacobian")
        self.lu_cache.clear()
        self.current = True

    def factor(self, gh):
        """LU of I - gh J (cached per gh); False when singular."""
        lu_cache = self.lu_cache
        lu = lu_cache.get(gh)
        if lu is None:
            for key, val in lu_cache.items():          # a round-off different step: reuse
                if abs(key - gh) <= 1e-9 * gh:
                    return val
            if len(lu_cache) >= 2:
                lu_cache.clear()
            M = -gh * self.J
            M.flat[::self.n + 1] += 1.0
            lu_, piv, info = _getrf(M, overwrite_a=True)
            self.counters.nlu += 1
            lu = (lu_, piv) if info == 0 else False
            lu_cache[gh] = lu
        return lu

    def solve(self, t_new, psi, gh, y, scale):
        """Solve y = psi + gh f(t_new, y) from the guess y. Returns (y, iterations) or
        (None, cause)."""
        lu = self.factor(gh)
        if lu is False:
            return None, "singular iteration matrix I - gh J"
        lu_, piv = lu
        f, counters, nd = self.f, self.counters, self.nd
        newton_tol, max_newton = self.newton_tol, self.max_newton
        if self.rate is not None:
            # the remembered contraction rate, raised towards 1 at every solve as RADAU5 does
            # (FACCON = MAX(FACCON, UROUND)**0.8) until an iteration measures it again: solves
            # that stop after one iteration cannot go on trusting a rate measured many steps
            # (and Jacobians) ago. A flat floor (1e-3) did: one-iteration "convergence" with
            # corrections up to 30 tolerances, with a stale J, held the flyball governor's
            # step at 2e-4 s at rtol 1e-3 (4,338 steps, against 166 at rtol 1e-4).
            self.rate = max(self.rate, EPS) ** 0.8
        rate = self.rate
        dn_old = 0.0
        for it in range(max_newton):
            fy = f(t_new, y)
            counters.nfev += 1
            if not math.isfinite(fy.dot(fy)) and not np.all(np.isfinite(fy)):
                return None, "non-finite derivative"
            dy, _ = _getrs(lu_, piv, psi + gh * fy - y)
            e = dy[:nd] / scale[:nd]
            dn = math.sqrt(float(np.dot(e, e)) / nd)
            if it > 0:
                rate = dn / dn_old
                slow = rate >= 1.0 or rate ** (max_newton - it) / (1.0 - rate) * dn > newton_tol
                if slow and dn <= newton_tol:
                    # a correction below the tolerance that no longer shrinks: the iteration
                    # has reached the round-off of f (CVODE's test, del min(1, rate) <= tol,
                    # accepts it too). At the singular start of rand2007 f's round-off is
                    # 1e-5 of f and such "divergence" failed Newton down to h = 4e-8 s.
                    self.rate = None
                    y = y + dy
                    if nd < self.n:
                        y = self._quadratures(t_new, psi, gh, y)
                    return y, it + 1
                if rate >= 1.0:
                    self.rate = None
                    return None, f"diverging, contraction rate {rate:.3g}"
                if slow:
                    self.rate = None
                    return None, f"too slow, contraction rate {rate:.3g}"
            y = y + dy
            if dn == 0.0 or (rate is not None and rate < 1.0
                             and rate / (1.0 - rate) * dn < newton_tol):
                if it > 0:
                    self.rate = rate
                if nd < self.n:
                    y = self._quadratures(t_new, psi, gh, y)
                return y, it + 1
            dn_old = dn
        self.rate = None
        return None, f"no convergence in {max_newton} iterations"

    def _quadratures(self, t_new, psi, gh, y):
        """The trailing quadratures (W) from the derivative at the converged state.

        The Newton update of a quadrature uses the derivative at the iterate before the last
        correction, linearised: when that derivative is a stiff quadratic form -- the power of
        a damper, c v^2 with c = 4e4 N s/m on the flyball governor -- the left-over c dv^2
        of a correction dv of the stiff velocity (large after a single iteration from the
        predictor) made W's error estimate noise (30 to 100 times its tolerance on one step,
        0.01 the next) and decided the step sizes. Its exact value costs one evaluation.
        """
        fy = self.f(t_new, y)
        self.counters.nfev += 1
        nd = self.nd
        y[nd:] = psi[nd:] + gh * fy[nd:]
        return y


class GearStepper(Stepper):
    """BDF4 (Eq. 13.26) with the SDIRK4 start-up; see the module docstring."""

    name = "bdf4"

    def __init__(self, opts):
        self.o = opts

    def start(self, problem, t0, y0, t_end, counters):
        o = self.o
        f = problem.rhs
        self.f, self.counters = f, counters
        n = y0.size
        self.n = n
        self.atol = atol_vector(o.atol, n)
        self.newton = NewtonSolver(problem, n, o.rtol, self.atol, o.newton_tol, o.max_newton,
                                   counters)
        self.fy = f(t0, y0)
        counters.nfev += 1
        raise_if_nonfinite(t0, self.fy, "derivative")
        span = t_end - t0
        if o.adaptive:
            h = o.step if o.step is not None else initial_step(
                f, t0, y0, self.fy, 3, o.rtol, self.atol, o.max_step, span, counters)
            h = min(h, o.max_step, span / 4.0)
        else:
            h = o.step
        self.Y = np.empty((5, n))          # y_n, y_(n-1), .., y_(n-4) spaced by hY
        self.Y[0] = y0
        self.n_hist = 1
        self.hY = h
        self.h_nodes = h                   # spacing of the accepted history's points
        self.slopes = np.empty((5, n))     # SDIRK stage derivatives
        self.refresh_next = True
        self.backoff = 0          # steps with a Jacobian evaluated up front (see ``step``)
        self.proactive = 0
        return h

    # ------------------------------------------------------------------ SDIRK4 start-up step
    def _sdirk(self, t, y, hs, scale):
        """One SDIRK4 step; returns (y_new, f_new, error vector, iterations) or None, cause."""
        gh = SD_GAMMA * hs
        slopes = self.slopes
        guess = y + gh * self.fy
        iters = 0
        Yst = y
        for i in range(5):
            psi = y + hs * np.dot(SD_COEF[i], slopes[:i]) if i else y
            if i:
                guess = psi + gh * slopes[i - 1]
            Yst, it = self.newton.solve(t + SD_NODES[i] * hs, psi, gh, guess, scale)
            if Yst is None:
                return None, it
            iters = max(iters, it)
            slopes[i] = (Yst - psi) * (1.0 / gh)
        err = None
        if self.o.adaptive:
            lu_, piv = self.newton.factor(gh)
            err, _ = _getrs(lu_, piv, hs * np.dot(SD_ERROR_WEIGHTS, slopes))   # filtered
        return (Yst, slopes[4].copy(), err, iters), None

    def step(self, t, y, t_new):
        o, newton = self.o, self.newton
        hs = t_new - t
        n = self.n
        while True:
            scale = self.atol + o.rtol * np.abs(y)
            startup = self.n_hist < 5
            if startup:
                if self.refresh_next:
                    newton.refresh(t, y, self.fy)
                    self.refresh_next = False
                if self.n_hist > 1 and hs != self.hY:
                    self.n_hist = 1                     # restart the uniform start-up
                    self.Y[0] = y
                out, cause = self._sdirk(t, y, hs, scale)
                if out is not None:
                    y_new, f_new, err_vec, iters = out
                    dense = _HermiteStep(t, hs, y, self.fy, y_new, f_new)
            else:
                Y = self.Y
                if hs != self.hY:
                    self.Y = Y = resample_matrix(5, hs / self.hY) @ Y
                    self.hY = hs
                y_p = np.dot(EXTRAPOLATE5, Y)                      # predictor
                psi = np.dot(BDF4_ALPHA, Y[:4])                   # Eq. (13.26)
                if self.refresh_next:
                    # J at the predicted end of the step, where Newton works: J can change
                    # fast along the solution (e.g. stiff directions rotating with a body)
                    newton.refresh(t_new, y_p)
                    self.refresh_next = False
                y_new, cause = newton.solve(t_new, psi, BDF4_BETA * hs, y_p, scale)
                out = y_new
                if y_new is not None:
                    iters = cause
                    err_vec = (y_new - y_p) * BDF4_ERR
                    f_new = None
                    dense = _HistoryPolynomial(t_new, hs, np.vstack([y_new[None], Y[:4]]))
            if out is not None:
                break
            if newton.current:
                return Step(t_new, None, failed=cause, k=5)
            self.counters.rejected += 1                 # retry with a fresh Jacobian
            self.refresh_next = True
            # a Jacobian one step old failed: evaluate it up front for the next few steps
            # (1, 2, 4, 8 then 8 each time it fails again) instead of failing every step
            self.backoff = min(2 * self.backoff + 1, 8)
            self.proactive = self.backoff
        if not newton.current:
            self.backoff = 0                            # the reused Jacobian did the job
        newton.current = False
        self.iters = iters
        self.h_last = hs
        self.f_new = f_new
        err = None
        if o.adaptive:
            sc = self.atol + o.rtol * np.maximum(np.abs(y), np.abs(y_new))
            e = err_vec / sc
            err = math.sqrt(float(np.dot(e, e)) / n)
        return Step(t_new, y_new, err, 4 if startup else 5, dense,
                    hold=self.n_hist + 1 < 5,
                    k_retry=None if startup else retry_exponent(hs, self.h_nodes))

    def accept(self, step, y_final):
        Y = self.Y
        Y[1:] = Y[:-1]
        Y[0] = y_final
        self.hY = self.h_nodes = self.h_last
        if self.n_hist < 5:
            self.fy = self.f_new
        self.n_hist = min(self.n_hist + 1, 5)
        if self.iters > 3:
            self.refresh_next = True                    # slow convergence: new J next step
        elif self.proactive > 0:
            self.proactive -= 1
            self.refresh_next = True


class _HermiteStep:
    """Cubic Hermite interpolant of one step, as a callable of the time (s)."""

    __slots__ = ("t", "h", "y0", "f0", "y1", "f1")

    def __init__(self, t, h, y0, f0, y1, f1):
        self.t, self.h, self.y0, self.f0, self.y1, self.f1 = t, h, y0, f0, y1, f1

    def __call__(self, s):
        return hermite((s - self.t) / self.h, self.h, self.y0, self.f0, self.y1, self.f1)


class _HistoryPolynomial:
    """The quartic through y_(n+1), y_n, .., y_(n-3) (spacing h), as a callable of the time."""

    __slots__ = ("t_new", "h", "Y")

    def __init__(self, t_new, h, Y):
        self.t_new, self.h, self.Y = t_new, h, Y

    def __call__(self, s):
        return np.dot(lagrange_weights((s - self.t_new) / self.h, 5), self.Y)


@register
class GearBDF4(Integrator):
    """Gear's BDF4 with Jacobian/LU reuse, SDIRK4 start-up, constant or variable step.

    Options: step (s; the constant step when not adaptive, else the first step), adaptive (True),
    fixed_step (False; True is the same as adaptive=False), rtol, atol (scalar or (n,); they set
    the Newton convergence scale in both modes and the error test in adaptive mode), max_step,
    min_step (s), newton_tol (default max(10 eps / rtol, min(0.03, sqrt(rtol)))), max_newton (8).

    Raises SimulationError (with ``.t``) when Newton does not converge at a constant step, or the
    step size underflows in adaptive mode.
    """

    name = "bdf4"
    order = 4
    adaptive = True
    multistep = True

    def __init__(self, step: Optional[float] = None, adaptive: bool = True,
                 fixed_step: bool = False, rtol: float = 1e-6, atol=1e-9,
                 max_step: Optional[float] = None, min_step: float = 0.0,
                 newton_tol: Optional[float] = None, max_newton: int = 8,
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
        self.make_controller()

    def __repr__(self) -> str:
        mode = "adaptive" if self.adaptive else "fixed"
        return f"GearBDF4({mode}, step={self.step!r}, rtol={self.rtol!r})"

    def make_stepper(self):
        return GearStepper(self)

    def make_controller(self):
        if not self.adaptive:
            return FixedStepController(self.step)
        # the history is re-spaced at every change: grow only by >= 1.25 (at most x MAX_GROWTH)
        return IController(safety=self.safety, max_factor=MAX_GROWTH, deadband=1.25)
