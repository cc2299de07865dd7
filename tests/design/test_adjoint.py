"""Adjoint gradients (spatialmbd.design.adjoint) against central differences with Richardson
extrapolation of the same discrete run, to 1e-6 relative: a pendulum, a closed-loop
slider-crank, and one model per force-element kind (every kind the design layer varies).

The adjoint differentiates the RK4 map of the run (fixed step, Euler parameters renormalised
after each step); the differences are taken of that same map (Adjoint.run), so both estimate
one derivative and the comparison measures the adjoint's own error (its vector-Jacobian
products are central differences of the compiled right-hand side)."""
from pathlib import Path

import numpy as np
import yaml
import pytest

from spatialmbd.design.adjoint import Adjoint, adjoint_gradients
from spatialmbd.errors import ModelError

import adjoint_cases as cases

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PENDULUM = EXAMPLES / "design" / "pendulum_damped.yaml"
RTOL = 1e-6


def costs(adj, Y, columns):
    """Two costs: the misfit of ``columns`` to 0.1 and the final value of the first column,
    as (values (2,), d/dY (n_out, n, 2))."""
    value, W = cases.misfit_weights(Y, columns, 0.1)
    Wf = np.zeros(Y.shape)
    Wf[-1, columns[0]] = 1.0
    return np.array([value, Y[-1, columns[0]]]), np.stack([W, Wf], axis=-1)


def richardson(adj, x, columns, rel=1e-3):
    """(R, error estimate) (2, p): central differences D(h), D(h/2) of the costs of the same
    RK4 run, R = (4 D(h/2) - D(h)) / 3, error |D(h) - D(h/2)| / 3 (of D(h/2); R is better)."""
    def c(xx):
        return costs(adj, adj.run(xx, derivatives=False), columns)[0]
    R = np.zeros((2, x.size))
    E = np.zeros((2, x.size))
    for j in range(x.size):
        h = rel * (abs(x[j]) if x[j] != 0 else 1.0)
        d = []
        for hh in (h, h / 2):
            e = np.zeros(x.size)
            e[j] = hh
            d.append((c(x + e) - c(x - e)) / (2 * hh))
        R[:, j] = (4 * d[1] - d[0]) / 3
        E[:, j] = abs(d[0] - d[1]) / 3
    return R, E


def check(model, params, columns, analysis=None):
    adj = Adjoint(model, list(params), analysis)
    x = np.array(list(params.values()), dtype=float)
    Y = adj.run(x)
    _, W = costs(adj, Y, [adj.column(c) for c in columns])
    G = adj.gradient(W)
    R, E = richardson(adj, x, [adj.column(c) for c in columns])
    adj.run(x)                     # again: parameters with disjoint floats now share builds
    G2 = adj.gradient(W)
    assert adj.structured          # the structured products passed their check at the start
    assert np.all(np.abs(R[0]) > 1e-9 * np.abs(R[0]).max())    # every parameter matters
    scale = np.abs(R).max(axis=1, keepdims=True)   # per cost: zero entries compared to it
    for g in (G, G2):
        assert np.all(np.abs(g - R) <= RTOL * np.maximum(np.abs(R), 1e-3 * scale) + 1e-15), \
            (g, R, E)
    return G, R


def test_pendulum_against_richardson():
    G, R = check(PENDULUM, {"bodies.pendulum.mass": 7.02, "bodies.pendulum.inertia.0":
                            0.5855265, "forces.pivot_damper.damping": 0.8,
                            "bodies.pendulum.angular_velocity.0": 0.5},
                 ["pendulum.wx", "pendulum.z"],
                 dict(type="dynamic", t_end=1.0, output_step=0.01,
                      method=dict(name="standard"), integrator=dict(name="rk4", step=0.005)))
    assert np.all(np.abs(G[0]) > 1e-6)                  # every parameter moves the misfit


def test_slider_crank_closed_loop_against_richardson():
    model, params = cases.slider_crank()
    G, _ = check(model, params, ["slider.x", "crank.wx"])
    assert np.count_nonzero(np.abs(G[0]) > 1e-8) == len(params)


@pytest.mark.parametrize("kind", sorted(cases.KINDS))
def test_force_element_kind_against_richardson(kind):
    model, params = cases.KINDS[kind]
    column = "link.y" if kind in ("joint_friction", "joint_limit") else "link.wx"
    check(model, params, [column, "link.vz" if column == "link.wx" else "link.vy"])


def test_structured_products_equal_the_dense_ones_along_the_run():
    model, params = cases.slider_crank()
    adj = Adjoint(model, list(params))
    x = np.array(list(params.values()))
    Y = adj.run(x)
    W = np.zeros(Y.shape)
    W[:, adj.column("slider.x")] = Y[:, adj.column("slider.x")]
    fast = adj.gradient(W)
    adj.structured = False
    dense = adj.gradient(W)
    np.testing.assert_allclose(fast, dense, rtol=1e-7, atol=1e-9 * np.abs(dense).max())


def test_outputs_agree_with_forward_sensitivities_and_checkpoints_do_not_matter():
    from spatialmbd.sweep import forward_sensitivities
    an = dict(type="dynamic", t_end=1.0, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk4", step=0.005))
    p = {"bodies.pendulum.mass": 7.02, "forces.pivot_damper.damping": 0.8}
    outs = ["final(pendulum.wx)", "rms(pendulum.y)", "peak(pendulum.wx)"]
    a = adjoint_gradients(PENDULUM, p, outs, an)
    b = adjoint_gradients(PENDULUM, p, outs, an, checkpoint=1)
    f = forward_sensitivities(PENDULUM, p, outs, an)
    np.testing.assert_allclose(a.nominal.values, f.nominal.values, rtol=1e-12)
    np.testing.assert_allclose(a.derivative.values, f.derivative.values, rtol=1e-7)
    np.testing.assert_allclose(a.derivative.values, b.derivative.values, rtol=1e-12)


@pytest.mark.parametrize("kind", sorted(cases.LAW_VALUES))
def test_force_law_values_are_refused_with_the_way_out(kind):
    model, params = cases.KINDS[kind]
    path = cases.LAW_VALUES[kind]
    with pytest.raises(ModelError, match=f"{path}.*cannot be varied by the adjoint.*fd"):
        Adjoint(model, [path]).run(np.array([0.3]))


def test_bad_input():
    with pytest.raises(ModelError, match="analysis values cannot be varied"):
        Adjoint(PENDULUM, ["analysis.t_end"])
    with pytest.raises(ModelError, match="'standard' or 'baumgarte'"):
        Adjoint(PENDULUM, ["bodies.pendulum.mass"], dict(type="dynamic", t_end=1.0,
                                                          method=dict(name="projection")))
    with pytest.raises(ModelError, match="'bodies.pendulum.masss' does not exist"):
        Adjoint(PENDULUM, ["bodies.pendulum.masss"])
    with pytest.raises(ModelError, match="call run"):
        Adjoint(PENDULUM, ["bodies.pendulum.mass"]).gradient(np.zeros((3, 14)))


# ------------------------------------------------------- identify() and optimize() use it
AN = dict(type="dynamic", t_end=1.0, output_step=0.01, method=dict(name="standard"),
          integrator=dict(name="rk4", step=0.005))


def test_optimize_auto_takes_the_adjoint_and_agrees_with_forward_sensitivities():
    from spatialmbd.design import optimize
    # the slowest swing: the rms rate over damping and initial rate, damping at its bound,
    # the initial rate interior; two parameters, one output -> the adjoint under "auto"
    p = {"forces.pivot_damper.damping": 0.8, "bodies.pendulum.angular_velocity.0": 0.5}
    bounds = {"forces.pivot_damper.damping": (0.1, 3.0),
              "bodies.pendulum.angular_velocity.0": (-5.0, 5.0)}
    auto = optimize(PENDULUM, "rms(pendulum.wx)", p, bounds=bounds, analysis=AN)
    forward = optimize(PENDULUM, "rms(pendulum.wx)", p, bounds=bounds, analysis=AN,
                       jacobian="forward")
    assert auto.jacobian == "adjoint" and forward.jacobian == "forward"
    assert auto.success and forward.success, auto.report()
    np.testing.assert_allclose(auto.x, forward.x, rtol=1e-6)
    assert auto.x[0] == pytest.approx(3.0) and abs(auto.x[1]) < 4.0     # bound, interior
    # with as many outputs as parameters "auto" keeps forward sensitivities
    one = optimize(PENDULUM, "-rms(pendulum.wx)", {"forces.pivot_damper.damping": 2.0},
                   bounds={"forces.pivot_damper.damping": (0.1, 5.0)}, analysis=AN,
                   max_iterations=1)
    assert one.jacobian == "forward"


def test_identify_adjoint_jacobian_equals_forward_sensitivities():
    from spatialmbd.design import identify
    from spatialmbd.design.problem import Experiment, Problem
    names = ["bodies.pendulum.mass", "forces.pivot_damper.damping",
             "bodies.pendulum.angular_velocity.0", "bodies.pendulum.inertia.0"]
    x = np.array([7.02, 0.8, 0.5, 0.5855265])
    t = np.array([0.25, 0.5, 1.0])                         # 3 residuals < 4 parameters
    e = Experiment("e", t, ["pendulum.wx"], np.zeros((t.size, 1)), {}, np.full(1, np.nan))
    auto = Problem(PENDULUM, names, [e], AN)
    fw = Problem(PENDULUM, names, [e], AN, jacobian="forward")
    assert auto.kinds == ["adjoint"] and fw.kinds == ["forward"]
    (ya,), (Ja,) = auto.evaluate(x, jacobian=True)
    (yf,), (Jf,) = fw.evaluate(x, jacobian=True)
    np.testing.assert_allclose(ya, yf, rtol=1e-12)
    np.testing.assert_allclose(Ja, Jf, rtol=1e-7, atol=1e-9 * np.abs(Jf).max())
    # an experiment with a value of its own (its initial rate): the override reaches the run
    own = Experiment("own", t, ["pendulum.wx"], np.zeros((t.size, 1)),
                     {"bodies.pendulum.angular_velocity.0": 1.5}, np.full(1, np.nan))
    pa = Problem(PENDULUM, names[:2], [own], AN, jacobian="adjoint")
    pf = Problem(PENDULUM, names[:2], [own], AN, jacobian="forward")
    (ya2,), (Ja2,) = pa.evaluate(x[:2], jacobian=True)
    (yf2,), (Jf2,) = pf.evaluate(x[:2], jacobian=True)
    assert np.abs(ya2 - ya).max() > 0.1                     # another run than the first
    np.testing.assert_allclose(ya2, yf2, rtol=1e-12)
    np.testing.assert_allclose(Ja2, Jf2, rtol=1e-7, atol=1e-9 * np.abs(Jf2).max())
    # a fit: 40 samples of the rate, mass and damping from 20 % off, both Jacobians
    t = np.linspace(0.025, 1.0, 40)
    ref = Problem(PENDULUM, names[:2], [Experiment("r", t, ["pendulum.wx"],
                                                   np.zeros((t.size, 1)), {},
                                                   np.full(1, np.nan))], AN, jacobian="forward")
    (clean,), _ = ref.evaluate(x[:2])
    rig = {"t": t, "pendulum.wx": clean[:, 0]}
    start = {names[0]: 5.6, names[1]: 0.64}
    fits = [identify(PENDULUM, rig, start, analysis=AN, jacobian=j) for j in ("adjoint",
                                                                             "forward")]
    for fit in fits:
        np.testing.assert_allclose(fit.estimates, x[:2], rtol=1e-6)
    np.testing.assert_allclose(fits[0].estimates, fits[1].estimates, rtol=1e-8)


def test_direct_parameters_need_no_builds():
    """A mass, an inertia and an initial rate are written into the built model's arrays for
    dF/dp and dy0/dp (design.adjoint_params): after the first gradient (one build pair per
    parameter) a gradient builds the model once plus one build pair for the damping, and
    equals the first gradient -- also at other parameter values, where the written
    derivatives follow the model (J'^-1 is not linear in the inertia)."""
    an = dict(type="dynamic", t_end=0.3, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk4", step=0.005))
    params = {"bodies.pendulum.mass": 7.02, "bodies.pendulum.inertia.0": 0.5855265,
              "forces.pivot_damper.damping": 0.8, "bodies.pendulum.angular_velocity.0": 0.5}
    adj = Adjoint(PENDULUM, list(params), an)
    x = np.array(list(params.values()))
    Y = adj.run(x)
    _, W = costs(adj, Y, [adj.column("pendulum.wx"), adj.column("pendulum.z")])
    G1 = adj.gradient(W)
    assert sorted(a for a, _ in adj._direct.values()) == ["inertia", "mass", "v0"]
    assert adj._groups == [[2]]
    n0 = adj.n_builds
    adj.run(x)
    assert adj.n_builds - n0 == 3
    np.testing.assert_allclose(adj.gradient(W), G1, rtol=1e-12, atol=0)
    x2 = x * np.array([1.1, 1.001, 1.2, 1.5])     # (the inertia near its triangle limit)
    adj.run(x2)
    G2 = adj.gradient(W)
    fresh = Adjoint(PENDULUM, list(params), an)
    fresh.run(x2)
    np.testing.assert_allclose(G2, fresh.gradient(W), rtol=1e-10, atol=0)
    assert np.abs(G2 - G1).max() > 1e-3 * np.abs(G1).max()     # the values did move


def test_a_rate_is_not_taken_for_direct_when_a_parameter_turns_its_body(tmp_path):
    """A rate in body axes looks direct while the body's orientation is the identity; with a
    parameter that turns the body (an initial angle), it keeps its builds
    (adjoint_params.keep_valid), and a later gradient at another orientation equals a fresh
    first gradient there."""
    an = dict(type="dynamic", t_end=0.2, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk4", step=0.005))
    base = {"bodies.pendulum.mass": 7.02, "bodies.pendulum.angular_velocity.0": 0.5}
    adj = Adjoint(PENDULUM, list(base), an)
    adj.run(np.array(list(base.values())))
    assert "v0" in [a for a, _ in adj._direct.values()]       # nothing turns the body
    data = yaml.safe_load(PENDULUM.read_text(encoding="utf-8"))
    data["bodies"][0]["orientation"] = {"bryant": [0.0, 0.0, 0.0]}
    turned = tmp_path / "turned.yaml"
    turned.write_text(yaml.safe_dump(data), encoding="utf-8")
    params = dict(base, **{"bodies.pendulum.orientation.bryant.0": 0.1})
    adj = Adjoint(turned, list(params), an)
    x = np.array(list(params.values()))
    Y = adj.run(x)
    assert "v0" not in [a for a, _ in adj._direct.values()]
    _, W = costs(adj, Y, [adj.column("pendulum.wx"), adj.column("pendulum.z")])
    adj.gradient(W)
    x2 = x + np.array([0.0, 0.0, 0.3])
    adj.run(x2)
    fresh = Adjoint(turned, list(params), an)
    fresh.run(x2)
    G, G_fresh = adj.gradient(W), fresh.gradient(W)
    # (the angle about the joint's own axis is nearly undone by the initial-condition
    # correction: its column is central-difference noise, ~1e-9 of the others)
    np.testing.assert_allclose(G, G_fresh, rtol=1e-10, atol=1e-9 * np.abs(G_fresh).max())
