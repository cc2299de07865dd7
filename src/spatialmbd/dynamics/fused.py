"""Whole runs in compiled code: the Dormand-Prince 5(4) / 8(5,3) and classic RK4 drivers over the
fused right-hand side of the standard, Baumgarte and projection methods.

The Python drivers of :mod:`..integrators` take one step per Python call; for a model whose
right-hand side is fully compiled (``System.fused``) these loops take many steps per call, with
the same arithmetic:

* :func:`dopri_steps` (its first call starting the run with :func:`dopri_start`):
  Dormand-Prince 5(4) as
  :class:`..integrators.runge_kutta_adaptive.DormandPrince45` with its default controller
  (Hairer's starting step, the PI controller with beta = 0.04, safety 0.9, factors 0.2..10,
  FSAL, Shampine's dense output), or DOP853 as :class:`..integrators.dop853.DormandPrince853`
  -- the pair is an argument (:mod:`..integrators.pairs`) --, the state projected after every
  accepted step and at every output as simulate() does (Euler parameters renormalised; with the
  projection method q and v onto Phi = 0 and D v = nu, and the FSAL derivative re-evaluated);
* :func:`rk4_outputs`: classic RK4 with step h, landing on every output time as
  :class:`..integrators.fixed_step.RungeKutta4` does;
* at every output the state and (optionally) vdot and lambda there (what
  :meth:`..results.Results.from_integration` evaluates), written as the output is reached:
  one compiled entry per driver, since each entry compiles the whole right-hand side again.

Both drivers are resumable: :func:`dopri_steps` returns after ``max_steps`` accepted steps with
its whole state in its arguments and return values, so a caller can run a long simulation in
slices and stay interruptible (Ctrl-C between slices, progress, streamed chunks) -- the slices
give the step sequence of one uninterrupted call. :func:`..simulate.simulate` uses them for
rk45 / rk4 runs without events, drivers, couplers or budgets; :mod:`..sweep.batch` for its
members.

Status codes: :data:`OK`, :data:`NEED_ROOM` or a failure (:data:`STATUS_TEXT`); a failed run
is rerun by the Python driver in simulate() (whose least-squares fallbacks may get through a
singular S or projection), which produces its diagnosis -- except a stalled step control
(:data:`UNDERFLOW`): simulate() then returns the outputs reached, diagnosed at the state where
the steps stalled.
"""
from __future__ import annotations

import math

import numpy as np

from ..integrators.controller import (end_step, landing_steps, landing_time, min_step_size,
                                      pi_factor, rejected_factor, start_first_guess, start_step)
from ..integrators.pairs import (DP8, pair_dense, pair_error, pair_interpolate,
                                 pair_stages)
from ..jit import njit
from . import system as cs
from .projection_kernels import project
from .standard import rhs_standard, stages_standard

__all__ = ["OK", "NEED_ROOM", "RHS_FAILED", "UNDERFLOW", "NOT_FINITE_STATE", "TOO_MANY_STEPS",
           "NOT_PROJECTED", "STATUS_TEXT", "dopri_start", "dopri_steps", "rk4_outputs",
           "project_state", "projection_params", "dopri_run"]

#: status codes of the compiled drivers (OK, or why a run stopped)
OK, RHS_FAILED, UNDERFLOW, NOT_FINITE_STATE, TOO_MANY_STEPS, NOT_PROJECTED = 0, 1, 2, 3, 4, 5
#: dopri_steps stopped before an accepted step whose outputs do not fit in Y (not a failure:
#: the caller makes room and calls again; the step is retaken, with the same result)
NEED_ROOM = 6
STATUS_TEXT = {RHS_FAILED: "the right-hand side failed (singular constraint Jacobian or "
                           "non-finite accelerations)",
               UNDERFLOW: "step size underflow (error test failed repeatedly)",
               NOT_FINITE_STATE: "the state became non-finite",
               TOO_MANY_STEPS: "more steps than max_steps",
               NOT_PROJECTED: "the projection onto the constraints failed (D D^T singular or "
                              "Newton not converged)"}

@njit
def _rms(x, scale):
    acc = 0.0
    for i in range(x.size):
        e = x[i] / scale[i]
        acc += e * e
    return math.sqrt(acc / x.size)


@njit
def _finite(y):
    s = 0.0
    for i in range(y.size):
        s += y[i] * y[i]
    return math.isfinite(s)


@njit
def _output_row(t, Y, Yd, Lam, row, y, F, I, W, mp, nb, lam_off, ydot):
    """Y[row] = y, and with Yd, Lam of as many rows as Y (else of none): vdot and lambda at
    it (NaN where the right-hand side fails) -- what Results.from_integration evaluates."""
    for i in range(y.size):
        Y[row, i] = y[i]
    if Yd.shape[0] == 0:
        return
    m = Lam.shape[1]
    if rhs_standard(t, Y[row], ydot, F, I, W, mp) < 0:
        for j in range(6 * nb):
            Yd[row, j] = np.nan
        for j in range(m):
            Lam[row, j] = np.nan
        return
    for j in range(6 * nb):
        Yd[row, j] = ydot[7 * nb + j]
    for j in range(m):
        Lam[row, j] = W[lam_off + j]


def projection_params(meth, tolerance=None) -> np.ndarray:
    """pp of :func:`project_state` for a method: [projects, tolerance, max_iterations,
    mass metric] (tolerance: the run's, :meth:`.projection.Projection.tolerance_for`; default
    the method's)."""
    tol = getattr(meth, "tolerance", 0.0) if tolerance is None else tolerance
    return np.array([1.0 if meth.projects else 0.0, float(tol),
                     float(getattr(meth, "max_iterations", 0)),
                     1.0 if getattr(meth, "metric", "mass") == "mass" else 0.0])


@njit
def project_state(t, y, F, I, W, pp, nb, dx):
    """The projection of simulate(): Euler parameters renormalised, and with the projection
    method (pp = [projects, tolerance, max_iterations]) q and v projected onto Phi = 0 and
    D v = nu (Eqs. 14.12, 14.19). False if the projection failed."""
    cs.normalize_y(y, nb)
    if pp[0] == 0.0:
        return True
    for i in range(dx.size):
        dx[i] = 0.0
    return project(t, y, F, I, W, pp[1], int(pp[2]), dx, pp[3] != 0.0) >= 0


@njit
def dopri_start(t, y, K0, F, I, W, mp, k_inv, rtol, atol, max_step, span, counters):
    """K0 = f(t, y) and the starting step of an embedded pair whose error behaves like h^k
    (Hairer, Norsett & Wanner II.4, as ``controller.initial_step``). Returns (status, h);
    counters[0] counts f."""
    n = y.size
    if rhs_standard(t, y, K0, F, I, W, mp) < 0:
        return RHS_FAILED, 0.0
    counters[0] += 1
    scale = np.empty(n)
    for i in range(n):
        scale[i] = atol + abs(y[i]) * rtol
    d0 = _rms(y, scale)
    d1 = _rms(K0, scale)
    h0 = start_first_guess(d0, d1, max_step, span)
    y1 = np.empty(n)
    for i in range(n):
        y1[i] = y[i] + h0 * K0[i]
    f1 = np.empty(n)
    if rhs_standard(t + h0, y1, f1, F, I, W, mp) < 0:
        return RHS_FAILED, 0.0
    counters[0] += 1
    for i in range(n):
        y1[i] = f1[i] - K0[i]
    d2 = _rms(y1, scale) / h0
    return OK, start_step(h0, d1, d2, k_inv, max_step, span)


@njit
def dopri_steps(t, y, K0, h, err_prev, F, I, W, mp, pp, pair, t0, t_out, k_out, k_base, rtol,
                atol, max_step, max_steps, nb, Y, Yd, Lam, lam_off, counters):
    """Up to ``max_steps`` accepted steps of the embedded Dormand-Prince pair ``pair``
    (:mod:`..integrators.pairs`: rk45 or dop853) from (t, y) with FSAL derivative K0
    and proposed step h (in place on y and K0), every output time t_out[k_out:] reached
    written into Y[k - k_base] (projected as simulate() does) and, when Yd and Lam have rows,
    vdot and lambda there. The first call passes h = 0: the output at t (if t_out[k_out] ==
    t), K0 = f(t, y) and the starting step come first. Returns (status, t, h, err_prev,
    k_out): call again with them to continue (t == t_out[-1]: done). Status NEED_ROOM: the
    next step's outputs do not fit in Y; nothing of that step is kept (state and counters as
    before it). counters: (nfev, steps, rejected), accumulated."""
    kind, tableau, nodes, ctrl = pair
    k_inv, beta, safety, min_factor, max_factor = ctrl[0], ctrl[1], ctrl[2], ctrl[3], ctrl[4]
    S = pair_stages(kind)
    n = y.size
    ydot = np.empty(n)
    t_end = t_out[-1]
    if h <= 0.0:                                     # the first call of a run
        if k_out < t_out.size and t_out[k_out] == t:
            if k_out - k_base >= Y.shape[0]:
                return NEED_ROOM, t, h, err_prev, k_out
            _output_row(t, Y, Yd, Lam, k_out - k_base, y, F, I, W, mp, nb, lam_off, ydot)
            k_out += 1
        if t >= t_end:
            return OK, t, h, err_prev, k_out
        code, h = dopri_start(t, y, K0, F, I, W, mp, ctrl[5], rtol, atol, max_step, t_end - t0,
                              counters)
        if code != OK:
            return code, t, h, err_prev, k_out
    K = np.empty((tableau.shape[0], n))
    for i in range(n):
        K[0, i] = K0[i]
    y_new = np.empty(n)
    y_raw = np.empty(n)
    delta = np.zeros(n)
    yo = np.empty(n)
    atol_v = np.full(n, atol)
    coef = np.empty((7, n))
    dx = np.zeros(6 * nb)
    span = t_end - t0
    nt = t_out.size
    alpha = k_inv - 0.75 * beta
    after_reject = False
    steps = 0
    while t < t_end and steps < max_steps:
        h_min = min_step_size(t, span, 0.0)
        h_start, c0, c2 = h, counters[0], counters[2]
        while True:
            hs = end_step(t, h, t_end)
            if hs < h_min:
                return UNDERFLOW, t, h, err_prev, k_out
            t_new = t_end if hs == t_end - t else t + hs
            done = stages_standard(t, y, hs, tableau, nodes, K, 1, S, y_new, t_new, F, I, W,
                                   mp)
            counters[0] += S - 1
            if done < S:
                err = math.inf
            else:
                err = pair_error(kind, y, y_new, K, hs, atol_v, rtol)
            if err <= 1.0:
                break
            counters[2] += 1
            h = hs * rejected_factor(err, k_inv, safety, min_factor)
            after_reject = True
        # accepted
        k_last = k_out
        while k_last < nt and t_out[k_last] <= t_new:
            k_last += 1
        if k_last - k_base > Y.shape[0]:             # no room for its outputs: retake later
            counters[0], counters[2] = c0, c2
            for i in range(n):
                K0[i] = K[0, i]
            return NEED_ROOM, t, h_start, err_prev, k_out
        fac, err_prev = pi_factor(err, err_prev, alpha, beta, safety, min_factor, max_factor,
                                  after_reject)
        after_reject = False
        for i in range(n):
            y_raw[i] = y_new[i]
        if not project_state(t_new, y_new, F, I, W, pp, nb, dx):
            return NOT_PROJECTED, t_new, h, err_prev, k_out
        changed = False
        for i in range(n):
            delta[i] = y_new[i] - y_raw[i]
            changed = changed or delta[i] != 0.0
        if k_out < nt and t_out[k_out] < t_new:      # an output inside: the dense output
            if kind == DP8:                          # its extra stages
                if stages_standard(t, y, hs, tableau, nodes, K, S, S + 3, yo,
                                   t + nodes[S + 2] * hs, F, I, W, mp) < S + 3:
                    return RHS_FAILED, t, h, err_prev, k_out
                counters[0] += 3
            pair_dense(kind, y, y_raw, K, hs, coef)
        if pp[0] != 0.0 and changed:                 # FSAL derivative at the projected state
            if rhs_standard(t_new, y_new, K[S - 1], F, I, W, mp) < 0:
                return RHS_FAILED, t_new, h, err_prev, k_out
            counters[0] += 1
        if not _finite(y_new):
            return NOT_FINITE_STATE, t_new, h, err_prev, k_out
        while k_out < nt and t_out[k_out] <= t_new:
            to = t_out[k_out]
            row = k_out - k_base
            if to == t_new:
                _output_row(to, Y, Yd, Lam, row, y_new, F, I, W, mp, nb, lam_off, ydot)
            else:
                pair_interpolate(kind, y, hs, coef, (to - t) / hs, delta, yo)
                if not project_state(to, yo, F, I, W, pp, nb, dx):
                    return NOT_PROJECTED, to, h, err_prev, k_out
                _output_row(to, Y, Yd, Lam, row, yo, F, I, W, mp, nb, lam_off, ydot)
            k_out += 1
        for i in range(n):
            K[0, i] = K[S - 1, i]
            y[i] = y_new[i]
        t = t_new
        steps += 1
        counters[1] += 1
        h = min(hs * fac, max_step)
    for i in range(n):
        K0[i] = K[0, i]
    return OK, t, h, err_prev, k_out


@njit
def rk4_outputs(t, y, F, I, W, mp, pp, t_out, k0, k1, k_base, h, nb, Y, Yd, Lam, lam_off,
                counters):
    """Classic RK4 with step h from (t, y) (in place on y) through the output times
    t_out[k0:k1], landing on each (its states into Y[k - k_base], and vdot, lambda into Yd,
    Lam when they have rows). Returns (status, t)."""
    n = y.size
    ydot = np.empty(n)
    k1v = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    dx = np.zeros(6 * nb)
    for ko in range(k0, k1):
        to = t_out[ko]
        if to > t:
            m = landing_steps(t, to, h)
            t_start = t
            for i in range(1, m + 1):
                t_new = landing_time(t_start, to, h, i)
                hh = t_new - t
                half = 0.5 * hh
                if rhs_standard(t, y, k1v, F, I, W, mp) < 0:
                    return RHS_FAILED, t
                for j in range(n):
                    tmp[j] = y[j] + half * k1v[j]
                if rhs_standard(t + half, tmp, k2, F, I, W, mp) < 0:
                    return RHS_FAILED, t
                for j in range(n):
                    tmp[j] = y[j] + half * k2[j]
                if rhs_standard(t + half, tmp, k3, F, I, W, mp) < 0:
                    return RHS_FAILED, t
                for j in range(n):
                    tmp[j] = y[j] + hh * k3[j]
                if rhs_standard(t + hh, tmp, k4, F, I, W, mp) < 0:
                    return RHS_FAILED, t
                for j in range(n):                   # Eq. (13.14), (13.19)
                    y[j] = y[j] + (hh / 6.0) * (k1v[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
                if not project_state(t_new, y, F, I, W, pp, nb, dx):
                    return NOT_PROJECTED, t_new
                if not _finite(y):
                    return NOT_FINITE_STATE, t_new
                t = t_new
                counters[0] += 4
                counters[1] += 1
        _output_row(to, Y, Yd, Lam, ko - k_base, y, F, I, W, mp, nb, lam_off, ydot)
    return OK, t


@njit
def dopri_run(y0, F, I, W, mp, pp, pair, t0, t_out, rtol, atol, max_step, max_steps, nb, Y,
              Yd, Lam, lam_off, counters):
    """A whole run of the Dormand-Prince pair ``pair`` from (t0, y0) through t_out (outputs
    into Y (nt, n), and vdot, lambda into Yd, Lam when they have rows), at most max_steps
    accepted steps. Returns (status, t)."""
    y = y0.copy()
    K0 = np.empty(y.size)
    code, t, h, err_prev, k_out = dopri_steps(t0, y, K0, 0.0, 1e-4, F, I, W, mp, pp, pair, t0,
                                              t_out,
                                              0, 0, rtol, atol, max_step, max_steps, nb, Y,
                                              Yd, Lam, lam_off, counters)
    if code == OK and t < t_out[-1]:
        return TOO_MANY_STEPS, t
    return code, t
