"""Actuators on joint coordinates (spatialmbd.forces.actuators): the effort through the
coordinate's exact Jacobian row (finite differences), closed forms (PD step response, saturated
motor, velocity servo, gear ratio), the energy balance with actuator work, every method alike,
bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fd_check import q_along, random_state
from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.motion import ConstantVelocity, Harmonic
from spatialmbd.outputs import force_outputs, joint_coordinates
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

I_ROTOR = 0.2        # kg m^2 about the joint axis


def rotor(**servo):
    """A rotor on a revolute joint about x (inertia I_ROTOR about it), no gravity, with one
    actuator ``servo`` = dict(type=..., ...) named "act"."""
    b = ModelBuilder("rotor", gravity=(0, 0, 0))
    b.add_body("rotor", mass=1.0, inertia=(I_ROTOR, 1.0, 1.0), position=(0, 0, 0))
    b.add_joint("revolute", "pivot", "ground", "rotor", point=(0, 0, 0), axis=(1, 0, 0))
    kind = servo.pop("type")
    b.add_force(kind, "act", joint="pivot", **servo)
    return b.compile()


def angle(res):
    return joint_coordinates(res, "pivot")["angle"]


def run(model, t_end=2.0, method="projection", **kw):
    kw.setdefault("output_step", 0.05)
    res = simulate(model, t_end=t_end, method=method, rtol=1e-11, atol=1e-12, **kw)
    assert res.status == "success", res.message
    return res


def pd_step(t, target, kp, kv, inertia):
    """Angle of I theta'' = kp (target - theta) - kv theta' from rest at 0 (underdamped)."""
    wn = math.sqrt(kp / inertia)
    zeta = kv / (2.0 * math.sqrt(kp * inertia))
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    return target * (1.0 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(
        1.0 - zeta * zeta) * np.sin(wd * t)))


# ------------------------------------------------------------------------- Jacobian row
@pytest.mark.parametrize("jtype, coordinate", [("revolute", "angle"),
                                               ("translational", "translation"),
                                               ("cylindrical", "angle"),
                                               ("cylindrical", "translation")])
def test_effort_acts_through_the_exact_jacobian_row(jtype, coordinate):
    """The generalized forces of an actuator of effort tau do the power tau q' with q' the
    finite-difference rate of its coordinate along random (unconstrained) motions: g = tau D_q^T
    with D_q the gradient of q."""
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 1.0, (1, 1, 1), r=(0, 0, 0))
    b.add_body("b", 1.0, (1, 1, 1), r=(0.3, 0.2, 0.1))
    b.add_joint(jtype, "j", "a", "b", point=(0.1, 0.1, 0), axis=(0.3, 1, 0.2))
    b.add_force("motor", "m", joint="j", coordinate=coordinate, gear=2.5, command=1.3)
    model = b.compile()
    group = model.force_groups[0]
    rng = np.random.default_rng(4)
    for _ in range(10):
        q0, v = random_state(rng, 2)
        h = 1e-5

        def q_at(dt):
            return group.details(BodyState.from_qv(q_along(q0, v, dt), v, dt), 0.0)[0, 0]
        dq = q_at(h) - q_at(-h)
        if coordinate == "angle":
            dq = (dq + math.pi) % (2 * math.pi) - math.pi
        state = BodyState.from_qv(q0, v, 0.0)
        g = np.zeros((3, 6))
        group.evaluate(state, 0.0, g)
        vv = np.concatenate([state.rdot, state.omega], axis=1)
        tau = 2.5 * 1.3
        assert float(np.sum(g[:2] * vv[:2])) == pytest.approx(tau * dq / (2 * h), rel=1e-7,
                                                              abs=1e-8)
        assert group.nonconservative_power(state, 0.0) == pytest.approx(
            float(np.sum(g[:2] * vv[:2])), rel=1e-12, abs=1e-12)


# ------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("method", ["standard", "baumgarte", "penalty", "augmented_lagrangian",
                                    "projection", "recursive"])
def test_pd_servo_step_response_is_the_second_order_closed_form(method):
    """I theta'' = kp (0.5 - theta) - kv theta': wn = sqrt(kp / I), zeta = kv / (2 sqrt(kp I)),
    to integration accuracy in every method."""
    kp, kv = 20.0, 1.0
    model = rotor(type="position_servo", kp=kp, kv=kv, reference=0.5)
    res = run(model, method=method)
    err = np.abs(angle(res) - pd_step(res.t, 0.5, kp, kv, I_ROTOR)).max()
    assert err < 1e-8 if method in ("penalty", "augmented_lagrangian") else err < 2e-10
    assert np.abs(res.energy()["error"]).max() < 1e-9


def test_saturated_motor_accelerates_at_its_force_limit():
    """command 10 N m, forcerange [-2, 2]: theta = (2 / I) t^2 / 2 exactly; the command and
    the effort are reported as clipped and the power is effort * theta'."""
    model = rotor(type="motor", command=10.0, forcerange=[-2.0, 2.0])
    res = run(model, t_end=1.0, outputs=["forces"])
    exact = 0.5 * (2.0 / I_ROTOR) * res.t ** 2
    assert np.abs(angle(res) - exact).max() < 1e-11 * max(1.0, exact.max())
    out = force_outputs(res, "act")
    assert np.allclose(out["effort"], 2.0) and np.allclose(out["command"], 10.0)
    assert np.allclose(out["power"], 2.0 * (2.0 / I_ROTOR) * res.t, rtol=1e-10, atol=1e-10)
    assert np.abs(res.energy()["error"]).max() < 1e-9


def test_gear_ratio_and_command_range():
    """effort = gear * clip(command, ctrlrange): gear 3, command 0.5 clipped to 0.2 -> 0.6 N m;
    a negative gear reverses it."""
    for gear, effort in ((3.0, 0.6), (-3.0, -0.6)):
        model = rotor(type="motor", command=0.5, gear=gear, ctrlrange=[-0.2, 0.2])
        res = run(model, t_end=1.0)
        exact = 0.5 * effort / I_ROTOR * res.t ** 2
        assert np.abs(angle(res) - exact).max() < 1e-11 * max(1.0, np.abs(exact).max()) * 5


def test_geared_position_servo_acts_on_the_actuator_coordinate():
    """gear G: L = G theta, f = kp (u - L) - kv L', effort G f: the joint sees the stiffness
    kp G^2 and damping kv G^2 and settles at u / G (MuJoCo's joint transmission)."""
    gear, kp, kv = 2.0, 5.0, 0.25
    model = rotor(type="position_servo", kp=kp, kv=kv, reference=1.0, gear=gear)
    res = run(model)
    expected = pd_step(res.t, 1.0 / gear, kp * gear ** 2, kv * gear ** 2, I_ROTOR)
    assert np.abs(angle(res) - expected).max() < 2e-10


def test_velocity_servo_first_order_response():
    """I omega' = kv (w_ref - omega): omega = w_ref (1 - exp(-kv t / I)); a reference of 10
    rad/s winds the rotor through several turns."""
    kv, w_ref = 0.4, 10.0
    model = rotor(type="velocity_servo", kv=kv, reference=w_ref)
    res = run(model, t_end=3.0, outputs=["forces"])
    tau = I_ROTOR / kv
    omega = w_ref * (1.0 - np.exp(-res.t / tau))
    theta = w_ref * (res.t - tau * (1.0 - np.exp(-res.t / tau)))
    out = force_outputs(res, "act")
    assert np.abs(out["coordinate_rate"] - omega).max() < 1e-9
    assert np.abs(out["coordinate"] - theta).max() < 1e-9          # unwrapped over turns
    assert np.allclose(out["effort"], kv * (w_ref - omega), atol=1e-9)


def test_position_servo_follows_a_reference_through_many_turns():
    """Reference w t (ConstantVelocity) with velocity feedforward: from rest the error e =
    w t - theta obeys I e'' + kv e' + kp e = 0 with e(0) = 0, e'(0) = w -- across the wrap of
    the atan2 angle at +-pi, several times."""
    kp, kv, w = 20.0, 1.0, 6.0
    model = rotor(type="position_servo", kp=kp, kv=kv, reference=ConstantVelocity(rate=w))
    res = run(model, t_end=3.0)
    wn = math.sqrt(kp / I_ROTOR)
    zeta = kv / (2 * math.sqrt(kp * I_ROTOR))
    wd = wn * math.sqrt(1 - zeta ** 2)
    e = w / wd * np.exp(-zeta * wn * res.t) * np.sin(wd * res.t)
    theta = np.unwrap(angle(res))
    assert theta[-1] > 2.5 * math.pi
    assert np.abs((w * res.t - theta) - e).max() < 1e-9


def test_translational_motor_and_servo():
    """A slider of mass 2 kg: a 3 N motor gives x = 3 t^2 / 4; a PD servo the closed form."""
    def slider(kind, **kw):
        b = ModelBuilder(gravity=(0, 0, 0))
        b.add_body("s", 2.0, (1, 1, 1), r=(0, 0, 0))
        b.add_joint("translational", "rail", "ground", "s", point=(0, 0, 0), axis=(0, 1, 0))
        b.add_force(kind, "act", joint="rail", **kw)
        return b.compile()
    res = run(slider("motor", command=3.0), t_end=1.0)
    x = joint_coordinates(res, "rail")["translation"]
    assert np.abs(x - 0.75 * res.t ** 2).max() < 1e-11
    res = run(slider("position_servo", kp=8.0, kv=0.5, reference=0.1), t_end=1.0)
    x = joint_coordinates(res, "rail")["translation"]
    assert np.abs(x - pd_step(res.t, 0.1, 8.0, 0.5, 2.0)).max() < 1e-11


def arm(reference, general=False):
    """A double pendulum under gravity with a position servo on each joint."""
    b = ModelBuilder("arm", gravity=(0, 0, -9.81))
    b.add_body("l1", 2.0, (0.02, 0.2, 0.2), position=(0.5, 0, 0))
    b.add_body("l2", 1.0, (0.01, 0.1, 0.1), position=(1.5, 0, 0))
    b.add_joint("revolute", "shoulder", "ground", "l1", point=(0, 0, 0), axis=(0, 1, 0))
    b.add_joint("revolute", "elbow", "l1", "l2", point=(1.0, 0, 0), axis=(0, 1, 0))
    for joint, kp, ref in (("shoulder", 400.0, reference[0]), ("elbow", 150.0, reference[1])):
        if general:
            b.add_force("general", joint + "_servo", joint=joint, gain=kp, bias=[0.0, -kp, -20.0],
                        command=ref, forcerange=[-60, 60])
        else:
            b.add_force("position_servo", joint + "_servo", joint=joint, kp=kp, kv=20.0, reference=ref,
                        forcerange=[-60, 60])
    return b.compile()


def test_every_method_gives_the_same_motion():
    """Servos holding a double pendulum against gravity (constant references): the same joint
    angles in every method, the recursive one included."""
    model = arm((-0.3, 0.6))
    ref = angle_pair(run(model, t_end=1.0, method="projection"))
    for method in ("standard", "baumgarte", "penalty", "augmented_lagrangian", "recursive"):
        got = angle_pair(run(model, t_end=1.0, method=method))
        assert np.abs(got - ref).max() < (1e-7 if method in ("penalty",
                                                                "augmented_lagrangian")
                                          else 1e-9), method


def angle_pair(res):
    return np.stack([joint_coordinates(res, j)["angle"] for j in ("shoulder", "elbow")])


def test_energy_balance_closes_with_actuator_work():
    """Servos following harmonic references (time-dependent laws) do work on the arm: the
    kinetic + gravitational energy changes by the integrated actuator power, which equals
    the sum of the actuators' power outputs."""
    model = arm((Harmonic(0.4, 3.0), Harmonic(0.3, 5.0, 0.5)))
    gaps = []
    for step in (0.002, 0.0005):
        res = run(model, t_end=2.0, method="projection", outputs=["forces"], output_step=step)
        en = res.energy()
        assert np.abs(en["work_nonconservative"]).max() > 1.0
        assert np.abs(en["error"]).max() < 1e-9
        power = sum(force_outputs(res, j + "_servo")["power"] for j in ("shoulder", "elbow"))
        dt = np.diff(res.t)
        work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * dt)])
        gaps.append(np.abs(work - en["work_nonconservative"]).max())
    # the trapezoidal rule over the power outputs converges to the integrated work: O(dt^2)
    assert gaps[1] < gaps[0] / 10 and gaps[1] < 5e-4
    # the gain/bias form of the same servos without velocity feedforward: MJCF <position>
    g = run(arm((0.2, -0.1), general=True), t_end=1.0)
    p = run(arm((0.2, -0.1)), t_end=1.0)
    assert np.abs(angle_pair(g) - angle_pair(p)).max() < 1e-10


# ------------------------------------------------------------------------- bad input
def test_bad_input_names_the_element():
    def builder():
        b = ModelBuilder(gravity=(0, 0, 0))
        b.add_body("a", 1.0, (1, 1, 1))
        b.add_joint("revolute", "pin", "ground", "a", point=(0, 0, 0), axis=(1, 0, 0))
        b.add_joint("spherical", "ball", "a", "ground", point=(1, 0, 0))
        return b
    cases = [
        (dict(type="position_servo", kp=1.0), "needs|give joint"),
        (dict(type="position_servo", joint="nope", kp=1.0), "unknown joint 'nope'"),
        (dict(type="position_servo", joint="pin", kp=-1.0), "kp: must be >= 0"),
        (dict(type="position_servo", joint="pin"), "needs kp"),
        (dict(type="velocity_servo", joint="pin", kv=-2.0), "kv: must be >= 0"),
        (dict(type="motor", joint="pin", forcerange=[2.0, -2.0]), "lower 2.0 > upper -2.0"),
        (dict(type="motor", joint="pin", ctrlrange=[1.0]), r"ctrlrange: give \[lower, upper\]"),
        (dict(type="motor", joint="pin", gear=0.0), "gear: must be nonzero"),
        (dict(type="motor", joint="ball"), "spherical joint"),
        (dict(type="motor", joint="pin", coordinate="translation"), "not a coordinate"),
        (dict(type="general", joint="pin", bias=[1, 2, 3, 4]), "bias: give 1 to 3"),
        (dict(type="position_servo", joint="pin", kp=1.0, velocity_feedforward="yes"),
         "true or false"),
    ]
    for spec, message in cases:
        kind = spec.pop("type")
        with pytest.raises(ModelError, match=message) as exc:
            builder().add_force(kind, "servo1", **spec)
        assert "servo1" in str(exc.value)
