"""Import that runs (issue 28 item 5, issue 31 item 7): the summary of what is left out,
--strict, the mesh sidecar (deduplicated, round trip, bad sidecars), MJCF/URDF accepted by
run/info/plot/animate, visual/collision roles, and the compiler's failures as located errors
without a MUJOCO_LOG.TXT."""
from __future__ import annotations

import os
import re
import zipfile

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from spatialmbd.cli import main  # noqa: E402
from spatialmbd.errors import ModelError  # noqa: E402
from spatialmbd.importers import read_mjcf  # noqa: E402
from spatialmbd.io.modelfile import (ModelFileError, load_builder, load_model,  # noqa: E402
                                     save_model)
from spatialmbd.meshes import compact  # noqa: E402

# a tetrahedron whose vertices MuJoCo repeats per face (an OBJ with one vertex per corner of
# each face), used by two geoms of two bodies
TETRA_OBJ = "\n".join(
    [f"v {x} {y} {z}" for face in ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3))
     for (x, y, z) in [((0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1))[i] for i in face]]
    + [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(4)]) + "\n"

ARM = """<mujoco model="arm"><compiler angle="radian" meshdir="."/>
  <asset><mesh name="tetra" file="tetra.obj"/>
    <material name="red" rgba="0.8 0.1 0.1 1"/></asset>
  <default><default class="visual"><geom contype="0" conaffinity="0" group="2"/></default>
    <default class="collision"><geom group="3"/></default></default>
  <worldbody>
    <body name="upper"><joint name="shoulder" type="hinge" axis="0 1 0" armature="0.1"
        limited="true" range="-7 7" frictionloss="0.2"/>
      <geom class="visual" type="mesh" mesh="tetra" material="red"/>
      <geom class="collision" type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="lower" pos="0.3 0 0"><joint name="elbow" type="hinge" axis="0 1 0"
          limited="true" range="-2 2"/>
        <geom class="visual" type="mesh" mesh="tetra" rgba="0 0 1 1"/>
        <geom class="collision" type="box" pos="0.1 0 0" size="0.1 0.02 0.02"/>
      </body></body></worldbody>
  <tendon><fixed name="tl" stiffness="5" armature="0.02"><joint joint="elbow" coef="1"/></fixed></tendon>
  <actuator><motor name="m1" tendon="tl"/>
    <general name="m2" joint="elbow" dyntype="filter" dynprm="0.1"/></actuator></mujoco>"""


@pytest.fixture
def arm(tmp_path):
    (tmp_path / "tetra.obj").write_text(TETRA_OBJ)
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    return path


# ------------------------------------------------------------------------------ summary
def test_import_succeeds_by_default_with_a_short_summary(arm, tmp_path, capsys):
    out = tmp_path / "arm.yaml"
    assert main(["import", str(arm), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    summary = ("left out of arm.xml: 1 actuator, 1 tendon, 1 joint limit, 2 colliding geoms")
    assert summary in err, err
    assert len(err.splitlines()) == 1 and "'m2'" not in err        # counts, not names
    assert main(["import", str(arm), "-o", str(out), "--verbose"]) == 0
    err = capsys.readouterr().err
    for line in ("actuator 'm2'", "tendon 'tl' (its armature)",
                 "joint limit 'shoulder' (range -7 .. 7 rad is a turn or more"):
        assert line in err, (line, err)
    assert main(["import", str(arm), "-o", str(out), "--lenient", "-q"]) == 0  # accepted
    assert capsys.readouterr().err == ""


def test_strict_refuses_with_exit_status_2(arm, tmp_path, capsys):
    out = tmp_path / "arm.yaml"
    assert main(["import", str(arm), "--strict", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "actuator 'm2'" in err and "tendon 'tl'" in err
    assert "Traceback" not in err and not out.exists()
    with pytest.raises(ModelError, match="tendon 'tl'"):
        read_mjcf(arm, strict=True)


def test_strict_refuses_the_approximations_the_default_lists_them(tmp_path, capsys):
    """A file whose only mapped-but-approximate features are a hinge's soft limit, its
    friction loss and a ball's range (issue 28): imported by default with the approximations
    counted on the summary line (named with --verbose); --strict refuses, naming each one
    and what would be approximated."""
    xml = tmp_path / "approx.xml"
    xml.write_text(
        '<mujoco><compiler angle="radian"/><option><flag contact="disable"/></option>'
        '<worldbody><body name="arm"><joint name="h" type="hinge" axis="0 1 0" '
        'range="-0.5 0.5" frictionloss="0.2"/><geom type="capsule" fromto="0 0 0 0.4 0 0" '
        'size="0.03"/><body name="tip" pos="0.4 0 0"><joint name="b" type="ball" '
        'range="0 0.7"/><geom type="sphere" size="0.05"/></body></body></worldbody>'
        '</mujoco>')
    out = tmp_path / "approx.yaml"
    assert main(["import", str(xml), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "note: approximated in approx.xml: 2 joint limits, 1 friction loss" in err, err
    assert len(err.splitlines()) == 1
    assert main(["import", str(xml), "-o", str(out), "--verbose"]) == 0
    err = capsys.readouterr().err
    for line in ("approximated joint limit 'h' (range -0.5 .. 0.5: MuJoCo's soft limit",
                 "approximated friction loss 'h' (0.2: MuJoCo's soft friction loss",
                 "approximated joint limit 'b' (ball range 0.7 rad"):
        assert line in err, (line, err)
    out.unlink()
    assert main(["import", str(xml), "--strict", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "approximated joint limit 'h'" in err and "approximated friction loss 'h'" in err
    assert "approximated joint limit 'b'" in err and "linear stop" in err
    assert "Traceback" not in err and not out.exists()


def test_left_out_is_structured(arm):
    with pytest.warns(UserWarning, match="left out: 1 actuator, 1 tendon"):
        imported = read_mjcf(arm)
    kinds = [x.kind for x in imported.left_out]
    assert kinds.count("actuator") == 1 and kinds.count("joint limit") == 1
    limit = next(x for x in imported.left_out if x.element == "shoulder" and
                 x.kind == "joint limit")
    assert limit.detail.startswith("range -7 .. 7 rad") and not limit.unsupported
    assert imported.summary.startswith("1 actuator, 1 tendon, 1 joint limit")
    # what maps is imported: the elbow's limit, the shoulder's friction loss and armature
    forces = imported.builder.forces
    assert forces["elbow_limit"].type == "joint_limit"
    assert forces["shoulder_friction"].params["frictionloss"] == 0.2
    assert forces["shoulder_armature"].params == {"joint": "shoulder", "inertia": 0.1}


# ------------------------------------------------------------------------------ sidecar
def test_meshes_go_once_into_a_sidecar_and_round_trip(arm, tmp_path):
    out = tmp_path / "arm.yaml"
    assert main(["import", str(arm), "-q", "-o", str(out)]) == 0
    sidecar = tmp_path / "arm.meshes.npz"
    assert sidecar.is_file() and not list(tmp_path.glob(".*.tmp"))
    text = out.read_text()
    assert "vertices" not in text and text.count("file: arm.meshes.npz") == 2
    with np.load(sidecar) as archive:
        assert sorted(archive.files) == ["tetra.faces", "tetra.vertices"]   # stored once
        V, F = archive["tetra.vertices"], archive["tetra.faces"]
    m = mujoco.MjModel.from_xml_path(str(arm))
    assert m.mesh_vertnum[0] > len(V) == 4                   # repeated vertices removed
    assert F.shape == (4, 3)
    # the same triangles as MuJoCo's (as vertex coordinates)
    mv = np.asarray(m.mesh_vert)[np.asarray(m.mesh_face)]
    np.testing.assert_array_equal(np.sort(V[F].reshape(4, -1), axis=0),
                                  np.sort(mv.reshape(4, -1), axis=0))
    builder, _ = load_builder(out)
    shapes = builder.bodies["upper"].shapes
    assert [s["role"] for s in shapes] == ["visual", "collision"]
    assert shapes[0]["color"] == "#cc1a1a"                    # the material's colour
    assert builder.bodies["lower"].shapes[0]["color"] == "#0000ff"
    # save again (sidecar path absolute now): loads to the same arrays
    again = save_model(builder, tmp_path / "again.yaml")
    b2, _ = load_builder(again)
    from spatialmbd.meshes import mesh_arrays
    V1, F1 = mesh_arrays(shapes[0])
    V2, F2 = mesh_arrays(b2.bodies["upper"].shapes[0])
    np.testing.assert_array_equal(V1, V2)
    np.testing.assert_array_equal(F1, F2)


def test_compact_removes_repeated_vertices():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    F = np.array([[0, 1, 2], [3, 5, 4]])
    U, G = compact(V, F)
    assert len(U) == 4
    np.testing.assert_array_equal(U[G], V[F])


def _write_sidecar(path, **arrays):
    np.savez(path, **arrays)


@pytest.mark.parametrize("arrays, match", [
    (None, "not found"),
    ({"other.vertices": np.eye(3), "other.faces": np.array([[0, 1, 2]])}, "has no mesh 'm'"),
    ({"m.vertices": np.ones((4, 2)), "m.faces": np.array([[0, 1, 2]])}, r"\(n, 3\) floats"),
    ({"m.vertices": np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]),
      "m.faces": np.array([[0, 1, 2]])}, r"vertices\[2\]: non-finite"),
    ({"m.vertices": np.eye(3), "m.faces": np.array([[0, 1, 7]])}, r"faces\[0\].*out of range"),
    ("garbage", "cannot be read"),
])
def test_bad_sidecar_is_a_model_error_naming_shape_body_and_file(tmp_path, arrays, match):
    sidecar = tmp_path / "m.meshes.npz"
    if arrays == "garbage":
        sidecar.write_bytes(b"not a zip file")
    elif arrays is not None:
        _write_sidecar(sidecar, **arrays)
    data = {"spatialmbd": 1, "bodies": [{"name": "link", "mass": 1.0, "inertia": [1, 1, 1],
                                         "shapes": [{"type": "mesh", "file": "m.meshes.npz",
                                                     "mesh": "m"}]}]}
    model = tmp_path / "m.yaml"
    import yaml
    model.write_text(yaml.safe_dump(data))
    with pytest.raises(ModelFileError) as info:
        load_model(model)
    text = str(info.value)
    assert re.search(match, text), text
    assert "bodies[0].shapes[0]" in text and "m.meshes.npz" in text
    if arrays is not None and arrays != "garbage":
        assert "body 'link'" in text


# ------------------------------------------------------------------------------ CLI on .xml
def test_run_info_plot_animate_accept_mjcf(arm, tmp_path, capsys):
    csv = tmp_path / "arm.csv"
    assert main(["run", str(arm), "--t-end", "0.05", "-q", "-o", str(csv)]) == 0
    assert csv.stat().st_size > 0
    assert main(["run", str(arm), "--strict", "--t-end", "0.05", "-o", str(csv)]) == 2
    assert "actuator 'm2'" in capsys.readouterr().err
    assert main(["info", str(arm), "--verbose"]) == 0
    captured = capsys.readouterr()
    assert "upper" in captured.out and "joint limit 'shoulder'" in captured.err
    png = tmp_path / "arm.png"
    assert main(["plot", str(arm), "--t-end", "0.05", "-y", "upper.z", "-o", str(png),
                 "--quiet"]) == 0
    assert png.stat().st_size > 1000
    html = tmp_path / "arm.html"
    assert main(["animate", str(arm), "--t-end", "0.05", "-q", "--renderer", "canvas",
                 "-o", str(html)]) == 0
    page = html.read_text()
    assert "#cc1a1a" in page            # the material's colour reaches the viewer


def test_viewer_draws_visual_shapes_only_where_a_body_has_them():
    from spatialmbd.viewer.animation import _shapes
    vis = {"type": "sphere", "radius": 0.1, "role": "visual"}
    col = {"type": "box", "size": [1, 1, 1], "role": "collision"}
    assert [s["type"] for s in _shapes([vis, col], "b")] == ["sphere"]
    assert [s["type"] for s in _shapes([col], "b")] == ["box"]        # nothing else to draw


# ------------------------------------------------------------------------------ issue 31.7
TWO = """<mujoco><worldbody>
  <body name="a"><freejoint/><geom size="0.1"/></body>
  <body name="b" pos="1 0 0"><freejoint/><geom size="0.1"/></body></worldbody>
  <equality><connect body1="a" body2="b" anchor="{anchor}"/></equality></mujoco>"""


@pytest.mark.parametrize("xml, match", [
    (TWO.format(anchor=""), r"line 4: <connect anchor=\"\">.*empty"),
    ("""<mujoco><worldbody><body name="a" pos="1e300 0 0"><freejoint/><geom size="0.1"/>
        </body></worldbody></mujoco>""", r"body 'a'.position.*out of range"),
    ("""<mujoco><worldbody><body name="a"><joint type="hinge"/><inertial pos="0 0 0"
        mass="1e300" diaginertia="1 1 1"/></body></worldbody></mujoco>""",
     r"body 'a'.mass: 1e\+300 kg is out of range"),
    ("""<robot name="r"><link name="base"/><link name="l1"><inertial><origin xyz="nan 0 0"/>
        <mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
        </link><joint name="j" type="continuous"><parent link="base"/><child link="l1"/>
        </joint></robot>""", r"line 1: <origin xyz=\"nan 0 0\"> of link 'l1': nan is not a "
                             "finite number"),
    ("<mujoco><worldbody><body><geom type='nonsense'/></body></worldbody></mujoco>",
     "MuJoCo could not compile the XML"),
])
def test_bad_files_are_one_located_model_error_without_a_log(tmp_path, monkeypatch, xml,
                                                             match):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ModelError) as info:
        read_mjcf(xml)
    assert re.search(match, str(info.value)), str(info.value)
    assert "\n" not in str(info.value)
    path = tmp_path / ("bad.urdf" if xml.startswith("<robot") else "bad.xml")
    path.write_text(xml)
    assert main(["import", str(path), "-o", str(tmp_path / "bad.yaml")]) == 2
    assert main(["run", str(path), "-q", "--t-end", "0.01"]) == 2
    assert os.listdir(tmp_path) == [path.name], os.listdir(tmp_path)   # no MUJOCO_LOG.TXT



def test_sidecar_is_a_plain_numpy_archive(arm, tmp_path):
    out = tmp_path / "arm.yaml"
    assert main(["import", str(arm), "-q", "-o", str(out)]) == 0
    assert zipfile.is_zipfile(tmp_path / "arm.meshes.npz")
    with np.load(tmp_path / "arm.meshes.npz") as archive:
        assert archive["tetra.vertices"].dtype == np.float32       # MuJoCo's own numbers
        assert archive["tetra.faces"].dtype == np.int32


def test_keyframe_option_starts_from_the_keyframe(tmp_path, capsys):
    xml = tmp_path / "swing.xml"
    xml.write_text("""<mujoco><worldbody><body name="arm"><joint name="h" type="hinge"
        axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"
        contype="0" conaffinity="0"/></body></worldbody>
      <actuator><motor name="m" joint="h"/></actuator>
      <keyframe><key name="kick" qpos="0.5" qvel="2" ctrl="0.3"/></keyframe></mujoco>""")
    out = tmp_path / "swing.yaml"
    assert main(["import", str(xml), "--keyframe", "kick", "-q", "-o", str(out)]) == 0
    builder = load_builder(out)[0]
    arm = builder.bodies["arm"]
    assert np.linalg.norm(arm.omega) == pytest.approx(2.0)            # qvel about the hinge
    assert arm.r[2] == pytest.approx(-0.15 * np.sin(0.5))               # rotated by qpos 0.5
    assert builder.forces["m"].params["command"] == 0.3
    assert main(["import", str(xml), "-q", "-o", str(out)]) == 0      # default: qpos0, at rest
    assert np.linalg.norm(load_builder(out)[0].bodies["arm"].omega) == 0
    assert main(["run", str(xml), "--keyframe", "nope", "--t-end", "0.01", "-q"]) == 2
    assert "keyframe 'nope'" in capsys.readouterr().err
