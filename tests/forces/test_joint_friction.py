"""Joint friction (forces/joint_friction.py): the slip against finite differences, the power,
a slider's stopping distance under constant Coulomb friction in every method, LuGre's stick
without creep, a bearing's run-down, the energy balance, files and bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.outputs import force_outputs
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

from fd_check import q_along, random_state

JOINTS = {"revolute": ("revolute", {}), "translational": ("translational", {}),
          "cylindrical": ("cylindrical", dict(coordinate="translation")),
          "spherical": ("spherical", {})}
LAWS = [dict(frictionloss=2.0, creep_velocity=0.1, viscous=0.3),
        dict(friction="stribeck", frictionloss=1.0, static_frictionloss=1.5,
             stribeck_velocity=0.2, creep_velocity=0.05),
        dict(friction="viscous", viscous=0.7)]


def two_bodies(case, **law):
    jtype, lkw = JOINTS[case]
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(1.0, -0.5, 0.8))
    axis = {} if jtype == "spherical" else dict(axis=(0.3, 0.4, 1.0))
    b.add_joint(jtype, "j", "a", "b", point=(0.5, 0, 0.5), **axis)
    b.add_force("joint_friction", "fr", joint="j", **lkw, **law)
    return b.compile()


@pytest.mark.parametrize("case", ["revolute", "translational", "cylindrical"])
def test_slip_is_the_rate_of_the_coordinate(case):
    """The slip the kernel uses, D_x v, against the central difference of the joint limit's
    coordinate (the same compiled coordinate) along the motion; and the friction opposes it."""
    model = two_bodies(case, frictionloss=1.0, creep_velocity=0.5)
    group = model.force_groups[0]
    coordinate = "translation" if case != "revolute" else "angle"
    b = ModelBuilder(gravity=(0, 0, 0))      # the same joint with a limit reading x
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(1.0, -0.5, 0.8))
    b.add_joint(JOINTS[case][0], "j", "a", "b", point=(0.5, 0, 0.5), axis=(0.3, 0.4, 1.0))
    b.add_force("joint_limit", "x", joint="j", upper=10.0, law="linear", stiffness=1.0,
                **({"coordinate": coordinate} if case == "cylindrical" else {}))
    limit = b.compile().force_groups[0]
    rng = np.random.default_rng(7)
    h, checked = 1e-6, 0
    while checked < 10:
        q0, v = random_state(rng, 2)
        xp, xm = (limit.details(BodyState.from_qv(q_along(q0, v, s), v, 0.0))[0, 3]
                  for s in (h, -h))
        if abs(xp - xm) > 0.5:
            continue
        d = group.details(BodyState.from_qv(q0, v, 0.0))[0]
        assert d[0] == pytest.approx((xp - xm) / (2 * h), rel=1e-6, abs=1e-7)
        assert d[3] * d[0] < 0 and abs(d[3]) == pytest.approx(
            math.tanh(abs(d[0]) / 0.5) * 1.0, rel=1e-12)
        checked += 1


@pytest.mark.parametrize("case", sorted(JOINTS))
@pytest.mark.parametrize("law", LAWS, ids=["coulomb", "stribeck", "viscous"])
def test_power_of_the_friction_is_its_reported_dissipation(case, law):
    model = two_bodies(case, **law)
    group = model.force_groups[0]
    rng = np.random.default_rng(11)
    for _ in range(8):
        q0, v = random_state(rng, 2)
        state = BodyState.from_qv(q0, v, 0.0)
        g = np.zeros((3, 6))
        group.evaluate(state, 0.0, g)
        power = float(np.sum(g[:2] * v))
        assert power == pytest.approx(group.nonconservative_power(state, 0.0), rel=1e-12,
                                      abs=1e-12)
        assert power <= 0.0


M, V0, F = 2.0, 1.5, 3.0
METHODS = ["standard", "baumgarte", "penalty", "augmented_lagrangian", "projection",
           "recursive"]


def slider(**law):
    b = ModelBuilder("slide", gravity=(0, 0, -9.81))
    b.add_body("block", M, (0.1, 0.1, 0.1), r=(0, 0, 0), rdot=(V0, 0, 0))
    b.add_joint("translational", "rail", "ground", "block", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("joint_friction", "fr", joint="rail", **law)
    return b


@pytest.mark.parametrize("method", METHODS)
def test_slider_under_constant_coulomb_friction_stops_at_the_closed_form_distance(method):
    """x = v0^2 / (2 F / m) = 0.75 m (the regularization tanh(v / v_eps) adds O(m v_eps^2 / F));
    the energy balance closes (the friction's work is the kinetic energy lost)."""
    res = simulate(slider(frictionloss=F, creep_velocity=1e-5).compile(), 1.5, method=method,
                   rtol=1e-10, atol=1e-12, output_step=0.05)
    assert res.success, res.message
    tol = 1e-7 if method == "penalty" else 1e-9
    assert res.q[-1, 0, 0] == pytest.approx(V0 ** 2 / (2 * F / M), abs=tol)
    en = res.energy()
    assert np.abs(en["error"]).max() < 10 * tol * 0.5 * M * V0 ** 2
    out = force_outputs(res, "fr")
    assert out["friction"][0] == pytest.approx(-F, rel=1e-9)


def test_lugre_holds_a_pushed_slider_without_creep():
    """A push of 0.8 F on a LuGre joint: the slider moves by its presliding deflection and
    stays (velocity 1e-12 m/s, no drift over the last half second); the regularized Coulomb law
    under the same push creeps at v_eps atanh(0.8)."""
    sigma0 = 1e5
    law = dict(friction="lugre", frictionloss=F, bristle_stiffness=sigma0,
               bristle_damping=2 * math.sqrt(sigma0 * M))
    runs = {}
    for name, kw in (("lugre", law), ("coulomb", dict(frictionloss=F, creep_velocity=1e-4))):
        b = slider(**kw)
        b.bodies["block"].rdot = np.zeros(3)
        b.add_force("point_force", "push", body="block", direction=(1, 0, 0),
                    magnitude=0.8 * F)
        runs[name] = simulate(b.compile(), 1.0, method="standard", rtol=1e-10, atol=1e-12,
                              output_step=0.05)
    res = runs["lugre"]
    assert res.success, res.message
    x = res.q[:, 0, 0]
    assert abs(x[-1] - x[len(x) // 2]) < 1e-10 and abs(res.v[-1, 0, 0]) < 1e-9
    assert 0 < x[-1] < 10 * 0.8 * F / sigma0
    out = force_outputs(res, "fr")
    assert out["bristle"][-1] == pytest.approx(0.8 * F / sigma0, rel=1e-6)
    assert np.abs(res.energy()["error"]).max() < 1e-9
    creep = runs["coulomb"].v[-1, 0, 0]
    assert creep == pytest.approx(1e-4 * math.atanh(0.8), rel=1e-6)


def test_constant_friction_moment_runs_down_a_spinning_wheel_in_the_closed_form_time():
    """A wheel (J = 0.4 kg m^2) on a revolute bearing at 10 rad/s with a friction moment of
    0.5 N m: omega(t) = 10 - (0.5 / 0.4) t until it stops at t = 8 s; after 1 s, 8.75 rad/s."""
    b = ModelBuilder("wheel", gravity=(0, 0, -9.81))
    b.add_body("wheel", 3.0, (0.2, 0.2, 0.4), omega=(0, 0, 10.0))
    b.add_joint("revolute", "bearing", "ground", "wheel", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_force("joint_friction", "fr", joint="bearing", frictionloss=0.5)
    res = simulate(b.compile(), 1.0, method="standard", rtol=1e-10, atol=1e-12,
                   output_step=0.1)
    assert res.v[-1, 0, 5] == pytest.approx(10.0 - 0.5 / 0.4, rel=1e-10)


def test_spherical_joint_friction_brakes_the_relative_rotation():
    """A ball joint's constant friction moment T opposes omega_j - omega_i: a ball spinning
    about a fixed direction slows at T / J."""
    b = ModelBuilder("ball", gravity=(0, 0, 0))
    b.add_body("ball", 1.0, (0.5, 0.5, 0.5), omega=(3.0, 4.0, 0.0))
    b.add_joint("spherical", "socket", "ground", "ball", point=(0, 0, 0))
    b.add_force("joint_friction", "fr", joint="socket", frictionloss=0.25)
    res = simulate(b.compile(), 1.0, method="projection", rtol=1e-10, atol=1e-12,
                   output_step=0.1)
    w = res.v[-1, 0, 3:]
    assert np.linalg.norm(w) == pytest.approx(5.0 - 0.25 / 0.5, rel=1e-10)
    assert np.allclose(w / np.linalg.norm(w), [0.6, 0.8, 0.0], atol=1e-12)


def test_friction_reads_from_a_model_file():
    from spatialmbd.io import load_model
    data = {"spatialmbd": 1, "name": "m", "gravity": [0, 0, 0],
            "bodies": [{"name": "arm", "mass": 1.0, "inertia": [0.1, 0.1, 0.1]}],
            "joints": [{"name": "pin", "type": "revolute", "body_i": "ground",
                        "body_j": "arm", "point": [0, 0, 0], "axis": [0, 0, 1]}],
            "forces": [{"name": "fr", "type": "joint_friction", "joint": "pin",
                        "friction": "lugre", "frictionloss": 0.2,
                        "bristle_stiffness": 1e3}]}
    model, _ = load_model(data)
    assert model.force_groups[0].state_rows().tolist() == [True]


@pytest.mark.parametrize("kw, match", [
    (dict(joint="pin", frictionloss=-1.0), "frictionloss: must be a finite number >= 0"),
    (dict(joint="pin"), "needs a friction level"),
    (dict(joint="nope", frictionloss=1.0), "unknown joint 'nope'"),
    (dict(joint="uj", frictionloss=1.0), "is a universal joint"),
    (dict(joint="cyl", frictionloss=1.0), "say which"),
    (dict(joint="pin", friction="stribeck", frictionloss=1.0), "static_frictionloss"),
    (dict(joint="pin", friction="stribeck", frictionloss=1.0, static_frictionloss=2.0),
     "stribeck_velocity"),
    (dict(joint="pin", friction="dry", frictionloss=1.0), "unknown friction law"),
    (dict(joint="pin", friction="lugre", frictionloss=1.0), "bristle_stiffness"),
    (dict(joint="pin", frictionloss=1.0, viscous=-2.0), "viscous"),
    (dict(joint="pin", friction="viscous", frictionloss=1.0), "only 'viscous'"),
])
def test_bad_friction_is_refused_naming_the_element(kw, match):
    b = ModelBuilder(gravity=(0, 0, 0))
    for n in ("a", "d", "e"):
        b.add_body(n, 1.0, (1, 1, 1))
    b.add_joint("revolute", "pin", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("universal", "uj", "ground", "d", point=(0, 0, 0), axis=(0, 0, 1),
                axis2=(1, 0, 0))
    b.add_joint("cylindrical", "cyl", "ground", "e", point=(0, 0, 0), axis=(0, 0, 1))
    with pytest.raises(ModelError, match=match) as err:
        b.add_force("joint_friction", "fr", **kw)
    assert "forces['fr']" in str(err.value)
