"""The finite-difference Jacobian of the implicit integrators (integrators/jacobian.py) and the
runs that crawled without it (issue #31 item 3, bench/robustness.py).

Closed-form checks of the increments: a linear right-hand side (exact columns, round-off
measured at the machine level, the small-component increment from atol / rtol) and the same
one with pseudo-random round-off of 1e-6 of f added (sqrt(eps) increments give noise columns,
the measured ones the Jacobian). Then the mechanisms of the benchmark that stalled or failed:
each run must end where an rk45 reference at rtol 1e-10 ends (bounds stated per case, a few
times the measured difference) within a bound on steps and evaluations that the old code
exceeded many times over (old figures in each docstring).
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from spatialmbd import models
from spatialmbd.integrators import ODEProblem, get_integrator
from spatialmbd.integrators.jacobian import EPS, MAX_NOISE, fd_jacobian, rhs_noise
from spatialmbd.io.modelfile import load_model
from spatialmbd.simulate import simulate

DATA = Path(__file__).parent.parent / "dynamics" / "data"
A = np.array([[-2.0, 1.0, 0.0, 3.0],
              [0.5, -1e3, 2.0, 0.0],
              [0.0, 4.0, -0.3, 1e2],
              [1.0, 0.0, 0.0, 0.0]])


def linear(t, y):
    return A @ y


def noisy(level):
    """A y plus a deterministic pseudo-random perturbation of ``level`` |A y| that changes
    completely for any change of y (a hash of its bits): round-off amplified to ``level``."""
    def f(t, y):
        fy = A @ y
        seed = int(np.frombuffer(y.tobytes(), dtype=np.uint64).sum() % (2 ** 32))
        r = np.random.default_rng(seed).uniform(-1.0, 1.0, y.size)
        return fy + level * np.abs(fy).max() * r
    return f


def test_linear_rhs_gives_its_matrix_and_machine_round_off():
    y = np.array([0.7, -1.3, 0.0, 2.5])      # a component at 0: increment from atol / rtol
    typical = np.full(4, 1e-9 / 1e-6)
    J = np.zeros((4, 4))
    calls = fd_jacobian(linear, 0.0, y, linear(0.0, y), typical, 4, J)
    assert calls == 5                         # 4 columns + the round-off probe
    assert np.abs(J - A).max() < 1e-6 * np.abs(A).max()
    noise = rhs_noise(linear, 0.0, y, linear(0.0, y), np.maximum(np.abs(y), typical), 4)
    assert EPS <= noise < 1e-12


def test_quadrature_columns_are_left_zero():
    y = np.array([0.7, -1.3, 0.4, 2.5])
    J = np.zeros((4, 4))
    assert fd_jacobian(linear, 0.0, y, linear(0.0, y), np.full(4, 1e-3), 3, J) == 4
    assert np.all(J[:, 3] == 0.0) and np.abs(J[:, :3] - A[:, :3]).max() < 1e-5 * 1e3


def test_noisy_rhs_gets_increments_sized_to_its_round_off():
    """f with round-off 1e-6 of itself: sqrt(eps) increments (the old ones) give columns that
    are noise (error ~ 1e-6 |f| / (1.5e-8 |y|), far above |J|); the measured increments
    (sqrt(1e-6) = 1e-3 relative) give the Jacobian to about 1e-3 of its norm."""
    f = noisy(1e-6)
    y = np.array([0.7, -1.3, 0.4, 2.5])
    typical = np.full(4, 1e-3)
    fy = f(0.0, y)
    noise = rhs_noise(f, 0.0, y, fy, np.maximum(np.abs(y), typical), 4)
    assert 1e-7 < noise <= MAX_NOISE
    J = np.zeros((4, 4))
    fd_jacobian(f, 0.0, y, fy, typical, 4, J)
    assert np.abs(J - A).max() < 1e-2 * np.abs(A).max()
    old = np.zeros((4, 4))                     # the sqrt(eps) increments of the old code
    for j in range(4):
        yj = y.copy()
        yj[j] += math.sqrt(EPS) * max(abs(y[j]), typical[j])
        old[:, j] = (f(0.0, yj) - fy) / (yj[j] - y[j])
    assert np.abs(old - A).max() > np.abs(A).max()


@pytest.mark.parametrize("name", ["bdf4", "scipy-radau", "scipy-bdf"])
def test_implicit_integrators_use_it_and_count_it(name):
    """A stiff linear problem: the run agrees with the exact solution and every evaluation,
    the Jacobian's included, is counted in nfev."""
    calls = [0]

    def f(t, y):
        calls[0] += 1
        return A[:3, :3] @ y

    y0 = np.array([1.0, 0.5, -0.2])
    res = get_integrator(name, rtol=1e-8, atol=1e-10).integrate(ODEProblem(f), 0.0, y0, [0.5])
    assert res.success, res.message
    w, V = np.linalg.eig(A[:3, :3])
    exact = (V @ (np.exp(w * 0.5) * np.linalg.solve(V, y0))).real
    assert np.abs(res.y[-1] - exact).max() < 1e-6
    assert res.counters.nfev == calls[0] and res.counters.njev >= 1


# --------------------------------------------------------------------------- mechanisms
def run(model, method, integrator, t_end=0.1):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(model, t_end, method=method, integrator=integrator)


def end_difference(model, method, res, t_end=0.1):
    """Largest difference of the body positions at t_end from rk45 at rtol 1e-10 (m)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = simulate(model, t_end, method=method, integrator="rk45", rtol=1e-10, atol=1e-12)
    assert ref.success, ref.message
    return float(np.abs(np.asarray(res.q[-1])[:, :3] - np.asarray(ref.q[-1])[:, :3]).max())


def test_radau_on_the_stiff_four_bar_does_not_crawl():
    """The four-bar with a 1e8 N/m spring-damper (bench n_four_bar_1_k1e+08): SciPy's num_jac
    columns for the state components at 0 were round-off and Radau's Newton diverged with a
    fresh Jacobian at every step: 14,260 steps and 619,751 evaluations for 0.1 s (stopped at
    10 s in the bench). Now 5,468 steps, 49,421 evaluations, 1.3e-6 m from the reference
    (rk45 at the default tolerance ends 2.8e-3 m away)."""
    b = models.n_four_bar(1)
    b.add_force("spring_damper", "spring", body_i="ground", body_j="coupler0",
                point_i=(1.5, 2.0, 0.0), stiffness=1e8, damping=1e5, natural_length=0.9)
    model = b.compile()
    res = run(model, "standard", "scipy-radau")
    assert res.success, res.message
    assert res.counters["steps"] < 8000 and res.counters["nfev"] < 150_000, res.counters
    assert end_difference(model, "standard", res) < 1e-5


def test_radau_from_the_singular_start_of_rand2000():
    """rand2000 (singular start): 1,855 steps and 218,226 evaluations before, 58 and 2,426
    now, 3.4e-11 m from the reference."""
    model, _ = load_model(DATA / "rand2000.json")
    res = run(model, "standard", "scipy-radau")
    assert res.success, res.message
    assert res.counters["steps"] < 300 and res.counters["nfev"] < 20_000, res.counters
    assert end_difference(model, "standard", res) < 1e-8


def test_bdf4_from_the_singular_start_of_rand2007():
    """rand2007: the right-hand side's round-off is 1e-5 of itself for the first 0.5 ms (the
    multiplier solve near the singular start); sqrt(eps) increments gave noise Jacobians and
    Newton failed with fresh ones: 896 steps (724 rejected) and 103,747 evaluations for the
    first 0.01 s (for 0.1 s: 3,280 steps, 406,359 evaluations, stopped at t = 0.073 s by the
    bench's 10 s). Now 82 steps and 6,510 evaluations for 0.01 s, 4.5e-11 m from the
    reference (683 steps for 0.1 s)."""
    model, _ = load_model(DATA / "rand2007.json")
    res = run(model, "standard", "bdf4", t_end=0.01)
    assert res.success, res.message
    assert res.counters["steps"] < 300 and res.counters["nfev"] < 30_000, res.counters
    assert end_difference(model, "standard", res, t_end=0.01) < 1e-8


def dead_centre_four_bar(n):
    """models.n_four_bar_flat: the N-four-bar started in its flat (singular) position."""
    return models.n_four_bar_flat(n).compile()


def test_bdf4_projection_through_the_dead_centre():
    """The double four-bar through its flat position with the projection method: the step
    size underflowed (2e-16 s) at t = 4.4e-6 s before; now 0.1 s in 208 steps, 5e-7 m from the
    reference."""
    model = dead_centre_four_bar(2)
    res = run(model, "projection", "bdf4")
    assert res.success, res.message
    assert res.counters["steps"] < 1000, res.counters
    assert end_difference(model, "projection", res) < 1e-5


@pytest.mark.parametrize("level, converges", [(1e-9, True), (1e-6, False)])
def test_bdf4_newton_accepts_corrections_stalled_below_its_tolerance(level, converges):
    """Newton started at the solution of y = psi + gh f(y), f = -y + round-off that grows by
    1.2 at every evaluation: the corrections are that round-off and grow (rate 1.2). Below
    the Newton tolerance (1e-3 of the error scale; ~1e-4 here) the iterate is accepted --
    the iteration has reached f's round-off, as CVODE's test accepts it (the old code failed
    it as "diverging"); above it (~1e-1) it still fails as diverging."""
    from spatialmbd.integrators.base import Counters
    from spatialmbd.integrators.gear import NewtonSolver

    y_star = np.array([1.0, 2.0, 3.0])
    gh = 0.1
    calls = [0]

    def f(t, y):
        calls[0] += 1
        return -y + level * 1.2 ** calls[0] * np.array([1.0, -1.0, 1.0])

    problem = ODEProblem(f, jac=lambda t, y: -np.eye(3))
    atol = np.full(3, 1e-9)
    newton = NewtonSolver(problem, 3, 1e-6, atol, 1e-3, 8, Counters())
    newton.refresh(0.0, y_star)
    scale = atol + 1e-6 * np.abs(y_star)
    y, cause = newton.solve(0.0, (1.0 + gh) * y_star, gh, y_star.copy(), scale)
    if converges:
        assert y is not None, cause
        assert np.abs((y - y_star) / scale).max() < 1e-2
    else:
        assert y is None and cause.startswith("diverging"), cause
