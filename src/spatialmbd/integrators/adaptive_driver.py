"""The one compiled adaptive Runge-Kutta driver: embedded pairs as data, any compiled
right-hand side through a *problem*.

:func:`rk_steps` takes up to ``max_steps`` accepted steps of an embedded pair
(:mod:`.pairs`: Dormand-Prince 5(4) or 8(5,3) with FSAL and dense output) with the step-size
rules of :mod:`.controller` (Hairer's starting step, the PI controller, the rejection factor),
exactly the arithmetic of the Python path (:class:`.runge_kutta_adaptive.DormandPrinceStepper`
with :class:`.controllers.PIController`, which call the same compiled rules). What it
integrates is a *problem*: a named tuple of the arrays its hooks need, whose type was
registered with :func:`register_problem` together with four compiled hooks (the compiled
counterpart of :class:`.base.ODEProblem`):

* ``rhs(problem, t, y, out) -> bool``: out = f(t, y); False when the right-hand side failed;
* ``stages(problem, t, y, hs, tableau, nodes, K, s0, s1, out, t_last) -> int``: the stages
  s0 .. s1-1 of a step, out = y + hs sum_j tableau[s, j] K[j], K[s] = f(t + nodes[s] hs, out)
  (t_last for the last one), as ``ODEProblem.stages``: the first stage not completed (s1 when
  all were). One hook call per step instead of one per stage: a call that takes the problem
  costs the reference counts of its arrays, which per stage was measurable (the hooks are
  inlined into the driver for the same reason);
* ``project(problem, t, y) -> int``: the accepted state y mapped in place onto its manifold;
  -1 if that failed, -2 if the run is to stop at this state (:data:`SINGULAR_STOP`), else
  flags: :data:`CORRECTS_DENSE` (the dense output of the step gets the linear correction
  theta (y_proj - y_raw), as :mod:`.driver` does) and :data:`NEW_DERIVATIVE` (the FSAL
  derivative is re-evaluated when the projection changed y);
* ``output(problem, t, row, y, interpolated) -> bool``: record the output at t into row
  ``row`` of the problem's output arrays (``interpolated``: y comes from the dense output,
  not from a step's end); False if that failed (a projection there).

Body coordinates (:mod:`..dynamics.fused`) and joint coordinates (:mod:`..dynamics.recursive`)
are two such problems. Numba resolves the hooks by the problem's type when it compiles the
driver for it (``numba.extending.overload``), so the driver is cached on disk per problem
type as any kernel; without Numba the hooks are looked up by type in Python.

The driver is resumable: it returns its whole state (t, h, err_prev, k_out) with a status, so a
caller runs a long simulation in slices (progress, Ctrl-C between them) with the step sequence
of one uninterrupted call. Status codes: :data:`OK`, :data:`NEED_ROOM` (the next step's
outputs do not fit in the ``rows`` the caller's window holds from output ``k_base`` on;
nothing of that step is kept) or a failure (:data:`STATUS_TEXT`).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import ENABLED, njit
from .controller import (end_step, min_step_size, pi_factor, rejected_factor,
                         start_first_guess, start_step)
from .pairs import DP8, pair_dense, pair_error, pair_interpolate, pair_stages

__all__ = ["OK", "RHS_FAILED", "UNDERFLOW", "NOT_FINITE_STATE", "TOO_MANY_STEPS",
           "NOT_PROJECTED", "NEED_ROOM", "SINGULAR_STOP", "STATUS_TEXT", "CORRECTS_DENSE",
           "NEW_DERIVATIVE",
           "register_problem", "problem_rhs", "problem_stages", "problem_project",
           "problem_output", "rk_start", "rk_steps", "rk_step", "kept_dense", "NO_KEEP",
           "atol_array", "finite"]

#: status codes (OK, or why a run stopped)
OK, RHS_FAILED, UNDERFLOW, NOT_FINITE_STATE, TOO_MANY_STEPS, NOT_PROJECTED = 0, 1, 2, 3, 4, 5
#: the next accepted step's outputs do not fit in the window (not a failure: the caller makes
#: room and calls again; the step is retaken, with the same result)
NEED_ROOM = 6
#: a problem's project hook returned -2: the run reached a state it must not go beyond (the
#: singular-position guard of :mod:`...dynamics.singular_guard`); (t, y) are that state
SINGULAR_STOP = 7
STATUS_TEXT = {RHS_FAILED: "the right-hand side failed (singular constraint Jacobian or "
                           "non-finite accelerations)",
               UNDERFLOW: "step size underflow (error test failed repeatedly)",
               NOT_FINITE_STATE: "the state became non-finite",
               TOO_MANY_STEPS: "more steps than max_steps",
               NOT_PROJECTED: "the projection onto the constraints failed (D D^T singular or "
                              "Newton not converged)",
               SINGULAR_STOP: "stopped at a singular position: the constraint drift decides "
                              "the branch there"}

#: flags of a problem's ``project`` hook
CORRECTS_DENSE, NEW_DERIVATIVE = 1, 2


# ----------------------------------------------------------------------------- problems
_HOOKS: dict = {}


def problem_rhs(problem, t, y, out):
    """out = f(t, y) of the problem; False when it failed."""
    return _HOOKS[type(problem)][0](problem, t, y, out)


def problem_stages(problem, t, y, hs, tableau, nodes, K, s0, s1, out, t_last):
    """The stages s0 .. s1-1 of a step; the first one not completed (s1: all were)."""
    return _HOOKS[type(problem)][1](problem, t, y, hs, tableau, nodes, K, s0, s1, out, t_last)


def problem_project(problem, t, y):
    """The accepted state projected in place; -1 (failed), -2 (stop here: a guard) or the
    flags."""
    return _HOOKS[type(problem)][2](problem, t, y)


def problem_output(problem, t, row, y, interpolated):
    """The output at t recorded into row ``row``; False when that failed."""
    return _HOOKS[type(problem)][3](problem, t, row, y, interpolated)


def register_problem(cls, rhs, stages, project, output) -> None:
    """Make the named-tuple class ``cls`` a problem of :func:`rk_steps`, with its compiled
    hooks (module docstring)."""
    _HOOKS[cls] = (rhs, stages, project, output)
    if not ENABLED:
        return
    from numba.core import types
    from numba.extending import overload

    def mine(problem):
        return isinstance(problem, types.BaseNamedTuple) and problem.instance_class is cls

    @overload(problem_rhs, inline="always")
    def _rhs(problem, t, y, out):
        if mine(problem):
            return lambda problem, t, y, out: rhs(problem, t, y, out)

    @overload(problem_stages, inline="always")
    def _stages(problem, t, y, hs, tableau, nodes, K, s0, s1, out, t_last):
        if mine(problem):
            return (lambda problem, t, y, hs, tableau, nodes, K, s0, s1, out, t_last:
                    stages(problem, t, y, hs, tableau, nodes, K, s0, s1, out, t_last))

    @overload(problem_project, inline="always")
    def _project(problem, t, y):
        if mine(problem):
            return lambda problem, t, y: project(problem, t, y)

    @overload(problem_output, inline="always")
    def _output(problem, t, row, y, interpolated):
        if mine(problem):
            return lambda problem, t, row, y, interpolated: output(problem, t, row, y,
                                                                   interpolated)


# ----------------------------------------------------------------------------- the driver
@njit
def finite(y):
    """Whether every entry of y is finite (one sum of squares)."""
    s = 0.0
    for i in range(y.size):
        s += y[i] * y[i]
    return math.isfinite(s)


@njit
def _rms(x, scale):
    """sqrt(mean((x / scale)^2))."""
    acc = 0.0
    for i in range(x.size):
        e = x[i] / scale[i]
        acc += e * e
    return math.sqrt(acc / x.size)


@njit
def rk_start(problem, t, y, K0, k_inv, rtol, atol, max_step, span, counters):
    """K0 = f(t, y) and Hairer's starting step for an error behaving like h^k (k_inv = 1/k;
    the rules :func:`.controller.start_first_guess` and :func:`.controller.start_step`, as
    :func:`.controller.initial_step` applies them on the Python path; atol (n,)). Returns
    (status, h); counters[0] counts f."""
    n = y.size
    if not problem_rhs(problem, t, y, K0):
        return RHS_FAILED, 0.0
    counters[0] += 1
    scale = np.empty(n)
    for i in range(n):
        scale[i] = atol[i] + abs(y[i]) * rtol
    d1 = _rms(K0, scale)
    h0 = start_first_guess(_rms(y, scale), d1, max_step, span)
    y1 = np.empty(n)
    for i in range(n):
        y1[i] = y[i] + h0 * K0[i]
    f1 = np.empty(n)
    if not problem_rhs(problem, t + h0, y1, f1):
        return RHS_FAILED, 0.0
    counters[0] += 1
    for i in range(n):
        y1[i] = f1[i] - K0[i]
    return OK, start_step(h0, d1, _rms(y1, scale) / h0, k_inv, max_step, span)


#: rk_steps' ``keep`` from Python when the caller needs no step's dense output (compiled
#: callers pass ``np.zeros((0, 1))``: a global array is read-only there)
NO_KEEP = np.zeros((0, 1))


def atol_array(atol, n):
    """atol as an (n,) array: a number repeated, or the per-component array itself."""
    return np.full(n, float(atol)) if np.ndim(atol) == 0 else np.asarray(atol, dtype=float)


if ENABLED:
    from numba.core import types as _types
    from numba.extending import overload as _overload

    @_overload(atol_array, inline="always")
    def _atol_array(atol, n):
        if isinstance(atol, _types.Number):
            return lambda atol, n: np.full(n, float(atol))
        return lambda atol, n: atol


@njit(inline="always")
def rk_attempt(problem, kind, tableau, nodes, t, y, K, hs, t_new, y_new):
    """The stages 1 .. S-1 of a step of hs from (t, y) with K[0] = f(t, y): y_new = the
    step's end, K[S-1] = f(t_new, y_new). The first stage not completed (S: all were; < 0: the
    problem asks the driver to stop)."""
    return problem_stages(problem, t, y, hs, tableau, nodes, K, 1, pair_stages(kind), y_new,
                          t_new)


@njit(inline="always")
def rk_dense(problem, kind, tableau, nodes, t, y, y_raw, K, hs, coef, counters):
    """coef: the dense output of the step from (t, y) to the unprojected y_raw (DP8: its three
    extra stages first, counted in counters[0]); False when the right-hand side failed."""
    if kind == DP8:
        S = pair_stages(kind)
        yo = np.empty(y.size)
        if problem_stages(problem, t, y, hs, tableau, nodes, K, S, S + 3, yo,
                          t + nodes[S + 2] * hs) < S + 3:
            return False
        counters[0] += 3
    pair_dense(kind, y, y_raw, K, hs, coef)
    return True


@njit
def rk_step(problem, pair, t, y, K, t_new, y_new, counters):
    """One step from (t, y) to t_new without error control (K (R, n), K[0] = f(t, y) on
    entry): y_new and K[1 .. S-1]; the first stage not completed (S: all were; < 0: the
    problem asks to stop). counters[0] counts f."""
    kind, tableau, nodes, _ = pair
    done = rk_attempt(problem, kind, tableau, nodes, t, y, K, t_new - t, t_new, y_new)
    counters[0] += max(done, 1) - 1
    return done


@njit
def kept_dense(problem, pair, t, keep, coef, counters):
    """The dense output's coefficients coef (7, n) of the step that rk_steps wrote into
    ``keep`` from t (DP8: its extra stages unless already evaluated); False if f failed."""
    kind, tableau, nodes, _ = pair
    R = tableau.shape[0]
    if kind == DP8 and keep[R + 4, 0] != 0.0:
        pair_dense(kind, keep[R], keep[R + 1], keep, keep[R + 3, 0], coef)
        return True
    return rk_dense(problem, kind, tableau, nodes, t, keep[R], keep[R + 1], keep,
                    keep[R + 3, 0], coef, counters)


@njit
def rk_steps(problem, t, y, K0, h, err_prev, pair, t0, t_out, k_out, k_base, rows, rtol, atol,
             max_step, max_steps, counters, keep):
    """Up to ``max_steps`` accepted steps of the embedded pair ``pair`` (:mod:`.pairs`) of
    ``problem`` from (t, y) with FSAL derivative K0 and proposed step h (in place on y and
    K0); every output time t_out[k_out:] reached is handed to the problem's output hook as row
    k - k_base (at most ``rows`` rows). The first call passes h = 0: the output at t (if
    t_out[k_out] == t), K0 = f(t, y) and the starting step come first. Returns (status, t, h,
    err_prev, k_out): call again with them to continue (t == t_out[-1]: done). counters:
    (nfev, steps, rejected), accumulated; a step retaken after NEED_ROOM is counted once.
    atol: a number or (n,) per component; ``pair``'s control row holds the controller's
    factors and the minimum step (:mod:`.pairs`). keep: :data:`NO_KEEP`, or a (R + 5, n)
    array (R = the tableau's rows) into which every accepted step writes what its dense
    output needs (:func:`kept_step`): the caller's events are located on it."""
    kind, tableau, nodes, ctrl = pair
    k_inv, beta, safety, min_factor, max_factor = ctrl[0], ctrl[1], ctrl[2], ctrl[3], ctrl[4]
    S = pair_stages(kind)
    n = y.size
    t_end = t_out[-1]
    span = t_end - t0
    nt = t_out.size
    atol_v = atol_array(atol, n)
    if h <= 0.0:                                     # the first call of a run
        if k_out < nt and t_out[k_out] == t:
            if k_out - k_base >= rows:
                return NEED_ROOM, t, h, err_prev, k_out
            problem_output(problem, t, k_out - k_base, y, False)
            k_out += 1
        if t >= t_end:
            return OK, t, h, err_prev, k_out
        code, h = rk_start(problem, t, y, K0, ctrl[5], rtol, atol_v, max_step, span, counters)
        if code != OK:
            return code, t, h, err_prev, k_out
    K = np.empty((tableau.shape[0], n))
    for i in range(n):
        K[0, i] = K0[i]
    y_new = np.empty(n)
    y_raw = np.empty(n)
    delta = np.zeros(n)
    no_delta = np.zeros(0)
    yo = np.empty(n)
    coef = np.empty((7, n))
    alpha = k_inv - 0.75 * beta
    after_reject = False
    steps = 0
    while t < t_end and steps < max_steps:
        h_min = min_step_size(t, span, ctrl[6])
        h_start, c0, c2 = h, counters[0], counters[2]
        while True:                                  # attempts until one passes the test
            hs = end_step(t, h, t_end)
            if hs < h_min:
                return UNDERFLOW, t, h, err_prev, k_out
            t_new = t_end if hs == t_end - t else t + hs
            done = rk_attempt(problem, kind, tableau, nodes, t, y, K, hs, t_new, y_new)
            if done < 0:                             # the problem asks to stop (an exception)
                return RHS_FAILED, t, h, err_prev, k_out
            counters[0] += S - 1
            err = pair_error(kind, y, y_new, K, hs, atol_v, rtol) if done == S else math.inf
            if err <= 1.0:
                break
            counters[2] += 1
            h = hs * rejected_factor(err, k_inv, safety, min_factor)
            after_reject = True
        # accepted
        k_last = k_out
        while k_last < nt and t_out[k_last] <= t_new:
            k_last += 1
        if k_last - k_base > rows:                   # no room for its outputs: retake later
            counters[0], counters[2] = c0, c2
            for i in range(n):
                K0[i] = K[0, i]
            return NEED_ROOM, t, h_start, err_prev, k_out
        fac, err_prev = pi_factor(err, err_prev, alpha, beta, safety, min_factor, max_factor,
                                  after_reject)
        after_reject = False
        for i in range(n):
            y_raw[i] = y_new[i]
        flags = problem_project(problem, t_new, y_new)
        if flags == -2:              # a guard stopped the run at this state: (t, y) <- it
            for i in range(n):
                y[i] = y_new[i]
            return SINGULAR_STOP, t_new, h, err_prev, k_out
        if flags < 0:
            return NOT_PROJECTED, t_new, h, err_prev, k_out
        changed = False
        if flags != 0:
            for i in range(n):
                delta[i] = y_new[i] - y_raw[i]
                changed = changed or delta[i] != 0.0
        dense = k_out < nt and t_out[k_out] < t_new  # an output inside: the dense output
        if dense:
            if not rk_dense(problem, kind, tableau, nodes, t, y, y_raw, K, hs, coef, counters):
                return RHS_FAILED, t, h, err_prev, k_out
        if keep.shape[0]:                            # the step, for the caller's dense output
            R = tableau.shape[0]
            for i in range(n):
                for j in range(R):
                    keep[j, i] = K[j, i]
                keep[R, i] = y[i]
                keep[R + 1, i] = y_raw[i]
                keep[R + 2, i] = delta[i] if flags & CORRECTS_DENSE else 0.0
            keep[R + 3, 0] = hs
            keep[R + 4, 0] = 1.0 if dense else 0.0   # DP8: the extra stages are in K
        if flags & NEW_DERIVATIVE and changed:       # FSAL derivative at the projected state
            if not problem_rhs(problem, t_new, y_new, K[S - 1]):
                return RHS_FAILED, t_new, h, err_prev, k_out
            counters[0] += 1
        if not finite(y_new):
            return NOT_FINITE_STATE, t_new, h, err_prev, k_out
        correction = delta if flags & CORRECTS_DENSE else no_delta
        while k_out < nt and t_out[k_out] <= t_new:
            to = t_out[k_out]
            if to == t_new:
                written = problem_output(problem, to, k_out - k_base, y_new, False)
            else:
                pair_interpolate(kind, y, hs, coef, (to - t) / hs, correction, yo)
                written = problem_output(problem, to, k_out - k_base, yo, True)
            if not written:
                return NOT_PROJECTED, to, h, err_prev, k_out
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
