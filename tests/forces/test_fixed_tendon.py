"""Fixed tendon (forces.fixed_tendon): the generalized forces are F times the exact gradient of
L = sum c_m q_m over every joint's bodies (finite differences of L along random motions, the
spring's energy), the closed-form oscillation of rotors coupled by a tendon spring, the
actuator part, and bad input named."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fd_check import q_along, random_state

from spatialmbd.errors import ModelError
from spatialmbd.model import ModelBuilder
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState


def chain(**tendon):
    """Ground -revolute- a -translational- b -cylindrical- c, and a revolute ground-d: four
    joints over four moving bodies and the ground (a carrier a that moves)."""
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 1.0, (0.1, 0.2, 0.3), r=(0.2, 0, 0))
    b.add_body("b", 2.0, (0.2, 0.1, 0.3), r=(0.5, 0.1, 0))
    b.add_body("c", 1.5, (0.3, 0.2, 0.1), r=(0.7, 0.2, 0.1))
    b.add_body("d", 0.5, (0.1, 0.1, 0.1), r=(-0.3, 0, 0.2))
    b.add_joint("revolute", "j1", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "j2", "a", "b", point=(0.4, 0.05, 0), axis=(1, 0.2, 0))
    b.add_joint("cylindrical", "j3", "b", "c", point=(0.6, 0.2, 0), axis=(0.1, 0.3, 1))
    b.add_joint("revolute", "j4", "ground", "d", point=(-0.3, 0, 0), axis=(1, 0, 0.3))
    b.add_force("fixed_tendon", "t", **tendon)
    return b


JOINTS = dict(joints=["j1", "j2", "j3", "j4"], coefficients=[0.7, -2.0, 1.3, 0.4])


def _check_power(group, q0, v, F, Ld, h, rel, abs):
    """The power of the generalized forces g at (q0, v) is F L', and its conservative part is
    -dE/dt by central differences of the potential along the motion (step h); returns the two
    potentials."""
    state = BodyState.from_qv(q0, v, 0.0)
    g = np.zeros((5, 6))
    group.evaluate(state, 0.0, g)
    vv = np.concatenate([state.rdot, state.omega], axis=1)
    power = float(np.sum(g[:4] * vv[:4]))
    assert power == pytest.approx(F * Ld, rel=1e-9, abs=1e-10)
    E = [group.potential_energy(BodyState.from_qv(q_along(q0, v, dt), v, dt), 0.0)
         for dt in (-h, h)]
    assert power - group.nonconservative_power(state, 0.0) == pytest.approx(
        -(E[1] - E[0]) / (2 * h), rel=rel, abs=abs)
    return E


@pytest.mark.parametrize("translation", [False, True])
def test_generalized_force_is_the_tendon_force_on_the_gradient_of_its_length(translation):
    """Along random (unconstrained) motions: the power of g equals F L' with L' the central
    difference of L, and for a spring alone g . v = -dE/dt (E = k (L - L0)^2 / 2)."""
    extra = {"coordinates": {"j3": "translation"}} if translation else {}
    model = chain(**JOINTS, **extra, stiffness=30.0, rest_length=0.2, damping=0.0,
                  command=0.8, gain=2.5, bias=[0.1, -3.0, 0.0]).compile()
    group = model.force_groups[0]
    rng = np.random.default_rng(7)
    for _ in range(10):
        q0, v = random_state(rng, 4)
        h = 1e-5

        def at(dt):
            return group.details(BodyState.from_qv(q_along(q0, v, dt), v, dt), 0.0)[0]
        L, Ld, f, F = at(0.0)
        Lp, Lm = at(h)[0], at(-h)[0]
        assert Ld == pytest.approx((Lp - Lm) / (2 * h), rel=1e-7, abs=1e-8)
        assert f == pytest.approx(2.5 * 0.8 + 0.1 - 3.0 * L, rel=1e-12)
        assert F == pytest.approx(f - 30.0 * (L - 0.2), rel=1e-12)
        _check_power(group, q0, v, F, Ld, h, rel=1e-6, abs=1e-8)


def rotors(coefs, inertias, **tendon):
    b = ModelBuilder(gravity=(0, 0, -9.81))
    for m, inertia in enumerate(inertias):
        b.add_body(f"r{m}", 1.0, (inertia, 0.5, 0.5), r=(m, 0, 0))
        b.add_joint("revolute", f"h{m}", "ground", f"r{m}", point=(m, 0, 0), axis=(1, 0, 0))
    b.add_force("fixed_tendon", "t", joints=[f"h{m}" for m in range(len(coefs))],
                coefficients=list(coefs), **tendon)
    return b


def angles(res, n):
    """Each rotor's angle about x from its body's y axis."""
    from spatialmbd.rotations import A_from_p
    out = np.zeros((len(res.t), n))
    for k in range(len(res.t)):
        for m in range(n):
            A = A_from_p(res.q[k, m, 3:])
            out[k, m] = math.atan2(A[2, 1], A[1, 1])
    return np.unwrap(out, axis=0)


@pytest.mark.parametrize("method", ["standard", "recursive"])
def test_rotors_on_a_tendon_spring_oscillate_at_the_closed_form_frequency(method):
    """Three rotors I_m on hinges, L = sum c_m q_m, spring k towards L0 from L = 0 at rest:
    I_m q_m'' = -c_m k (L - L0), so L - L0 = -L0 cos(w t), w^2 = k sum c_m^2 / I_m, and
    q_m = (c_m / I_m) / (sum c^2 / I) L0 (1 - cos w t)."""
    coefs, inertias, k, L0 = (1.0, -0.5, 2.0), (0.2, 0.1, 0.4), 8.0, 0.3
    model = rotors(coefs, inertias, stiffness=k, rest_length=L0).compile()
    t = np.linspace(0, 2, 41)
    res = simulate(model, 2.0, t_eval=t, method=method, integrator="rk45", rtol=1e-11,
                   atol=1e-12)
    assert res.status == "success", res.message
    q = angles(res, 3)
    s = sum(c * c / i for c, i in zip(coefs, inertias))
    w = math.sqrt(k * s)
    for m, (c, inertia) in enumerate(zip(coefs, inertias)):
        expected = c / inertia / s * L0 * (1 - np.cos(w * t))
        assert np.abs(q[:, m] - expected).max() < 1e-8
    from spatialmbd.outputs import force_outputs
    out = force_outputs(res, "t")                # L, L', actuator force, tendon force
    assert np.abs(out["length"] - L0 * (1 - np.cos(w * t))).max() < 1e-8
    assert np.abs(out["force"] + k * (out["length"] - L0)).max() < 1e-10
    energy = res.energy()                       # the spring's energy closes the balance
    assert energy["elastic"].max() > 0.1
    assert np.abs(energy["error"]).max() < 1e-8


def test_tendon_actuator_accelerates_each_joint_by_its_coefficient():
    """A motor on the tendon (gain 2, command 1.5, force range 2.5): F = 2.5 (clipped),
    q_m'' = c_m F / I_m."""
    coefs, inertias = (1.0, -3.0), (0.2, 0.5)
    model = rotors(coefs, inertias, gain=2.0, command=1.5, forcerange=[-2.5, 2.5]).compile()
    t = np.linspace(0, 0.5, 11)
    res = simulate(model, 0.5, t_eval=t, integrator="rk45", rtol=1e-11, atol=1e-12)
    q = angles(res, 2)
    for m, (c, inertia) in enumerate(zip(coefs, inertias)):
        assert np.abs(q[:, m] - 0.5 * c * 2.5 / inertia * t ** 2).max() < 1e-9


@pytest.mark.parametrize("params, match", [
    (dict(joints=["j1", "nope"], coefficients=[1, 1]),
     r"forces\['t2'\]\.joints: unknown joint 'nope'"),
    (dict(joints=["j1", "j2"], coefficients=[1]),
     r"coefficients: give one finite number per joint \(2\)"),
    (dict(joints=["j1"] * 5, coefficients=[1] * 5), r"joints: give a list of 1 to 4"),
    (dict(joints=["j1", "j1"], coefficients=[1, 2]), r"'j1'.*appears twice|appears twice"),
    (dict(joints=["j1"], coefficients=[1], stiffness=-1), r"stiffness: must be >= 0"),
    (dict(joints=["j1"], coefficients=[1], ctrlrange=[1, -1]), r"ctrlrange: lower 1.0 > upper"),
    (dict(joints=["j1"], coefficients=[1], bias=[1, 2]), r"bias: give \[b0, b1, b2\]"),
    (dict(joints=["s"], coefficients=[1]), r"joint 's' is a spherical joint"),
    (dict(joints=["j1"], coefficients=[1], range=[0.2, -0.2], limit_stiffness=1.0),
     r"range: lower 0.2 > upper -0.2"),
    (dict(joints=["j1"], coefficients=[1], range=[-0.2, 0.2]), r"needs limit_stiffness="),
    (dict(joints=["j1"], coefficients=[1], range=[-0.2, 0.2], limit_stiffness=0),
     r"limit_stiffness: must be > 0"),
    (dict(joints=["j1"], coefficients=[1], limit_stiffness=10.0), r"without range has no limit"),
    (dict(joints=["j1"], coefficients=[1], frictionloss=-1.0), r"frictionloss: must be >= 0"),
    (dict(joints=["j1"], coefficients=[1], rest_length=[0.2, 0.1]),
     r"rest_length: lower 0.2 > upper"),
    (dict(joints=["j1"], coefficients=[1], frictionloss=1.0, creep_velocity=0),
     r"creep_velocity: must be > 0"),
])
def test_bad_input_names_the_element(params, match):
    b = chain(**JOINTS)
    b.add_body("e", 1.0, (0.1, 0.1, 0.1), r=(0, 1, 0))
    b.add_joint("spherical", "s", "ground", "e", point=(0, 1, 0))
    with pytest.raises(ModelError, match=match):
        b.add_force("fixed_tendon", "t2", **params)
        b.compile()


@pytest.mark.parametrize("side", ["lower", "upper"])
def test_limit_force_is_the_stop_on_the_gradient_of_the_length(side):
    """With the limit passed (L below lo or above hi): F = +-max(K delta + C delta', 0), the
    power of g is F L', and its conservative part is -dV/dt of V = K delta^2 / 2 (central
    differences along random motions, the spring and actuator off)."""
    lo, hi = (0.6, 5.0) if side == "lower" else (-5.0, -0.6)
    model = chain(**JOINTS, range=[lo, hi], limit_stiffness=400.0,
                  limit_damping=3.0).compile()
    group = model.force_groups[0]
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(40):
        q0, v = random_state(rng, 4)
        h = 1e-6
        state = BodyState.from_qv(q0, v, 0.0)
        L, Ld, f, F = group.details(state, 0.0)[0]
        if not (L < lo if side == "lower" else L > hi):
            continue
        delta, rate = (lo - L, -Ld) if side == "lower" else (L - hi, Ld)
        expect = max(400.0 * delta + 3.0 * rate, 0.0) * (1.0 if side == "lower" else -1.0)
        assert F == pytest.approx(expect, rel=1e-12, abs=1e-12)
        E = _check_power(group, q0, v, F, Ld, h, rel=1e-5, abs=1e-7)
        assert E[0] >= 0.0 and E[1] >= 0.0
        checked += 1
    assert checked >= 5


def test_slider_rests_on_its_tendon_limit_at_the_closed_form_compression():
    """A 2 kg slider on a vertical translational joint, its tendon L = 0.5 x limited below at
    lo = -0.1: at rest on the stop 0.5 K delta = m g (the stop's force c F on the joint), so
    x = (lo - delta) / 0.5 with delta = 2 m g / K; released at rest 0.2 m above it, it lands
    and settles there (the limit's damping), and the energy balance closes."""
    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("s", 2.0, (0.1, 0.1, 0.1), r=(0, 0, 0))
    b.add_joint("translational", "x", "ground", "s", point=(0, 0, 0), axis=(0, 0, 1))
    K, C = 2e4, 400.0          # on x: 5,000 N/m and 100 N s/m, damping ratio 0.5
    b.add_force("fixed_tendon", "t", joints=["x"], coefficients=[0.5], range=[-0.1, 1.0],
                limit_stiffness=K, limit_damping=C)
    model = b.compile()
    res = simulate(model, 3.0, method="standard", integrator="rk45", rtol=1e-10, atol=1e-12,
                   output_step=0.01)
    assert res.status == "success"
    delta = 2.0 * 2.0 * 9.81 / K
    x_rest = (-0.1 - delta) / 0.5
    z = res.q[:, 0, 2]
    assert z.min() < x_rest                              # it did land on the stop
    assert z[-1] == pytest.approx(x_rest, abs=1e-9)
    e = res.energy()
    assert abs(e["error"]).max() < 1e-6 * abs(e["work_nonconservative"][-1])



def slider(angle_deg=90.0, speed=0.0, **tendon):
    """A 2 kg slider on a translational joint inclined angle_deg from the horizontal, started
    at ``speed`` along it, its tendon L = 0.5 x."""
    a = math.radians(angle_deg)
    axis = (math.cos(a), 0.0, math.sin(a))
    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("s", 2.0, (0.1, 0.1, 0.1), r=(0, 0, 0), rdot=tuple(speed * x for x in axis))
    b.add_joint("translational", "x", "ground", "s", point=(0, 0, 0), axis=axis)
    b.add_force("fixed_tendon", "t", joints=["x"], coefficients=[0.5], **tendon)
    return b.compile()


def test_tendon_friction_creeps_at_the_closed_form_speed_and_stops_a_slide():
    """Tendon friction -F tanh(L' / v_eps) on L = 0.5 x: (1) a vertical slider held by a level
    F above its weight's 2 m g creeps at the steady L' = -v_eps atanh(2 m g / F); (2) a
    horizontal one started at 1 m/s stops after m v0^2 / (2 (0.5 F)) (less the tail of the
    regularization, of order v_eps / v0 relative), dissipating its kinetic energy."""
    m, g = 2.0, 9.81
    F, v_eps = 3.0 * 2.0 * m * g, 1e-3
    res = simulate(slider(frictionloss=F, creep_velocity=v_eps), 1.0, method="standard",
                   integrator="rk45", rtol=1e-10, atol=1e-12, output_step=0.01)
    Ld = 0.5 * res.v[-1, 0, 2]
    assert Ld == pytest.approx(-v_eps * math.atanh(2.0 * m * g / F), rel=1e-6)
    F = 8.0
    res = simulate(slider(0.0, 1.0, frictionloss=F, creep_velocity=1e-6), 1.0,
                   method="standard", integrator="rk45", rtol=1e-10, atol=1e-12,
                   output_step=0.01)
    stop = m * 1.0 ** 2 / (2 * 0.5 * F)                  # 0.25 m after 0.5 s
    assert res.q[-1, 0, 0] == pytest.approx(stop, rel=1e-4)
    assert abs(res.v[-1, 0, 0]) < 1e-5
    e = res.energy()
    assert e["work_nonconservative"][-1] == pytest.approx(-0.5 * m, rel=1e-6)
    assert abs(e["error"]).max() < 1e-8


def test_spring_dead_band_holds_no_force_inside_and_rests_at_its_edge():
    """rest_length [a, b]: no spring force for a <= L <= b, k (L - b) above, k (L - a) below
    (force outputs at set states); a vertical slider (load 2 m g on L = 0.5 x) hung on it
    with damping settles at the band's lower edge stretched by the closed form 2 m g / k."""
    model = slider(stiffness=500.0, damping=150.0, rest_length=[-0.05, 0.02])  # overdamped
    group = model.force_groups[0]
    for x, expect in ((0.0, 0.0), (0.03, 0.0), (0.1, -500.0 * (0.05 - 0.02)),
                      (-0.2, -500.0 * (-0.1 + 0.05))):
        q = np.array([[0.0, 0.0, x, 1.0, 0.0, 0.0, 0.0]])
        F = group.details(BodyState.from_qv(q, np.zeros((1, 6)), 0.0), 0.0)[0][3]
        assert F == pytest.approx(expect, abs=1e-12), x
    res = simulate(model, 6.0, method="standard", integrator="rk45", rtol=1e-10, atol=1e-12,
                   output_step=0.01)
    L = 0.5 * res.q[-1, 0, 2]
    assert L == pytest.approx(-0.05 - 2.0 * 2.0 * 9.81 / 500.0, abs=1e-8)
    e = res.energy()
    assert abs(e["error"]).max() < 1e-7
