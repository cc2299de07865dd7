"""Contact models: a slider-crank with a clearance joint, spheres in a box and a pile of mixed
convex shapes."""
from __future__ import annotations

import math

import numpy as np

from ..model import ModelBuilder
from ..motion import ConstantVelocity


def slider_crank_clearance(clearance: float = 5e-4, crank_speed: float = 20.0,
                           ideal: bool = False) -> ModelBuilder:
    """Planar slider-crank whose rod-slider joint has radial clearance (the setting of much of
    the clearance-joint literature, e.g. Flores et al., Kinematics and dynamics of multibody
    systems with imperfect joints, 2008): crank 0.05 m (0.30 kg) driven at ``crank_speed``
    rad/s about global z, connecting rod 0.12 m (0.21 kg), slider 0.14 kg along global x,
    gravity -y. At the rod-slider pin a journal of radius 10 mm - ``clearance`` on the rod sits
    in a 10 mm bearing on the slider: Lankarani-Nikravesh contact (K = 1e9 N/m^1.5, e = 0.9)
    with Coulomb friction mu = 0.01. ``ideal`` puts a revolute joint there instead (the
    reference). The journal starts centred; the contact force history is ``res.contacts()``.
    """
    L1, L2 = 0.05, 0.12
    b = ModelBuilder("slider_crank_ideal" if ideal else "slider_crank_clearance",
                     gravity=(0.0, -9.81, 0.0))
    b.add_body("crank", 0.30, (1e-4, 1e-4, 1e-4), r=(L1 / 2, 0.0, 0.0),
               omega=(0.0, 0.0, crank_speed), rdot=(0.0, crank_speed * L1 / 2, 0.0),
               shapes=[{"type": "box", "size": [L1, 0.01, 0.01], "center": [0, 0, 0]}])
    b.add_body("rod", 0.21, (2.5e-4, 2.5e-4, 2.5e-4), r=(L1 + L2 / 2, 0.0, 0.0),
               rdot=(0.0, crank_speed * L1 / 2, 0.0),
               omega=(0.0, 0.0, -crank_speed * L1 / L2),
               shapes=[{"type": "box", "size": [L2, 0.008, 0.008], "center": [0, 0, 0]}])
    b.add_body("slider", 0.14, (1e-4, 1e-4, 1e-4), r=(L1 + L2, 0.0, 0.0),
               shapes=[{"type": "box", "size": [0.04, 0.025, 0.025], "center": [0, 0, 0]}])
    b.add_joint("revolute", "A", "ground", "crank", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "B", "crank", "rod", point=(L1, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "guide", "ground", "slider", point=(L1 + L2, 0, 0),
                axis=(1, 0, 0))
    b.add_driver("angle", "motor", ConstantVelocity(rate=crank_speed), joint="A")
    if ideal:
        b.add_joint("revolute", "C", "rod", "slider", point=(L1 + L2, 0, 0), axis=(0, 0, 1))
    else:
        b.add_force("contact", "C", body_i="slider", body_j="rod",
                    shape_i={"type": "bearing", "radius": 0.01, "axis": [0, 0, 1]},
                    shape_j={"type": "journal", "radius": 0.01 - clearance,
                             "center": [L2 / 2, 0, 0]},
                    law="lankarani_nikravesh", stiffness=1e9, restitution=0.9,
                    friction="coulomb", mu=0.01, creep_velocity=1e-4)
    return b


def spheres_in_box(n_side: int = 4, radius: float = 0.02, mass: float = 0.03,
                   seed: int = 1) -> ModelBuilder:
    """n_side^3 spheres poured into an open box: a lattice with a small random offset above a
    floor and four walls (a ``sphere_set``: the pairs come from the broad phase), linear
    contact K = 2e4 N/m with damping 2 N s/m and Coulomb friction mu = 0.3 regularised with a
    creep velocity of 1 cm/s (a smaller one makes the sticking contacts stiff: the explicit
    step must stay below about 3 v_eps m / (7 mu f_N))."""
    rng = np.random.default_rng(seed)
    step = 2.0 * radius + 0.004
    half = n_side * step / 2.0 + 0.002
    b = ModelBuilder("spheres_in_box", gravity=(0.0, 0.0, -9.81))
    names = []
    for i in range(n_side):
        for j in range(n_side):
            for k in range(n_side):
                p = (-half + radius + 0.002 + i * step, -half + radius + 0.002 + j * step,
                     radius + 0.01 + 1.5 * k * step)
                p = tuple(np.array(p) + rng.uniform(-0.001, 0.001, 3))
                names.append(b.add_body(f"s{i}{j}{k}", mass, (0.4 * mass * radius ** 2,) * 3,
                                        r=p, shapes=[{"type": "sphere", "radius": radius}]))
    walls = [{"normal": [0, 0, 1], "point": [0, 0, 0]},
             {"normal": [1, 0, 0], "point": [-half, 0, 0]},
             {"normal": [-1, 0, 0], "point": [half, 0, 0]},
             {"normal": [0, 1, 0], "point": [0, -half, 0]},
             {"normal": [0, -1, 0], "point": [0, half, 0]}]
    b.add_force("sphere_set", "grains", bodies=names, radius=radius, walls=walls,
                law="linear", stiffness=2e4, damping=2.0, mu=0.3, creep_velocity=1e-2)
    return b


#: the shapes of :func:`mixed_pile`, in turn (half sizes about 2 to 3 cm)
PILE_SHAPES = (
    {"type": "box", "half_extents": [0.03, 0.025, 0.02]},
    {"type": "sphere", "radius": 0.025},
    {"type": "capsule", "radius": 0.015, "half_length": 0.02},
    {"type": "cylinder", "radius": 0.022, "half_length": 0.018},
    {"type": "ellipsoid", "semi_axes": [0.03, 0.024, 0.02]},
    {"type": "convex", "vertices": [[0.03, 0, 0], [-0.03, 0, 0], [0, 0.025, 0],
                                    [0, -0.025, 0], [0, 0, 0.02], [0, 0, -0.02],
                                    [0.015, 0.015, 0.012], [-0.015, -0.015, -0.012]]},
)


def display_shape(shape: dict) -> list:
    """The display shapes (docs/model-file.md, "Shapes") of a convex contact shape: a box,
    sphere, capsule or cylinder as itself; an ellipsoid as an inline mesh of 42 vertices on its
    surface (ELLIPSOID_MESH), a convex hull as the inline mesh of its hull (faces wound outward;
    both under the 64 vertices that would send a mesh to a sidecar file)."""
    kind = shape["type"]
    if kind == "box":
        return [{"type": "box", "size": [2.0 * h for h in shape["half_extents"]]}]
    if kind == "sphere":
        return [{"type": "sphere", "radius": shape["radius"]}]
    if kind in ("capsule", "cylinder"):
        return [{"type": kind, "radius": shape["radius"],
                 "length": 2.0 * shape["half_length"]}]
    if kind == "ellipsoid":
        V, F = _unit_sphere_mesh(*ELLIPSOID_MESH)
        return [{"type": "mesh", "vertices": (V * np.asarray(shape["semi_axes"])).tolist(),
                 "faces": F.tolist()}]
    if kind == "convex":
        return [_hull_mesh(np.asarray(shape["vertices"], dtype=float))]
    return []


#: the ellipsoid's display mesh: (longitudes, latitude bands)
ELLIPSOID_MESH = (8, 6)


def _unit_sphere_mesh(n_lon: int, n_lat: int):
    """(vertices, faces) of a UV sphere of radius 1: two poles and n_lat - 1 rings of n_lon
    points (exact sines and cosines: the same bits on every machine), faces wound outward."""
    V = [[0.0, 0.0, 1.0]]
    for i in range(1, n_lat):
        th = math.pi * i / n_lat
        for j in range(n_lon):
            ph = 2.0 * math.pi * j / n_lon
            V.append([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
    V.append([0.0, 0.0, -1.0])
    south = len(V) - 1
    F = []
    for j in range(n_lon):
        k = (j + 1) % n_lon
        F.append([0, 1 + j, 1 + k])
        last = 1 + (n_lat - 2) * n_lon
        F.append([south, last + k, last + j])
    for i in range(n_lat - 2):
        a, b = 1 + i * n_lon, 1 + (i + 1) * n_lon
        for j in range(n_lon):
            k = (j + 1) % n_lon
            F.append([a + j, b + j, b + k])
            F.append([a + j, b + k, a + k])
    return np.array(V), np.array(F, dtype=int)


def _hull_mesh(points: np.ndarray) -> dict:
    """The inline display mesh of the convex hull of ``points``: its vertices, triangles wound
    outward (counter-clockwise seen from outside)."""
    from scipy.spatial import ConvexHull
    hull = ConvexHull(points)
    used = sorted(set(int(i) for f in hull.simplices for i in f))
    index = {v: k for k, v in enumerate(used)}
    centre = points[used].mean(axis=0)
    faces = []
    for f in hull.simplices:
        a, b, c = (points[i] for i in f)
        if float(np.dot(np.cross(b - a, c - a), (a + b + c) / 3.0 - centre)) < 0.0:
            f = (f[0], f[2], f[1])
        faces.append([index[int(i)] for i in f])
    return {"type": "mesh", "vertices": points[used].tolist(), "faces": faces}


def mixed_pile(n_side: int = 3, layers: int = 3, mass: float = 0.05,
               seed: int = 2) -> ModelBuilder:
    """n_side^2 x layers bodies of mixed convex shapes (box, sphere, capsule, cylinder,
    ellipsoid, convex hull: :data:`PILE_SHAPES` in turn), turned at random, poured into an open
    box of a floor and four walls onto a block fixed to the ground at its centre, all in one
    ``shape_set`` (the pairs come from the broad phase: the cost per evaluation grows
    linearly with the number of bodies). Linear contact K = 2e4 N/m per contact point with
    damping 5 N s/m and Coulomb friction mu = 0.4 with a creep velocity of 1 cm/s. The inertia
    of each body is that of the box bounding its shape (the same mass for all).

    Integrate it with a fixed step (rk4, 0.25 ms: the example's setting; energy + dissipated
    work then closes to about 5 % of the dissipated work, 10 % at 0.5 ms): the contact points
    come and go (a linear law's damping force jumps at each touch, a face manifold takes over
    from a vertex), and an error-controlled integrator spends its steps on those jumps (rk45 at
    rtol 1e-5 takes 60,000 steps per second of this pile)."""
    rng = np.random.default_rng(seed)
    step = 0.075
    half = n_side * step / 2.0 + 0.01
    b = ModelBuilder("mixed_pile", gravity=(0.0, 0.0, -9.81))
    names, shapes = [], []
    for k in range(layers):
        for i in range(n_side):
            for j in range(n_side):
                shape = PILE_SHAPES[len(names) % len(PILE_SHAPES)]
                p = (-half + 0.01 + (i + 0.5) * step, -half + 0.01 + (j + 0.5) * step,
                     0.12 + k * step)
                q = rng.normal(size=4)
                q = q / math.sqrt(math.fsum(q * q))    # no BLAS: the same bits on every machine
                ext = 2.0 * np.array([0.03, 0.025, 0.02])
                inertia = tuple(mass / 12.0 * (ext[[1, 0, 0]] ** 2 + ext[[2, 2, 1]] ** 2))
                names.append(b.add_body(f"p{len(names):02d}", mass, inertia, r=p,
                                        p=tuple(q),
                                        shapes=display_shape(shape)))
                shapes.append(shape)
    walls = [{"normal": [0, 0, 1], "point": [0, 0, 0]},
             {"normal": [1, 0, 0], "point": [-half, 0, 0]},
             {"normal": [-1, 0, 0], "point": [half, 0, 0]},
             {"normal": [0, 1, 0], "point": [0, -half, 0]},
             {"normal": [0, -1, 0], "point": [0, half, 0]}]
    block = {"type": "box", "half_extents": [0.04, 0.04, 0.03], "center": [0.0, 0.0, 0.03]}
    b.add_force("shape_set", "pile", bodies=names + ["ground"], shapes=shapes + [block],
                walls=walls, law="linear", stiffness=2e4, damping=5.0, mu=0.4,
                creep_velocity=1e-2)
    return b


#: the domino of :func:`dominoes`: height (z), thickness (x), width (y) in m, mass in kg
DOMINO = dict(height=0.1, thickness=0.02, width=0.05, mass=0.05)


def domino_tipping_speed(height=DOMINO["height"], thickness=DOMINO["thickness"],
                         g=9.81) -> float:
    """The smallest angular velocity (rad/s) about its front bottom edge with which a rigid
    domino standing on a rigid floor tips over: its centre of mass must reach the top of its
    arc, 1/2 I_e w^2 = m g (d - h/2), with d = sqrt(h^2 + t^2) / 2 the edge-to-centre distance
    and I_e = m (h^2 + t^2) / 3 its moment of inertia about the edge."""
    d = 0.5 * math.hypot(height, thickness)
    i_e = (height ** 2 + thickness ** 2) / 3.0
    return math.sqrt(2.0 * g * (d - 0.5 * height) / i_e)


def dominoes(n: int = 8, spacing: float = 0.06, push: float = 3.0) -> ModelBuilder:
    """A row of n dominoes (models.DOMINO: 0.1 x 0.02 x 0.05 m, 50 g) standing on the floor
    ``spacing`` apart along x, in one ``shape_set`` with the floor as its wall: linear contact
    K = 2e4 N/m per contact point, damping 2 N s/m, Coulomb friction mu = 0.5 (creep velocity
    1 mm/s). The first domino is started turning about its front bottom edge at ``push`` times
    models.domino_tipping_speed (rad/s, its centre of mass moving with the turn), and knocks
    the others over in turn; at rest each leans on the next at arccos(thickness / spacing)
    from the vertical (70.5 degrees here), the last lies flat. Integrate it with rk4 at 0.1 ms
    (the example's setting)."""
    h, t, w, m = DOMINO["height"], DOMINO["thickness"], DOMINO["width"], DOMINO["mass"]
    inertia = (m / 12.0 * (w * w + h * h), m / 12.0 * (t * t + h * h),
               m / 12.0 * (t * t + w * w))
    b = ModelBuilder("dominoes", gravity=(0.0, 0.0, -9.81))
    box = {"type": "box", "half_extents": [t / 2.0, w / 2.0, h / 2.0]}
    names = []
    omega = push * domino_tipping_speed(h, t)
    for k in range(n):
        spin = omega if k == 0 else 0.0
        # about the front bottom edge (x = t/2, z = 0): v = omega x (centre - edge)
        names.append(b.add_body(f"d{k}", m, inertia, r=(k * spacing, 0.0, h / 2.0),
                                omega=(0.0, spin, 0.0),
                                rdot=(spin * h / 2.0, 0.0, spin * t / 2.0),
                                shapes=display_shape(box)))
    b.add_force("shape_set", "dominoes", bodies=names, shape=box,
                walls=[{"normal": [0, 0, 1], "point": [0, 0, 0]}], law="linear",
                stiffness=2e4, damping=2.0, mu=0.5, creep_velocity=1e-3)
    return b


EXAMPLES = {
    "slider_crank_clearance": (slider_crank_clearance, {}, dict(
        type="dynamic", t_end=2 * math.pi / 20.0, output_step=1e-3,
        method={"name": "projection"}, integrator={"name": "rk45", "rtol": 1e-8,
                                                   "atol": 1e-10})),
    "spheres_in_box": (spheres_in_box, {}, dict(
        type="dynamic", t_end=1.0, output_step=0.01, method={"name": "standard"},
        integrator={"name": "rk45", "rtol": 1e-5, "atol": 1e-7})),
    "mixed_pile": (mixed_pile, {}, dict(
        type="dynamic", t_end=1.0, output_step=0.01, method={"name": "standard"},
        integrator={"name": "rk4", "step": 2.5e-4})),
    "dominoes": (dominoes, {}, dict(
        type="dynamic", t_end=1.0, output_step=0.01, method={"name": "standard"},
        integrator={"name": "rk4", "step": 1e-4})),
}
