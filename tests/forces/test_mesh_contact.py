"""Triangle meshes and height fields against convex shapes (spatialmbd.forces.contact.mesh_*):
the narrow phase against coal's BVHModel on random poses, the height field against its
equivalent mesh, the merged manifold (a box resting across triangles, a sphere rolling over
seams), the wrench against finite differences of the energy, and bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.forces.contact import convex_shapes as CS
from spatialmbd.forces.contact import heightfield as HF
from spatialmbd.forces.contact import mesh_query as MQ
from spatialmbd.forces.contact import mesh_shape as MS
from spatialmbd.forces.contact import support as sup
from spatialmbd.rotations import normalize_p
from spatialmbd.state import BodyState

from contact_oracle import SHAPES, _coal_query, coal_shape, frame, random_rotation
from fd_check import q_along

CURVED = {"cylinder", "ellipsoid"}


def bumpy(n=6, size=1.2, amplitude=0.1, seed=7):
    """A non-convex terrain patch: (heights (n+1, n+1), size, vertices, faces)."""
    H = np.random.default_rng(seed).uniform(-amplitude, amplitude, (n + 1, n + 1))
    V, F, _ = HF.triangles(H, (size, size))
    return H, (size, size), V, F


def plane_mesh(n=5, half=1.0, seed=3):
    """A flat square z = 0 cut into 2 n^2 triangles of irregular shapes (jittered vertices)."""
    x = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(x, x)
    jitter = np.random.default_rng(seed).uniform(-0.3, 0.3, (n + 1, n + 1, 2)) * (x[1] - x[0])
    jitter[[0, -1], :, :] = 0.0
    jitter[:, [0, -1], :] = 0.0
    V = np.column_stack([(X + jitter[..., 0]).ravel(), (Y + jitter[..., 1]).ravel(),
                         np.zeros(X.size)])
    _, F, _ = HF.triangles(np.zeros((n + 1, n + 1)), (2 * half, 2 * half))
    return V, F


def mesh_rows(V, F):
    nb = MS.check_surface(V, F, "mesh")
    return MS.mesh_rows(V, F, nb, MS.build_bvh(V, F))


@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_mesh_distance_against_coal(shape):
    """2,000 random poses of each convex shape over a bumpy (non-convex) terrain of 72
    triangles: the least signed distance over the triangles (the narrow phase the contacts
    start from) agrees with coal's BVHModel distance to 1e-9 m (1e-7 m for a cylinder, as
    for the convex pairs; 1e-6 m for an ellipsoid, coal's own error) when separated, and so
    do the normals (1e-6, curved shapes 1e-4, 99% of poses: a few sit where two triangles
    are equally near); penetrating polytopes, spheres and capsules
    agree to 1e-9 m with the deepest of coal's per-triangle contacts (coal.collide; its
    distance() stops at the first triangle in collision). Coal's EPA is not used for the
    curved shapes (see test_contact_convex)."""
    coal = pytest.importorskip("coal")
    H, size, V, F = bumpy()
    P = mesh_rows(V, F)
    W = np.zeros(2 * sup.SIDE_WIDTH)
    W[sup.SIDE_WIDTH:] = CS.side_block(*SHAPES[shape])
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(F), len(V))
    model.addVertices(V)
    model.addTriangles(F.astype(np.int64))
    model.endModel()
    body = coal_shape(SHAPES[shape])
    rng = np.random.default_rng(sum(map(ord, shape)))
    fm = frame(np.zeros(3), np.eye(3))
    errors = {"sep": [], "pen": [], "normal": []}
    for _ in range(2000):
        R = random_rotation(rng)
        c = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.15, 0.6)])
        d, n, a, b, t = MQ.mesh_signed_distance(P, 0, fm, W, frame(c, R))
        dc, nc, p1, p2, tol = _coal_query(model, coal.Transform3s(), body,
                                          coal.Transform3s(R, c))
        if not np.isfinite(dc):
            continue
        if d > 0:
            errors["sep"].append(abs(d - dc))
            if d > 1e-3:
                errors["normal"].append(np.linalg.norm(np.array(n) - nc))
        elif shape not in CURVED:                   # coal's deepest triangle of all
            request = coal.CollisionRequest(coal.CollisionRequestFlag.CONTACT, 1000)
            request.gjk_tolerance = request.epa_tolerance = 1e-12
            result = coal.CollisionResult()
            coal.collide(model, coal.Transform3s(), body, coal.Transform3s(R, c), request,
                         result)
            depths = [x.penetration_depth for x in result.getContacts()]
            errors["pen"].append(abs(d - min(depths)))
    assert len(errors["sep"]) > 300
    # ellipsoid: coal's own distance is off by up to 4e-6 m (docs/contact.md)
    assert max(errors["sep"]) < {"cylinder": 1e-7, "ellipsoid": 1e-6}.get(shape, 1e-9)
    assert np.quantile(errors["normal"], 0.99) < (1e-4 if shape in CURVED else 1e-6)
    if shape not in CURVED:
        assert len(errors["pen"]) > 200 and max(errors["pen"]) < 1e-9


def _pose_state(c, R):
    from spatialmbd.rotations import p_from_A
    q = np.zeros((1, 7))
    q[0, :3], q[0, 3:] = c, p_from_A(R)
    return BodyState.from_qv(q, np.zeros((1, 6)))


def _model(shape_i, shape_j, r=(0.0, 0.0, 1.0), gravity=0.0, m=2.0, **law):
    b = ModelBuilder(gravity=(0, 0, -gravity))
    b.add_body("b", m, (0.02, 0.03, 0.04), r=r)
    law = law or dict(law="linear", stiffness=1e5)
    b.add_force("mesh_contact", "m", body_i="ground", body_j="b", shape_i=shape_i,
                shape_j=shape_j, **law)
    return b.compile()


SHAPE_DICTS = {"sphere": {"type": "sphere", "radius": 0.12},
               "box": {"type": "box", "half_extents": (0.1, 0.15, 0.05)},
               "capsule": {"type": "capsule", "radius": 0.05, "half_length": 0.15,
                           "axis": (1.0, 0.0, 0.0)}}


def test_heightfield_equals_its_mesh():
    """A height field and the mesh of the same triangles (found through the tree instead of
    the grid cells) give the same wrench on a sphere, a box and a capsule in 200 random poses
    each over a bumpy terrain (to 1e-12 relative)."""
    from spatialmbd.forces.kernels import evaluate_group
    H, size, V, F = bumpy()
    hf = {"type": "heightfield", "heights": H.tolist(), "size": list(size)}
    mesh = {"type": "mesh", "vertices": V.tolist(), "faces": F.tolist()}
    rng = np.random.default_rng(11)
    touching = 0
    for name, shape in SHAPE_DICTS.items():
        groups = [_model(s, shape).force_groups[0] for s in (hf, mesh)]
        for _ in range(200):
            c = (rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(0.0, 0.15))
            state = _pose_state(c, random_rotation(rng))
            g1, g2 = (evaluate_group(g, state, 0.0)[0] for g in groups)
            assert np.allclose(g1, g2, rtol=1e-12, atol=1e-12 * (1 + np.abs(g1).max()))
            touching += bool(np.any(g1))
    assert touching > 150


def test_box_rests_across_triangles_at_the_static_compression():
    """A box (2 kg, K = 1e6 N/m per point) dropped onto a flat mesh of 50 irregular triangles
    with seams under it settles at m g / (4 K) below the touch height on its four corners,
    without rocking (tilt < 1e-9 rad) or creeping (drift < 1e-6 m)."""
    from spatialmbd.simulate import simulate
    V, F = plane_mesh()
    k, m = 1e6, 2.0
    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("b", m, (0.02, 0.03, 0.04), r=(0.01, -0.02, 0.05 + 1e-4))
    b.add_force("mesh_contact", "m", body_i="ground", body_j="b",
                shape_i={"type": "mesh", "vertices": V.tolist(), "faces": F.tolist()},
                shape_j=SHAPE_DICTS["box"], law="linear", stiffness=k,
                damping=2 * math.sqrt(k * m), friction="coulomb", mu=0.5)
    model = b.compile()
    group = model.force_groups[0]
    below = group.contacts(_pose_state((0.01, -0.02, 0.0499), np.eye(3)))
    assert below.shape[0] == 4                      # the corners, whatever the triangles
    res = simulate(model, 1.0, output_step=0.01, rtol=1e-9, atol=1e-12)
    q = res.q[-1, 0] if res.q.ndim == 3 else res.q[-1]
    delta = m * 9.81 / (4 * k)
    assert q[2] == pytest.approx(0.05 - delta, abs=1e-3 * delta)
    p = q[3:7] / np.linalg.norm(q[3:7])
    assert np.linalg.norm(p[1:]) < 1e-9
    assert np.hypot(q[0] - 0.01, q[1] + 0.02) < 1e-6


def test_sphere_crosses_seams_without_a_bump():
    """A sphere pressed 1 mm into a flat mesh of irregular triangles, moved along a line that
    crosses seams and passes over vertices: the contact force is the same everywhere (one
    contact, normal +z, f = K delta to 1e-9 relative), and rolling across the mesh under
    gravity its height stays within 1e-9 m of the static compression."""
    from spatialmbd.forces.kernels import evaluate_group
    from spatialmbd.simulate import simulate
    V, F = plane_mesh()
    R, k, m = 0.12, 1e5, 1.0
    mesh = {"type": "mesh", "vertices": V.tolist(), "faces": F.tolist()}
    model = _model(mesh, SHAPE_DICTS["sphere"], r=(0, 0, R), stiffness=k, law="linear")
    group = model.force_groups[0]
    xs = np.linspace(-0.7, 0.7, 1401)
    forces = []
    for x in xs:
        state = _pose_state((x, 0.3 * x + 0.05, R - 1e-3), np.eye(3))
        c = group.contacts(state)
        assert c.shape[0] == 1 and np.allclose(c[0, 3:6], (0, 0, 1), atol=1e-12)
        forces.append(evaluate_group(group, state, 0.0)[0][0])
    forces = np.array(forces)
    assert np.allclose(forces[:, 2], k * 1e-3, rtol=1e-9)
    assert np.abs(forces[:, [0, 1, 3, 4, 5]]).max() < 1e-9 * k * 1e-3
    b = ModelBuilder(gravity=(0, 0, -9.81))
    delta = m * 9.81 / k
    b.add_body("s", m, (0.4 * m * R * R,) * 3, r=(-0.6, -0.1, R - delta), rdot=(1.0, 0.2, 0.0),
               omega=(-0.2 / R, 1.0 / R, 0.0))
    b.add_force("mesh_contact", "m", body_i="ground", body_j="s", shape_i=mesh,
                shape_j=SHAPE_DICTS["sphere"], law="linear", stiffness=k,
                damping=2 * math.sqrt(k * m), friction="coulomb", mu=0.5)
    res = simulate(b.compile(), 1.0, output_step=0.002, rtol=1e-10, atol=1e-12)
    z = (res.q[:, 0, 2] if res.q.ndim == 3 else res.q[:, 2])
    x = (res.q[:, 0, 0] if res.q.ndim == 3 else res.q[:, 0])
    assert x[-1] > 0.3                               # it crossed several triangles
    assert np.abs(z - (R - delta)).max() < 1e-9


BOWL_AND_RIDGE = {
    # a small tilted plane of 2 large triangles (the box's corners inside one prism)
    "box-tilted": ({"type": "mesh", "vertices": [[-2, -2, -0.2], [2, -2, 0.2], [2, 2, 0.2],
                                                  [-2, 2, -0.2]],
                    "faces": [[0, 1, 2], [0, 2, 3]]}, "box", (0.3, 0.8, 0.08)),
    # a ridge (roof) under a sphere: the edge contact
    "sphere-ridge": ({"type": "mesh", "vertices": [[-1, -1, 0], [0, -1, 0.3], [0, 1, 0.3],
                                                    [-1, 1, 0], [1, -1, 0], [1, 1, 0]],
                      "faces": [[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]]}, "sphere",
                     (0.0, 0.0, 0.415)),
    # a sphere on a bumpy terrain (faces, edges and vertices)
    "sphere-bumpy": (None, "sphere", (0.1, 0.1, 0.3)),
}


@pytest.mark.parametrize("case", sorted(BOWL_AND_RIDGE))
def test_wrench_energy_and_power(case):
    """Sum over bodies of g . v = -dE/dt + P_diss along random motions near contact (E from
    4th-order central differences): the merged contacts' forces act where the elastic energy
    and the dissipated power say (linear law with damping, Stribeck friction). The cases are
    vertices of the shape over a face, an edge contact and support points; a point made by
    clipping (a capsule's segment cut by a triangle's side) slides along the segment, and
    its gap rate has the extra term docs/contact.md describes for the convex manifolds."""
    from spatialmbd.forces.kernels import evaluate_group
    mesh, shape, c0 = BOWL_AND_RIDGE[case]
    if mesh is None:
        H, size, V, F = bumpy()
        mesh = {"type": "heightfield", "heights": H.tolist(), "size": list(size)}
    law = dict(law="linear", stiffness=2e4, damping=30.0, friction="stribeck",
               mu_static=0.5, mu_dynamic=0.3, stribeck_velocity=0.2, creep_velocity=0.5,
               viscous=2.0)
    model = _model(mesh, SHAPE_DICTS[shape], r=(0, 0, 2.0), **law)
    group = model.force_groups[0]
    rng = np.random.default_rng(sum(map(ord, case)))
    h = 1e-6
    checked = 0
    for _ in range(8):
        q0 = np.zeros((1, 7))
        q0[0, :3] = np.array(c0) + rng.normal(size=3) * (0.01, 0.01, 0.002)
        if shape == "box":                          # flat on the plane z = 0.1 x, 3 mm in
            from spatialmbd.rotations import p_from_A
            sn, cs = -0.1 / math.sqrt(1.01), 1.0 / math.sqrt(1.01)
            A = np.array([[cs, 0.0, sn], [0.0, 1.0, 0.0], [-sn, 0.0, cs]])
            x0, y0 = q0[0, 0], q0[0, 1]
            q0[0, :3] = np.array([x0, y0, 0.1 * x0]) + (0.05 - 0.003) * A[:, 2]
            q0[0, 3:] = normalize_p(p_from_A(A) + rng.normal(size=4) * 0.003)
        elif case == "sphere-bumpy":                # lowered until it touches, then 2 mm
            q0[0, 3:] = normalize_p(np.array([1.0, *(rng.normal(size=3) * 0.05)]))
            while len(group.contacts(BodyState.from_qv(q0, np.zeros((1, 6))))) == 0:
                q0[0, 2] -= 0.002
            q0[0, 2] -= 0.002
        else:
            q0[0, 3:] = normalize_p(np.array([1.0, *(rng.normal(size=3) * 0.05)]))
        v = rng.normal(size=(1, 6)) * 0.1
        state = BodyState.from_qv(q0, v)
        if len(group.contacts(state)) == 0:
            continue

        def energy(dt):
            return evaluate_group(group, BodyState.from_qv(q_along(q0, v, dt), v), 0.0)[1].sum()
        e = [energy(k * h) for k in (-2, -1, 1, 2)]
        dE = (e[0] - 8 * e[1] + 8 * e[2] - e[3]) / (12 * h)
        gen, en, power = evaluate_group(group, state, 0.0)
        assert en.sum() > 0.0
        delivered = np.sum(gen[:1] * v)
        assert delivered == pytest.approx(-dE + power.sum(), abs=1e-6 * (1 + abs(dE)))
        assert np.all(power <= 1e-12)
        checked += 1
    assert checked >= 4


def _builder():
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("b", 1.0, (0.01, 0.01, 0.01), r=(0, 0, 5.0))
    return b


SQUARE_V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]


@pytest.mark.parametrize("shape_i, key, text", [
    ({"type": "mesh", "vertices": SQUARE_V, "faces": [[0, 1, 4]]}, "shape_i.faces[0]",
     "out of range"),
    ({"type": "mesh", "vertices": SQUARE_V, "faces": [[0, 1, 1]]}, "shape_i.faces[0]",
     "repeats a vertex"),
    ({"type": "mesh", "vertices": SQUARE_V[:3] + [[2, 0, 0]], "faces": [[0, 1, 3]]},
     "shape_i.faces[0]", "zero area"),
    ({"type": "mesh", "vertices": SQUARE_V[:3] + [[0, float("nan"), 0]],
      "faces": [[0, 1, 2]]}, "shape_i.vertices[3]", "non-finite"),
    ({"type": "mesh", "vertices": SQUARE_V + [[0.5, 0.5, 1], [0.5, 0.5, -1]],
      "faces": [[0, 1, 4], [1, 0, 5], [0, 1, 2]]}, "shape_i.faces[2]", "non-manifold edge"),
    ({"type": "mesh", "vertices": SQUARE_V, "faces": [[0, 1, 2], [0, 3, 2]]},
     "shape_i.faces[1]", "wound the same way"),
    ({"type": "mesh", "vertices": SQUARE_V + [[2, 1, 0], [2, 2, 0]],
      "faces": [[0, 1, 2], [2, 4, 5]]}, "shape_i.vertices[2]", "non-manifold vertex"),
    ({"type": "heightfield", "heights": [[0, 0], [0, float("nan")]], "size": [1, 1]},
     "shape_i.heights[1][1]", "finite height"),
    ({"type": "heightfield", "heights": [[0, 0], [0, 0]], "size": [1, 0]}, "shape_i.size",
     "two positive"),
    ({"type": "heightfield", "heights": [[0, 0, 0]], "size": [1, 1]}, "shape_i.heights",
     "2 x 2"),
])
def test_bad_meshes_name_the_element_and_the_value(shape_i, key, text):
    b = _builder()
    with pytest.raises(ModelError) as err:
        b.add_force("mesh_contact", "m", body_i="ground", body_j="b", shape_i=shape_i,
                    shape_j=SHAPE_DICTS["sphere"], law="linear", stiffness=1e4)
        b.compile()
    assert f"forces['m'].{key}" in str(err.value) and text in str(err.value)


def test_refused_laws_and_shapes():
    b = _builder()
    mesh = {"type": "mesh", "vertices": SQUARE_V, "faces": [[0, 1, 2], [0, 2, 3]]}
    for extra, text in ((dict(law="hunt_crossley"), "'linear'"),
                        (dict(friction="lugre", mu=0.3), "lugre"),
                        (dict(shape_j={"type": "plane", "normal": (0, 0, 1)}), "convex")):
        kw = dict(law="linear", stiffness=1e4, shape_j=SHAPE_DICTS["sphere"])
        kw.update(extra)
        with pytest.raises(ModelError, match=text):
            b.add_force("mesh_contact", "m", body_i="ground", body_j="b", shape_i=mesh, **kw)
            b.compile()


def test_model_file_mesh_and_heightfield(tmp_path):
    """Both shapes in a model file (forces of type mesh_contact), and a mesh from an OBJ
    file."""
    from spatialmbd.io import load_model
    obj = tmp_path / "floor.obj"
    obj.write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n")
    path = tmp_path / "m.yaml"
    path.write_text(f"""spatialmbd: 1
gravity: [0, 0, -9.81]
bodies:
  - {{name: ball, mass: 1.0, inertia: [0.01, 0.01, 0.01], position: [0, 0, 0.3]}}
  - {{name: puck, mass: 1.0, inertia: [0.01, 0.01, 0.01], position: [3, 0, 0.3]}}
forces:
  - {{name: hf, type: mesh_contact, body_i: ground, body_j: ball,
     shape_i: {{type: heightfield, heights: [[0, 0, 0], [0, 0.1, 0], [0, 0, 0]], size: [2, 2]}},
     shape_j: {{type: sphere, radius: 0.1}}, law: linear, stiffness: 1.0e+5}}
  - {{name: floor, type: mesh_contact, body_i: ground, body_j: puck,
     shape_i: {{type: mesh, file: {str(obj)!r}, center: [3, 0, 0]}},
     shape_j: {{type: cylinder, radius: 0.1, half_length: 0.05}}, law: linear,
     stiffness: 1.0e+5}}
""")
    model, _ = load_model(path)
    names = [n for g in model.force_groups for n in g.names]
    assert names[:8] == [f"hf[{k}]" for k in range(8)] and names[8:] == ["floor[0]", "floor[1]"]
