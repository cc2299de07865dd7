"""MJCF / URDF import (spatialmbd.importers.mjcf) checked against MuJoCo itself.

Each model file of examples/mjcf is imported, simulated by spatialmbd (rk45, rtol 1e-10), and
simulated by MuJoCo (mj_step, RK4 at h = 1e-4 s, contact disabled, no damping or armature in the
files).  Both integrate the same equations of motion, so on the tree models the centre-of-mass
trajectories agree to the integration tolerances: 1e-8 m asserted (measured: double pendulum
2.1e-11 m, 6-DoF URDF arm 8.1e-10 m, gimbal 2.5e-12 m, over motions of about 1 m).

The four-bar's loop is closed by an MJCF ``connect``.  MuJoCo enforces it softly: its anchors
drift apart by a loop-closure error e (measured during MuJoCo's own run); spatialmbd closes it
exactly, so the trajectories can agree only to the order of e.  Accuracy stated and asserted:
|x_spatialmbd - x_mujoco| <= 20 e_max.  With the file's stiff solref 0.0005 / solimp 0.9999,
e_max = 1.5e-9 m and the difference is 4.9e-9 m; with MuJoCo's default solref 0.02 the same file
gives e_max = 1.5e-3 m and a difference of 4.4e-3 m (same ratio, about 3).
"""
from __future__ import annotations

import pathlib
import warnings

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from spatialmbd.errors import ModelError  # noqa: E402
from spatialmbd.importers import read_mjcf  # noqa: E402
from spatialmbd.importers.massprops import shape_mass_properties  # noqa: E402
from spatialmbd.importers.mjcf import MJCFImportWarning  # noqa: E402
from spatialmbd.io.modelfile import load_builder, model_to_dict, save_model  # noqa: E402
from spatialmbd.simulate import simulate  # noqa: E402

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples" / "mjcf"
H_MUJOCO = 1e-4


def mujoco_run(m, t_end, n_out, loop=None):
    """MuJoCo RK4 at H_MUJOCO, contact off: body centres of mass (n_out + 1, nbody, 3) and the
    largest distance between the anchors of equality ``loop`` (connect by body ids)."""
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = H_MUJOCO
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    steps = int(round(t_end / H_MUJOCO))
    every = steps // n_out
    out, gap = [d.xipos.copy()], 0.0
    for k in range(steps):
        mujoco.mj_step(m, d)
        if loop is not None:
            b1, b2 = m.eq_obj1id[loop], m.eq_obj2id[loop]
            a1 = d.xpos[b1] + d.xmat[b1].reshape(3, 3) @ m.eq_data[loop, 0:3]
            a2 = d.xpos[b2] + d.xmat[b2].reshape(3, 3) @ m.eq_data[loop, 3:6]
            gap = max(gap, float(np.linalg.norm(a1 - a2)))
        if (k + 1) % every == 0:
            out.append(d.xipos.copy())
    return np.array(out), gap


def compare(imported, t_end, n_out=20, loop=None):
    """max |centre of mass (spatialmbd) - centre of mass (MuJoCo)| over bodies and times (m),
    the motion's size (m) and MuJoCo's loop-closure error."""
    model = imported.builder.compile()
    t = np.linspace(0.0, t_end, n_out + 1)
    res = simulate(model, t_end, t_eval=t, integrator="rk45", rtol=1e-10, atol=1e-12)
    assert res.status == "success", res.message
    X, gap = mujoco_run(imported.mj_model, t_end, n_out, loop)
    m = imported.mj_model
    err, size = 0.0, 0.0
    for k, ids in enumerate(imported.groups.values()):
        mass = m.body_mass[ids]
        com = (X[:, ids, :] * mass[None, :, None]).sum(axis=1) / mass.sum()
        err = max(err, float(np.abs(res.q[:, k, :3] - com).max()))
        size = max(size, float(np.ptp(com, axis=0).max()))
    return err, size, gap


def test_double_pendulum_matches_mujoco():
    imported = read_mjcf(EXAMPLES / "double_pendulum.xml")
    assert imported.left_out == []
    assert [j.type for j in imported.builder.joints.values()] == ["revolute", "revolute"]
    err, size, _ = compare(imported, 1.0)
    assert size > 0.3          # it really swings
    assert err < 1e-8, err


def test_urdf_arm_matches_mujoco():
    with pytest.warns(MJCFImportWarning, match=r"left out: \d+ colliding geoms"):
        imported = read_mjcf(EXAMPLES / "arm6.urdf")
    b = imported.builder
    # the base is fused to the world, the tool link to link6 (fixed joints)
    assert list(b.bodies) == ["link1", "link2", "link3", "link4", "link5", "link6"]
    assert len(imported.groups["link6"]) == 1 and b.bodies["link6"].mass == pytest.approx(0.5)
    assert [j.type for j in b.joints.values()] == ["revolute"] * 6
    err, size, _ = compare(imported, 0.6)
    assert size > 0.3
    assert err < 1e-8, err


def test_four_bar_connect_becomes_exact_spherical_joint():
    imported = read_mjcf(EXAMPLES / "four_bar.xml")
    joints = imported.builder.joints
    assert joints["loop"].type == "spherical" and joints["crank_coupler"].type == "spherical"
    loop = mujoco.mj_name2id(imported.mj_model, mujoco.mjtObj.mjOBJ_EQUALITY, "loop")
    err, size, gap = compare(imported, 0.5, loop=loop)
    assert size > 0.1
    assert 0 < gap < 1e-6      # MuJoCo's soft closure: small but not zero
    assert err < 20 * gap, (err, gap)


@pytest.mark.parametrize("name", ["double_pendulum.xml", "arm6.urdf", "four_bar.xml"])
def test_yaml_round_trip_is_identical(name, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MJCFImportWarning)
        builder = read_mjcf(EXAMPLES / name).builder
    path = save_model(builder, tmp_path / "model.yaml")
    again, _ = load_builder(path)
    assert model_to_dict(again) == model_to_dict(builder)
    a, b = builder.compile(), again.compile()
    for key in ("q0", "v0", "mass", "inertia", "gravity"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))


# ----------------------------------------------------------------------------------------------
# mass properties from shapes
# ----------------------------------------------------------------------------------------------
def test_mass_properties_of_shapes_match_mujoco_compiler():
    xml = """<mujoco><worldbody>
      <body name="cap"><freejoint/><geom type="capsule" size="0.1 0.3" density="700"/></body>
      <body name="cyl"><freejoint/><geom type="cylinder" size="0.1 0.3" density="700"/></body>
      <body name="box"><freejoint/><geom type="box" size="0.1 0.2 0.3" density="700"/></body>
      <body name="ball"><freejoint/><geom type="sphere" size="0.15" density="700"/></body>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    shapes = [dict(type="capsule", radius=0.1, length=0.6),
              dict(type="cylinder", radius=0.1, length=0.6),
              dict(type="box", size=[0.2, 0.4, 0.6]), dict(type="sphere", radius=0.15)]
    for body, shape in enumerate(shapes, start=1):
        mp = shape_mass_properties(shape, 700.0)
        assert mp.mass == pytest.approx(m.body_mass[body], rel=1e-12)
        np.testing.assert_allclose(np.diag(mp.inertia), m.body_inertia[body], rtol=1e-12)


# ----------------------------------------------------------------------------------------------
# joint combinations, weld, bad input
# ----------------------------------------------------------------------------------------------
GIMBAL = """<mujoco model="gimbal"><option><flag contact="disable"/></option><worldbody>
  <body name="frame" pos="0 0 1">
    <joint name="outer" type="hinge" axis="1 0 0"/><joint name="inner" type="hinge" axis="0 1 0"/>
    <geom type="box" pos="0.3 0.1 -0.2" size="0.2 0.05 0.1" density="500"/>
    <body name="weight" pos="0.5 0 -0.3">
      <joint name="slider" type="slide" axis="0 0 1"/><joint name="spin" type="hinge" axis="0 0 1"/>
      <geom type="sphere" size="0.08" density="3000"/>
    </body>
  </body>
  <body name="free_block" pos="1 0 1"><freejoint/>
    <geom type="box" size="0.05 0.05 0.05" density="1000"/></body>
</worldbody></mujoco>"""


def test_joint_combinations_and_free_body_match_mujoco():
    imported = read_mjcf(GIMBAL)
    joints = imported.builder.joints
    assert {n: j.type for n, j in joints.items()} == {"outer_inner": "universal",
                                                      "slider_spin": "cylindrical"}
    err, size, _ = compare(imported, 0.5)
    assert size > 0.05 and err < 1e-8, (err, size)


def test_weld_equality_becomes_fixed_joint():
    xml = """<mujoco><option><flag contact="disable"/></option><worldbody>
      <body name="arm"><joint name="pivot" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02" density="1000"/></body>
      <body name="lump" pos="0.4 0 0"><freejoint/><geom type="sphere" size="0.05" density="1000"/>
      </body></worldbody>
      <equality><weld name="glue" body1="arm" body2="lump"/></equality></mujoco>"""
    imported = read_mjcf(xml)
    assert imported.builder.joints["glue"].type == "fixed"
    model = imported.builder.compile()
    res = simulate(model, 0.3, t_eval=[0.0, 0.3], rtol=1e-10, atol=1e-12)
    # the lump stays rigidly at the arm's tip: its distance to the pivot is constant
    np.testing.assert_allclose(np.linalg.norm(res.q[:, 1, :3], axis=1), 0.4, atol=1e-8)


BAD = """<mujoco><worldbody>
  <body name="a"><joint name="ja" type="hinge" axis="0 1 0" armature="0.1" limited="true"
      range="-1 1"/><geom name="ga" type="box" size=".1 .1 .1"/><site name="sa"/>
    <body name="b" pos="0.3 0 0"><joint name="jb" type="hinge" axis="0 1 0"/>
      <geom name="gb" type="box" size=".1 .1 .1"/><site name="sb"/></body></body>
  </worldbody>
  <tendon><spatial name="cable" stiffness="10"><site site="sa"/><site site="sb"/></spatial></tendon>
  <actuator><motor name="motor_a" tendon="cable"/></actuator>
  <equality><joint name="couple" joint1="ja" joint2="jb" polycoef="0 1 0.5 0 0"/></equality>
  <contact><pair name="touch" geom1="ga" geom2="gb"/></contact>
</mujoco>"""


def test_unsupported_features_are_named():
    with pytest.raises(ModelError) as info:
        read_mjcf(BAD, strict=True)
    text = str(info.value)
    for word in ("tendon 'cable'", "actuator 'motor_a'", "equality constraint 'couple'",
                 "contact pair 'touch'", "strict=False"):
        assert word in text, (word, text)
    # the soft limit mapped onto a linear stop is an approximation: refused too (issue 28)
    assert "approximated joint limit 'ja'" in text and "colliding geom" not in text
    assert "armature" not in text                                       # imported
    with pytest.warns(MJCFImportWarning) as record:
        imported = read_mjcf(BAD)                                      # the default
    messages = " ".join(str(w.message) for w in record)
    assert ("left out: 1 actuator, 1 tendon, 1 contact pair, 1 equality constraint, 2 "
            "colliding geoms; approximated: 1 joint limit") in messages, messages
    assert [(x.kind, x.element) for x in imported.approximated] == [("limit approximation",
                                                                     "ja")]
    kinds = {(x.kind, x.element) for x in imported.left_out}
    assert {("tendon", "cable"), ("actuator", "motor_a"),
            ("colliding geom", "ga"), ("colliding geom", "gb"), ("equality", "couple"),
            ("contact pair", "touch")} == kinds
    assert "polycoef" in next(x.detail for x in imported.left_out if x.kind == "equality")
    assert list(imported.builder.joints) == ["ja", "jb"]
    assert imported.builder.forces["ja_limit"].type == "joint_limit"     # imported now
    assert imported.builder.forces["ja_armature"].params["inertia"] == 0.1


def test_hinge_spring_damper_imported_exactly():
    xml = """<mujoco><compiler angle="radian"/><option><flag contact="disable"/></option>
      <worldbody><body name="bob"><joint name="pin" type="hinge" axis="0 0 1" stiffness="3" damping="0.2"
          springref="0.5"/><geom type="box" pos="0.2 0 0" size="0.2 0.02 0.02" density="900"/>
      </body></worldbody></mujoco>"""
    imported = read_mjcf(xml)
    force = imported.builder.forces["pin_spring"]
    assert force.type == "rotational_spring_damper"
    assert force.params["stiffness"] == 3 and force.params["damping"] == pytest.approx(0.2)
    assert force.params["rest_angle"] == pytest.approx(0.5)
    err, size, _ = compare(imported, 1.0)
    assert size > 0.05 and err < 1e-8, (err, size)


def test_urdf_link_without_inertial_is_reported():
    urdf = """<robot name="r"><link name="base"/>
      <link name="l1"><collision><geometry><box size="0.1 0.1 0.4"/></geometry></collision>
      </link><joint name="j" type="continuous"><parent link="base"/><child link="l1"/>
      <axis xyz="0 1 0"/></joint></robot>"""
    with pytest.warns(MJCFImportWarning, match=r"URDF link 'l1' has no <inertial>: its mass 4 kg"):
        imported = read_mjcf(urdf)
    assert imported.builder.bodies["l1"].mass == pytest.approx(1000 * 0.1 * 0.1 * 0.4)


def test_names_shared_across_kinds_are_made_unique_and_keyframes_noted():
    # MJCF names are unique per kind; ours are unique across bodies, joints and forces
    xml = """<mujoco><compiler angle="radian"/><worldbody>
      <body name="arm"><joint name="arm" type="hinge" axis="0 1 0" damping="0.1"/>
        <geom type="box" pos="0.1 0 0" size="0.1 0.01 0.01"/></body></worldbody>
      <equality><weld name="arm_spring" body1="arm"/></equality>
      <keyframe><key name="home" qpos="0.3"/></keyframe></mujoco>"""
    with pytest.warns(MJCFImportWarning, match=r"left out: 1 colliding geom, 1 keyframe"):
        imported = read_mjcf(xml, strict=False)
    builder = imported.builder
    assert ("keyframe", "home") in [(x.kind, x.element) for x in imported.left_out]
    assert list(builder.bodies) == ["arm"]
    assert list(builder.joints) == ["arm_", "arm_spring_"]     # joints are named first
    assert list(builder.forces) == ["arm_spring"]
    assert builder.forces["arm_spring"].params["joint"] == "arm_"


def test_massless_body_and_missing_file_are_model_errors(tmp_path):
    xml = """<mujoco><worldbody><body name="ghost"><freejoint/><site name="s"/></body>
      </worldbody></mujoco>"""
    with pytest.raises(ModelError):
        read_mjcf(xml)
    with pytest.raises(ModelError, match="no such"):
        read_mjcf(tmp_path / "nothing.xml")


def test_cli_import_and_run(tmp_path, capsys):
    from spatialmbd.cli import main
    out = tmp_path / "fb.yaml"
    assert main(["import", str(EXAMPLES / "four_bar.xml"), "-o", str(out)]) == 0
    builder, _ = load_builder(out)
    assert builder.joints["loop"].type == "spherical"
    assert main(["import", str(tmp_path / "none.xml")]) == 2
    bad = tmp_path / "bad.xml"
    bad.write_text(BAD)
    assert main(["import", str(bad), "--strict", "-o", str(tmp_path / "bad.yaml")]) == 2
    assert "tendon 'cable'" in capsys.readouterr().err
    assert main(["import", str(bad), "--lenient", "-q", "-o", str(tmp_path / "bad.yaml")]) == 0
    assert main(["info", str(EXAMPLES / "double_pendulum.xml")]) == 0
    csv = tmp_path / "dp.csv"
    assert main(["run", str(EXAMPLES / "double_pendulum.xml"), "--t-end", "0.02", "-q",
                 "-o", str(csv)]) == 0
    assert csv.stat().st_size > 0


def test_example_script_runs(tmp_path):
    import runpy
    script = runpy.run_path(str(EXAMPLES / "import_four_bar.py"))
    out = script["main"](tmp_path, t_end=0.05)
    assert out["results"].status == "success"
    assert out["yaml"].is_file() and out["html"].stat().st_size > 500_000  # WebGL page
