"""The second-order initial velocity correction at a start with dependent rows
(dynamics/flex_correction.py): a first-order flex that no motion has is removed, a velocity
along a branch is kept, and every method then describes the projection method's motion."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.dynamics.correction import correct_initial_conditions
from spatialmbd.dynamics.flex_correction import remove_flex
from spatialmbd.io.modelfile import load_model
from spatialmbd.models import _slender_inertia
from spatialmbd.rank import row_rank, self_stresses

DATA = Path(__file__).parent / "data"


def flat_triangle(flex: float):
    """Two bars pinned to the ground at x = 0 and x = 2 and to each other at x = 1: a triangle
    with its three revolute joints on one line (sides 1 + 1 = 2), rigid, but with a first-order
    flex: bar a turning at +flex rad/s about z, bar b at -flex (the common pin moving along y).
    A free body with its own velocity rides along, unconnected."""
    b = ModelBuilder("flat_triangle", gravity=(0.0, -9.81, 0.0))
    b.add_body("a", 1.0, _slender_inertia(1.0, 1.0, 0), r=(0.5, 0.0, 0.0),
               omega=(0.0, 0.0, flex), rdot=(0.0, 0.5 * flex, 0.0))
    b.add_body("b", 2.0, _slender_inertia(2.0, 1.0, 0), r=(1.5, 0.0, 0.0),
               omega=(0.0, 0.0, -flex), rdot=(0.0, 0.5 * flex, 0.0))
    b.add_body("free", 1.0, (0.1, 0.1, 0.1), r=(0.0, 3.0, 0.0), rdot=(1.0, 2.0, 3.0),
               omega=(0.5, 0.0, 0.0))
    b.add_joint("revolute", "O", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "A", "a", "b", point=(1, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "B", "b", "ground", point=(2, 0, 0), axis=(0, 0, 1))
    return b.compile()


def dead_centre_four_bar(n: int):
    """models.n_four_bar_flat: the N-four-bar started in its flat (singular) position."""
    return models.n_four_bar_flat(n).compile()


def second_order_residual(model, q, v):
    """max |w^T gamma| over the self-stresses w of D at (q, v)."""
    cv = model.assembler.evaluate(q, v, 0.0)
    D = np.asarray(cv.D.toarray() if hasattr(cv.D, "toarray") else cv.D)
    W = self_stresses(D, row_rank(D))
    return float(np.abs(W.T @ cv.gamma).max()) if W.size else 0.0


def test_flat_triangle_flex_is_removed_and_the_free_body_kept():
    """Closed form: the triangle is rigid, so its bars' corrected velocities are zero; the
    free body's velocity is untouched. The given flex satisfies D v = 0 (the text's velocity
    correction leaves it), but w^T gamma = O(flex^2) != 0."""
    model = flat_triangle(2.0)
    q, v = model.q0, model.v0.reshape(-1)
    cv = model.assembler.evaluate(q, v, 0.0)
    assert np.abs(cv.D @ v - cv.nu).max() < 1e-14             # a first-order flex
    assert second_order_residual(model, q, v) > 1.0             # not a second-order one
    qc, vc, report = correct_initial_conditions(model, q, v)
    vc = vc.reshape(model.nb, 6)
    assert np.abs(vc[:2]).max() < 1e-12                         # the rigid triangle stands
    assert np.array_equal(vc[2], model.v0.reshape(model.nb, 6)[2])
    assert report.flex_before > 1.0 and report.flex_after < 1e-12
    assert "first-order flex" in report.summary()


def test_flex_correction_keeps_held_coordinates():
    """A held coordinate (bar a's omega_z) is not changed by the correction."""
    model = flat_triangle(2.0)
    hold = np.zeros(6 * model.nb, dtype=bool)
    hold[5] = True                                              # bar a's omega_z
    v, _, _ = remove_flex(model, model.q0, model.v0.reshape(-1), 0.0, hold)
    assert v[5] == 2.0


@pytest.mark.parametrize("n", [1, 2])
def test_velocity_along_a_branch_is_kept(n):
    """The N-four-bar at its flat position moving along the parallelogram branch: the rows
    are dependent there (and the planar loops' rows everywhere), but the velocity is a motion's,
    w^T gamma = 0 -- unchanged."""
    model = dead_centre_four_bar(n)
    v0 = model.v0.reshape(-1)
    assert row_rank(np.asarray(model.assembler.evaluate(model.q0, v0, 0.0).D)).dependent.size
    v, before, after = remove_flex(model, model.q0, v0, 0.0)
    assert np.array_equal(v, v0) and before == 0.0


def test_redundant_loops_away_from_singular_positions_are_kept():
    model = models.n_four_bar(3).compile()
    v0 = model.v0.reshape(-1)
    v, before, _ = remove_flex(model, model.q0, v0, 0.0)
    assert np.array_equal(v, v0) and before == 0.0


@pytest.mark.parametrize("name", ["rand2000", "rand2007"])
def test_regression_models_start_consistent(name):
    model, _ = load_model(DATA / f"{name}.json")
    q, v, report = correct_initial_conditions(model, model.q0, model.v0)
    assert report.flex_before > 1e-3
    assert second_order_residual(model, q, v.reshape(-1)) < 1e-10
    cv = model.assembler.evaluate(q, v, 0.0)
    assert np.abs(cv.D @ v.reshape(-1) - cv.nu).max() < 1e-12
