"""Kinematic analysis (ch. 7) and mobility (ch. 2) against closed forms."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.errors import ConvergenceError, ModelError, SingularMatrixError
from spatialmbd.kinematics import kinematic_analysis, mobility, solve_positions
from spatialmbd.motion import ConstantVelocity, Harmonic
from spatialmbd.rotations import rotate_p


def test_slider_crank_matches_closed_form_over_a_revolution():
    omega = 6.0
    model = models.slider_crank(crank_speed=omega).compile()
    t = np.linspace(0.0, 2 * np.pi / omega, 145)
    res = kinematic_analysis(model, t, tol=1e-12)
    assert res.status == "success"
    k = model.body_index("slider")
    x, xd, xdd = models.slider_crank_exact(omega * t, omega)
    assert np.abs(res.q[:, k, 0] - x).max() < 1e-10
    assert np.abs(res.v[:, k, 0] - xd).max() < 1e-10
    assert np.abs(res.vdot[:, k, 0] - xdd).max() < 1e-10
    # the slider stays on the x axis and does not rotate
    assert np.abs(res.q[:, k, 1:3]).max() < 1e-12
    assert np.abs(res.v[:, k, 3:]).max() < 1e-10


def test_slider_crank_velocities_are_derivatives_of_positions():
    model = models.slider_crank(crank_speed=6.0).compile()
    h = 1e-5
    t = np.array([0.3 - h, 0.3, 0.3 + h])
    res = kinematic_analysis(model, t, tol=1e-13)
    pt = res.points["crank.B"]
    assert np.allclose((pt["r"][2] - pt["r"][0]) / (2 * h), pt["rdot"][1], atol=1e-8)
    assert np.allclose((pt["rdot"][2] - pt["rdot"][0]) / (2 * h), pt["rddot"][1], atol=1e-6)


def test_four_bar_fig_2_1_has_two_degrees_of_freedom():
    mob = mobility(models.four_bar().compile())
    assert mob.grubler == 2 and mob.rank == 16 and mob.dof == 2 and mob.n_redundant == 0


def test_driven_rsur_four_bar_follows_closed_form():
    model = models.four_bar("universal", crank_speed=1.0).compile()
    t = np.linspace(0, 2 * np.pi, 121)
    res = kinematic_analysis(model, t, tol=1e-12)
    assert res.status == "success"
    D0 = np.array(models.FOUR_BAR["rocker_pivot"])
    exact = np.array([D0 + 2.5 * models.four_bar_rocker_direction(th) for th in t])
    assert np.abs(res.points["rocker.C"]["r"] - exact).max() < 1e-10


def test_bricard_gruebler_zero_but_one_dof_and_redundant_equation_named():
    mob = mobility(models.bricard().compile())
    assert mob.grubler == 0
    assert mob.rank == 29 and mob.dof == 1 and mob.n_redundant == 1
    assert mob.redundant[0][2] == "revolute"
    assert "redundant equations: 1" in mob.report()


def test_newton_converges_quadratically():
    model = models.slider_crank(crank_speed=6.0).compile()
    q = model.q0.copy()
    rng = np.random.default_rng(3)
    q[:, :3] += 0.01 * rng.normal(size=(3, 3))
    q[:, 3:] = rotate_p(q[:, 3:], 0.02 * rng.normal(size=(3, 3)))
    _, info = solve_positions(model, q, t=0.2, tol=1e-14)
    r = np.array(info.residuals)
    assert info.converged and info.iterations <= 6
    # e_{k+1} <= C e_k^2 in the asymptotic range
    ratios = r[2:-1] / r[1:-2] ** 2
    assert np.all(ratios < 100), r


def test_kinematic_analysis_needs_all_dofs_driven():
    with pytest.raises(ModelError, match="as many drivers as degrees of freedom"):
        kinematic_analysis(models.slider_crank(driven=False).compile(), [0.0, 0.1])


def test_too_many_drivers_named():
    b = models.slider_crank(crank_speed=6.0)
    b.add_driver("coordinate", "slider_x", ConstantVelocity(rate=0.1, initial=0.2), body="slider",
                 coordinate="x")
    with pytest.raises(ModelError, match="more drivers than degrees of freedom"):
        kinematic_analysis(b.compile(), [0.0, 0.1])


def test_non_converging_newton_reports_time_and_joints():
    b = models.slider_crank(crank_speed=6.0)
    b.add_driver("coordinate", "slider_x", Harmonic(amplitude=5.0, frequency=1.0, offset=0.2),
                 body="slider", coordinate="x")
    b.drivers.pop("crank_drive")
    model = b.compile()
    res = kinematic_analysis(model, np.linspace(0, 1.5, 16))
    assert res.status == "failed"
    assert "t =" in res.message and ("did not converge" in res.message or "singular" in res.message)
    assert len(res.t) >= 1  # everything computed before the failure is returned


def test_singular_jacobian_names_joints():
    b = ModelBuilder()
    b.add_body("a", 1.0, (1, 1, 1))
    b.add_joint("revolute", "r1", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "r2", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    model = b.compile()
    from spatialmbd.kinematics import JacobianFactor
    D = model.assembler.evaluate(model.q0, None, 0.0).D
    with pytest.raises(SingularMatrixError, match="r1|r2"):
        JacobianFactor(np.vstack([D[:6]]), model, 0.0)


def test_coordinate_and_translation_drivers():
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("slider", 1.0, (1, 1, 1))
    b.add_joint("cylindrical", "cyl", "ground", "slider", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_driver("translation", "lift", Harmonic(0.5, 2.0), joint="cyl")
    b.add_driver("angle", "turn", ConstantVelocity(rate=3.0), joint="cyl")
    model = b.compile()
    t = np.linspace(0, 3, 31)
    res = kinematic_analysis(model, t, tol=1e-13)
    assert res.status == "success"
    assert np.allclose(res.q[:, 0, 2], 0.5 * np.sin(2 * t), atol=1e-12)
    assert np.allclose(res.v[:, 0, 5], 3.0, atol=1e-12)
    assert np.allclose(res.vdot[:, 0, 2], -2.0 * np.sin(2 * t), atol=1e-10)
    # the angle driver passes pi without trouble: e0 = cos(3t/2)
    assert np.allclose(np.abs(res.q[:, 0, 3]), np.abs(np.cos(1.5 * t)), atol=1e-12)


def test_mobility_of_a_state_off_the_manifold_is_that_of_the_mechanism():
    """The Bricard linkage 1.5e-6 off its constraint manifold (as a long run leaves it) still
    has one degree of freedom: the rank is taken at the assembled state."""
    from spatialmbd import models
    from spatialmbd.rotations import normalize_p
    model = models.bricard().compile()
    q = model.q0.copy()
    rng = np.random.default_rng(0)
    q[:, 3:] = normalize_p(q[:, 3:] + 4e-7 * rng.normal(size=(model.nb, 4)))
    mob = mobility(model, q)
    assert mob.violation > 1e-6 and 0 < mob.correction < 1e-5
    assert (mob.grubler, mob.dof, mob.n_redundant) == (0, 1, 1)
    assert "violates the constraints" in mob.report()
    assert mob.singular_values[-1] < 1e-12       # at the given state it is 2e-7
