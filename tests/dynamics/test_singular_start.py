"""Mechanisms that start at a singular configuration, and the regularised multiplier solve.

The two regression models start where some constraint rows are dependent, with an initial
velocity that makes them independent at once: the rows kept in the multiplier solve are then
nearly dependent for the first moments (S = D M^-1 D^T with a pivot ratio near 1e-16), and
the plain Cholesky amplified round-off and drift by 1 / pivot until rk45's step size
underflowed at t ~ 1e-6 s after thousands of rejected steps. The solve is regularised there
(dynamics/sparse.py, iterated Tikhonov below a pivot ratio of SINGULAR_PIVOT)."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from spatialmbd.dynamics import sparse as spc
from spatialmbd.io.modelfile import load_model
from spatialmbd.simulate import simulate

DATA = Path(__file__).parent / "data"
METHODS = ("standard", "baumgarte", "penalty", "augmented_lagrangian", "projection")


@pytest.mark.parametrize("name", ["rand2000", "rand2007"])
def test_singular_start_runs_in_few_steps_with_every_method(name):
    """Every method runs the 0.1 s; the penalty methods on rand2007 only with singular=
    'continue': from t = 0.07 s on their runs head back towards the singular position they
    started at (r, the guard's measure of the distance to it, falling from its largest value)
    while their compliance keeps the drift eps far above it (r a fraction of sqrt(eps / L);
    the standard method's r is several times sqrt(eps / L)) -- the drift decides the
    branch there, and by default the run stops with the diagnosis
    (test_penalty_stops_where_its_compliance_decides_the_branch)."""
    model, _ = load_model(DATA / f"{name}.json")
    runs = {}
    for method in METHODS:
        options = {"singular": "continue"} if name == "rand2007" and method in (
            "penalty", "augmented_lagrangian") else None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = simulate(model, 0.1, method=method, integrator="rk45", output_step=0.01,
                           max_steps=400, method_options=options)
        assert res.status == "success" and res.t[-1] == 0.1, (method, res.message)
        runs[method] = res
        viol = res.constraint_violation()
        # every constraint row -- the ones dependent at the start included -- holds
        limit = 1e-4 if method in ("penalty", "augmented_lagrangian") else 1e-6
        assert viol["position"].max() < limit, (method, viol["position"].max())
    # the multiplier methods describe one motion (the flex part of the initial velocity, which
    # the projection method removed at its first projection, is removed for every method by the
    # initial-condition correction: test_flex_correction.py and the test below)
    ref = runs["standard"].q[:, :, :3]
    assert np.abs(runs["baumgarte"].q[:, :, :3] - ref).max() < 1e-3
    # the start is sensitive: the augmented Lagrangian (its own iteration tolerance) and the
    # penalty method (compliant constraints, default alpha) end 1.7e-3 and 3.7e-3 m away on
    # rand2007 -- the same motion, not the same digits
    for method in ("penalty", "augmented_lagrangian"):
        assert np.abs(runs[method].q[:, :, :3] - ref).max() < 1e-2, method


@pytest.mark.parametrize("name", [
    pytest.param("rand2000", marks=pytest.mark.xfail(
        strict=True, reason="open: 6.3e-4 m at rtol 1e-8 after the correction (6e-3 before); "
        "the start's quadratic consistency condition has several roots and the one the "
        "projection method reaches is not yet the one the correction picks every time")),
    "rand2007"])
def test_singular_start_every_multiplier_method_follows_the_projection_method(name):
    """The start is inconsistent at second order (a first-order flex); before the
    initial-condition correction removed it, the projection method ended 6e-3 to 8e-3 m away
    from the others (2e-2 m at rtol 1e-8). Now the motions agree to a bound tied to the
    integration tolerance: within 1e3 rtol (the near-singular start amplifies the local
    errors; rand2007 measured 1.3e-7 m at rtol 1e-8, was 2e-2 m)."""
    model, _ = load_model(DATA / f"{name}.json")
    rtol = 1e-8
    runs = {}
    for method in ("standard", "baumgarte", "projection"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[method] = simulate(model, 0.1, method=method, integrator="rk45", rtol=rtol,
                                    atol=1e-2 * rtol, output_step=0.01, max_steps=2000)
        assert runs[method].status == "success", (method, runs[method].message)
    ref = runs["projection"].q[:, :, :3]
    for method in ("standard", "baumgarte"):
        assert np.abs(runs[method].q[:, :, :3] - ref).max() < 1e3 * rtol, method


def test_penalty_stops_where_its_compliance_decides_the_branch():
    """rand2007 under the penalty method with its defaults: the singular-position guard
    (dynamics/singular_guard.py) stops the run before 0.1 s with the diagnosis naming the
    joints, keeping the outputs reached. The stop is decided by the approach (r halving from
    its largest value, near t = 0.075 s), r being well inside the guard's band there."""
    model, _ = load_model(DATA / "rand2007.json")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(model, 0.1, method="penalty", integrator="rk45", output_step=0.01,
                       max_steps=400)
    assert res.status == "failed" and 0.05 < res.t[-1] < 0.1, (res.status, res.t[-1])
    assert "stopped at a singular position" in res.message
    assert "near-dependent equations are in joint(s)" in res.message
    assert "projection method" in res.message and "singular='continue'" in res.message


def test_regularised_solve_is_exact_away_from_singular_and_bounded_at_it():
    """The compiled solve on a dense 3 x 3 pattern: an SPD matrix with a pivot ratio above
    SINGULAR_PIVOT is solved exactly by the plain path; a singular one (rank 2) with a
    consistent right-hand side gives a solution of A lam = b (the accelerations need no more),
    and an inconsistent one a bounded lam instead of round-off over the pivot."""
    rows, cols = np.triu_indices(3)
    sym = spc.SparseCholesky(3, rows, cols)
    arrays = sym.arrays()

    def cx_of(A):
        Cx = np.zeros(sym.Ci.size)
        Cx[sym.positions(rows, cols)] = A[rows, cols]
        return Cx

    rng = np.random.default_rng(3)
    X = rng.normal(size=(3, 3))
    A = X @ X.T + 0.5 * np.eye(3)
    Cx, Lx, x, y = cx_of(A), np.zeros(sym.nnz_L), np.zeros(3), np.zeros(3)
    assert spc.numeric_ratio(arrays, Cx, Lx, x) > spc.SINGULAR_PIVOT
    b = rng.normal(size=3)
    lam = b.copy()
    spc.solve(arrays, Lx, lam, y)
    assert np.allclose(A @ lam, b, rtol=0, atol=1e-13)
    # the regularised path agrees with the plain one on a regular matrix
    lam2 = b.copy()
    assert spc.solve_regularised(arrays, Cx, Lx, x, y, lam2)
    assert np.abs(lam2 - lam).max() < 1e-10 * np.abs(lam).max()
    # singular: rank 2
    V = rng.normal(size=(3, 2))
    A = V @ V.T
    Cx = cx_of(A)
    assert spc.numeric_ratio(arrays, Cx, Lx, x) <= spc.SINGULAR_PIVOT
    b = A @ rng.normal(size=3)                       # consistent
    lam = b.copy()
    assert spc.solve_regularised(arrays, Cx, Lx, x, y, lam)
    assert np.abs(A @ lam - b).max() < 1e-6 * np.abs(b).max()
    null = np.linalg.svd(A)[0][:, -1]
    lam = (b + 1e-8 * null).copy()                   # inconsistent by 1e-8
    assert spc.solve_regularised(arrays, Cx, Lx, x, y, lam)
    assert np.abs(lam).max() < 1e6                   # round-off / pivot would be ~1e8
