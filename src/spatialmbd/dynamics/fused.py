"""Whole runs in compiled code over the fused right-hand side of the standard, Baumgarte and
projection methods: the body-coordinate problem of the one compiled adaptive driver, and the
classic RK4 driver.

The Python drivers of :mod:`..integrators` take one step per Python call; for a model whose
right-hand side is fully compiled (``System.fused``) these loops take many steps per call, with
the same arithmetic:

* :func:`dopri_steps`: the body coordinates as a problem (:class:`BodyProblem`) of
  :func:`..integrators.adaptive_driver.rk_steps` -- Dormand-Prince 5(4) or DOP853
  (:mod:`..integrators.pairs`) with the integrator's controller, as
  :class:`..integrators.runge_kutta_adaptive.DormandPrince45` and
  :class:`..integrators.dop853.DormandPrince853` --, the state projected after every
  accepted step and at every output as simulate() does (Euler parameters renormalised; with the
  projection method q and v onto Phi = 0 and D v = nu, and the FSAL derivative re-evaluated);
* :func:`rk4_outputs`: classic RK4 with step h, landing on every output time as
  :class:`..integrators.fixed_step.RungeKutta4` does;
* at every output the state and (optionally) vdot and lambda there (what
  :meth:`..results.Results.from_integration` evaluates), written as the output is reached.

Both drivers are resumable: :func:`dopri_steps` returns after ``max_steps`` accepted steps with
its whole state in its arguments and return values, so a caller can run a long simulation in
slices and stay interruptible (Ctrl-C between slices, progress, streamed chunks) -- the slices
give the step sequence of one uninterrupted call. :func:`..simulate.simulate` uses them for
rk45 / rk4 runs without events, drivers, couplers or budgets; :mod:`..sweep.batch` for its
members.

Status codes (those of :mod:`..integrators.adaptive_driver`): :data:`OK`, :data:`NEED_ROOM`
or a failure (:data:`STATUS_TEXT`); a failed run is rerun by the Python driver in simulate()
(whose least-squares fallbacks may get through a singular S or projection), which produces its
diagnosis -- except a stalled step control (:data:`UNDERFLOW`): simulate() then returns the
outputs reached, diagnosed at the state where the steps stalled.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..integrators.adaptive_driver import (CORRECTS_DENSE, NEED_ROOM, NEW_DERIVATIVE,  # noqa: F401
                                           NOT_FINITE_STATE, NOT_PROJECTED, OK, RHS_FAILED,
                                           SINGULAR_STOP, STATUS_TEXT, TOO_MANY_STEPS,
                                           UNDERFLOW, finite,
                                           register_problem, rk_steps)
from ..integrators.controller import landing_steps, landing_time
from ..jit import njit
from . import system as cs
from .projection_kernels import project
from .singular_guard import GUARD_FACTOR, passes_guard
from .standard import rhs_standard, stages_standard

__all__ = ["OK", "NEED_ROOM", "RHS_FAILED", "UNDERFLOW", "NOT_FINITE_STATE", "TOO_MANY_STEPS",
           "NOT_PROJECTED", "SINGULAR_STOP", "STATUS_TEXT", "BodyProblem", "dopri_steps",
           "rk4_outputs", "project_state", "projection_params", "guarded", "dopri_run"]


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


def projection_params(meth, tolerance=None, length=None) -> np.ndarray:
    """pp of :func:`project_state` for a method: [projects, tolerance, max_iterations,
    mass metric, guard on, guard factor, length, the guard's last ratio] (the compiled drivers are one-step ones;
    tolerance: the run's, :meth:`.projection.Projection.tolerance_for`; default the method's;
    the singular-position guard of :mod:`.singular_guard` is on for a method that follows its
    drift with option singular="stop", given the model's size ``length``)."""
    tol = getattr(meth, "tolerance", 0.0) if tolerance is None else tolerance
    guard = length is not None and guarded(meth)
    return np.array([1.0 if meth.projects else 0.0, float(tol),
                     float(getattr(meth, "max_iterations", 0)),
                     1.0 if getattr(meth, "metric", "mass") in ("mass", "auto") else 0.0,
                     1.0 if guard else 0.0, GUARD_FACTOR, float(length or 1.0), 0.0])


def guarded(meth) -> bool:
    """Whether runs of ``meth`` stop at a singular position (:mod:`.singular_guard`)."""
    return bool(getattr(meth, "follows_drift", False)) and getattr(meth, "singular",
                                                                   "") == "stop"


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


#: the body coordinates y = [q, v, W] as a problem of the compiled driver: the method's
#: packs (F, I, W, mp, pp: :func:`projection_params`), the output window (Y, Yd, Lam, the
#: multipliers' offset lam_off in W) and scratch (ydot (n,), dx (6 nb))
BodyProblem = namedtuple("BodyProblem", ["F", "I", "W", "mp", "pp", "nb", "Y", "Yd", "Lam",
                                         "lam_off", "ydot", "dx"])


@njit(inline="always")
def _body_rhs(p, t, y, out):
    return rhs_standard(t, y, out, p.F, p.I, p.W, p.mp) >= 0


@njit(inline="always")
def _body_stages(p, t, y, hs, tableau, nodes, K, s0, s1, out, t_last):
    return stages_standard(t, y, hs, tableau, nodes, K, s0, s1, out, t_last, p.F, p.I, p.W,
                           p.mp)


@njit(inline="always")
def _body_project(p, t, y):
    if not project_state(t, y, p.F, p.I, p.W, p.pp, p.nb, p.dx):
        return -1
    if not passes_guard(t, y, p.F, p.I, p.W, p.pp[4:8]):
        return -2
    return CORRECTS_DENSE | (NEW_DERIVATIVE if p.pp[0] != 0.0 else 0)


@njit                      # (not inlined: Numba's inliner loses a variable of its branch)
def _body_output(p, t, row, y, interpolated):
    if interpolated and not project_state(t, y, p.F, p.I, p.W, p.pp, p.nb, p.dx):
        return False
    _output_row(t, p.Y, p.Yd, p.Lam, row, y, p.F, p.I, p.W, p.mp, p.nb, p.lam_off, p.ydot)
    return True


register_problem(BodyProblem, _body_rhs, _body_stages, _body_project, _body_output)


@njit
def dopri_steps(t, y, K0, h, err_prev, F, I, W, mp, pp, pair, t0, t_out, k_out, k_base, rtol,
                atol, max_step, max_steps, nb, Y, Yd, Lam, lam_off, counters):
    """Up to ``max_steps`` accepted steps of the embedded pair ``pair``
    (:mod:`..integrators.pairs`: rk45 or dop853) of the body coordinates from (t, y) with FSAL
    derivative K0 and proposed step h (in place on y and K0), every output time t_out[k_out:]
    reached written into Y[k - k_base] (projected as simulate() does) and, when Yd and Lam have
    rows, vdot and lambda there: :func:`..integrators.adaptive_driver.rk_steps` of a
    :class:`BodyProblem`. The first call passes h = 0. Returns (status, t, h, err_prev,
    k_out); status NEED_ROOM: the next step's outputs do not fit in Y (nothing of that step
    kept). counters: (nfev, steps, rejected), accumulated."""
    problem = BodyProblem(F, I, W, mp, pp, nb, Y, Yd, Lam, lam_off, np.empty(y.size),
                          np.zeros(6 * nb))
    return rk_steps(problem, t, y, K0, h, err_prev, pair, t0, t_out, k_out, k_base,
                    Y.shape[0], rtol, atol, max_step, max_steps, counters,
                    np.zeros((0, 1)))


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
                if not passes_guard(t_new, y, F, I, W, pp[4:8]):
                    return SINGULAR_STOP, t_new
                if not finite(y):
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
