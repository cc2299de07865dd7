"""Force kernels against finite differences: the power of each element equals minus the rate
of its potential energy (conservative parts) or the stated non-conservative power."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.motion import Harmonic
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

from fd_check import q_along, random_state


def two_bodies():
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(1.0, -0.5, 0.8))
    b.add_joint("revolute", "hinge", "a", "b", point=(0.5, 0, 0.5), axis=(0.3, 0.4, 1.0))
    return b


def generalized(model, state, t):
    g = np.zeros((model.nb + 1, 6))
    for group in model.force_groups:
        group.evaluate(state, t, g)
    return g[:model.nb]


def power(model, q, v, t):
    state = BodyState.from_qv(q, v, t)
    return float(np.sum(generalized(model, state, t) * v.reshape(model.nb, 6)))


def potential(model, q, t):
    state = BodyState.from_qv(q, None, t)
    return sum(g.potential_energy(state, t) for g in model.force_groups)


@pytest.mark.parametrize("nonlinear", [None, [30.0, -20.0, 15.0]])
@pytest.mark.parametrize("kind", ["spring_damper", "rotational_spring_damper"])
def test_conservative_part_is_minus_gradient_of_potential(kind, nonlinear):
    """Also for a nonlinear stiffness k + k1 |d| + k2 d^2 + k3 |d|^3 (potential
    k d^2/2 + k1 |d|^3/3 + k2 d^4/4 + k3 |d|^5/5)."""
    b = two_bodies()
    extra = {} if nonlinear is None else {"nonlinear_stiffness": nonlinear}
    if kind == "spring_damper":
        b.add_force("spring_damper", "s", body_i="a", body_j="b", point_i=(0.2, 0.1, 0),
                    point_j=(-0.1, 0.3, 0.2), stiffness=50.0, natural_length=0.4, **extra)
    else:
        b.add_force("rotational_spring_damper", "s", joint="hinge", stiffness=7.0,
                    rest_angle=0.1, **extra)
    model = b.compile()
    rng = np.random.default_rng(1)
    for _ in range(10):
        q0, v = random_state(rng, 2)
        q0[1, :3] = q0[0, :3] + rng.uniform(0.5, 1.0) * rng.normal(size=3)
        h = 1e-5
        dV = (potential(model, q_along(q0, v, h), 0.0)
              - potential(model, q_along(q0, v, -h), 0.0)) / (2 * h)
        assert power(model, q0, v, 0.0) == pytest.approx(-dV, rel=1e-6, abs=1e-7)


@pytest.mark.parametrize("kind", ["spring_damper", "rotational_spring_damper", "point_force",
                                  "torque"])
def test_nonconservative_power_is_the_power_of_the_forces(kind):
    b = two_bodies()
    if kind == "spring_damper":
        b.add_force("spring_damper", "s", body_i="a", body_j="b", point_i=(0.2, 0.1, 0),
                    point_j=(-0.1, 0.3, 0.2), damping=3.0, actuator=Harmonic(2.0, 1.0))
    elif kind == "rotational_spring_damper":
        b.add_force("rotational_spring_damper", "s", joint="hinge", damping=2.0,
                    actuator=Harmonic(1.5, 2.0, 0.3))
    elif kind == "point_force":
        b.add_force("point_force", "f", body="b", point=(0.3, -0.2, 0.1), direction=(0, 1, 2),
                    frame="body", magnitude=Harmonic(3.0, 1.0, 0.2))
    else:
        b.add_force("torque", "n", body="a", direction=(1, 0, 1), magnitude=2.5)
    model = b.compile()
    rng = np.random.default_rng(2)
    for _ in range(10):
        q0, v = random_state(rng, 2)
        q0[1, :3] = q0[0, :3] + rng.uniform(0.5, 1.0) * rng.normal(size=3)
        t = rng.uniform(0, 2)
        state = BodyState.from_qv(q0, v, t)
        p_nc = sum(g.nonconservative_power(state, t) for g in model.force_groups)
        assert power(model, q0, v, t) == pytest.approx(p_nc, rel=1e-12, abs=1e-12)


def test_spring_damper_signs_and_rate():
    """A stretched spring pulls the points together; ldot (11.8) is the FD rate of the length."""
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 1.0, (1, 1, 1), r=(0, 0, 0))
    b.add_body("b", 1.0, (1, 1, 1), r=(2, 0, 0))
    b.add_force("spring_damper", "s", body_i="a", body_j="b", stiffness=10.0, natural_length=1.0)
    model = b.compile()
    state = BodyState.from_qv(model.q0, None, 0.0)
    g = generalized(model, state, 0.0)
    assert np.allclose(g[0, :3], [10.0, 0, 0]) and np.allclose(g[1, :3], [-10.0, 0, 0])
    # the kernel's length and rate, read through its energy (k = 2, l0 = 0: V = l^2) and its
    # non-conservative power (c = 0, unit actuator force: P = -ldot)
    b.add_force("spring_damper", "probe", body_i="a", body_j="b", stiffness=2.0,
                natural_length=0.0, actuator=1.0)
    probe = b.compile().force_groups[0]
    rng = np.random.default_rng(3)
    q0, v = random_state(rng, 2)
    h = 1e-6

    def length(q):
        state = BodyState.from_qv(q, None, 0.0)
        return np.sqrt(probe._run(state, 0.0)[1][1])
    rate = (length(q_along(q0, v, h)) - length(q_along(q0, v, -h))) / (2 * h)
    ldot = -probe._run(BodyState.from_qv(q0, v, 0.0), 0.0)[2][1]
    assert ldot == pytest.approx(rate, rel=1e-7)


def test_user_force_and_gravity_enter_g():
    from spatialmbd.dynamics import EquationsOfMotion

    def push(t, q, v):
        f = np.zeros((1, 3))
        f[0, 0] = 2.0 * t
        return f, np.zeros((1, 3))

    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("a", 3.0, (1, 2, 2.5), omega=(0.3, -0.2, 0.5))
    b.add_force("user", "push", function=push)
    model = b.compile()
    eom = EquationsOfMotion(model)
    ev = eom.evaluate(1.5, model.q0, model.v0.reshape(-1))
    assert np.allclose(ev.g[:3], [3.0, 0, -3.0 * 9.81])
    J = np.diag([1.0, 2.0, 2.5])
    w = np.array([0.3, -0.2, 0.5])
    assert np.allclose(ev.g[3:], -np.cross(w, J @ w))                 # gyroscopic (10.4)


@pytest.mark.parametrize("method", ["standard", "projection"])
def test_every_compiled_force_type_balances_energy_in_the_fused_right_hand_side(method):
    """Ground-attached and body-body elements of every compiled type, time-dependent laws
    included, plus a Python user force: the work integrated in the right-hand side balances
    the kinetic and potential energy to integrator tolerance."""
    from spatialmbd.simulate import simulate
    b = ModelBuilder("edge", gravity=(0, 0, -9.81))
    b.add_body("a", 2.0, (0.1, 0.2, 0.25), r=(0, 0.5, 0))
    b.add_body("c", 1.0, (0.05, 0.06, 0.07), r=(0.3, 1.2, -0.2), bryant=(0.2, 0.1, -0.3))
    b.add_joint("revolute", "pin", "ground", "a", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("rotational_spring_damper", "rs", joint="pin", stiffness=30.0, damping=0.3,
                rest_angle=0.2)
    b.add_force("spring_damper", "sg", body_i="ground", body_j="a", point_i=(0, 1, 1),
                point_j=(0, 0.5, 0), stiffness=40.0, damping=0.5)
    b.add_force("bushing", "bu", body_i="a", body_j="c", point_i=(0.3, 0.7, -0.2),
                stiffness=(300, 200, 100), damping=0.5, rotational_stiffness=(5, 6, 7),
                rotational_damping=0.02)
    b.add_force("bushing", "bg", body_i="c", body_j="ground", stiffness=50.0,
                rotational_stiffness=2.0)
    b.add_force("point_force", "pf", body="c", point=(0.1, 0, 0), direction=(0, 0, 1),
                frame="body", magnitude=Harmonic(3.0, 2.0))
    b.add_force("torque", "tq", body="a", direction=(1, 0, 0), magnitude=Harmonic(1.0, 3.0, 0.5))
    b.add_force("user", "drag", function=lambda t, q, v: (-0.2 * v[:, :3], -0.01 * v[:, 3:]))
    model = b.compile()
    res = simulate(model, 1.0, method=method, integrator="rk45", rtol=1e-10, atol=1e-12,
                   output_step=0.01)
    assert res.success, res.message
    energy = res.energy()
    assert np.abs(energy["error"]).max() < 1e-8 * np.abs(energy["kinetic"]).max()


def test_zero_length_spring_damper_starts_at_coincident_points():
    """A spring-damper of zero free length whose points coincide at the start (Project
    Chrono's TranSpring_Case01 set-up): the direction there is the limit along the motion,
    so the body launched along x from the anchor is the damped oscillator
    m x'' = -k x - c x', x(0) = 0, x'(0) = v0, through the anchor at every half period."""
    m, k, c, v0 = 2.0, 50.0, 1.5, 0.8
    b = ModelBuilder("zero_length", gravity=(0.0, 0.0, 0.0))
    b.add_body("a", m, (0.1, 0.1, 0.1), r=(0.3, -0.2, 0.5), rdot=(v0, 0.0, 0.0))
    b.add_force("spring_damper", "s", body_i="ground", body_j="a", point_i=(0.3, -0.2, 0.5),
                stiffness=k, damping=c)                     # natural length: assembled, 0
    model = b.compile()
    assert model.force_groups[0].l0[0] == 0.0
    res = simulate(model, 3.0, output_step=0.01, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    w = np.sqrt(k / m)
    zeta = c / (2.0 * np.sqrt(k * m))
    wd = w * np.sqrt(1.0 - zeta ** 2)
    x = v0 / wd * np.exp(-zeta * w * res.t) * np.sin(wd * res.t)
    r = res.q[:, 0, :3] - np.array([0.3, -0.2, 0.5])
    assert np.abs(r[:, 0] - x).max() < 1e-8
    assert np.abs(r[:, 1:]).max() < 1e-12
    # the element's power balances the energy: T + V_spring + damper work constant
    en = res.energy()
    assert np.abs(en["error"]).max() < 1e-8


def test_zero_length_with_a_free_length_is_still_refused():
    """Coincident points of a spring with l0 > 0: the direction of its force k l0 is undefined
    and the run stops, naming the element."""
    b = ModelBuilder("zero_length_l0", gravity=(0.0, 0.0, 0.0))
    b.add_body("a", 1.0, (0.1, 0.1, 0.1), r=(0.0, 0.0, 0.0))
    b.add_force("spring_damper", "spring1", body_i="ground", body_j="a", stiffness=5.0,
                natural_length=0.2)
    res = simulate(b.compile(), 0.1)
    assert res.status == "failed" and "spring_damper: spring1" in res.message


def test_zero_length_spring_damper_holds_a_body_dropped_from_its_anchor():
    """Project Chrono's TranSpring_Case01: the body at rest on the anchor of a zero-length
    spring-damper (k = 10 N/m, c = 0.5 N s/m, m = 1 kg), released under gravity: at t = 0 the
    points coincide at rest (no spring force), then z(t) follows
    m z'' = -k z - c z' - m g from z = 0, z' = 0."""
    m, k, c, g = 1.0, 10.0, 0.5, 9.80665
    b = ModelBuilder("tran_spring_case01", gravity=(0.0, 0.0, -g))
    b.add_body("pendulum", m, (0.04, 0.1, 0.1), r=(0.0, 0.0, 0.0))
    b.add_force("spring_damper", "spring", body_i="pendulum", body_j="ground",
                stiffness=k, damping=c)
    res = simulate(b.compile(), 5.0, output_step=0.01, rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    w, zeta = np.sqrt(k / m), c / (2.0 * np.sqrt(k * m))
    wd = w * np.sqrt(1.0 - zeta ** 2)
    z = -m * g / k * (1.0 - np.exp(-zeta * w * res.t) * (np.cos(wd * res.t)
                                                         + zeta * w / wd * np.sin(wd * res.t)))
    assert np.abs(res.q[:, 0, 2] - z).max() < 1e-8
    assert np.abs(res.q[:, 0, :2]).max() == 0.0 and np.abs(res.v[:, 0, 3:]).max() == 0.0
    # the outputs, from the coincident start on: no force at rest, then k |z| + c |z'|
    from spatialmbd.outputs import force_outputs
    out = force_outputs(res, "spring")
    assert np.all(np.isfinite(out["force"])) and out["force"][0] == 0.0
    zd = res.v[:, 0, 2]
    assert np.allclose(out["force"][1:], k * np.abs(res.q[1:, 0, 2]) + c * np.sign(
        res.q[1:, 0, 2]) * zd[1:], rtol=1e-10, atol=1e-12)


def test_nonlinear_spring_force_law_and_its_outputs():
    """A body on a vertical spring of stiffness k + k1 |d| + k3 |d|^3: the force the kernel
    applies at a given deflection is k(d) d, the outputs report the same force and energy, and
    a run conserves T + V_g + V_e."""
    from spatialmbd.outputs import force_outputs
    k, k1, k3 = 200.0, 50.0, 4e3
    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("m", 2.0, (0.1, 0.1, 0.1), r=(0, 0, -0.5))
    b.add_joint("translational", "guide", "ground", "m", point=(0, 0, -0.5), axis=(0, 0, 1))
    b.add_force("spring_damper", "s", body_i="ground", body_j="m", point_i=(0, 0, 0),
                point_j=(0, 0, 0), stiffness=k, nonlinear_stiffness=[k1, 0.0, k3],
                natural_length=0.4)
    model = b.compile()
    d = 0.1
    g = generalized(model, BodyState.from_qv(model.q0, np.zeros((1, 6)), 0.0), 0.0)
    assert g[0, 2] == pytest.approx((k + k1 * d + k3 * d**3) * d, rel=1e-14)   # pulls up
    res = simulate(model, 1.0, output_step=0.01, rtol=1e-10, atol=1e-12)
    out = force_outputs(res, "s")
    dd = out["deflection"]
    assert np.allclose(out["force"], (k + k1 * np.abs(dd) + k3 * np.abs(dd)**3) * dd,
                       rtol=1e-12, atol=1e-9)
    assert np.allclose(out["energy"], k * dd**2 / 2 + k1 * np.abs(dd)**3 / 3
                       + k3 * np.abs(dd)**5 / 5, rtol=1e-12, atol=1e-12)
    en = res.energy()
    assert np.abs(en["total"] - en["total"][0]).max() < 1e-7
    assert np.abs(en["elastic"] - out["energy"]).max() < 1e-12


@pytest.mark.parametrize("value", [[1.0, 2.0, 3.0, 4.0], ["a"], [np.nan], [[1.0, 2.0]], []])
def test_bad_nonlinear_stiffness_is_refused_naming_the_element(value):
    from spatialmbd.errors import ModelError
    b = two_bodies()
    with pytest.raises(ModelError, match=r"forces\['s'\].nonlinear_stiffness: give 1 to 3"):
        b.add_force("rotational_spring_damper", "s", joint="hinge", stiffness=7.0,
                    nonlinear_stiffness=value)
        b.compile()
