"""What acts on imported joints (importers/mjcf/joint_elements.py): limits, friction loss,
springs and dampers of hinge, slide and ball joints, actuators, fixed tendons -- each mapping's
element and parameters (closed forms of docs/import.md), and a simulation against MuJoCo (RK4,
h = 1e-4 s) where the mapping is exact (asserted 1e-8 m) or where it is not (the measured
difference pinned, documented in docs/import.md)."""
from __future__ import annotations

import math
import pathlib
import sys

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from test_mujoco_agreement import compare  # noqa: E402

from spatialmbd.importers import read_mjcf  # noqa: E402
from spatialmbd.importers.mjcf.joint_elements import creep_velocity, impedance  # noqa: E402
from spatialmbd.outputs import force_outputs  # noqa: E402

HEAD = ('<mujoco><compiler angle="radian"/><option timestep="0.0001" gravity="0 0 -9.81">'
        '<flag contact="disable"/></option>')


def pendulum(joint_attributes, extra=""):
    return (HEAD + '<worldbody><body name="arm"><joint name="h" type="hinge" axis="0 1 0" '
            + joint_attributes + '/><geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>'
            '</body></worldbody>' + extra + '</mujoco>')


def test_limit_stiffness_and_damping_follow_solref_and_solimp():
    # the reference q = 0.4 (MuJoCo's qpos0) is our zero: the stops move by -0.4
    imported = read_mjcf(pendulum('ref="0.4" range="-1 1.5" solreflimit="0.01 0.8" '
                                  'solimplimit="0.95 0.99 0.001"'))
    limit = imported.builder.forces["h_limit"].params
    inertia = 1.0 / imported.mj_model.dof_invweight0[0]
    assert limit["lower"] == pytest.approx(-1.4) and limit["upper"] == pytest.approx(1.1)
    assert limit["law"] == "linear"
    # K = d k I, C = d b I with k = 1/(d^2 tc^2 dr^2), b = 2/(d tc), d = dmax = 0.99
    assert limit["stiffness"] == pytest.approx(inertia / (0.99 * 0.01 ** 2 * 0.8 ** 2), rel=1e-12)
    assert limit["damping"] == pytest.approx(2 * inertia / 0.01, rel=1e-12)
    # MuJoCo's refsafe: the time constant is at least two of the file's time steps
    clamped = read_mjcf(pendulum('range="-1 1" solreflimit="0.001 1"').replace(
        'timestep="0.0001"', 'timestep="0.002"')).builder.forces["h_limit"].params
    assert clamped["damping"] == pytest.approx(2 * inertia / 0.004, rel=1e-12)
    # direct stiffness/damping (negative solref): k = -solref0 / d^2, b = -solref1 / d
    direct = read_mjcf(pendulum('range="-1 1" solreflimit="-5000 -30"')).builder \
        .forces["h_limit"].params
    assert direct["stiffness"] == pytest.approx(5000 / 0.95 * inertia, rel=1e-12)
    assert direct["damping"] == pytest.approx(30 * inertia, rel=1e-12)


def test_impedance_is_mujocos_sigmoid():
    solimp = (0.9, 0.95, 0.001, 0.5, 2.0)
    assert impedance(solimp, 0.0) == 0.9 and impedance(solimp, 1.0) == 0.95
    assert impedance(solimp, 0.00025) == pytest.approx(0.9 + 0.05 * 2 * 0.25 ** 2)
    assert impedance(solimp, 0.00075) == pytest.approx(0.9 + 0.05 * (1 - 2 * 0.25 ** 2))


def test_limit_hit_differs_from_mujocos_soft_limit_by_the_documented_amount():
    # a horizontal arm falls onto its stop at -0.6 rad (about 2.4 rad/s at the touch)
    measured = {}
    for key, solref in (("default", ""), ("stiff", 'solreflimit="0.005 1"')):
        imported = read_mjcf(pendulum('range="-0.6 0.6" ' + solref))
        err, size, res = compare(imported, 1.0, n_out=200)
        stop = force_outputs(res, "h_limit")
        assert stop["active"].any() and size > 0.1
        measured[key] = (err, stop["penetration"].max())
    # docs/import.md: 1.7e-3 m with the default solref 0.02 (penetration 0.049 rad),
    # 1.2e-4 m with solref 0.005 (0.011 rad): the difference shrinks with the time constant
    assert 1e-3 < measured["default"][0] < 2.5e-3, measured
    assert 5e-5 < measured["stiff"][0] < 2e-4, measured
    assert measured["default"][1] == pytest.approx(0.049, abs=2e-3)


def test_frictionloss_becomes_regularized_coulomb_with_mujocos_creep():
    imported = read_mjcf(pendulum('frictionloss="1.0" damping="0.05"'))
    friction = imported.builder.forces["h_friction"].params
    inertia = 1.0 / imported.mj_model.dof_invweight0[0]
    d = 0.9                                   # solimp dmin: the friction row's impedance
    b = 2 / (d * 0.02)                        # default solref 0.02 1
    assert friction["frictionloss"] == 1.0
    assert friction["creep_velocity"] == pytest.approx((1 - d) * 1.0 / (d * b * inertia))
    assert creep_velocity(mujoco, imported.mj_model, (0.02, 1), (0.9, 0.95, 0.001, 0.5, 2),
                          inertia, 1.0) == pytest.approx(friction["creep_velocity"])
    # the arm swings down, stops and creeps: measured 5.8e-4 m from MuJoCo over 1 s
    err, size, _ = compare(imported, 1.0, n_out=100)
    assert size > 0.2 and err < 1e-3, err


def test_frictionloss_while_slipping_agrees_until_the_first_reversal():
    imported = read_mjcf(pendulum('frictionloss="0.3" damping="0.05"'))
    err_slip, _, _ = compare(imported, 0.55, n_out=11)       # before the swing reverses
    assert err_slip < 3e-5, err_slip
    err, _, _ = compare(imported, 1.0, n_out=20)             # after it: 2.4e-3 m measured
    assert 1e-3 < err < 4e-3, err


def test_slide_and_hinge_with_reference_offsets_springs_and_servos_are_exact():
    xml = HEAD + """<worldbody>
      <body name="arm"><joint name="h" type="hinge" axis="0 1 0" ref="0.7" damping="0.1"
          range="-1 2.5" springref="0.2" stiffness="1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body name="slider" pos="0.3 0 0"><joint name="s" type="slide" axis="1 0 0" ref="0.05"
            range="-0.2 0.3" springref="0.1" stiffness="100" damping="1"/>
          <geom type="box" pos="0.05 0 0" size="0.05 0.02 0.02"/></body></body></worldbody>
      <actuator><position name="ph" joint="h" kp="30" kv="1" ctrlrange="-3 3"/>
        <position name="ps" joint="s" kp="500" kv="10"/></actuator></mujoco>"""
    imported = read_mjcf(xml)
    assert imported.left_out == []
    forces = imported.builder.forces
    assert forces["h_spring"].params["rest_angle"] == pytest.approx(0.2 - 0.7)
    assert forces["s_spring"].type == "spring_damper"
    assert forces["s_spring"].params["natural_length"] == pytest.approx(10.0 + 0.1 - 0.05)
    assert forces["s_limit"].params["lower"] == pytest.approx(-0.25)
    # a servo about qpos = 0.7 holds our angle -0.7: general with b0 = -kp gear offset
    assert forces["ph"].type == "general"
    assert forces["ph"].params["bias"] == pytest.approx([-30 * 0.7, -30, -1])
    forces["ph"].params["command"], forces["ps"].params["command"] = 0.9, 0.12
    err, size, res = compare(imported, 1.0, lambda t: [0.9, 0.12])
    assert size > 0.05 and err < 1e-8, err
    assert not any(force_outputs(res, n)["active"].any() for n in ("h_limit", "s_limit"))


def test_ball_spring_and_damper_are_exact_and_its_range_is_left_out():
    xml = HEAD + """<worldbody><body name="top" pos="0 0 1" euler="0.5 0.3 0">
        <joint name="b" type="ball" stiffness="3" damping="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.3 0.1 -0.3" size="0.03"/></body></worldbody>
        </mujoco>"""
    imported = read_mjcf(xml)
    forces = imported.builder.forces
    assert forces["b_spring"].type == "bushing"
    assert forces["b_spring"].params["rotational_stiffness"] == 3
    assert forces["b_damper"].params == {"joint": "b", "friction": "viscous", "viscous": 0.05}
    err, size, _ = compare(imported, 1.0)
    assert size > 0.05 and err < 1e-8, err
    ranged = read_mjcf(xml.replace('damping="0.05"', 'range="0 1" frictionloss="0.1"'))
    reasons = {x.kind: x.detail for x in ranged.left_out}
    assert "joint limit" not in reasons                    # imported (below)
    assert ranged.builder.forces["b_limit"].params["coordinate"] == "rotation"
    assert "three components" in reasons["frictionloss"]


def test_ball_range_hit_differs_from_mujocos_soft_limit_by_the_documented_amount():
    """A ball joint's range bounds its whole rotation angle |quat2vel(qpos)| (MuJoCo): the
    joint_limit on the coordinate 'rotation'. An arm (0.4 m, with a sideways offset, so it
    swings and twists) falls from horizontal onto a range of 0.6 rad (docs/import.md)."""
    xml = HEAD + """<worldbody><body name="arm"><joint name="b" type="ball" range="0 0.6"/>
        <geom type="capsule" fromto="0 0 0 0.4 0.1 0" size="0.03"/></body></worldbody>
        </mujoco>"""
    measured = {}
    for key, solref in (("default", ""), ("stiff", ' solreflimit="0.005 1"')):
        imported = read_mjcf(xml.replace('range="0 0.6"', 'range="0 0.6"' + solref))
        limit = imported.builder.forces["b_limit"]
        assert limit.params["coordinate"] == "rotation" and limit.params["upper"] == 0.6
        assert [x.element for x in imported.approximated] == ["b"]
        err, size, res = compare(imported, 1.0, n_out=200)
        stop = force_outputs(res, "b_limit")
        assert stop["active"].any() and size > 0.1
        measured[key] = (err, stop["penetration"].max())
    # docs/import.md: 1.5e-2 m with the default solref (penetration 0.048 rad, as the
    # hinge's 0.049), 5.3e-3 m with solref 0.005 (0.011 rad): it shrinks with the time
    # constant, less than for the hinge (the swing after the bounce is three-dimensional)
    assert 1e-2 < measured["default"][0] < 2e-2, measured
    assert 3e-3 < measured["stiff"][0] < 8e-3, measured
    assert measured["default"][1] == pytest.approx(0.048, abs=2e-3)
    assert measured["stiff"][1] == pytest.approx(0.0114, abs=1e-3)


def test_fixed_tendon_held_by_an_equality_is_an_exact_coupler():
    xml = HEAD + """<worldbody>
      <body name="a"><joint name="ja" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/></body>
      <body name="b" pos="0 0.3 0"><joint name="jb" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0.1" size="0.03"/></body></worldbody>
      <tendon><fixed name="link"><joint joint="ja" coef="1"/><joint joint="jb" coef="2"/></fixed>
        <fixed name="lone" stiffness="3"><joint joint="ja" coef="1"/></fixed></tendon>
      <equality><tendon name="hold" tendon1="link" polycoef="0.1 0 0 0 0" solref="0.0005 1"
          solimp="0.9999 0.9999 0.001"/></equality></mujoco>"""
    imported = read_mjcf(xml)
    coupler = imported.builder.couplers["hold"]
    assert (coupler.joint1, coupler.joint2) == ("ja", "jb")
    assert coupler.params == {"c1": 1.0, "c2": 2.0, "c0": 0.1}
    assert imported.left_out == [], imported.summary
    lone = imported.builder.forces["lone_spring"]        # a one-joint tendon's spring
    assert lone.type == "fixed_tendon" and lone.params["stiffness"] == 3.0
    # MuJoCo's tendon equality is soft (stiff here): measured 1.7e-10 m without the offset
    imported.builder.couplers["hold"].params["c0"] = 0.0
    m = imported.mj_model
    m.eq_data[0, 0] = 0.0
    err, size, _ = compare(imported, 1.0)       # the tendon 'lone' holds ja back
    assert size > 0.05 and err < 1e-8, err


def test_disabled_limits_friction_and_actuation_add_nothing():
    xml = pendulum('range="-1 1" frictionloss="0.2"',
                   '<actuator><motor name="m" joint="h"/></actuator>').replace(
        '<flag contact="disable"/>',
        '<flag contact="disable" limit="disable" frictionloss="disable" actuation="disable"/>')
    imported = read_mjcf(xml)
    assert imported.builder.forces == {}
    assert [(x.kind, x.element) for x in imported.left_out] == [("actuator", "m")]


def test_actuators_that_do_not_map_are_left_out_with_the_reason():
    xml = pendulum('', '<tendon><fixed name="t"><joint joint="h" coef="1"/></fixed></tendon>'
                   '<actuator><motor name="on_tendon" tendon="t"/>'
                   '<general name="filtered" joint="h" dyntype="filter" dynprm="0.1"/>'
                   '<motor name="plain" joint="h" gear="3"/></actuator>')
    imported = read_mjcf(xml)
    details = {x.element: x.detail for x in imported.left_out if x.kind == "actuator"}
    assert "on_tendon" not in details                  # a fixed tendon's actuator imports
    assert imported.builder.forces["on_tendon"].type == "fixed_tendon"
    assert "activation dynamics" in details["filtered"]
    assert imported.builder.forces["plain"].params == {"joint": "h", "coordinate": "angle",
                                                        "gear": 3.0}
    assert math.isfinite(imported.builder.compile().nb)


def test_degenerate_limit_and_joint_force_clamp_are_left_out_once():
    # a margin that closes the range leaves the limit out with the stop's own error; a
    # joint's actuatorfrcrange (the clamp of its actuators' sum) is reported once
    imported = read_mjcf(pendulum('range="0 1" margin="0.5" actuatorfrcrange="-1 1"',
                                  '<actuator><motor name="a" joint="h"/>'
                                  '<motor name="b" joint="h"/></actuator>'))
    items = {(x.kind, x.element): x.detail for x in imported.left_out}
    assert "must be less than upper" in items[("joint limit", "h")]
    assert list(items).count(("actuator force range", "h")) == 1
    assert [x.kind for x in imported.left_out].count("actuator force range") == 1
    assert sorted(imported.builder.forces) == ["a", "b"]
