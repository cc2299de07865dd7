"""Convex contact shapes (box, cylinder, ellipsoid, convex hull with spheres, capsules and
planes): the narrow phase against coal on 1,000 random poses per pair, the gap rate against
finite differences, the stiffness from materials, a box and a cylinder resting flat without
rocking (static compression m g / k_eff) and bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.forces.contact import support as sup
from spatialmbd.forces.contact.manifold import OPEN
from spatialmbd.state import BodyState

from contact_oracle import SHAPES, HULL_POINTS, compare, summary
from fd_check import q_along
from spatialmbd.rotations import normalize_p

NAMES = sorted(SHAPES)
PAIRS = [(a, b) for k, a in enumerate(NAMES) for b in NAMES[k:]]
CURVED = {"cylinder", "ellipsoid"}


@pytest.mark.parametrize("pair", [f"{a}-{b}" for a, b in PAIRS])
def test_narrow_phase_against_coal(pair):
    """1,000 random poses per pair. Separated: the distance agrees with coal's or is certified
    by the support functions (the separation along our normal, a lower bound of the true
    distance, reached; our distance is an upper bound, its witness points lie in the shapes)
    to 1e-9 m -- 1e-7 m for cylinder pairs (GJK's simplex degenerates on the cylinder's
    flat-to-curved boundary). Penetrating: our depth is reached along our normal (EPA's
    certificate, 1e-9 m; 1e-7 m for curved pairs, iterative) and coal's normal shows no
    smaller penetration (1e-9 m); pairs of polytopes, spheres and capsules agree with coal's
    depth, normal and witness planes to 1e-9. Coal's penetration of curved shapes is not used
    (its EPA fails at tight tolerances and then contradicts its own normal)."""
    pytest.importorskip("coal")
    a, b = pair.split("-")
    curved = bool({a, b} & CURVED)
    s = summary(compare(a, b, 1000, seed=sum(map(ord, pair))))
    assert s["separated"] > 100 and s["penetrating"] > 100
    assert s["verified_sep"] < (1e-7 if "cylinder" in (a, b) else 1e-9)
    assert s["certificate_pen"] < (1e-7 if curved else 1e-9)
    assert s["coal_normal_better"] < 1e-9
    if not curved:
        assert s["distance"] < 1e-9 and s["certificate_sep"] < 1e-9
        assert s["depth"] < 1e-9
        assert s["normal_pen"] < 1e-6
        assert s["points_along_n"] < 1e-9


# ------------------------------------------------------------------ models of resting shapes
BOX_BASE = {"type": "box", "half_extents": (0.5, 0.4, 0.1), "center": (0, 0, -0.1)}
PLANE = {"type": "plane", "normal": (0, 0, 1.0)}
RESTING = {   # (shape on the ground, shape on the body, height of the body's centre at touch)
    "box-box": (BOX_BASE, {"type": "box", "half_extents": (0.1, 0.15, 0.05)}, 0.05),
    "box-capsule": (BOX_BASE, {"type": "capsule", "radius": 0.05, "half_length": 0.2,
                               "axis": (1.0, 0.0, 0.0)}, 0.05),
    "box-cylinder": (BOX_BASE, {"type": "cylinder", "radius": 0.1, "half_length": 0.05},
                     0.05),
    "box-convex": (BOX_BASE, {"type": "convex", "vertices": [[x, y, z] for x in (-.1, .1)
                                                             for y in (-.1, .1)
                                                             for z in (-.05, .05)]
                              + [[0, 0, 0.09]]}, 0.05),
    "plane-cylinder": (PLANE, {"type": "cylinder", "radius": 0.1, "half_length": 0.05}, 0.05),
    "plane-cylinder-side": (PLANE, {"type": "cylinder", "radius": 0.1, "half_length": 0.2,
                                    "axis": (1.0, 0.0, 0.0)}, 0.1),
    "plane-convex": (PLANE, {"type": "convex", "vertices": HULL_POINTS.tolist()}, None),
    "plane-ellipsoid": (PLANE, {"type": "ellipsoid", "semi_axes": (0.1, 0.2, 0.05)}, 0.05),
}


def resting_model(pair, gravity=0.0, **law):
    shape_i, shape_j, h = RESTING[pair]
    if h is None:
        h = -HULL_POINTS[:, 2].min()
    b = ModelBuilder(gravity=(0, 0, -gravity))
    b.add_body("b", 2.0, (0.02, 0.03, 0.04), r=(0.01, -0.02, h - 1e-4))
    law = law or dict(law="linear", stiffness=1e5)
    b.add_force("contact", "c", body_i="ground", body_j="b", shape_i=shape_i, shape_j=shape_j,
                **law)
    return b.compile()


@pytest.mark.parametrize("pair", sorted(RESTING))
def test_gap_rate_of_resting_shapes(pair):
    """A shape resting on a face, moved by small random rotations and velocities: every
    contact point is a vertex (or a rim point, the deepest point of a curved shape) of one
    body over a face of the other, where the gap rate is exactly n . v_rel; checked against
    4th-order central differences of the gaps along the motion."""
    model = resting_model(pair)
    group = model.force_groups[0]
    rng = np.random.default_rng(sum(map(ord, pair)))
    q_ref = np.array([[*model.bodies_r[0], *model.bodies_p[0]]]) if hasattr(model, "bodies_r") \
        else None
    h = 1e-5
    checked = 0
    for _ in range(6):
        q0 = np.zeros((1, 7))
        spec = group  # noqa: F841
        q0[0, :3] = (0.01, -0.02, RESTING[pair][2] if RESTING[pair][2] else
                     -HULL_POINTS[:, 2].min())
        q0[0, :3] += rng.normal(size=3) * (0.01, 0.01, 0.001) - (0, 0, 0.002)
        tilt = rng.normal(size=3) * 0.02
        q0[0, 3:] = normalize_p(np.array([1.0, *(tilt / 2)]))[None]
        v = rng.normal(size=(1, 6)) * 0.1
        if pair == "plane-cylinder":
            v[0, 3:5] = 0.0       # rim points off the deepest: exact only for a flat cap
            q0[0, 3:] = (1.0, 0.0, 0.0, 0.0)
        d = group.details(BodyState.from_qv(q0, v))
        act = d[:, 0] < 0.5 * OPEN
        if pair.startswith("plane-cylinder"):
            act[[1, 2, 4, 5]] = False      # the +-120 deg rim points: exact for a flat cap only

        def gap(dt):
            return group.gaps(BodyState.from_qv(q_along(q0, v, dt), v))
        g = [gap(k * h) for k in (-2, -1, 1, 2)]
        fd = (g[0] - 8 * g[1] + 8 * g[2] - g[3]) / (12 * h)
        assert np.allclose(fd[act], d[act, 1], atol=1e-7 * (1 + np.abs(fd).max())), pair
        assert np.allclose(np.linalg.norm(d[act, 13:16], axis=1), 1.0)
        checked += act.sum()
    assert checked >= 6


def settle(pair, k, m=2.0, t_end=1.5, **extra):
    """Body of mass m dropped 0.1 mm onto the face, damped, friction on: its final pose and
    the contact details."""
    from spatialmbd.simulate import simulate
    shape_i, shape_j, h = RESTING[pair]
    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("b", m, (0.02, 0.03, 0.04), r=(0.01, -0.02, h + 1e-4))
    b.add_force("contact", "c", body_i="ground", body_j="b", shape_i=shape_i, shape_j=shape_j,
                law="linear", stiffness=k, damping=2 * math.sqrt(k * m), friction="coulomb",
                mu=0.5, **extra)
    model = b.compile()
    res = simulate(model, t_end, output_step=0.01, rtol=1e-9, atol=1e-12)
    return model, res, h


@pytest.mark.parametrize("pair, points", [("box-box", 4), ("box-convex", 4),
                                          ("box-cylinder", 4), ("plane-cylinder", 3),
                                          ("plane-cylinder-side", 2), ("box-capsule", 2)])
def test_resting_flat_static_compression(pair, points):
    """A shape resting flat settles at the static compression m g / (points K) below the
    touch height, without rocking (tilt < 1e-9 rad) or creeping (drift < 1e-6 m)."""
    k, m = 1e6, 2.0
    model, res, h = settle(pair, k, m)
    q = res.q[-1, 0] if res.q.ndim == 3 else res.q[-1]
    delta = m * 9.81 / (points * k)
    assert q[2] == pytest.approx(h - delta, abs=1e-3 * delta)
    p = q[3:7] / np.linalg.norm(q[3:7])
    assert np.linalg.norm(p[1:]) < 1e-9
    assert np.hypot(q[0] - 0.01, q[1] + 0.02) < 1e-6


def test_stiffness_from_materials_per_pair():
    """Hertz for curved shapes, the flat punch for faces (docs/contact.md, table of pairs)."""
    E, nu = 2e11, 0.3
    Es = E / (1 - nu * nu)

    def K(shape_i, shape_j):
        b = ModelBuilder(gravity=(0, 0, 0))
        b.add_body("b", 1.0, (0.01, 0.01, 0.01), r=(0, 0, 5.0))
        b.add_force("contact", "c", body_i="ground", body_j="b", shape_i=shape_i,
                    shape_j=shape_j, law="hunt_crossley", restitution=0.8, young_j=E,
                    poisson_j=nu)
        g = b.compile().force_groups[0]
        return g.param[:, 9], g.param[:, 10]
    k, n = K(PLANE, {"type": "box", "half_extents": (0.1, 0.2, 0.3)})
    assert np.allclose(k, 2 * Es * math.sqrt(0.4 * 0.6 / math.pi) / 4) and np.all(n == 1.0)
    k, n = K(PLANE, {"type": "cylinder", "radius": 0.1, "half_length": 0.2})
    assert np.allclose(k, 2 * Es * 0.1 / 3) and np.all(n == 1.0) and k.size == 6
    k, n = K(PLANE, {"type": "ellipsoid", "semi_axes": (0.1, 0.2, 0.4)})
    assert np.allclose(k, 4 / 3 * Es * math.sqrt(0.2)) and np.all(n == 1.5)
    k, n = K({"type": "box", "half_extents": (1, 1, 0.1)}, {"type": "capsule", "radius": 0.05,
                                                             "half_length": 0.2})
    assert np.allclose(k, 4 / 3 * Es * math.sqrt(0.05)) and k.size == 2
    k, n = K({"type": "box", "half_extents": (1, 1, 0.1)},
             {"type": "box", "half_extents": (0.1, 0.2, 0.05)})
    assert np.allclose(k, 2 * Es * math.sqrt(0.4 * 0.2 / math.pi) / 4) and k.size == 4


@pytest.mark.parametrize("shape, key, text", [
    ({"type": "cylinder", "radius": 0.0, "half_length": 0.1}, "shape_j.radius", "zero size"),
    ({"type": "cylinder", "radius": 0.1}, "shape_j.half_length", "positive number"),
    ({"type": "ellipsoid", "semi_axes": (0.1, float("nan"), 0.1)}, "shape_j.semi_axes",
     "3 positive"),
    ({"type": "convex", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]},
     "shape_j.vertices", "degenerate hull"),
    ({"type": "convex", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, float("nan")]]},
     "shape_j.vertices[3]", "finite"),
    ({"type": "convex", "vertices": [[0, 0, 0], [1, 0, 0]]}, "shape_j.vertices",
     "at least 4"),
    ({"type": "convex", "vertices": np.random.default_rng(0).normal(size=(400, 3)).tolist()},
     "shape_j.vertices", "simplify"),
])
def test_bad_shapes_name_the_shape(shape, key, text):
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("b", 1.0, (0.01, 0.01, 0.01), r=(0, 0, 5.0))
    with pytest.raises(ModelError) as err:
        b.add_force("contact", "c", body_i="ground", body_j="b", shape_i=PLANE, shape_j=shape,
                    law="linear", stiffness=1e4)
    assert f"forces['c'].{key}" in str(err.value) and text in str(err.value)


def test_model_file_shapes(tmp_path):
    """The new shapes in a model file: a cylinder and a convex hull on a box."""
    from spatialmbd.io import load_model
    path = tmp_path / "m.yaml"
    path.write_text("""spatialmbd: 1
gravity: [0, 0, -9.81]
bodies:
  - {name: can, mass: 1.0, inertia: [0.01, 0.01, 0.01], position: [0, 0, 0.3]}
  - {name: gem, mass: 1.0, inertia: [0.01, 0.01, 0.01], position: [1, 0, 0.3]}
contacts:
  - {name: c1, body_i: ground, body_j: can, shape_i: {type: plane, normal: [0, 0, 1]},
     shape_j: {type: cylinder, radius: 0.1, half_length: 0.2}, law: linear, stiffness: 1.0e+5}
  - {name: c2, body_i: ground, body_j: gem,
     shape_i: {type: box, half_extents: [2, 2, 0.1], center: [0, 0, -0.1]},
     shape_j: {type: convex, vertices: [[0.1, 0, 0], [-0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1],
                                        [0, 0, -0.1]]},
     law: hunt_crossley, restitution: 0.5, young_j: 1.0e+9}
""")
    model, _ = load_model(path)
    names = [n for g in model.force_groups for n in g.names]
    assert names[:6] == [f"c1[{k}]" for k in range(6)] and "c2[0]" in names
    assert sup.N_COLUMNS == model.force_groups[0].param.shape[1]


@pytest.mark.parametrize("pair", ["box-box", "box-capsule", "box-cylinder", "box-convex",
                                  "plane-ellipsoid", "plane-cylinder-side"])
def test_wrench_energy_and_power_of_resting_shapes(pair):
    """Sum over bodies of g . v = -dE/dt + P_diss along random motions near rest (E from 4th
    order central differences): the manifold points' forces are applied where the elastic
    energy and the dissipated power say, with a hysteresis law and Stribeck friction."""
    from spatialmbd.forces.kernels import evaluate_group
    law = dict(law="hunt_crossley", stiffness=2e4, restitution=0.6, friction="stribeck",
               mu_static=0.5, mu_dynamic=0.3, stribeck_velocity=0.2, creep_velocity=0.5,
               viscous=2.0)
    model = resting_model(pair, **law)
    group = model.force_groups[0]
    rng = np.random.default_rng(sum(map(ord, pair)) + 1)
    h = 1e-5
    for _ in range(4):
        q0 = np.zeros((1, 7))
        q0[0, :3] = (0.01, -0.02, RESTING[pair][2] - 0.002)
        q0[0, :3] += rng.normal(size=3) * (0.01, 0.01, 0.0005)
        q0[0, 3:] = normalize_p(np.array([1.0, *(rng.normal(size=3) * 0.01)]))[None]
        v = rng.normal(size=(1, 6)) * 0.1
        if pair == "plane-cylinder-side":
            v[0, 3:] = 0.0

        def energy(dt):
            s = BodyState.from_qv(q_along(q0, v, dt), v)
            return evaluate_group(group, s, 0.0)[1].sum()
        e = [energy(k * h) for k in (-2, -1, 1, 2)]
        dE = (e[0] - 8 * e[1] + 8 * e[2] - e[3]) / (12 * h)
        gen, en, power = evaluate_group(group, BodyState.from_qv(q0, v), 0.0)
        assert en.sum() > 0.0
        delivered = np.sum(gen[:1] * v)
        assert delivered == pytest.approx(-dE + power.sum(), abs=1e-6 * (1 + abs(dE)))
        assert np.all(power <= 1e-12)


@pytest.mark.parametrize("degrees, tips", [(26.0, False), (27.2, True)])
def test_box_on_a_ramp_tips_at_the_closed_form_angle(degrees, tips):
    """A box (half width b = 0.05 m, half height h = 0.1 m) standing on a tilted slab with
    mu = 0.9 > tan(theta) does not slide; it tips over iff tan(theta) > b / h (26.57 deg):
    0.57 deg below it stays on its face (rotation relative to the slab < 1e-3 rad after 0.6 s),
    0.63 deg above it has rotated by more than 0.2 rad (box-box manifold on the slab's face;
    measured: 4e-5 rad at 26.2 deg, 0.71 rad at 27.0 deg)."""
    from spatialmbd.simulate import simulate
    th = math.radians(degrees)
    R = np.array([[math.cos(th), 0, math.sin(th)], [0, 1, 0], [-math.sin(th), 0, math.cos(th)]])
    b_, h_ = 0.05, 0.1
    m = 1.0
    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("box", m, (m * (b_**2 + h_**2) / 3,) * 3, r=tuple(R @ (0, 0, 0.1 + h_ + 1e-5)),
               p=(math.cos(th / 2), 0.0, math.sin(th / 2), 0.0))
    k = 1e6
    b.add_force("contact", "c", body_i="ground", body_j="box",
                shape_i={"type": "box", "half_extents": (2.0, 2.0, 0.1), "axes": R},
                shape_j={"type": "box", "half_extents": (b_, b_, h_)},
                law="linear", stiffness=k, damping=2 * math.sqrt(k * m / 4),
                friction="coulomb", mu=0.9, creep_velocity=1e-3)
    res = simulate(b.compile(), 0.6, output_step=0.01, rtol=1e-8, atol=1e-10)
    p = res.q[-1, 0, 3:] if res.q.ndim == 3 else res.q[-1, 3:]
    p = p / np.linalg.norm(p)
    angle = 2 * math.acos(min(1.0, abs(p[0] * math.cos(th / 2) + p[2] * math.sin(th / 2))))
    assert (angle > 0.2) if tips else (angle < 1e-3)
