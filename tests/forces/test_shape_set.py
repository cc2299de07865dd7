"""The shape_set element (forces.contact.shape_set): many convex shapes found by the broad phase.

It must equal ``contact`` elements declared for every pair and wall (to round-off) whichever
shapes meet, its conservative part must be the gradient of its energy, boxes stacked on the
floor must rest at the static compression of their face manifolds, and bad input must be a
ModelError naming the element and the key."""
import itertools

import numpy as np
import pytest

from fd_check import q_along
from test_sphere_set import _forces
from spatialmbd import ModelBuilder, models
from spatialmbd.errors import ModelError
from spatialmbd.simulate import simulate

SHAPES = [{"type": "box", "half_extents": [0.05, 0.04, 0.03]},
          {"type": "sphere", "radius": 0.04, "center": [0.005, 0.0, -0.004]},
          {"type": "capsule", "radius": 0.025, "half_length": 0.035, "axis": [1, 1, 0]},
          {"type": "cylinder", "radius": 0.035, "half_length": 0.03},
          {"type": "ellipsoid", "semi_axes": [0.05, 0.04, 0.035]},
          {"type": "convex", "vertices": (np.random.default_rng(1).normal(size=(10, 3))
                                          * 0.03).tolist()}]
WALLS = [{"normal": [0, 0, 1], "point": [0, 0, 0]},
         {"normal": [-1, 0, 0], "point": [0.23, 0, 0]}]
LAW = dict(law="linear", stiffness=1e4, damping=20.0, mu=0.4, creep_velocity=1e-3)
#: a block fixed to the ground among the bodies (a shape of the set on "ground")
BLOCK = {"type": "box", "half_extents": [0.03, 0.03, 0.02], "center": [0.09, 0.05, 0.0]}


def _lattice(n):
    b = ModelBuilder("shapes", gravity=(0, 0, -9.81))
    pos = np.stack(np.meshgrid(np.arange(3) * 0.09, np.arange(2) * 0.09, np.arange(2) * 0.09,
                               indexing="ij"), -1).reshape(-1, 3)[:n] + [0, 0, 0.06]
    for k in range(n):
        b.add_body(f"b{k}", 1.0 + 0.1 * k, (0.001, 0.002, 0.003), r=tuple(pos[k]))
    return b


def test_equals_contact_elements_for_every_pair_and_wall():
    """12 bodies, every shape type against every other and against the walls, a block fixed
    to the ground, one body carrying two shapes: the same generalized forces, energy and power
    as a contact element per pair, at random poses where many of them touch."""
    n = 12
    shapes = [SHAPES[k % len(SHAPES)] for k in range(n)]
    bodies = [f"b{k}" for k in range(n)]
    extra = {"type": "sphere", "radius": 0.02, "center": [-0.05, 0.0, 0.0]}   # on b0 too
    set_bodies, set_shapes = bodies + ["b0", "ground"], shapes + [extra, BLOCK]
    a = _lattice(n)
    a.add_force("shape_set", "set", bodies=set_bodies, shapes=set_shapes, walls=WALLS, **LAW)
    b = _lattice(n)
    for i, j in itertools.combinations(range(len(set_bodies)), 2):
        if set_bodies[i] != set_bodies[j]:
            b.add_force("contact", f"c{i}_{j}", body_i=set_bodies[i], body_j=set_bodies[j],
                        shape_i=set_shapes[i], shape_j=set_shapes[j], **LAW)
    for i, name in enumerate(set_bodies[:-1]):
        for w, wall in enumerate(WALLS):
            b.add_force("contact", f"w{i}_{w}", body_i="ground", body_j=name,
                        shape_i={"type": "plane", **wall}, shape_j=set_shapes[i], **LAW)
    ma, mb = a.compile(), b.compile()
    assert list(ma.force_groups[0].names[-2:]) == ["set[b0#2]", "set[ground]"]
    rng = np.random.default_rng(5)
    q0 = np.array(ma.q0).reshape(n, 7)
    touching = 0
    for _ in range(6):
        q = q0.copy()
        q[:, :3] += rng.normal(scale=0.02, size=(n, 3))
        p = rng.normal(size=(n, 4))
        q[:, 3:] = p / np.linalg.norm(p, axis=1, keepdims=True)
        v = rng.normal(size=(n, 6))
        ga, ea, pa = _forces(ma, q, v)
        gb, eb, pb = _forces(mb, q, v)
        assert np.allclose(ga, gb, rtol=1e-12, atol=1e-9 * np.abs(gb).max())
        assert ea == pytest.approx(eb, rel=1e-12) and pa == pytest.approx(pb, rel=1e-12)
        touching += ea > 0
    assert touching >= 5                      # the states do have contacts


def test_conservative_part_is_the_gradient_of_its_energy():
    """Without damping and friction (hertz law), the power of the forces is -dV/dt along a
    motion where boxes, hulls and cylinders press on each other and on the floor."""
    rng = np.random.default_rng(3)
    b = ModelBuilder("pile", gravity=(0, 0, 0))
    n = 8
    pos = np.stack(np.meshgrid(np.arange(2) * 0.1, np.arange(2) * 0.1,
                               np.arange(2) * 0.075, indexing="ij"), -1).reshape(-1, 3)
    for k in range(n):
        p = np.array([1.0, 0, 0, 0]) + rng.normal(scale=0.05, size=4)
        b.add_body(f"b{k}", 1.0, (0.01, 0.01, 0.01), r=tuple(pos[k] + [0, 0, 0.03]),
                   p=tuple(p / np.linalg.norm(p)))
    kinds = [SHAPES[0], SHAPES[3], SHAPES[5], SHAPES[4]]
    b.add_force("shape_set", "pile", bodies=[f"b{k}" for k in range(n)],
                shapes=[kinds[k % 4] for k in range(n)],
                walls=[{"normal": [0, 0, 1], "point": [0, 0, 0]}], law="hertz",
                stiffness=1e7)
    model = b.compile()
    q0 = np.array(model.q0).reshape(n, 7)
    v = rng.normal(scale=0.1, size=(n, 6))
    h = 1e-7

    def V(dt):
        return _forces(model, q_along(q0, v, dt), v)[1]

    dV = (V(-2 * h) - 8 * V(-h) + 8 * V(h) - V(2 * h)) / (12 * h)
    g, energy, power = _forces(model, q0, v)
    assert energy > 0 and power == 0.0
    assert dV == pytest.approx(-np.sum(g[:n] * v), rel=1e-6)


def test_stacked_boxes_rest_at_the_static_compression_of_their_face_manifolds():
    """A smaller box turned by 0.3 rad stacked on a box on the floor (linear law): the top
    one rests on the four corners of its face manifold with the lower box, m g / (4 K) deep;
    the lower one on its four floor vertices under both weights, 2 m g / (4 K) deep -- so
    the face manifold is found (one witness point would let the top box rock and sink
    m g / K)."""
    h, ht, m, K = 0.03, 0.02, 1.5, 1e5
    b = ModelBuilder("stack", gravity=(0, 0, -9.81))
    b.add_body("low", m, (m / 3 * 2 * h * h,) * 3, r=(0.0, 0.0, h + 0.002))
    b.add_body("top", m, (m / 3 * 2 * ht * ht,) * 3, r=(0.0, 0.0, 2 * h + ht + 0.006),
               bryant=(0.0, 0.0, 0.3))
    b.add_force("shape_set", "stack", bodies=["low", "top"],
                shapes=[{"type": "box", "half_extents": [h, h, h]},
                        {"type": "box", "half_extents": [ht, ht, ht]}],
                walls=[{"normal": [0, 0, 1], "point": [0, 0, 0]}], law="linear", stiffness=K,
                damping=300.0, mu=0.5, creep_velocity=1e-3)
    res = simulate(b.compile(), 1.0, method="standard", output_step=0.01, rtol=1e-9,
                   atol=1e-11)
    assert res.status == "success"
    d_low = 2 * m * 9.81 / (4 * K)
    d_top = m * 9.81 / (4 * K)
    z = res.q[-1, :, 2]
    assert z[0] == pytest.approx(h - d_low, abs=1e-9)
    assert z[1] == pytest.approx(z[0] + h + ht - d_top, abs=1e-9)
    assert np.abs(res.v[-1]).max() < 1e-6


def test_bad_input_is_a_model_error():
    b = _lattice(3)
    names = ["b0", "b1", "b2"]
    box = {"type": "box", "half_extents": [0.02, 0.02, 0.02]}
    cases = [
        (dict(shape=box, law="hunt_crossley", stiffness=1e5), "impact velocity"),
        (dict(shape=box, law="linear", stiffness=1e5, friction="lugre"), "bristle"),
        (dict(shape=box, law="linear"), "stiffness"),
        (dict(shape=box, stiffness=-1.0), "stiffness"),
        (dict(shape=box, stiffness=1e5, walls=[{"normal": [0, 0, 0]}]), "must not be zero"),
        (dict(shape=box, stiffness=1e5, walls=[{"normal": [0, 0, 1]}] * 7), "at most 6"),
        (dict(shape=box, stiffness=1e5, mu=-0.1), "mu"),
        (dict(stiffness=1e5), "either 'shape'"),
        (dict(shape=box, shapes=[box] * 3, stiffness=1e5), "either 'shape'"),
        (dict(shapes=[box] * 2, stiffness=1e5), "list of 3 shape dicts"),
        (dict(shape={"type": "plane", "normal": [0, 0, 1]}, stiffness=1e5), "as 'walls'"),
        (dict(shape={"type": "box", "half_extents": [0.1, 0, 0.1]}, stiffness=1e5),
         "half_extents"),
        (dict(shape={"type": "convex", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]},
              stiffness=1e5), "vertices"),
        (dict(shape={"type": "sphere", "radius": float("nan")}, stiffness=1e5), "radius"),
        (dict(shape=box, stiffness=1e5, margin=-1e-3), "margin"),
    ]
    for params, text in cases:
        with pytest.raises(ModelError, match=text) as err:
            b.add_force("shape_set", "g", bodies=names, **params)
        assert "forces['g']" in str(err.value)
    with pytest.raises(ModelError, match=r"bodies\[1\].*no body named 'nope'"):
        b.add_force("shape_set", "g", bodies=["b0", "nope"], shape=box, stiffness=1.0)
    with pytest.raises(ModelError, match="list of body names"):
        b.add_force("shape_set", "g", bodies="b0", shape=box, stiffness=1.0)
    deep = ModelBuilder("deep")
    deep.add_body("a", 1.0, (1, 1, 1), r=(0, 0, 1))
    deep.add_body("b", 1.0, (1, 1, 1), r=(0.03, 0, 1))
    deep.add_force("shape_set", "g", bodies=["a", "b"], shape=box, stiffness=1.0)
    with pytest.raises(ModelError, match="interpenetrate"):
        deep.compile()
    wall = ModelBuilder("wall")
    wall.add_body("a", 1.0, (1, 1, 1), r=(0, 0, 0.005))
    wall.add_force("shape_set", "g", bodies=["a"], shape=box, stiffness=1.0,
                   walls=[{"normal": [0, 0, 1], "point": [0, 0, 0]}])
    with pytest.raises(ModelError, match=r"walls\[0\].*into the wall"):
        wall.compile()


def test_mixed_pile_example_settles_inside_its_box():
    """models.mixed_pile (examples/mixed_pile.yaml) with the example's integrator, 2 x 2 x 3
    bodies for time: every body ends inside the box (its centre above the floor and inside the
    walls by more than its smallest half size less the contact's reach), and energy +
    dissipated work is conserved to the integration error, which halving the step cuts (the
    touches are jumps of the force: a fixed step meets them at first to second order)."""
    model = models.mixed_pile(n_side=2, layers=3).compile()
    errors = []
    for step in (5e-4, 2.5e-4):
        res = simulate(model, 1.0, method="standard", integrator="rk4", step=step,
                       output_step=0.01)
        assert res.status == "success"
        q = res.q[-1]
        half = 2 * 0.075 / 2 + 0.01
        assert np.all(q[:, 2] > 0.012)
        assert np.all(np.abs(q[:, :2]) < half - 0.012)
        E = res.energy()
        assert E["work_nonconservative"][-1] < -0.5         # the drop's energy dissipated
        errors.append(np.abs(E["error"]).max() / abs(E["work_nonconservative"][-1]))
    assert errors[1] < 0.6 * errors[0] and errors[1] < 0.06     # 0.105 and 0.045
