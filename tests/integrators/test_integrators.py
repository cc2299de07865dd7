"""Tests of the time integrators of text ch. 13 (spatialmbd.integrators)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from spatialmbd.errors import SimulationError, SingularMatrixError
from spatialmbd.integrators import INTEGRATORS, Counters, ODEProblem, get_integrator
from spatialmbd.integrators.controller import resample_matrix
from spatialmbd.integrators.runge_kutta_adaptive import DOPRI_DENSE, DOPRI_WEIGHTS, dopri_dense

OWN = ["euler", "heun", "rk4", "abm4", "bdf4", "rk45", "dop853"]
SCIPY = ["scipy-rk45", "scipy-dop853", "scipy-radau", "scipy-bdf", "scipy-lsoda"]
FIXED_OPTS = {"euler": dict(step=1e-3), "heun": dict(step=1e-3), "rk4": dict(step=1e-2)}


def opts_for(name):
    return dict(FIXED_OPTS.get(name, {}))


# --------------------------------------------------------------------------- test problems
class Counted:
    """Wrap a right-hand side and count its calls (to check the nfev counter)."""

    def __init__(self, fun):
        self.fun = fun
        self.calls = 0

    def __call__(self, t, y):
        self.calls += 1
        return self.fun(t, y)


def limit_cycle(t, y):
    """Nonlinear 2-D ODE with the attracting unit circle; r' = r (1 - r^2), theta' = 1."""
    r2 = y[0] * y[0] + y[1] * y[1]
    return np.array([-y[1] + y[0] * (1.0 - r2), y[0] + y[1] * (1.0 - r2)])


def limit_cycle_exact(t, r0=0.5):
    t = np.asarray(t, dtype=float)
    r = 1.0 / np.sqrt(1.0 + (1.0 / r0 ** 2 - 1.0) * np.exp(-2.0 * t))
    return np.stack([r * np.cos(t), r * np.sin(t)], axis=-1)


Y0_LC = np.array([0.5, 0.0])

# stiff linear problem y' = A (y - g(t)) + g'(t), eigenvalues of A: -1 and -1e4
_V = np.array([[1.0, 0.5], [0.3, 1.0]])
A_STIFF = _V @ np.diag([-1.0, -1.0e4]) @ np.linalg.inv(_V)
_W, _Vinv = np.array([-1.0, -1.0e4]), np.linalg.inv(_V)
V_STIFF = np.array([1.0, -2.0])      # initial deviation: excites both the slow and fast modes


def stiff_rhs(t, y):
    return A_STIFF @ (y - np.array([math.sin(t), math.cos(t)])) + np.array([math.cos(t),
                                                                            -math.sin(t)])


def stiff_exact(t):
    return (np.array([math.sin(t), math.cos(t)])
            + _V @ (np.exp(_W * t) * (_Vinv @ V_STIFF)))


# --------------------------------------------------------------------------- order of convergence
ORDER_CASES = [
    ("euler", 1, [0.01, 0.005, 0.0025, 0.00125], {}),
    ("heun", 2, [0.04, 0.02, 0.01, 0.005], {}),
    ("rk4", 4, [0.1, 0.05, 0.025, 0.0125], {}),
    ("abm4", 4, [0.05, 0.025, 0.0125, 0.00625], dict(adaptive=False)),
    ("bdf4", 4, [0.05, 0.025, 0.0125, 0.00625], dict(fixed_step=True, rtol=1e-12, atol=1e-12)),
]


@pytest.mark.parametrize("name, order, steps, opts", ORDER_CASES, ids=[c[0] for c in ORDER_CASES])
def test_order_of_convergence(name, order, steps, opts):
    """Log-log slope of the global error at t_end vs h equals the order within 0.3."""
    t_end = 2.0
    exact = limit_cycle_exact(t_end)
    errors = []
    for h in steps:
        res = get_integrator(name, step=h, **opts).integrate(ODEProblem(limit_cycle), 0.0, Y0_LC,
                                                             [t_end])
        assert res.success, res.message
        assert res.counters.steps == pytest.approx(t_end / h, abs=1)   # really constant h
        errors.append(np.linalg.norm(res.y[-1] - exact))
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(slope - order) < 0.3, f"{name}: slope {slope:.3f}, errors {errors}"
    # every halving of h divides the error by about 2^order (not just on average)
    ratios = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(ratios - order) < 0.5), ratios


def test_fixed_step_lands_on_outputs():
    """Steps of h, shortened only to land on each output time; outputs are step points."""
    res = get_integrator("rk4", step=0.03).integrate(ODEProblem(limit_cycle), 0.0, Y0_LC,
                                                     [0.0, 0.1, 0.2, 0.25])
    assert res.success
    assert res.counters.steps == 4 + 4 + 2
    assert res.counters.nfev == 4 * res.counters.steps
    np.testing.assert_array_equal(res.y[0], Y0_LC)
    np.testing.assert_allclose(res.y, limit_cycle_exact(res.t), atol=1e-7)


def test_resample_matrix_reproduces_cubics():
    """History re-spacing is exact for polynomials of degree m - 1."""
    p = np.poly1d([0.3, -1.2, 0.7, 2.0])
    r = 0.37
    hist = p(-np.arange(4.0))
    np.testing.assert_allclose(resample_matrix(4, r) @ hist, p(-r * np.arange(4.0)), rtol=1e-12)
    np.testing.assert_allclose(resample_matrix(4, 1.0), np.eye(4), atol=1e-15)


# --------------------------------------------------------------------------- rk45
def test_rk45_error_scales_with_tolerance():
    t_end = 10.0
    tols = [1e-4, 1e-6, 1e-8]
    errors, steps = [], []
    for tol in tols:
        res = get_integrator("rk45", rtol=tol, atol=tol).integrate(ODEProblem(limit_cycle), 0.0,
                                                                   Y0_LC, [t_end])
        assert res.success
        errors.append(np.abs(res.y[-1] - limit_cycle_exact(t_end)).max())
        steps.append(res.counters.steps)
        assert errors[-1] < 100 * tol
    slope = np.polyfit(np.log(tols), np.log(errors), 1)[0]
    assert 0.8 < slope < 1.2, (slope, errors)
    assert steps[0] < steps[1] < steps[2]


def test_rk45_dense_output_between_steps():
    tol = 1e-8
    t_eval = np.linspace(0.0, 10.0, 501)
    res = get_integrator("rk45", rtol=tol, atol=tol).integrate(ODEProblem(limit_cycle), 0.0,
                                                               Y0_LC, t_eval)
    assert res.success
    assert res.counters.steps < len(t_eval) / 3        # most outputs are interpolated
    err = np.abs(res.y - limit_cycle_exact(t_eval)).max(axis=1)
    assert err.max() < 30 * tol
    # the interpolated outputs are as accurate as the error already made at the step ends
    coarse = get_integrator("rk45", rtol=tol, atol=tol).integrate(
        ODEProblem(limit_cycle), 0.0, Y0_LC, [10.0])
    assert err.max() < 3 * np.abs(coarse.y[-1] - limit_cycle_exact(10.0)).max()


def test_dopri_continuous_extension_hits_step_ends():
    """Shampine's extension: row sums are b, theta = 0 and 1 give y_n and y_(n+1)."""
    np.testing.assert_allclose(DOPRI_DENSE.sum(axis=1), np.append(DOPRI_WEIGHTS, 0.0), atol=1e-15)
    rng = np.random.default_rng(1)
    K = rng.normal(size=(7, 3))
    y, h = rng.normal(size=3), 0.37
    np.testing.assert_array_equal(dopri_dense(y, h, K, 0.0), y)
    np.testing.assert_allclose(dopri_dense(y, h, K, 1.0), y + h * DOPRI_WEIGHTS @ K[:6],
                               rtol=0, atol=1e-15)


@pytest.mark.parametrize("tol", [1e-4, 1e-6, 1e-8])
def test_rk45_step_count_close_to_scipy(tol):
    fun = Counted(limit_cycle)
    res = get_integrator("rk45", rtol=tol, atol=tol).integrate(ODEProblem(fun), 0.0, Y0_LC,
                                                               [10.0])
    ref = solve_ivp(limit_cycle, (0.0, 10.0), Y0_LC, method="RK45", rtol=tol, atol=tol)
    ref_steps = len(ref.t) - 1
    assert abs(res.counters.steps - ref_steps) <= 0.25 * ref_steps + 2, (res.counters, ref_steps)
    assert res.counters.nfev == fun.calls
    # FSAL: 6 evaluations per attempted step, + f(t0) + 1 for the initial step selection
    assert fun.calls == 2 + 6 * (res.counters.steps + res.counters.rejected)


def test_rk45_per_component_atol_and_max_step():
    atol = np.array([1e-10, 1e-6])
    res = get_integrator("rk45", rtol=1e-6, atol=atol, max_step=0.05).integrate(
        ODEProblem(limit_cycle), 0.0, Y0_LC, [1.0])
    assert res.success and res.counters.steps >= 20
    with pytest.raises(ValueError, match="atol"):
        get_integrator("rk45", atol=[1e-6, 1e-6, 1e-6]).integrate(ODEProblem(limit_cycle), 0.0,
                                                                  Y0_LC, [1.0])


# --------------------------------------------------------------------------- dop853
def _one_dop853_step(h):
    """(y_new, dense output at the step's middle) of one DOP853 step of h from the exact state
    at t = 0.3 of the limit cycle (the compiled driver's step and dense output)."""
    from spatialmbd.integrators.adaptive_driver import kept_dense, rk_step
    from spatialmbd.integrators.adaptive_run import CallbackProblem, _Run, _RUNS
    from spatialmbd.integrators.pairs import PAIR_DP8, pair_interpolate
    t0 = 0.3
    y0 = limit_cycle_exact(t0)
    _RUNS[-1] = _Run(ODEProblem(limit_cycle))
    try:
        p, cnt = CallbackProblem(-1), np.zeros(3, dtype=np.int64)
        R = PAIR_DP8[1].shape[0]
        keep = np.zeros((R + 5, 2))
        keep[0] = limit_cycle(t0, y0)
        y_new = np.empty(2)
        assert rk_step(p, PAIR_DP8, t0, y0, keep, t0 + h, y_new, cnt) == 13
        keep[R], keep[R + 1], keep[R + 3, 0] = y0, y_new, h
        coef = np.empty((7, 2))
        assert kept_dense(p, PAIR_DP8, t0, keep, coef, cnt)
        assert cnt[0] == 12 + 3                       # the step's stages, the dense output's
        mid = np.empty(2)
        pair_interpolate(PAIR_DP8[0], y0, h, coef, 0.5, keep[R + 2], mid)
    finally:
        del _RUNS[-1]
    return y_new, mid


def test_dop853_step_and_dense_output_orders():
    """Local error of a step ~ h^9 (order 8), of the dense output ~ h^8 (order 7)."""
    hs = np.array([0.4, 0.2, 0.1])
    step_err, dense_err = [], []
    for h in hs:
        y_new, y_mid = _one_dop853_step(h)
        step_err.append(np.abs(y_new - limit_cycle_exact(0.3 + h)).max())
        dense_err.append(np.abs(y_mid - limit_cycle_exact(0.3 + 0.5 * h)).max())
    step_slope = np.polyfit(np.log(hs), np.log(step_err), 1)[0]
    dense_slope = np.polyfit(np.log(hs), np.log(dense_err), 1)[0]
    assert 8.5 < step_slope < 10.0, (step_slope, step_err)
    assert 7.5 < dense_slope < 9.5, (dense_slope, dense_err)


def test_dop853_against_scipy_and_rk45_at_tight_tolerance():
    """About SciPy's DOP853 step count (its own controller differs slightly: factors 0.2..10),
    every evaluation counted, the error following the tolerance, and far fewer evaluations
    than rk45 at rtol 1e-10."""
    t_end = 10.0
    for tol in (1e-6, 1e-8, 1e-10):
        fun = Counted(limit_cycle)
        res = get_integrator("dop853", rtol=tol, atol=tol).integrate(ODEProblem(fun), 0.0,
                                                                     Y0_LC, [t_end])
        assert res.success, res.message
        ref = solve_ivp(limit_cycle, (0.0, t_end), Y0_LC, method="DOP853", rtol=tol, atol=tol)
        ref_steps = len(ref.t) - 1
        assert abs(res.counters.steps - ref_steps) <= 0.25 * ref_steps + 2, (tol, res.counters,
                                                                             ref_steps)
        assert res.counters.nfev == fun.calls
        # FSAL: 12 evaluations per attempted step, + f(t0) + 1 for the initial step
        assert fun.calls == 2 + 12 * (res.counters.steps + res.counters.rejected)
        assert np.abs(res.y[-1] - limit_cycle_exact(t_end)).max() < 100 * tol
    rk45 = get_integrator("rk45", rtol=1e-10, atol=1e-10).integrate(ODEProblem(limit_cycle),
                                                                    0.0, Y0_LC, [t_end])
    assert res.counters.nfev < rk45.counters.nfev / 2.5, (res.counters, rk45.counters)


def test_dop853_dense_output_costs_three_stages_per_step_with_outputs():
    tol = 1e-9
    t_eval = np.linspace(0.0, 10.0, 501)
    fun = Counted(limit_cycle)
    res = get_integrator("dop853", rtol=tol, atol=tol).integrate(ODEProblem(fun), 0.0, Y0_LC,
                                                                 t_eval)
    assert res.success and res.counters.nfev == fun.calls
    assert res.counters.steps < len(t_eval) / 5          # most outputs are interpolated
    # every step holds outputs here: 12 + 3 evaluations per accepted step
    assert fun.calls == 2 + 12 * (res.counters.steps + res.counters.rejected) \
        + 3 * res.counters.steps
    # the interpolated outputs as accurate as the step ends (the global error peaks near
    # t = 2 on this problem, 3.6e-9, then decays onto the attracting circle)
    assert np.abs(res.y - limit_cycle_exact(t_eval)).max() < 10 * tol


# --------------------------------------------------------------------------- multistep, adaptive
@pytest.mark.parametrize("name", ["abm4", "bdf4"])
def test_adaptive_multistep_accuracy_and_dense_output(name):
    t_eval = np.linspace(0.0, 5.0, 101)
    errs = []
    for tol in (1e-5, 1e-8):
        fun = Counted(limit_cycle)
        res = get_integrator(name, rtol=tol, atol=tol).integrate(ODEProblem(fun), 0.0, Y0_LC,
                                                                 t_eval)
        assert res.success, res.message
        assert res.counters.nfev == fun.calls
        errs.append(np.abs(res.y - limit_cycle_exact(t_eval)).max())
        assert errs[-1] < 300 * tol, (name, tol, errs[-1], res.counters)
    assert errs[1] < errs[0] / 100


def test_abm4_pece_costs_two_evaluations_per_step():
    fun = Counted(limit_cycle)
    res = get_integrator("abm4", step=0.01, fixed_step=True).integrate(ODEProblem(fun), 0.0,
                                                                       Y0_LC, [1.0])
    # f(t0), 3 RK4 start-up steps (4 evaluations each), then PECE (2 evaluations per step)
    assert res.counters.steps == 100
    assert fun.calls == res.counters.nfev == 1 + 3 * 4 + 2 * 97


# --------------------------------------------------------------------------- stiff problem
def test_bdf4_stiff_fixed_step_stable_and_accurate():
    t_eval = np.linspace(0.0, 2.0, 21)
    h = 0.01                     # h |lambda_max| = 100, far beyond explicit stability (~2.8)
    fun = Counted(stiff_rhs)
    res = get_integrator("bdf4", step=h, fixed_step=True).integrate(ODEProblem(fun), 0.0,
                                                                    stiff_exact(0.0), t_eval)
    assert res.success, res.message
    exact = np.array([stiff_exact(t) for t in t_eval])
    assert np.abs(res.y - exact).max() < 1e-6
    c = res.counters
    assert c.steps == 200 and c.nfev == fun.calls
    assert c.njev <= 2 and c.nlu <= 4          # Jacobian and LU reused across steps
    assert c.nfev < 3 * c.steps
    # the same step makes the explicit RK4 blow up: the test problem really is stiff
    rk = get_integrator("rk4", step=h).integrate(ODEProblem(stiff_rhs), 0.0, stiff_exact(0.0),
                                                 t_eval)
    assert rk.status == "failed" and "non-finite" in rk.message


def test_bdf4_stiff_adaptive_with_analytic_jacobian():
    t_eval = np.linspace(0.0, 2.0, 21)
    problem = ODEProblem(stiff_rhs, jac=lambda t, y: A_STIFF)
    res = get_integrator("bdf4", rtol=1e-6, atol=1e-8).integrate(problem, 0.0, stiff_exact(0.0),
                                                                 t_eval)
    assert res.success, res.message
    exact = np.array([stiff_exact(t) for t in t_eval])
    assert np.abs(res.y - exact).max() < 1e-4
    assert res.counters.steps < 400                 # rk45 needs ~6000 steps here
    assert res.counters.njev <= 3


def test_bdf4_beats_rk45_on_a_stiff_problem_in_evaluations():
    """Finite-difference Jacobian (no jac given): still far fewer evaluations than rk45, whose
    step is bounded by stability (h |lambda| < ~3.3), at the same accuracy."""
    t_eval = np.linspace(0.0, 2.0, 21)
    exact = np.array([stiff_exact(t) for t in t_eval])
    out = {}
    for name in ("bdf4", "rk45"):
        fun = Counted(stiff_rhs)
        res = get_integrator(name, rtol=1e-6, atol=1e-8).integrate(
            ODEProblem(fun), 0.0, stiff_exact(0.0), t_eval)
        assert res.success, res.message
        assert res.counters.nfev == fun.calls
        assert np.abs(res.y - exact).max() < 1e-4, name
        out[name] = res.counters
    assert out["bdf4"].nfev * 10 < out["rk45"].nfev, out
    assert out["bdf4"].rejected < 0.2 * out["bdf4"].steps, out["bdf4"]


def test_bdf4_error_follows_the_tolerance_on_the_flyball_governor():
    """The stiff flyball governor (8e5 N/m springs, 4e4 N s/m dampers, whose directions turn
    with the shaft) over a grid of 11 tolerances from 3e-3 to 1e-5: the position error against
    a tight reference stays within 10 rtol at every one (measured 0.4..3.5 rtol), and no
    tolerance crawls (under 200 steps for 1 s; 4,338 steps once at rtol 1e-3 with a stale
    Jacobian). Physics, not a step count that round-off can flip: the step counts themselves
    are not monotone in rtol (see docs/integrators.md)."""
    from spatialmbd import models
    from spatialmbd.simulate import simulate
    model = models.flyball_governor().compile()
    ref = simulate(model, 1.0, output_step=0.1, method="recursive", rtol=1e-11, atol=1e-13)
    for rtol in (3e-3, 2e-3, 1e-3, 5e-4, 3e-4, 2e-4, 1e-4, 5e-5, 3e-5, 2e-5, 1e-5):
        res = simulate(model, 1.0, output_step=0.1, method="projection", integrator="bdf4",
                       rtol=rtol, atol=rtol * 1e-2)
        assert res.success, res.message
        error = np.abs(res.q[:, :, :3] - ref.q[:, :, :3]).max()
        assert error < 10 * rtol, (rtol, error)
        assert res.counters["steps"] < 200, (rtol, res.counters)


def test_bdf4_newton_failure_raises_with_time():
    """y' = y^2 blows up at t = 1: the implicit equation loses its solution before that."""
    res = get_integrator("bdf4", step=0.1, fixed_step=True).integrate(
        ODEProblem(lambda t, y: y * y), 0.0, [1.0], np.linspace(0.0, 2.0, 21))
    assert res.status == "failed"
    assert "Newton" in res.message and res.t_fail < 1.0
    assert f"t = {res.t_fail:.6g} s" in res.message
    assert len(res.t) >= 5


# --------------------------------------------------------------------------- projection hook
def _rotation(t, y):
    return np.array([-y[1], y[0]])


def _normalise(calls):
    def project(t, y):
        calls.append(t)
        return y / np.linalg.norm(y)
    return project


@pytest.mark.parametrize("name", OWN + SCIPY)
def test_projection_keeps_outputs_on_the_circle(name):
    calls = []
    t_eval = np.linspace(0.0, 3.0, 31)
    fun = Counted(_rotation)
    opts = opts_for(name)
    if name in ("euler", "heun"):
        opts = dict(step=0.01)
    res = get_integrator(name, **opts).integrate(ODEProblem(fun, project=_normalise(calls)),
                                                 0.0, [1.0, 0.0], t_eval)
    assert res.success, res.message
    np.testing.assert_allclose(np.linalg.norm(res.y, axis=1), 1.0, rtol=0, atol=1e-13)
    assert len(calls) >= len(t_eval)
    assert res.counters.nfev == fun.calls
    tol = 0.02 if name == "euler" else 1e-3
    np.testing.assert_allclose(res.y[:, 0], np.cos(t_eval), atol=tol)
    if name in OWN:
        assert len(calls) >= res.counters.steps        # applied to every accepted step


def test_without_projection_euler_drifts_off_the_circle():
    res = get_integrator("euler", step=0.01).integrate(ODEProblem(_rotation), 0.0, [1.0, 0.0],
                                                       [3.0])
    assert np.linalg.norm(res.y[-1]) - 1.0 > 1e-2


# --------------------------------------------------------------------------- failures
def _raises_at_half(t, y):
    if t >= 0.5:
        raise SingularMatrixError(f"mass matrix singular (raised at {t})")
    return np.array([-y[1], y[0]])


def _nan_after_half(t, y):
    if t >= 0.5:
        return np.array([np.nan, 0.0])
    return np.array([-y[1], y[0]])


@pytest.mark.parametrize("name", OWN + SCIPY)
@pytest.mark.parametrize("rhs", [_raises_at_half, _nan_after_half], ids=["raises", "nan"])
def test_failure_returns_partial_result(name, rhs):
    t_eval = np.linspace(0.0, 1.0, 11)
    res = get_integrator(name, **opts_for(name)).integrate(ODEProblem(rhs), 0.0, [1.0, 0.0],
                                                           t_eval)
    assert res.status == "failed" and not res.success
    assert res.t_fail is not None and f"t = {res.t_fail:.6g} s" in res.message
    if rhs is _raises_at_half:
        assert "mass matrix singular" in res.message
        assert res.t_fail <= 0.5 + 1e-12
    else:
        assert "finite" in res.message
        assert res.t_fail <= 0.7
    assert 1 <= len(res.t) <= 6
    np.testing.assert_array_equal(res.t, t_eval[:len(res.t)])
    assert np.all(res.t <= 0.5 + 1e-12)
    np.testing.assert_allclose(res.y[:, 0], np.cos(res.t), atol=1e-3)


@pytest.mark.parametrize("name", ["rk45", "abm4", "bdf4", "scipy-rk45"])
def test_step_size_underflow_at_singularity(name):
    res = get_integrator(name).integrate(ODEProblem(lambda t, y: y * y), 0.0, [1.0],
                                         [0.5, 1.5, 2.0])
    assert res.status == "failed"
    assert 0.99 < res.t_fail <= 1.0 + 1e-6
    assert "step size" in res.message
    assert len(res.t) == 1 and res.y[0, 0] == pytest.approx(2.0, rel=1e-4)


def test_underflow_error_is_simulation_error_with_time():
    integ = get_integrator("rk45")
    with pytest.raises(SimulationError) as info:
        integ._integrate(ODEProblem(lambda t, y: y * y), 0.0, np.array([1.0]), np.array([2.0]),
                         Counters(), [], None)
    assert 0.99 < info.value.t <= 1.0 + 1e-6


def test_unknown_name_lists_valid_names():
    with pytest.raises(ValueError) as info:
        get_integrator("rk99")
    for name in OWN + SCIPY:
        assert name in str(info.value)
    assert set(OWN + SCIPY) <= set(INTEGRATORS)


@pytest.mark.parametrize("name, opts, text", [
    ("euler", dict(step=0.0), "step=0.0"),
    ("rk4", dict(step=-0.1), "step=-0.1"),
    ("heun", dict(step=float("nan")), "step=nan"),
    ("rk45", dict(rtol=0.0), "rtol=0.0"),
    ("rk45", dict(atol=-1e-6), "atol=-1e-06"),
    ("rk45", dict(max_step=0.0), "max_step=0.0"),
    ("rk45", dict(rtol=1e-18), "rtol=1e-18"),
    ("abm4", dict(fixed_step=True), "step"),
    ("abm4", dict(step=-1.0), "step=-1.0"),
    ("bdf4", dict(adaptive=False), "step"),
    ("bdf4", dict(atol=0.0), "atol=0.0"),
    ("bdf4", dict(max_newton=0), "max_newton=0"),
    ("scipy-bdf", dict(rtol=-1.0), "rtol=-1.0"),
    ("scipy-lsoda", dict(atol=[1e-6, -1.0]), "atol"),
])
def test_bad_options_rejected_at_construction(name, opts, text):
    with pytest.raises(ValueError) as info:
        get_integrator(name, **opts)
    assert text in str(info.value)


# --------------------------------------------------------------------------- bookkeeping
@pytest.mark.parametrize("name", OWN + SCIPY)
def test_counters_outputs_and_progress(name):
    fun = Counted(limit_cycle)
    seen = []
    t_eval = np.array([0.25, 0.5, 1.0])                   # first output after t0
    res = get_integrator(name, **opts_for(name)).integrate(ODEProblem(fun), 0.0, Y0_LC, t_eval,
                                                           progress=seen.append)
    assert res.success, res.message
    np.testing.assert_array_equal(res.t, t_eval)
    np.testing.assert_allclose(res.y, limit_cycle_exact(t_eval), atol=2e-3)
    c = res.counters
    assert c.nfev == fun.calls
    assert len(seen) == c.steps > 0
    assert np.all(np.diff(seen) > 0) and seen[-1] == 1.0
    assert c.wall_time > 0


def test_output_at_t0_is_initial_state():
    for name in OWN:
        res = get_integrator(name, **opts_for(name)).integrate(ODEProblem(limit_cycle), 0.0,
                                                               Y0_LC, [0.0, 0.1])
        np.testing.assert_array_equal(res.y[0], Y0_LC)


# --------------------------------------------------------------------------- controllers
def test_controllers_step_size_formulas():
    from spatialmbd.integrators import FixedStepController, IController, PIController
    c = IController(safety=0.9, min_factor=0.2, max_factor=10.0)
    assert c.accept(0.1, 0.5, 5, False) == pytest.approx(0.1 * 0.9 * 0.5 ** (-1 / 5))
    assert c.accept(0.1, 1e-12, 5, False) == pytest.approx(1.0)          # max_factor
    assert c.accept(0.1, 0.5, 5, True) == pytest.approx(0.1)             # no growth after reject
    assert c.reject(0.1, 32.0, 5) == pytest.approx(0.1 * 0.9 / 2.0)
    assert c.reject(0.1, 1e9, 5) == pytest.approx(0.02)                  # min_factor
    assert c.reject(0.1, float("nan"), 5) == pytest.approx(0.02)
    assert c.failed(0.1) == pytest.approx(0.05)
    d = IController(max_factor=2.0, deadband=1.25)
    assert d.accept(0.1, 0.9, 5, False) == 0.1                           # 0.92 < 1.25: keep h
    assert d.accept(0.1, 0.001, 5, False) == pytest.approx(0.2)          # grows, capped at x2
    assert d.accept(0.1, 0.001, 5, False, hold=True) == 0.1              # start-up: keep
    pi = PIController(beta=0.04)
    first = pi.accept(0.1, 0.5, 5, False)
    assert first == pytest.approx(0.1 * 0.9 * 0.5 ** -(0.2 - 0.03) * 1e-4 ** 0.04)
    assert pi.accept(0.1, 0.5, 5, False) == pytest.approx(
        0.1 * 0.9 * 0.5 ** -(0.2 - 0.03) * 0.5 ** 0.04)                  # remembers ||e_prev||
    f = FixedStepController(0.01)
    assert not f.adaptive and f.accept(0.003, 0.5, 5, False) == 0.01
    with pytest.raises(ValueError, match="deadband"):
        IController(deadband=0.5)
