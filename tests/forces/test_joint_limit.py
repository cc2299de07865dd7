"""Joint limits (forces/joint_limit.py): the coordinate's Jacobian row and the stop's energy
against finite differences, the restitution of each law against its closed form, every method
on one motion, located impact events, outputs, files and bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.forces.contact.laws import CHI, produced_restitution
from spatialmbd.outputs import force_outputs
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

from fd_check import q_along, random_state

JOINTS = {  # joint type, joint keywords, limit keywords (stops that most random states pass)
    "revolute": ("revolute", {}, dict(lower=2.5)),
    "translational": ("translational", {}, dict(upper=-0.5)),
    "cylindrical_angle": ("cylindrical", {}, dict(coordinate="angle", upper=-2.5)),
    "cylindrical_translation": ("cylindrical", {}, dict(coordinate="translation", lower=0.5)),
    "screw": ("screw", dict(pitch=0.1), dict(coordinate="angle", lower=-0.4, upper=0.2)),
    "cone": ("spherical", {}, dict(upper=0.3, axis_i=(0, 0, 1), axis_j=(0.2, 0.1, 1))),
}


def two_bodies(case, **law):
    jtype, jkw, lkw = JOINTS[case]
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(1.0, -0.5, 0.8))
    axis = {} if jtype == "spherical" else dict(axis=(0.3, 0.4, 1.0))
    b.add_joint(jtype, "j", "a", "b", point=(0.5, 0, 0.5), **axis, **jkw)
    b.add_force("joint_limit", "stop", joint="j", **lkw, **law)
    return b.compile()


def details(model, q, v):
    g = model.force_groups[0]
    return g.details(BodyState.from_qv(q, v, 0.0))[0]


@pytest.mark.parametrize("case", sorted(JOINTS))
def test_coordinate_rate_is_the_derivative_of_the_coordinate(case):
    """x' = D_x v (the kernel's Jacobian row) against the central difference of x along the
    motion, at random states (joints violated)."""
    model = two_bodies(case, law="linear", stiffness=100.0)
    rng = np.random.default_rng(3)
    h, checked = 1e-6, 0
    while checked < 10:
        q0, v = random_state(rng, 2)
        xp, xm = (details(model, q_along(q0, v, s), v)[3] for s in (h, -h))
        x0 = details(model, q0, v)
        if abs(xp - xm) > 0.5 or (case == "cone" and x0[3] < 1e-3):   # an angle's cut
            continue
        assert x0[4] == pytest.approx((xp - xm) / (2 * h), rel=1e-6, abs=1e-7)
        checked += 1


@pytest.mark.parametrize("case", sorted(JOINTS))
@pytest.mark.parametrize("law", [dict(law="linear", stiffness=300.0, damping=4.0),
                                 dict(law="hunt_crossley", stiffness=500.0, restitution=0.6)])
def test_power_is_minus_the_rate_of_the_potential_plus_the_dissipation(case, law):
    """The stop's power on the bodies g . v equals -dV/dt (V: its potential energy, by finite
    differences) plus the dissipated power it reports."""
    model = two_bodies(case, **law)
    group = model.force_groups[0]
    rng = np.random.default_rng(5)
    h, checked = 1e-6, 0
    while checked < 8:
        q0, v = random_state(rng, 2)
        state = BodyState.from_qv(q0, v, 0.0)
        d = group.details(state)
        if d[0, 0] > -1e-3 or abs(d[0, 0]) > 1.0:      # penetrated, away from an angle's cut
            continue
        g = np.zeros((3, 6))
        group.evaluate(state, 0.0, g)
        power = float(np.sum(g[:2] * v))
        V = [group.potential_energy(BodyState.from_qv(q_along(q0, v, s), None, 0.0), 0.0)
             for s in (h, -h)]
        dV = (V[0] - V[1]) / (2 * h)
        assert power == pytest.approx(-dV + group.nonconservative_power(state, 0.0), rel=1e-6,
                                      abs=1e-6)
        checked += 1


# ------------------------------------------------------------------------- closed forms
M, L_ARM, JC, W0 = 2.0, 0.5, 0.01, 2.0
I_PIN = JC + M * L_ARM ** 2                   # inertia about the pin


def rotor(joint="revolute", **law):
    """A pendulum swinging in the horizontal plane (gravity along the pin) at W0 rad/s onto a
    stop at 0.3 rad: gravity does no work, the stop meets a free coordinate of inertia
    I_PIN (a translational joint: the mass M at W0 m/s)."""
    b = ModelBuilder("stop", gravity=(0, 0, -9.81))
    if joint == "revolute":
        b.add_body("arm", M, (JC, JC, JC), r=(L_ARM, 0, 0), rdot=(0, L_ARM * W0, 0),
                   omega=(0, 0, W0))
        b.add_joint("revolute", "pin", "ground", "arm", point=(0, 0, 0), axis=(0, 0, 1))
    else:
        b.add_body("arm", M, (JC, JC, JC), r=(0, 0, 0), rdot=(W0, 0, 0))
        b.add_joint("translational", "pin", "ground", "arm", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("joint_limit", "stop", joint="pin", upper=0.3, **law)
    return b.compile()


def linear_restitution(K, c, inertia):
    """The rebound ratio of f = K delta + c delta' clipped at f >= 0 on a free inertia: the
    force vanishes at omega_d t = pi - phi, tan(phi) = 2 zeta sqrt(1 - zeta^2) / (1 - 2
    zeta^2), and the speed there is v0 exp(-zeta (pi - phi) / sqrt(1 - zeta^2))."""
    z = c / (2 * math.sqrt(K * inertia))
    phi = math.atan2(2 * z * math.sqrt(1 - z * z), 1 - 2 * z * z)
    return math.exp(-z * (math.pi - phi) / math.sqrt(1 - z * z)), z


@pytest.mark.parametrize("joint", ["revolute", "translational"])
def test_linear_stop_rebounds_with_the_kelvin_voigt_restitution(joint):
    K, c = 2000.0, 5.0
    inertia = I_PIN if joint == "revolute" else M
    res = simulate(rotor(joint, law="linear", stiffness=K, damping=c), 0.5, method="standard",
                   rtol=1e-11, atol=1e-12, output_step=0.05)
    assert res.success, res.message
    rate = res.v[-1, 0, 5] if joint == "revolute" else res.v[-1, 0, 0]
    e, zeta = linear_restitution(K, c, inertia)
    assert -rate / W0 == pytest.approx(e, abs=1e-7)
    # the stop never pulls: above the textbook dashpot value exp(-zeta pi / sqrt(1 - zeta^2))
    assert e > math.exp(-zeta * math.pi / math.sqrt(1 - zeta * zeta)) + 1e-3


@pytest.mark.parametrize("law", ["hunt_crossley", "lankarani_nikravesh", "flores", "gonthier",
                                 "carvalho_martins"])
def test_hysteresis_stops_rebound_with_their_produced_restitution(law):
    res = simulate(rotor(law=law, stiffness=2e4, restitution=0.7), 0.5, method="standard",
                   rtol=1e-11, atol=1e-12, output_step=0.05)
    assert res.success, res.message
    assert -res.v[-1, 0, 5] / W0 == pytest.approx(produced_restitution(CHI[law](0.7)),
                                                  abs=1e-7)
    # one located touch event, at the stop (0.3 rad at W0) with the approach speed W0
    assert len(res.contact_log) == 1
    t, row, v0 = res.contact_log[0]
    assert t == pytest.approx(0.3 / W0, abs=1e-12) and v0 == pytest.approx(W0, rel=1e-12)
    out = force_outputs(res, "stop")
    assert np.all(out["impact_velocity"][res.t >= t] == pytest.approx(W0))
    assert not np.any(out["active"][res.t < t - 1e-9])


METHODS = ["standard", "baumgarte", "penalty", "augmented_lagrangian", "projection"]


@pytest.mark.parametrize("law", [dict(law="linear", stiffness=3000.0, damping=8.0),
                                 dict(law="lankarani_nikravesh", stiffness=3e4, exponent=1.5,
                                      restitution=0.5)])
def test_every_method_gives_the_same_motion_and_the_energy_balance_closes(law):
    """A double pendulum under gravity whose elbow hits both stops: every body-coordinate
    method (and the recursive one for the linear law, which needs no impact memory) gives the
    same motion, and the energy balance (elastic energy of the stop, its dissipated work)
    closes."""
    b = ModelBuilder("double", gravity=(0, -9.81, 0))
    b.add_body("upper", 1.0, (0.01, 0.01, 0.02), r=(0.25, 0, 0))
    b.add_body("lower", 0.5, (0.005, 0.005, 0.01), r=(0.75, 0, 0))
    b.add_joint("revolute", "shoulder", "ground", "upper", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "elbow", "upper", "lower", point=(0.5, 0, 0), axis=(0, 0, 1))
    b.add_force("joint_limit", "elbow_stop", joint="elbow", lower=-0.6, upper=0.4, **law)
    model = b.compile()
    methods = METHODS + (["recursive"] if law["law"] == "linear" else [])
    runs = {m: simulate(model, 1.5, method=m, rtol=1e-10, atol=1e-12, output_step=0.05)
            for m in methods}
    ref = runs["standard"]
    out = force_outputs(ref, "elbow_stop")
    assert out["active"].sum() >= 2 and out["force"].max() > 0 and out["force"].min() < 0
    for m, res in runs.items():
        assert res.success, (m, res.message)
        tol = 1e-5 if m == "penalty" else 1e-7
        assert np.abs(res.q[:, :, :3] - ref.q[:, :, :3]).max() < tol, m
        en = res.energy()
        assert np.abs(en["error"]).max() < 10 * tol * np.abs(en["kinetic"]).max(), m


def test_recursive_method_refuses_a_limit_that_needs_the_impact_memory():
    model = rotor(law="hunt_crossley", stiffness=2e4, restitution=0.7)
    with pytest.raises(ModelError, match="events"):
        simulate(model, 0.2, method="recursive")


def test_cone_limit_holds_a_spherical_pendulum_inside_its_cone():
    """A spherical pendulum launched at 3 m/s (it would swing up about 0.46 m) with its axis
    0.25 rad inside a 0.3 rad cone (stiff linear stop): the stop engages and the angle between
    the axes stays within the penetration sqrt(2 T / K) ~ 0.01 rad of 0.3."""
    b = ModelBuilder("cone", gravity=(0, 0, -9.81))
    b.add_body("bob", 1.0, (0.01, 0.01, 0.01), r=(0, 0, -1.0))
    b.add_joint("spherical", "ball", "ground", "bob", point=(0, 0, 0))
    b.add_force("joint_limit", "cone", joint="ball", upper=0.3, axis_i=(0, 0, -1),
                axis_j=(math.sin(0.25), 0, -math.cos(0.25)), law="linear", stiffness=1e5,
                damping=20.0)
    res = simulate(b.compile(), 1.0, method="standard", rtol=1e-9, atol=1e-11,
                   output_step=0.01, v0=np.array([[0, 3.0, 0, 3.0, 0, 0]]))
    assert res.success, res.message
    out = force_outputs(res, "cone")
    assert out["active"].any() and out["coordinate"].max() < 0.3 + 0.02


# ------------------------------------------------------------------------------ files, input
def test_limit_reads_from_a_model_file():
    from spatialmbd.io import load_model
    data = {"spatialmbd": 1, "name": "m", "gravity": [0, 0, 0],
            "bodies": [{"name": "arm", "mass": 1.0, "inertia": [0.1, 0.1, 0.1]}],
            "joints": [{"name": "pin", "type": "revolute", "body_i": "ground",
                        "body_j": "arm", "point": [0, 0, 0], "axis": [0, 0, 1]}],
            "forces": [{"name": "stop", "type": "joint_limit", "joint": "pin", "lower": -1.0,
                        "upper": 1.0, "law": "flores", "stiffness": 1e4,
                        "restitution": 0.8}]}
    model, _ = load_model(data)
    assert model.force_groups[0].name == "joint_limit"


@pytest.mark.parametrize("kw, match", [
    (dict(joint="pin", lower=1.0, upper=0.5, stiffness=1.0), "lower = 1 must be less"),
    (dict(joint="nope", upper=0.5, stiffness=1.0), "unknown joint 'nope'"),
    (dict(joint="ball", upper=0.5, coordinate="angle", stiffness=1.0), "not a coordinate"),
    (dict(joint="uj", upper=0.5, stiffness=1.0), "is a universal joint"),
    (dict(joint="cyl", upper=0.5, stiffness=1.0), "say which"),
    (dict(joint="pin", stiffness=1.0), "lower and/or an upper"),
    (dict(joint="pin", upper=0.5), "stiffness"),
    (dict(joint="pin", upper=0.5, stiffness=1.0, law="hunt_crossley"), "restitution"),
    (dict(joint="pin", upper=0.5, stiffness=-1.0, law="linear"), "stiffness"),
    (dict(joint="ball", lower=0.1, upper=0.5, stiffness=1.0, law="linear"), "half-angle"),
    (dict(joint="pin", lower=-4.0, upper=3.0, stiffness=1.0, law="linear"), "less than a turn"),
])
def test_bad_limits_are_refused_naming_the_element(kw, match):
    b = ModelBuilder(gravity=(0, 0, 0))
    for n in ("a", "c", "d", "e"):
        b.add_body(n, 1.0, (1, 1, 1))
    b.add_joint("revolute", "pin", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("spherical", "ball", "ground", "c", point=(0, 0, 0))
    b.add_joint("universal", "uj", "ground", "d", point=(0, 0, 0), axis=(0, 0, 1),
                axis2=(1, 0, 0))
    b.add_joint("cylindrical", "cyl", "ground", "e", point=(0, 0, 0), axis=(0, 0, 1))
    with pytest.raises(ModelError, match=match) as err:
        b.add_force("joint_limit", "stop", **kw)
    assert "forces['stop']" in str(err.value)
