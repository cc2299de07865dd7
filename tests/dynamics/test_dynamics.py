"""Forward dynamics (ch. 10-14): Newton-Euler residuals, energy, methods and integrators agree,
reactions against exact relations, redundant constraints, failures and bad input."""
import warnings

import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.dynamics import EquationsOfMotion, get_method
from spatialmbd.errors import ModelError
from spatialmbd.guards import PlausibilityWarning
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.simulate import RedundantConstraintsWarning, simulate

TIGHT = dict(integrator="rk45", rtol=1e-10, atol=1e-12)


@pytest.fixture(scope="module")
def crank():
    return models.slider_crank(driven=False).compile()


def test_newton_euler_residual_vanishes_for_each_body(crank):
    res = simulate(crank, 0.3, output_step=0.05, **TIGHT)
    assert res.success
    eom = EquationsOfMotion(crank)
    for k in range(len(res.t)):
        ev = eom.evaluate(res.t[k], res.q[k], res.v[k].reshape(-1))
        resid = ev.M.dot(res.vdot[k].reshape(-1)) - ev.g - ev.cv.D.T @ res.lam[k]
        assert np.abs(resid).max() < 1e-9 * max(1.0, np.abs(ev.g).max())


def test_energy_is_conserved_for_a_conservative_system():
    model = models.chain(3, "spherical").compile()
    res = simulate(model, 1.0, output_step=0.01, method="projection", **TIGHT)
    en = res.energy()
    scale = np.abs(en["gravitational"]).max() + 1.0
    assert np.abs(en["error"]).max() < 1e-8 * scale
    assert np.abs(en["kinetic"]).max() > 1.0          # it really moved


@pytest.mark.parametrize("method", ["standard", "baumgarte", "penalty", "augmented_lagrangian",
                                    "projection"])
def test_all_methods_agree_on_a_closed_loop(crank, method):
    ref = simulate(crank, 0.4, output_step=0.1, method="projection", **TIGHT)
    res = simulate(crank, 0.4, output_step=0.1, method=method, integrator="rk45", rtol=1e-9,
                   atol=1e-11)
    assert res.success
    tol = 1e-6 if method in ("penalty",) else 1e-7
    assert np.abs(res.q - ref.q).max() < tol
    assert np.abs(res.lam - ref.lam).max() < 1e3 * tol * max(1, np.abs(ref.lam).max())


@pytest.mark.parametrize("integrator,options,tol", [
    ("euler", dict(step=2e-5), 2e-3), ("heun", dict(step=1e-3), 1e-5),
    ("rk4", dict(step=2e-3), 1e-7), ("abm4", dict(rtol=1e-9, atol=1e-11), 1e-7),
    ("bdf4", dict(rtol=1e-9, atol=1e-11), 1e-7), ("rk45", dict(rtol=1e-9, atol=1e-11), 1e-7),
    ("scipy-dop853", dict(rtol=1e-10, atol=1e-12), 1e-7),
    ("scipy-radau", dict(rtol=1e-8, atol=1e-10), 1e-6),
    ("scipy-lsoda", dict(rtol=1e-9, atol=1e-11), 1e-6),
])
def test_all_integrators_agree(integrator, options, tol):
    model = models.pendulum_ch15().compile()
    ref = simulate(model, 0.2, output_step=0.05, **TIGHT)
    res = simulate(model, 0.2, output_step=0.05, method="projection", integrator=integrator,
                   integrator_options=options)
    assert res.success, res.message
    assert np.allclose(res.t, ref.t)
    assert np.abs(res.q - ref.q).max() < tol


def test_rk4_shows_fourth_order_on_the_pendulum():
    model = models.pendulum_ch15().compile()
    ref = simulate(model, 0.5, output_step=0.5, **TIGHT).q[-1]
    hs = np.array([0.04, 0.02, 0.01])
    errs = [np.abs(simulate(model, 0.5, output_step=0.5, integrator="rk4", step=h).q[-1]
                   - ref).max() for h in hs]
    slope = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert abs(slope - 4.0) < 0.3


@pytest.mark.parametrize("method", ["projection", "recursive"])
def test_pendulum_reaction_matches_energy_solution(method):
    """Pivot reaction of the chapter 15 pendulum against the exact relations of the physical
    pendulum: omega^2 = 2 m g d sin(phi) / I_O, alpha = m g d cos(phi) / I_O (phi below the
    horizontal), R = m a_c - m g; in body coordinates and in joint coordinates."""
    model = models.pendulum_ch15().compile()
    res = simulate(model, 2.0, output_step=0.01, method=method, **TIGHT)
    m, g, d = 7.02, 9.81, 0.5
    I_O = 0.5855265 + m * d * d
    r = res.body("pendulum")["r"]
    phi = np.arctan2(-r[:, 2], r[:, 1])
    w2 = 2 * m * g * d * np.sin(phi) / I_O
    alpha = m * g * d * np.cos(phi) / I_O
    e_r = np.stack([np.zeros_like(phi), np.cos(phi), -np.sin(phi)], axis=1)   # pivot -> com
    e_t = np.stack([np.zeros_like(phi), -np.sin(phi), -np.cos(phi)], axis=1)  # direction of motion
    a_c = -w2[:, None] * d * e_r + alpha[:, None] * d * e_t
    exact = m * a_c - m * np.array([0, 0, -g])
    R = res.reactions()["pivot"]
    assert R.body_j == "pendulum" and R.body_i == "ground"
    assert np.abs(R.force_j - exact).max() < 1e-6 * m * g
    assert np.allclose(R.force_i, -R.force_j, atol=1e-9)
    # no moment about the axis x; the moment normal to it is the inertia coupling (zero here)
    assert np.abs(R.moment_j[:, 0]).max() < 1e-8


def test_driven_dynamics_agrees_with_kinematics():
    model = models.slider_crank(crank_speed=6.0).compile()
    t = np.linspace(0, 0.5, 11)
    kin = kinematic_analysis(model, t, tol=1e-12)
    dyn = simulate(model, 0.5, t_eval=t, method="projection", **TIGHT)
    assert np.abs(dyn.q - kin.q).max() < 1e-9
    assert np.abs(dyn.vdot - kin.vdot).max() < 1e-6
    # the driver torque does work: the energy balance includes it
    assert np.abs(dyn.energy()["error"]).max() < 1e-7


def test_redundant_bricard_runs_with_named_warning():
    model = models.bricard().compile()
    with pytest.warns(RedundantConstraintsWarning, match="P5|P4|P3|P2|P1|O"):
        res = simulate(model, 0.5, output_step=0.05, method="standard", **TIGHT)
    assert res.success and res.redundant_joints
    reactions = res.reactions()
    assert not reactions[res.redundant_joints[0]].unique
    assert np.abs(res.energy()["error"]).max() < 1e-7
    assert np.abs(res.q[-1, 0, :3] - res.q[0, 0, :3]).max() > 1e-3   # it moved


def test_penalty_and_augmented_lagrangian_handle_redundancy_without_warning_needed():
    model = models.bricard().compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        a = simulate(model, 0.2, output_step=0.1, method="augmented_lagrangian", **TIGHT)
        b = simulate(model, 0.2, output_step=0.1, method="projection", **TIGHT)
    assert a.success and np.abs(a.q - b.q).max() < 1e-6


def test_failure_midway_returns_partial_results():
    def bad(t, q, v):
        f = np.zeros((1, 3))
        if t > 0.2:
            f[0, 0] = np.nan
        return f, np.zeros((1, 3))
    b = models.pendulum_ch15()
    b.add_force("user", "bad", function=bad)
    res = simulate(b.compile(), 1.0, output_step=0.05)
    assert res.status == "failed"
    assert "t =" in res.message and ("NaN" in res.message or "finite" in res.message)
    assert 0.1 < res.t[-1] <= 0.25 and len(res.q) == len(res.t)


@pytest.mark.parametrize("kwargs,match", [
    (dict(method="lagrangian-magic"), "valid names"),
    (dict(integrator="rk99"), "valid names"),
    (dict(method="baumgarte", method_options=dict(alpha=-1)), "alpha: must be >= 0"),
    (dict(method="penalty", method_options=dict(alpha=0)), "alpha: must be > 0"),
    (dict(integrator="rk4", step=-0.1), "step"),
    (dict(integrator="rk45", rtol=0.0), "rtol"),
    (dict(integrator="rk4", rtol=1e-3), "takes no rtol"),
])
def test_bad_settings_rejected_before_running(kwargs, match):
    model = models.pendulum_ch15().compile()
    with pytest.raises((ValueError, ModelError), match=match):
        simulate(model, 1.0, **kwargs)


def test_initial_conditions_are_corrected_and_reported(crank):
    q0 = crank.q0.copy()
    q0[1, :3] += (0.003, -0.002, 0.001)
    v0 = crank.v0.copy()
    v0[2, 0] += 0.5
    res = simulate(crank, 0.05, q0=q0, v0=v0, output_step=0.05, **TIGHT)
    rep = res.correction
    assert rep.phi_before > 1e-3 and rep.phi_after < 1e-12 and rep.phidot_after < 1e-10
    assert rep.max_position_change > 1e-3 and rep.max_velocity_change > 0.1
    assert res.constraint_violation()["position"][0] < 1e-12
    # holding coordinates fixed: the others then move further (the crank turns 0.14 rad), which
    # the plausibility check reports
    with pytest.warns(PlausibilityWarning, match="crank moved"):
        res2 = simulate(crank, 0.05, q0=q0, v0=v0, output_step=0.05, hold={"rod": ["x"]},
                        **TIGHT)
    assert res2.q[0, 1, 0] == pytest.approx(q0[1, 0], abs=1e-14)


def test_outputs_are_at_the_requested_times():
    model = models.pendulum_ch15().compile()
    t_eval = np.array([0.0, 0.013, 0.1, 0.25, 0.4])
    res = simulate(model, t_eval=t_eval, **TIGHT)
    assert np.array_equal(res.t, t_eval)
    ref = simulate(model, 0.4, output_step=0.001, **TIGHT)
    k = int(round(0.25 / 0.001))
    assert np.abs(res.q[3] - ref.q[k]).max() < 1e-9


def test_results_table_columns():
    model = models.pendulum_ch15().compile()
    df = simulate(model, 0.1, output_step=0.05, **TIGHT).to_dataframe()
    for col in ("t", "pendulum.x", "pendulum.e0", "pendulum.wx", "pivot.pendulum.fz",
                "pivot.ground.mx", "violation.position", "violation.velocity", "energy.total",
                "energy.error"):
        assert col in df.columns
    assert len(df) == 3


def test_a_method_instance_holds_no_state_between_runs():
    """The augmented Lagrangian's iteration count goes into the results of each run, and a
    second run with the same method instance starts from the configured settings."""
    from spatialmbd.dynamics.augmented_lagrangian import AugmentedLagrangian
    model = models.slider_crank(driven=False).compile()
    meth = AugmentedLagrangian(alpha=1e6)
    a = simulate(model, 0.05, method=meth, output_step=0.01)
    meth.alpha = 123.0                                # as an adaptation would leave it
    b = simulate(model, 0.05, method=meth, output_step=0.01)
    assert a.counters["method_iterations"] > 0
    assert a.counters["method_iterations"] == b.counters["method_iterations"]
    assert np.array_equal(a.q, b.q) and meth.alpha == 1e6


@pytest.mark.parametrize("build", [lambda: models.slider_crank(), models.flyball_governor,
                                   models.rolling_disc, models.bricard])
def test_result_tables_equal_the_per_output_evaluation(build):
    """reactions() and constraint_violation() (the compiled constraint rows, one call per
    output, in blocks) against D^T lam and Phi, D v - nu of the constraint groups evaluated in
    Python at every output."""
    import warnings
    model = build().compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(model, 0.1, method="standard", output_step=0.01)
    res._ROWS_PER_BLOCK = 3                                   # several blocks
    R, viol = res.reactions(), res.constraint_violation()
    for k, state in enumerate(res.states()):
        phi, Dv = [], []
        for g, off in zip(model.constraint_groups, model.group_offsets):
            ev = g.evaluate(state, res.t[k])
            lam = res.lam[k, off:off + g.size].reshape(g.n, g.n_eq)
            gen = np.einsum("nmc,nm->nc", ev.D, lam)
            for n, name in enumerate(g.names):
                si = state.A[g.body_i[n]] @ g.geometry.s_i[n]
                assert np.allclose(R[name].force_i[k], gen[n, :3], rtol=1e-12, atol=1e-9)
                assert np.allclose(R[name].force_j[k], gen[n, 6:9], rtol=1e-12, atol=1e-9)
                assert np.allclose(R[name].moment_i[k], gen[n, 3:6] - np.cross(si, gen[n, :3]),
                                   rtol=1e-12, atol=1e-9)
            v = np.vstack([res.v[k], np.zeros((1, 6))])
            Dv.append(np.einsum("nmc,nc->nm", ev.D[:, :, :6], v[g.body_i])
                      + np.einsum("nmc,nc->nm", ev.D[:, :, 6:], v[g.body_j]) - ev.nu)
            phi.append(ev.phi)
        phi = np.concatenate([p.ravel() for p in phi])
        assert np.isclose(viol["phi_squared"][k], phi @ phi, rtol=1e-9, atol=1e-30)
        # |D v - nu| is at round-off here (a few 1e-15 m/s), which a different order of
        # summation changes in its last bits: equal to 1e-9 or to 100 eps of the terms
        terms = np.linalg.norm(np.concatenate([np.abs(d).ravel() for d in Dv])) + \
            float(np.abs(res.v[k]).max())
        assert np.isclose(viol["velocity"][k], np.linalg.norm(np.concatenate(
            [d.ravel() for d in Dv])), rtol=1e-9, atol=100 * np.finfo(float).eps * terms)


def test_right_hand_side_leaves_out_redundant_rows_as_simulate_does():
    """On the N-four-bar (9 redundant equations for N = 3) the stand-alone right-hand side solves
    with the independent rows, as simulate() does: same accelerations, without the
    least-squares fallback on every call."""
    from spatialmbd.dynamics import standard
    from spatialmbd.simulate import right_hand_side
    model = models.n_four_bar(3).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        res = simulate(model, 0.1, output_step=0.1, method="standard")
    f, y0 = right_hand_side(model, "standard")
    y1 = np.concatenate([res.q[-1].ravel(), res.v[-1].ravel(), [res.work[-1]]])
    calls = []
    real = standard.fallback_multipliers
    standard.fallback_multipliers = lambda *a, **k: calls.append(1) or real(*a, **k)
    try:
        ydot = f(0.1, y1)
    finally:
        standard.fallback_multipliers = real
    assert not calls
    np.testing.assert_allclose(ydot[7 * model.nb:13 * model.nb], res.vdot[-1].ravel(),
                               rtol=1e-10, atol=1e-10)


def test_an_unstable_explicit_run_is_named_so_not_a_singular_position():
    """rk4 with a step too large for the flyball governor's stiff springs blows up; the
    bodies then reach positions where D looks singular, but the message names the
    instability (and what to do), not a singular position."""
    model = models.flyball_governor().compile()
    res = simulate(model, 0.05, output_step=0.01, method="projection", integrator="rk4",
                   step=1e-3)
    assert res.status == "failed"
    assert "integration became unstable" in res.message and "smaller step" in res.message
    assert "singular position" not in res.message
