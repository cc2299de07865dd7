"""The penalty methods' option ``project`` (dynamics/penalty.py, dynamics/step_projection.py):
the augmented Lagrangian projects by default in the mass metric, the penalty method on request
in the metric of its leading matrix K = M + alpha D^T D (Bayo and Ledesma)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from spatialmbd import models
from spatialmbd.dynamics.augmented_lagrangian import AugmentedLagrangian
from spatialmbd.dynamics.penalty import Penalty
from spatialmbd.dynamics.system import System
from spatialmbd.errors import ModelError
from spatialmbd.kinematics import apply_correction
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate


def _mass(model, q):
    """The mass matrix (6 nb) with the inertia in global axes (v = [rdot, omega])."""
    M = np.zeros((6 * model.nb, 6 * model.nb))
    for b in range(model.nb):
        A = A_from_p(q[b, 3:])
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = model.mass[b] * np.eye(3)
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = A @ model.inertia[b] @ A.T
    return M


def _dense_projection(model, alpha, t, q, v, iterations):
    """The K-metric projection written out with dense matrices."""
    for _ in range(iterations):
        cv = model.assembler.evaluate(q, None, t)
        D = np.asarray(cv.D.toarray() if hasattr(cv.D, "toarray") else cv.D)
        K = _mass(model, q) + alpha * D.T @ D
        q = apply_correction(q, np.linalg.solve(K, -alpha * D.T @ cv.phi))
    cv = model.assembler.evaluate(q, v, t)
    D = np.asarray(cv.D.toarray() if hasattr(cv.D, "toarray") else cv.D)
    M = _mass(model, q)
    return q, np.linalg.solve(M + alpha * D.T @ D, M @ v + alpha * D.T @ cv.nu)


def test_penalty_projection_is_the_k_metric_projection():
    """The compiled projection equals the dense formula at perturbed states of the 2-loop
    N-four-bar, away from and next to a flat position (where K's near-dependent direction is
    left alone: the correction there differs from the mass metric's)."""
    model = models.n_four_bar(2).compile()
    ref = simulate(model, 0.72, method="projection", output_step=0.001)
    meth = Penalty(project=True)
    system = System.for_model(model)
    nb = model.nb
    rng = np.random.default_rng(3)
    for i in (100, 600, 716):
        y = np.concatenate([ref.q[i].ravel(), ref.v[i].ravel()])
        y = y + 1e-6 * rng.standard_normal(y.size)
        got = meth.project_y(system, ref.t[i], y, 0.0)       # tol 0: all its iterations
        q, v = _dense_projection(model, meth.alpha, ref.t[i], y[:7 * nb].reshape(nb, 7),
                                 y[7 * nb:13 * nb], 10)
        dq, dv = got[:7 * nb] - y[:7 * nb], got[7 * nb:13 * nb] - y[7 * nb:13 * nb]
        # K is ill-conditioned (alpha |D|^2 / m ~ 1e7, more next to the flat position): both
        # solves carry its round-off, cond eps relative to the correction
        assert np.abs(got[:7 * nb] - q.ravel()).max() <= 1e-6 * np.abs(dq).max()
        assert np.abs(got[7 * nb:13 * nb] - v).max() <= 1e-3 * np.abs(dv).max()
        cv = model.assembler.evaluate(got[:7 * nb].reshape(nb, 7), None, ref.t[i])
        if i != 716:                                     # away from the flat position
            assert np.abs(cv.phi).max() < 1e-12


@pytest.mark.parametrize("method", ["penalty", "augmented_lagrangian"])
def test_projection_removes_the_drift_of_the_penalty_methods(method):
    """A closed loop away from its singular positions (the N-four-bar over its first 0.5 s):
    with the projection the constraint violation stays at the projection's tolerance, without
    it at the penalty's compliance (a soft alpha = 1e5 to make it plain)."""
    model = models.n_four_bar(2).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        on = simulate(model, 0.5, method=method, method_options={"project": True, "alpha": 1e5},
                      rtol=1e-8, atol=1e-10, output_step=0.01)
        off = simulate(model, 0.5, method=method, method_options={"project": False, "alpha": 1e5},
                       rtol=1e-8, atol=1e-10, output_step=0.01)
    assert on.status == off.status == "success"
    phi_on = np.max(list(on.constraint_violation().values())[0])
    phi_off = np.max(list(off.constraint_violation().values())[0])
    assert phi_on < 1e-9 and phi_on < phi_off        # |Phi| 2-norm; projected: max 1e-10
    if method == "penalty":           # the augmented Lagrangian's iterations hold it anyway
        assert phi_off > 100 * phi_on
    assert on.settings["method_options"]["project"] is True
    # the stabilisation terms are off with the projection, on without it (their defaults)
    assert (on.settings["method_options"]["omega"], on.settings["method_options"]["mu"]) == \
        (0.0, 0.0)
    assert (off.settings["method_options"]["omega"], off.settings["method_options"]["mu"]) == \
        (10.0, 1.0)


def test_defaults_and_bad_option():
    assert AugmentedLagrangian().projects and not AugmentedLagrangian().follows_drift
    assert not Penalty().projects and Penalty().follows_drift    # the text's method
    assert AugmentedLagrangian(omega=5.0, mu=0.5).params()[2:4].tolist() == [5.0, 0.5]
    with pytest.raises(ModelError, match="penalty project: expected true or false"):
        simulate(models.n_four_bar(2).compile(), 0.1, method="penalty",
                 method_options={"project": "yes"})
