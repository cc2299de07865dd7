"""Singular positions passed by design: the projection method through every flat position of
the N-four-bar (IFToMM A02), checked against the closed form of the parallelogram branch.

On that branch every crank angle phi (from the vertical) obeys I phi'' = K sin phi
(models.n_four_bar), so the tip of crank 1 has the exact path (1 - sin phi, cos phi). The
assertions are on that path and on the status -- not on step counts -- and the same runs are
repeated under two OpenBLAS kernels in tests/test_same_answer.py."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from spatialmbd import models
from spatialmbd.dynamics import EquationsOfMotion
from spatialmbd.dynamics.projection import Projection
from spatialmbd.integrators.dormand_prince import DormandPrince45 as RK45
from spatialmbd.kinematics import mobility
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate


def branch_error(model, res, n):
    """Largest distance (m) of crank 1's tip from the exact parallelogram-branch path over the
    outputs."""
    L, a, g = 1.0, 0.02, 9.81
    inertia = (n + 1) * ((L * L + a * a) / 12.0 + L * L / 4.0) + n * L * L
    K = g * L * ((n + 1) / 2.0 + n)
    exact = solve_ivp(lambda t, y: [y[1], K / inertia * np.sin(y[0])], (0.0, res.t[-1]),
                      [0.0, -1.0], method="DOP853", rtol=1e-13, atol=1e-13, t_eval=res.t)
    k = model.body_index("crank1")
    tips = res.q[:, k, :3] + np.einsum("tij,j->ti", A_from_p(res.q[:, k, 3:]),
                                       np.array([0.0, 0.5, 0.0]))
    phi = exact.y[0]
    path = np.stack([1.0 - np.sin(phi), np.cos(phi), np.zeros_like(phi)], axis=1)
    return float(np.linalg.norm(tips - path, axis=1).max()), phi


@pytest.mark.parametrize("method", ["projection", "augmented_lagrangian"])
@pytest.mark.parametrize("n, integrator, rtol", [(2, "rk45", 1e-6), (2, "rk45", 1e-10),
                                                 (2, "dop853", 1e-10), (8, "rk45", 1e-8),
                                                 (8, "dop853", 1e-10)])
def test_projection_follows_the_parallelogram_branch_through_every_flat_position(
        method, n, integrator, rtol):
    """10 s: 14 flat positions. Before, rk45 at rtol 1e-10 crawled into any budget at the first
    (68,200 steps for 3.3 s), and the Euclidean projection put an energy error into every
    passage (3.4e-4 m off after 10 s at rtol 1e-10); dop853 at 1e-10 and N = 8 at 1e-8 stopped
    or left the branch. The augmented Lagrangian with its projection (its default) passes
    likewise; without it, it stopped with the diagnosis (test_singular_guard)."""
    model = models.n_four_bar(n).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(model, 10.0, method=method, integrator=integrator, rtol=rtol,
                       atol=rtol * 1e-2, output_step=0.05, max_wall_time=120.0)
    assert res.status == "success" and res.t[-1] == 10.0, res.message
    err, phi = branch_error(model, res, n)
    flats = np.floor((-phi[-1] - np.pi / 2) / np.pi) + 1
    assert flats >= 10                                   # it did pass the flat positions
    # the integration error at this rtol, not a branch jump (those are ~1 m); the augmented
    # Lagrangian's accelerations carry its iteration tolerance (1e-8 of |vdot|), a floor under
    # its error below the integrator's at rtol 1e-10 (N = 8, dop853: 3.2e-6 m)
    bound = {1e-6: 2e-4, 1e-8: 2e-6, 1e-10: 2e-6}[rtol]
    if method == "augmented_lagrangian":
        bound = max(bound, 5e-6)
    assert err < bound, err


def test_projection_tolerance_follows_the_integrator_atol():
    """A projection left at 1e-10 under an atol of 1e-12 hides position errors that the
    near-singular accelerations amplify; the run's tolerance is min(method's, atol), never
    below the round-off floor of the positions."""
    meth = Projection()
    q = np.zeros((2, 7))
    q[:, 3] = 1.0
    assert meth.tolerance_for(RK45(rtol=1e-6, atol=1e-8), q) == 1e-10       # the method's
    assert meth.tolerance_for(RK45(rtol=1e-10, atol=1e-12), q) == 1e-12
    floor = 64 * np.finfo(float).eps * 1e3
    q[0, 0] = 1e3
    assert meth.tolerance_for(RK45(rtol=1e-13, atol=1e-16), q) == pytest.approx(floor)


def test_projection_corrections_are_in_the_mass_metric():
    """The projection's velocity correction is dv = -M^-1 D^T (D M^-1 D^T)^-1 (D v - nu): M dv
    lies in the row space of D, and it is the smallest correction in kinetic energy (the
    Euclidean one of 14.19 differs)."""
    model = models.n_four_bar(2).compile()
    eom = EquationsOfMotion(model)
    meth = Projection()
    meth.setup(eom, np.array([r[0] for r in mobility(model).redundant], dtype=np.int64))
    q0 = np.asarray(model.q0, dtype=float)
    rng = np.random.default_rng(3)
    v = np.asarray(model.v0, dtype=float).ravel() + 1e-3 * rng.standard_normal(6 * model.nb)
    q, v_new = meth.project(eom, 0.0, q0, v)
    ev = eom.evaluate(0.0, q, v_new)
    D = ev.cv.D.toarray() if hasattr(ev.cv.D, "toarray") else np.asarray(ev.cv.D)
    assert np.abs(D @ v_new - ev.cv.nu).max() < 1e-12
    M = ev.M.dense()
    Mdv = M @ (v_new - v)
    coef = np.linalg.lstsq(D.T, Mdv, rcond=None)[0]
    assert np.linalg.norm(D.T @ coef - Mdv) < 1e-10 * max(1.0, np.linalg.norm(Mdv))
    # the Euclidean correction of 14.19 would not be: its M dv is off the row space of D
    dv_e = -D.T @ np.linalg.lstsq(D @ D.T, D @ v - ev.cv.nu, rcond=None)[0]
    coef_e = np.linalg.lstsq(D.T, M @ dv_e, rcond=None)[0]
    assert np.linalg.norm(D.T @ coef_e - M @ dv_e) > 1e-6 * np.linalg.norm(M @ dv_e)
