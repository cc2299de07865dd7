"""The text's example and classic mechanisms: the chapter 15 pendulum, slider-crank, four-bar,
chain and Bricard's overconstrained linkage."""
from __future__ import annotations

import numpy as np

from ..model import ModelBuilder
from ..motion import ConstantVelocity


G_TEXT = 9.81


def pendulum_ch15() -> ModelBuilder:
    """The simple pendulum of the text's chapter 15 (Tables 15.1-15.2).

    One body, m = 7.02 kg, centroidal inertias (0.5855265, 0.0010530, 0.5855265) kg m^2: a 1 m
    solid cylinder along body y. Assumed geometry (the text gives only the length; ERRATA):
    pivot at one end, at the global origin, revolute axis = global x; released at rest from
    the horizontal xy-plane with the cylinder along +y (centre of mass at (0, 0.5, 0)); gravity
    9.81 m/s^2 along -z.
    """
    b = ModelBuilder("pendulum_ch15", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("pendulum", mass=7.02, inertia=(0.5855265, 0.0010530, 0.5855265),
               r=(0.0, 0.5, 0.0), points={"tip": (0.0, 0.5, 0.0), "pivot": (0.0, -0.5, 0.0)},
               shapes=[{"type": "cylinder", "radius": 0.02, "length": 1.0,
                        "center": [0, 0, 0], "axis": [0, 1, 0]}])
    b.add_joint("revolute", "pivot", "ground", "pendulum", point=(0, 0, 0), axis=(1, 0, 0))
    return b


def slider_crank(driven: bool = True, crank_speed: float = 6.0) -> ModelBuilder:
    """Spatial slider-crank (IFToMM benchmark data).

    Crank 0.08 m turning about global x at A = (0, 0.1, 0.12), pointing up at t = 0
    (B = (0, 0.1, 0.2)); connecting rod 0.3 m from B to C = (0.2, 0, 0); slider along global x.
    Joints: revolute A (ground-crank), spherical B (crank-rod), universal C (rod-slider, cross
    axes (1, 2, 0)/sqrt 5 on the rod and z on the slider), translational (ground-slider, x).
    Masses 0.12, 0.5, 2 kg; gravity -z. driven=True adds an angle driver turning the crank at
    ``crank_speed`` rad/s (kinematic analysis); otherwise the crank starts at that speed.
    """
    b = ModelBuilder("slider_crank", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("crank", 0.12, (1e-4, 1e-4, 1e-5), r=(0.0, 0.1, 0.16),
               omega=(0.0 if driven else crank_speed, 0.0, 0.0),
               points={"B": (0, 0, 0.04)},
               shapes=[{"type": "box", "size": [0.01, 0.01, 0.08], "center": [0, 0, 0]}])
    d = np.array([0.2, -0.1, -0.2]) / 0.3
    y = np.array([1.0, 2.0, 0.0]) / np.sqrt(5.0)
    b.add_body("rod", 0.5, (4e-4, 4e-3, 4e-3), r=(0.1, 0.05, 0.1),
               A=np.column_stack([d, y, np.cross(d, y)]),
               shapes=[{"type": "box", "size": [0.3, 0.01, 0.01], "center": [0, 0, 0]}])
    b.add_body("slider", 2.0, (1e-4, 1e-4, 1e-4), r=(0.2, 0.0, 0.0),
               shapes=[{"type": "box", "size": [0.05, 0.03, 0.03], "center": [0, 0, 0]}])
    b.add_joint("revolute", "A", "ground", "crank", point=(0, 0.1, 0.12), axis=(1, 0, 0))
    b.add_joint("spherical", "B", "crank", "rod", point=(0, 0.1, 0.2))
    b.add_joint("universal", "C", "rod", "slider", point=(0.2, 0, 0), axis=y, axis2=(0, 0, 1))
    b.add_joint("translational", "D", "ground", "slider", point=(0.2, 0, 0), axis=(1, 0, 0))
    if driven:
        b.add_driver("angle", "crank_drive", ConstantVelocity(rate=crank_speed), joint="A")
    return b


def slider_crank_exact(theta, omega: float = 6.0):
    """Closed-form slider position, velocity and acceleration of :func:`slider_crank` for the
    crank angle theta (rad) turning at constant omega: x = sqrt(L^2 - |B_yz|^2)."""
    theta = np.asarray(theta, dtype=float)
    s, c = np.sin(theta), np.cos(theta)
    By, Bz = 0.1 - 0.08 * s, 0.12 + 0.08 * c
    g = By**2 + Bz**2
    dBy, dBz = -0.08 * c, -0.08 * s
    ddBy, ddBz = 0.08 * s, -0.08 * c
    dg = 2 * (By * dBy + Bz * dBz)
    ddg = 2 * (dBy**2 + By * ddBy + dBz**2 + Bz * ddBz)
    x = np.sqrt(0.09 - g)
    xd = -dg * omega / (2 * x)
    xdd = -(ddg * omega**2 + 2 * xd**2) / (2 * x)
    return x, xd, xdd


FOUR_BAR = dict(crank=1.0, coupler=3.5, rocker=2.5, rocker_pivot=(2.0, 0.5, 1.5))


def four_bar(coupler_joint: str = "spherical", crank_speed: float | None = None) -> ModelBuilder:
    """Spatial four-bar (RSSR) of the text's Fig. 2.1: two revolute and two spherical joints.

    Crank (1 m) about global z at the origin, tip B = (cos th, sin th, 0); rocker (2.5 m) about
    global y at D0 = (2, 0.5, 1.5); coupler (3.5 m) from B to the rocker tip C with spherical
    joints at both ends. Gruebler: 6*3 - (2*5 + 2*3) = 2 DoF, the second being the idle spin of
    the coupler about its own axis. coupler_joint="universal" puts a universal joint at C
    (RSUR), which removes the spin (1 DoF). crank_speed adds an angle driver on the crank.
    """
    p = FOUR_BAR
    D0 = np.array(p["rocker_pivot"])
    B = np.array([p["crank"], 0.0, 0.0])
    C = D0 + p["rocker"] * four_bar_rocker_direction(0.0)
    b = ModelBuilder("four_bar", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("crank", 1.0, (1e-3, 0.08, 0.08), r=B / 2,
               points={"B": (0.5, 0, 0)},
               shapes=[{"type": "box", "size": [1.0, 0.05, 0.05], "center": [0, 0, 0]}])
    u = (C - B) / np.linalg.norm(C - B)
    w = np.cross(u, [0.0, 0.0, 1.0])
    w /= np.linalg.norm(w)
    b.add_body("coupler", 3.5, (3.5e-3, 3.6, 3.6), r=(B + C) / 2,
               A=np.column_stack([u, w, np.cross(u, w)]),
               shapes=[{"type": "box", "size": [3.5, 0.05, 0.05], "center": [0, 0, 0]}])
    e = (C - D0) / p["rocker"]
    b.add_body("rocker", 2.5, (2.5e-3, 1.3, 1.3), r=(C + D0) / 2,
               A=np.column_stack([e, [0, 1, 0], np.cross(e, [0, 1, 0])]),
               points={"C": (1.25, 0, 0)},
               shapes=[{"type": "box", "size": [2.5, 0.05, 0.05], "center": [0, 0, 0]}])
    b.add_joint("revolute", "crank_pivot", "ground", "crank", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("spherical", "B", "crank", "coupler", point=B)
    if coupler_joint == "spherical":
        b.add_joint("spherical", "C", "coupler", "rocker", point=C)
    else:
        h = np.cross(u, [0.0, 1.0, 0.0])                  # normal to the coupler and to y
        b.add_joint("universal", "C", "coupler", "rocker", point=C, axis=h / np.linalg.norm(h),
                    axis2=(0, 1, 0))
    b.add_joint("revolute", "rocker_pivot", "ground", "rocker", point=D0, axis=(0, 1, 0))
    if crank_speed is not None:
        b.add_driver("angle", "crank_drive", ConstantVelocity(rate=crank_speed),
                     joint="crank_pivot")
    return b


def four_bar_rocker_direction(theta: float) -> np.ndarray:
    """Closed-form unit vector D0 -> C of :func:`four_bar` for crank angle theta (the branch
    through the assembled configuration): solves |D0 + c e(phi) - B(theta)| = L."""
    p = FOUR_BAR
    D0 = np.array(p["rocker_pivot"])
    c, L = p["rocker"], p["coupler"]
    e1, e2 = np.array([1.0, 0, 0]), np.array([0, 0, -1.0])      # normal to the rocker axis y
    B = np.array([p["crank"] * np.cos(theta), p["crank"] * np.sin(theta), 0.0])
    w = D0 - B
    a_, b_ = 2 * c * (w @ e1), 2 * c * (w @ e2)
    k = L**2 - w @ w - c * c
    base = np.arctan2(b_, a_)
    phi = base - np.arccos(k / np.hypot(a_, b_))
    return np.cos(phi) * e1 + np.sin(phi) * e2


def chain(n: int, joint: str = "spherical", length: float = 1.0, mass: float = 1.0,
          gravity: float = G_TEXT) -> ModelBuilder:
    """N-link spatial chain for scaling benchmarks (issue: N identical slender links).

    Link k (k = 0..n-1): centre ((k + 1/2) L, 0, 0), body axes = global, slender rod along x
    with centroidal inertia diag(1e-4, m L^2/12, m L^2/12); joint k at (k L, 0, 0) joins link
    k-1 (the ground for k = 0) to link k: spherical joints, or revolute joints about global y.
    Released at rest, horizontal, gravity along -z.
    """
    if joint not in ("spherical", "revolute"):
        raise ValueError("joint must be 'spherical' or 'revolute'")
    b = ModelBuilder(f"chain{n}_{joint}", gravity=(0.0, 0.0, -gravity))
    inertia = (1e-4, mass * length**2 / 12, mass * length**2 / 12)
    prev = "ground"
    for k in range(n):
        name = f"link{k}"
        b.add_body(name, mass, inertia, r=((k + 0.5) * length, 0.0, 0.0),
                   shapes=[{"type": "box", "size": [length, 0.04, 0.04], "center": [0, 0, 0]}])
        if joint == "spherical":
            b.add_joint("spherical", f"j{k}", prev, name, point=(k * length, 0.0, 0.0))
        else:
            b.add_joint("revolute", f"j{k}", prev, name, point=(k * length, 0.0, 0.0),
                        axis=(0.0, 1.0, 0.0))
        prev = name
    return b


def bricard() -> ModelBuilder:
    """Bricard mechanism (IFToMM benchmark A04).

    Five 1 m, 1 kg bars of square section 0.1 m (inertia 0.0016667 about the bar, 0.0841667
    across), six revolute joints; Gruebler 0 DoF but it moves with 1 DoF (one redundant
    equation everywhere). Gravity -y, released at rest. Body axes parallel to global axes.
    """
    b = ModelBuilder("bricard", gravity=(0.0, -G_TEXT, 0.0))
    pts = {"O": (0, 0, 0), "P1": (1, 0, 0), "P2": (1, -1, 0), "P3": (1, -1, 1),
           "P4": (0, -1, 1), "P5": (0, 0, 1)}
    along, across = 0.0016667, 0.0841667
    ends = [("O", "P1"), ("P1", "P2"), ("P2", "P3"), ("P3", "P4"), ("P4", "P5")]
    for k, (a, c) in enumerate(ends):
        pa, pc = np.array(pts[a], float), np.array(pts[c], float)
        axis = int(np.argmax(np.abs(pc - pa)))
        inertia = [across] * 3
        inertia[axis] = along
        size = [0.1, 0.1, 0.1]
        size[axis] = 1.0
        b.add_body(f"bar{k + 1}", 1.0, inertia, r=(pa + pc) / 2,
                   points={"end": tuple((pc - pa) / 2)},
                   shapes=[{"type": "box", "size": size, "center": [0, 0, 0]}])
    axes = {"O": (0, 1, 0), "P1": (0, 0, 1), "P2": (1, 0, 0), "P3": (0, 1, 0), "P4": (0, 0, 1),
            "P5": (1, 0, 0)}
    chain_bodies = ["ground", "bar1", "bar2", "bar3", "bar4", "bar5", "ground"]
    for k, name in enumerate(["O", "P1", "P2", "P3", "P4", "P5"]):
        b.add_joint("revolute", name, chain_bodies[k], chain_bodies[k + 1], point=pts[name],
                    axis=axes[name])
    return b


#: Example models by name: name -> (builder function, keyword arguments, suggested analysis).
#: The analysis dict uses the keys of a model file's ``analysis`` section.
EXAMPLES = {
    "pendulum_ch15": (pendulum_ch15, {}, dict(type="dynamic", t_end=10.0, output_step=0.02,
                                              method={"name": "standard"},
                                              integrator={"name": "rk45", "rtol": 1e-6,
                                                          "atol": 1e-9})),
    "slider_crank": (slider_crank, {"driven": True},
                     dict(type="kinematic", t_end=2 * np.pi / 6.0, output_step=0.01)),
    "four_bar": (four_bar, {}, dict(type="dynamic", t_end=3.0, output_step=0.01,
                                    method={"name": "projection"},
                                    integrator={"name": "rk45", "rtol": 1e-8, "atol": 1e-10})),
    "bricard": (bricard, {}, dict(type="dynamic", t_end=10.0, output_step=0.01,
                                  method={"name": "projection"},
                                  integrator={"name": "rk45", "rtol": 1e-8, "atol": 1e-10})),
}
