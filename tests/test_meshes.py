"""Mesh shapes (spatialmbd.meshes): model files (relative files, inline triangles, errors),
mass properties of a closed mesh against the closed form, MJCF meshes imported as meshes, and
both renderers drawing a mesh (headless Chromium: tests/viewer/test_viewer.py)."""
from __future__ import annotations

import numpy as np
import pytest

from spatialmbd.errors import ModelError
from spatialmbd.io.modelfile import ModelFileError, load_model
from spatialmbd.meshes import mesh_arrays


def cube_mesh(a, center=(0.0, 0.0, 0.0)):
    """A closed cube of side a (12 triangles, counter-clockwise seen from outside)."""
    c = np.asarray(center, dtype=float)
    V = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    V = c + 0.5 * a * V
    # vertex index = 4 i + 2 j + k for (x, y, z) = (+-1 by i, j, k)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    F = []
    for q in quads:
        F += [(q[0], q[1], q[2]), (q[0], q[2], q[3])]
    return V, np.array(F)


def _outward(V, F):
    """Signed volume by the divergence theorem: positive when every face winds outward."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def test_cube_helper_is_closed_and_outward():
    V, F = cube_mesh(2.0)
    assert _outward(V, F) == pytest.approx(8.0)


def test_mesh_arrays_scale_and_checks():
    V, F = cube_mesh(1.0)
    V2, F2 = mesh_arrays({"type": "mesh", "vertices": V, "faces": F, "scale": [1, 2, 3]})
    assert np.allclose(V2, V * [1, 2, 3]) and np.array_equal(F2, F)
    for bad, match in [({"vertices": V, "faces": F + 10}, "out of range"),
                       ({"vertices": V[:, :2], "faces": F}, r"\(n, 3\)"),
                       ({"vertices": V, "faces": F, "scale": 0}, "positive"),
                       ({"vertices": V * np.nan, "faces": F}, "non-finite"),
                       ({"file": "x.stl", "vertices": V, "faces": F}, "not both"),
                       ({}, "needs a file")]:
        with pytest.raises(ModelError, match=match):
            mesh_arrays(dict(type="mesh", **bad), "shape")


def _write_obj(path, V, F):
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in V] + [
        f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")


def test_model_file_mesh_relative_to_the_file_and_density(tmp_path):
    pytest.importorskip("trimesh")
    a, rho = 0.3, 2700.0
    V, F = cube_mesh(a)
    (tmp_path / "parts").mkdir()
    _write_obj(tmp_path / "parts" / "cube.obj", V, F)
    other = tmp_path / "elsewhere"
    other.mkdir()
    (tmp_path / "m.yaml").write_text(f"""spatialmbd: 1
name: meshes
bodies:
  - name: block
    density: {rho}
    shapes:
      - {{type: mesh, file: parts/cube.obj, color: "#aa3300"}}
  - name: plate
    mass: 1.0
    inertia: [0.1, 0.1, 0.1]
    position: [1, 0, 0]
    shapes:
      - {{type: mesh, file: parts/cube.obj, scale: [2, 1, 0.5], p: [1, 0, 0, 0]}}
""")
    import os
    cwd = os.getcwd()
    os.chdir(other)                     # the file is found relative to the model, not the cwd
    try:
        model, _ = load_model(tmp_path / "m.yaml")
    finally:
        os.chdir(cwd)
    m = rho * a**3                                         # closed form: a cube
    assert model.mass[0] == pytest.approx(m, rel=1e-12)
    assert np.allclose(model.inertia[0], np.eye(3) * m * a**2 / 6.0, rtol=1e-12, atol=0)
    from spatialmbd.animation import static_scene
    from spatialmbd.viewer.animation import _shape
    shapes = static_scene(model)["bodies"][1]["shapes"]
    assert shapes[0]["file"] == str((tmp_path / "parts" / "cube.obj").resolve())
    drawn = _shape(shapes[0], "plate")
    Vd = np.asarray(drawn["vertices"]).reshape(-1, 3)
    assert np.allclose(Vd, V * [2, 1, 0.5], atol=1e-6)
    assert drawn["faces"] == F.ravel().tolist()


def test_model_file_mesh_errors_name_the_shape_and_line(tmp_path):
    (tmp_path / "bad.yaml").write_text("""spatialmbd: 1
name: bad
bodies:
  - name: part
    mass: 1.0
    inertia: [0.01, 0.01, 0.01]
    shapes:
      - {type: mesh, file: missing.stl}
      - {type: mesh, vertices: [[0,0,0],[1,0,0],[0,1,0]], faces: [[0,1,7]]}
      - {type: mesh, vertices: [[0,0,0],[1,0,0],[0,1,0]], faces: [[0,1,2]], scale: -1}
      - {type: mesh}
      - {type: mesh, vertices: [[0,0,0],[1,0,0],[0,1,0]], faces: [[0,1,2]], radius: 1}
""")
    with pytest.raises(ModelFileError) as info:
        load_model(tmp_path / "bad.yaml")
    text = str(info.value)
    for where, what in [("shapes[0]", "missing.stl' not found"), ("shapes[1]", "out of range"),
                        ("shapes[2]", "positive"), ("shapes[3]", "a file or vertices"),
                        ("shapes[4].radius", "a mesh takes no 'radius'")]:
        line = next((ln for ln in text.splitlines() if where in ln and what in ln), None)
        assert line is not None, (where, what, text)
        assert "(line " in line


def test_mjcf_mesh_geom_imported_as_its_triangles():
    mujoco = pytest.importorskip("mujoco")
    import warnings
    from spatialmbd.animation import static_scene
    from spatialmbd.importers.mjcf import read_mjcf
    V, F = cube_mesh(0.2)
    verts = " ".join(f"{x:g}" for x in V.ravel())
    faces = " ".join(str(int(i)) for i in F.ravel())
    xml = f"""<mujoco><asset><mesh name="cube" vertex="{verts}" face="{faces}"/></asset>
    <worldbody><body name="b" pos="0 0 1"><joint name="h" type="hinge" axis="0 1 0"/>
    <geom type="mesh" mesh="cube" density="1000" pos="0.3 0 0"/></body></worldbody></mujoco>"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        imp = read_mjcf(xml)
    model = imp.builder.compile()
    shape = static_scene(model)["bodies"][0]["shapes"][0]
    assert shape["type"] == "mesh"
    Vm = np.asarray(shape["vertices"], dtype=float)
    Fm = np.asarray(shape["faces"])
    assert _outward(Vm, Fm) == pytest.approx(0.2**3, rel=1e-6)      # closed and outward
    assert model.mass[0] == pytest.approx(1000 * 0.2**3, rel=1e-6)   # MuJoCo's mass from it
    # the mesh's own centroid sits at the body's centre of mass (the geom carries the body)
    A = mujoco  # noqa: F841 (the import above is the availability check)
    from spatialmbd.rotations import A_from_p
    R = A_from_p(np.asarray(shape.get("p", [1, 0, 0, 0]), dtype=float))
    centroid = np.asarray(shape["center"]) + R @ Vm.mean(axis=0)
    assert np.allclose(centroid, 0.0, atol=1e-6)
