"""Mass properties of shapes (spatialmbd.importers.massprops) and bodies given by density and
shapes in model files."""
from __future__ import annotations

import numpy as np
import pytest

from spatialmbd.errors import ModelError
from spatialmbd.importers.massprops import (body_mass_properties, capsule, combine, cylinder,
                                            shape_mass_properties, sphere)
from spatialmbd.io.modelfile import ModelFileError, load_builder


def test_capsule_is_cylinder_plus_sphere_split():
    # independent check: a capsule of zero length is a sphere; the two caps together are a
    # sphere whose halves moved apart by L (parallel-axis theorem with the half-sphere centroid)
    rho, r = 1200.0, 0.07
    np.testing.assert_allclose(capsule(rho, r, 0.0).inertia, sphere(rho, r).inertia, rtol=1e-12)
    L = 0.4
    cap, cyl, ball = capsule(rho, r, L), cylinder(rho, r, L), sphere(rho, r)
    assert cap.mass == pytest.approx(cyl.mass + ball.mass, rel=1e-14)
    # axial moment: no parallel-axis term
    assert cap.inertia[2, 2] == pytest.approx(cyl.inertia[2, 2] + ball.inertia[2, 2], rel=1e-14)
    # transverse: sphere's own + m_s ((L/2)^2 + 2 (L/2) (3 r / 8))  (each half at L/2 + 3r/8)
    extra = ball.mass * ((L / 2) ** 2 + 2 * (L / 2) * 3 * r / 8)
    assert cap.inertia[0, 0] == pytest.approx(cyl.inertia[0, 0] + ball.inertia[0, 0] + extra,
                                              rel=1e-12)


def test_shapes_rotated_and_combined():
    # two unit-density cubes side by side make one 2 x 1 x 1 box
    a = shape_mass_properties(dict(type="box", size=[1, 1, 1], center=[-0.5, 0, 0]), 1.0)
    b = shape_mass_properties(dict(type="box", size=[1, 1, 1], center=[0.5, 0, 0]), 1.0)
    both = combine([a, b])
    whole = shape_mass_properties(dict(type="box", size=[2, 1, 1]), 1.0)
    assert both.mass == pytest.approx(2.0)
    np.testing.assert_allclose(both.com, 0, atol=1e-15)
    np.testing.assert_allclose(both.inertia, whole.inertia, rtol=1e-12)
    # a cylinder along x has its axial moment about x
    c = shape_mass_properties(dict(type="cylinder", radius=0.2, length=1.0, axis=[1, 0, 0]), 3.0)
    assert c.inertia[0, 0] == pytest.approx(c.mass * 0.2**2 / 2, rel=1e-12)
    with pytest.raises(ModelError, match="density"):
        shape_mass_properties(dict(type="sphere", radius=1.0), -1.0)


def test_mesh_mass_properties_through_trimesh():
    pytest.importorskip("trimesh")
    # a unit cube as a closed triangle mesh: the box formula
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    f = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    mp = shape_mass_properties(dict(type="mesh", vertices=v, faces=f), 500.0)
    box = shape_mass_properties(dict(type="box", size=[1, 1, 1]), 500.0)
    assert mp.mass == pytest.approx(500.0)
    np.testing.assert_allclose(mp.com, 0.5)
    np.testing.assert_allclose(mp.inertia, box.inertia, atol=1e-9)
    with pytest.raises(ModelError, match="watertight"):
        shape_mass_properties(dict(type="mesh", vertices=v, faces=f[:-1]), 500.0)


def _model(body):
    return {"spatialmbd": 1, "name": "m", "bodies": [dict({"name": "b"}, **body)]}


def test_model_file_body_from_density_and_shapes():
    # a 0.2 x 0.1 x 0.1 m steel-like box: m = 7800 * 0.002 = 15.6 kg, I = m (b^2 + c^2) / 12
    builder, _ = load_builder(_model({"density": 7800, "shapes": [
        {"type": "box", "size": [0.2, 0.1, 0.1]}]}))
    body = builder.bodies["b"]
    m = 7800 * 0.2 * 0.1 * 0.1
    assert body.mass == pytest.approx(m, rel=1e-14)
    np.testing.assert_allclose(np.diag(body.inertia), m / 12 * np.array(
        [0.02, 0.05, 0.05]), rtol=1e-13)
    # a rod as a capsule along x plus a centred sphere: the sum of both closed forms
    builder, _ = load_builder(_model({"density": 1000, "shapes": [
        {"type": "capsule", "radius": 0.01, "length": 0.5, "axis": [1, 0, 0]},
        {"type": "sphere", "radius": 0.03}]}))
    cap, ball = capsule(1000, 0.01, 0.5), sphere(1000, 0.03)
    body = builder.bodies["b"]
    assert body.mass == pytest.approx(cap.mass + ball.mass, rel=1e-14)
    # about x (the capsule's axis): axial moment of the capsule
    assert body.inertia[0, 0] == pytest.approx(cap.inertia[2, 2] + ball.inertia[0, 0], rel=1e-12)


@pytest.mark.parametrize("body, match", [
    ({"density": 1000, "shapes": [{"type": "sphere", "radius": 0.1, "center": [0.2, 0, 0]}]},
     r"centre of mass of its shapes is at \[0.2, 0.0, 0.0\]"),
    ({"density": 1000, "mass": 1, "shapes": [{"type": "sphere", "radius": 0.1}]}, "not both"),
    ({"density": 1000, "shapes": []}, "needs shapes"),
    ({"density": -5, "shapes": [{"type": "sphere", "radius": 0.1}]}, "density"),
    ({"density": 1000, "shapes": [{"type": "capsule", "radius": 0.1}]}, "length"),
])
def test_model_file_density_errors_name_the_problem(body, match):
    with pytest.raises(ModelFileError, match=match):
        load_builder(_model(body))


def test_body_mass_properties_per_shape_density():
    shapes = [{"type": "box", "size": [0.1, 0.1, 0.1], "center": [-0.1, 0, 0]},
              {"type": "box", "size": [0.1, 0.1, 0.1], "center": [0.05, 0, 0]}]
    # densities 1000 and 2000 put the centre of mass at x = (-0.1 + 2 * 0.05) / 3 = 0
    mass, inertia = body_mass_properties(shapes, [1000.0, 2000.0])
    assert mass == pytest.approx(3.0)
    with pytest.raises(ModelError, match="move every shape"):
        body_mass_properties(shapes, 1000.0)
