"""IFToMM benchmark problems (IFToMM benchmark library): the simple and double pendulum, the
heavy top, the N-four-bar, the flyball governor, a robot arm and the spatial slider-crank."""
from __future__ import annotations

import numpy as np

from ..model import ModelBuilder
from .textbook import G_TEXT, slider_crank


# ------------------------------------------------------------------------------------------
# Validation models (appended): data and source stated in each docstring.
# ------------------------------------------------------------------------------------------
def _slender_inertia(mass: float, length: float, axis: int, side: float = 0.02):
    """Centroidal moments of a uniform square-section bar of the given length along body
    ``axis`` (0, 1, 2): m (L^2 + a^2) / 12 across, m a^2 / 6 about the bar (a = side)."""
    across = mass * (length**2 + side**2) / 12.0
    inertia = [across] * 3
    inertia[axis] = mass * side**2 / 6.0
    return tuple(inertia)


def simple_pendulum_a01(x0: float = 1.0, inertia: float = 1e-6) -> ModelBuilder:
    """IFToMM benchmark A01 (IFToMM benchmark library): planar simple pendulum.

    Point mass 1 kg on a massless 1 m link, pivot at the origin, gravity 9.81 m/s^2 along -y,
    released at rest from the horizontal at x = x0 (+1 m as in the 2006 MBSBenchmark
    specification, -1 m in the IFToMM version). The point mass is a body with the small
    centroidal inertia ``inertia`` (kg m^2, a body needs one), which lengthens the period by
    inertia / (2 m L^2) relatively (5e-7 for the default). Revolute joint about global z.
    """
    b = ModelBuilder("simple_pendulum_a01", gravity=(0.0, -G_TEXT, 0.0))
    b.add_body("mass", 1.0, (inertia, inertia, inertia), r=(x0, 0.0, 0.0),
               shapes=[{"type": "sphere", "radius": 0.05, "center": [0, 0, 0]}])
    b.add_joint("revolute", "pivot", "ground", "mass", point=(0, 0, 0), axis=(0, 0, 1))
    return b


def double_pendulum() -> ModelBuilder:
    """Spatial double pendulum (constructed for validation; no published reference: check
    energy conservation and constraints).

    Two uniform bars, 1 m, 1 kg, square section 0.02 m. Bar 1 along +y from the origin,
    revolute to the ground at the origin about global x; bar 2 along +x from the tip of bar 1
    at (0, 1, 0), revolute to bar 1 about bar 1's own long axis (global y as assembled), so the
    second bar swings out of the plane of the first. Released at rest from this horizontal
    configuration; gravity 9.81 m/s^2 along -z.
    """
    b = ModelBuilder("double_pendulum", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("bar1", 1.0, _slender_inertia(1.0, 1.0, 1), r=(0.0, 0.5, 0.0),
               shapes=[{"type": "box", "size": [0.02, 1.0, 0.02], "center": [0, 0, 0]}])
    b.add_body("bar2", 1.0, _slender_inertia(1.0, 1.0, 0), r=(0.5, 1.0, 0.0),
               shapes=[{"type": "box", "size": [1.0, 0.02, 0.02], "center": [0, 0, 0]}])
    b.add_joint("revolute", "shoulder", "ground", "bar1", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_joint("revolute", "elbow", "bar1", "bar2", point=(0, 1, 0), axis=(0, 1, 0))
    return b


HEAVY_TOP = dict(mass=1.0, l=0.1, I1=0.004, I3=0.008, theta=np.pi / 6, spin=50.0)


def heavy_top(theta: float = HEAVY_TOP["theta"], spin: float = HEAVY_TOP["spin"],
              precession: float | None = None) -> ModelBuilder:
    """Heavy symmetric top on a spherical joint at its tip (constructed for validation).

    m = 1 kg, centre of mass l = 0.1 m from the tip along the symmetry axis (body z),
    centroidal inertia (0.004, 0.004, 0.008) kg m^2; tip fixed at the origin by a spherical
    joint to the ground; gravity 9.81 m/s^2 along -z. Symmetry axis tilted by ``theta`` from
    the upward vertical towards +x; angular velocity Omega z + psidot e3 with the axial
    component w3 = ``spin`` (rad/s). ``precession`` = Omega (rad/s); default: the slow steady
    precession rate of the closed form A Omega^2 cos(theta) - C w3 Omega + m g l = 0
    (A = I1 + m l^2, C = I3), for which theta stays constant and the axis turns at Omega.
    """
    p = HEAVY_TOP
    m, l, I1, I3 = p["mass"], p["l"], p["I1"], p["I3"]
    if precession is None:
        A_, C = I1 + m * l * l, I3
        a, bq, c = A_ * np.cos(theta), -C * spin, m * G_TEXT * l
        precession = (-bq - np.sqrt(bq * bq - 4 * a * c)) / (2 * a)
    e3 = np.array([np.sin(theta), 0.0, np.cos(theta)])
    psidot = spin - precession * np.cos(theta)
    omega = precession * np.array([0.0, 0.0, 1.0]) + psidot * e3
    A = np.array([[np.cos(theta), 0.0, np.sin(theta)], [0.0, 1.0, 0.0],
                  [-np.sin(theta), 0.0, np.cos(theta)]])           # Ry(theta)
    r = l * e3
    b = ModelBuilder("heavy_top", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("top", m, (I1, I1, I3), r=r, A=A, omega=omega, rdot=np.cross(omega, r),
               points={"tip": (0, 0, -l)},
               shapes=[{"type": "cylinder", "radius": 0.12, "length": 0.02,
                        "center": [0, 0, 0], "axis": [0, 0, 1]},
                       {"type": "cylinder", "radius": 0.005, "length": 0.2,
                        "center": [0, 0, 0], "axis": [0, 0, 1]}])
    b.add_joint("spherical", "tip", "ground", "top", point=(0, 0, 0))
    return b


def n_four_bar(n: int = 2) -> ModelBuilder:
    """IFToMM benchmark A02, N-four-bar mechanism (IFToMM benchmark library), built
    from spatial revolute joints (all axes global z), hence with redundant equations.

    2N+1 uniform bars of 1 m, 1 kg (square section 0.02 m): cranks k = 0..N pinned to the
    ground at (k, 0, 0), vertical, tips at (k, 1, 0); N horizontal couplers joining
    neighbouring tips. Gravity 9.81 m/s^2 along -y. Initially every crank turns at
    omega = -1 rad/s about z and the couplers translate at 1 m/s along x. On the parallelogram
    branch every crank angle phi (from the vertical, about z) obeys I phi'' = K sin phi with
    I = (N+1) (I_c + m L^2/4) + N m L^2, K = m g L ((N+1)/2 + N), I_c = m (L^2 + a^2)/12 the
    bars' centroidal moment (a = 0.02 m; slender bars, I_c = m L^2/12, give
    I = m L^2 ((N+1)/3 + N)). Each time the cranks are horizontal the
    mechanism passes a singular configuration.
    """
    b = ModelBuilder(f"n_four_bar{n}", gravity=(0.0, -G_TEXT, 0.0))
    for k in range(n + 1):
        b.add_body(f"crank{k}", 1.0, _slender_inertia(1.0, 1.0, 1), r=(k, 0.5, 0.0),
                   omega=(0.0, 0.0, -1.0), rdot=(0.5, 0.0, 0.0),
                   shapes=[{"type": "box", "size": [0.02, 1.0, 0.02], "center": [0, 0, 0]}])
        b.add_joint("revolute", f"O{k}", "ground", f"crank{k}", point=(k, 0, 0),
                    axis=(0, 0, 1))
    for k in range(n):
        b.add_body(f"coupler{k}", 1.0, _slender_inertia(1.0, 1.0, 0), r=(k + 0.5, 1.0, 0.0),
                   rdot=(1.0, 0.0, 0.0),
                   shapes=[{"type": "box", "size": [1.0, 0.02, 0.02], "center": [0, 0, 0]}])
        b.add_joint("revolute", f"A{k}", f"crank{k}", f"coupler{k}", point=(k, 1, 0),
                    axis=(0, 0, 1))
        b.add_joint("revolute", f"B{k}", f"coupler{k}", f"crank{k + 1}", point=(k + 1, 1, 0),
                    axis=(0, 0, 1))
    return b


def n_four_bar_flat(n: int = 1) -> ModelBuilder:
    """The linkage of :func:`n_four_bar` started exactly in its flat (singular) position and
    moving through it along the parallelogram branch: cranks along +x (tips at (k + 1, 0, 0)),
    couplers collinear with them, every crank turning at -1 rad/s about z (the rows of the
    loops are dependent at t = 0 and independent a moment later: a singular start). Gravity
    9.81 m/s^2 along -y; the bars as in :func:`n_four_bar`, slender."""
    b = ModelBuilder(f"n_four_bar{n}_dead_centre", gravity=(0.0, -G_TEXT, 0.0))
    for k in range(n + 1):
        b.add_body(f"crank{k}", 1.0, _slender_inertia(1.0, 1.0, 0), r=(k + 0.5, 0.0, 0.0),
                   omega=(0.0, 0.0, -1.0), rdot=(0.0, -0.5, 0.0))
        b.add_joint("revolute", f"O{k}", "ground", f"crank{k}", point=(k, 0, 0),
                    axis=(0, 0, 1))
    for k in range(n):
        b.add_body(f"coupler{k}", 1.0, _slender_inertia(1.0, 1.0, 0), r=(k + 1.5, 0.0, 0.0),
                   rdot=(0.0, -1.0, 0.0))
        b.add_joint("revolute", f"A{k}", f"crank{k}", f"coupler{k}", point=(k + 1, 0, 0),
                    axis=(0, 0, 1))
        b.add_joint("revolute", f"B{k}", f"coupler{k}", f"crank{k + 1}", point=(k + 2, 0, 0),
                    axis=(0, 0, 1))
    return b


def flyball_governor() -> ModelBuilder:
    """IFToMM benchmark A05, stiff flyball governor (IFToMM benchmark library).

    Shaft: prism 0.01 x 0.01 x 1.0 m, 0.3 kg, centre (0, 0, 0.5), revolute to the ground at the
    origin about z. Slider: cube 0.1 m, 3 kg, centre (0, 0, 0.5), translational joint along the
    shaft (z). Two rods (prisms 1.0 x 0.01 x 0.01 m, 0.3 kg) pinned to the shaft at
    A = (0.05, 0, 1) and B = (-0.05, 0, 1) about the y axis, pointing outward 30 deg below the
    horizontal, each carrying a 5 kg point mass at its tip (1 m from the pivot): each rod and
    its point mass are one rigid body here (5.3 kg, centre of mass 5.15 / 5.3 m from the pivot,
    inertia of the rod plus the point mass by the parallel-axis theorem). Spring-dampers
    k = 8e5 N/m, c = 4e4 N s/m, natural length 0.5 m, from the slider points (+-0.05, 0, 0.5)
    to the rod midpoints (+-0.4830127, 0, 0.75), unstretched at t = 0. Every body starts with
    omega = (0, 0, 2 pi) rad/s (velocities of the centres omega x r). Gravity 9.81 m/s^2
    along -z. No torque acts about the shaft axis: the angular momentum about z is conserved.
    """
    w = np.array([0.0, 0.0, 2.0 * np.pi])
    b = ModelBuilder("flyball_governor", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("shaft", 0.3, (0.3 * (1.0 + 1e-4) / 12, 0.3 * (1.0 + 1e-4) / 12, 0.3 * 2e-4 / 12),
               r=(0, 0, 0.5), omega=w,
               shapes=[{"type": "box", "size": [0.01, 0.01, 1.0], "center": [0, 0, 0]}])
    b.add_body("slider", 3.0, (3 * 0.02 / 12,) * 3, r=(0, 0, 0.5), omega=w,
               shapes=[{"type": "box", "size": [0.1, 0.1, 0.1], "center": [0, 0, 0]}])
    m_rod, m_ball, L = 0.3, 5.0, 1.0
    m = m_rod + m_ball
    xc = (m_rod * 0.5 * L + m_ball * L) / m                     # from the pivot, along the rod
    across = (m_rod * (L**2 + 1e-4) / 12 + m_rod * (xc - 0.5 * L)**2
              + m_ball * (L - xc)**2)
    along = m_rod * 2e-4 / 12
    b.add_joint("revolute", "shaft_pivot", "ground", "shaft", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "slider_guide", "shaft", "slider", point=(0, 0, 0.5),
                axis=(0, 0, 1))
    c30, s30 = np.cos(np.pi / 6), np.sin(np.pi / 6)
    for side, name in ((1.0, "rod_A"), (-1.0, "rod_B")):
        pivot = np.array([0.05 * side, 0.0, 1.0])
        u = np.array([side * c30, 0.0, -s30])                    # along the rod, outward
        r = pivot + xc * u
        A = np.column_stack([u, [0.0, 1.0, 0.0], np.cross(u, [0.0, 1.0, 0.0])])
        b.add_body(name, m, (along, across, across), r=r, A=A, omega=w, rdot=np.cross(w, r),
                   points={"mid": (0.5 * L - xc, 0, 0), "tip": (L - xc, 0, 0)},
                   shapes=[{"type": "box", "size": [1.0, 0.01, 0.01],
                            "center": [0.5 * L - xc, 0, 0]},
                           {"type": "sphere", "radius": 0.05, "center": [L - xc, 0, 0]}])
        b.add_joint("revolute", f"pin_{name[-1]}", "shaft", name, point=pivot, axis=(0, 1, 0))
        b.add_force("spring_damper", f"spring_{name[-1]}", body_i="slider", body_j=name,
                    point_i=(0.05 * side, 0.0, 0.0), point_j="mid", stiffness=8e5,
                    damping=4e4, natural_length=0.5)
    return b


ROBOT_ARM = [
    # name, mass (kg), length (m), joint axis (global, as assembled), joint stiffness (N m/rad),
    # joint damping (N m s/rad)
    ("base", 10.0, 0.40, (0, 0, 1), 2000.0, 40.0),
    ("upper_arm", 8.0, 0.60, (0, 1, 0), 2000.0, 40.0),
    ("forearm", 5.0, 0.50, (0, 1, 0), 400.0, 8.0),
    ("wrist1", 1.0, 0.10, (1, 0, 0), 2.0, 0.04),
    ("wrist2", 0.8, 0.10, (0, 1, 0), 5.0, 0.1),
    ("flange", 0.5, 0.10, (1, 0, 0), 0.5, 0.01),
]


def robot_arm(stiffness_scale: float = 1.0, damping_scale: float = 1.0) -> ModelBuilder:
    """Six-DoF serial robot arm with compliant joints (constructed for validation; the data are
    representative of a small industrial arm, not a particular product).

    Six links, all uniform bars of square section 0.08 m: a base column 0.4 m (10 kg) turning
    about global z on the ground at the origin, an upper arm 0.6 m (8 kg) and a forearm 0.5 m
    (5 kg) pitching about y, and a wrist of three 0.1 m links (1, 0.8, 0.5 kg) rolling about
    x, pitching about y and rolling about x. Assembled with the base vertical and the arm
    stretched horizontally along +x from the shoulder at (0, 0, 0.4). Every joint carries a
    rotational spring-damper (ROBOT_ARM table: stiffness 2000, 2000, 400, 2, 5, 0.5 N m/rad,
    damping 40, 40, 8, 0.04, 0.1, 0.01 N m s/rad, times the scale arguments; rest angle = the
    assembled angle), chosen so that every joint mode is near 15-30 rad/s. Released at rest
    under gravity 9.81 m/s^2 along -z, the arm sags and the damped oscillation decays.
    """
    b = ModelBuilder("robot_arm", gravity=(0.0, 0.0, -G_TEXT))
    side = 0.08
    x = 0.0
    prev = "ground"
    for k, (name, mass, length, axis, stiff, damp) in enumerate(ROBOT_ARM):
        if k == 0:
            start = np.array([0.0, 0.0, 0.0])
            centre = np.array([0.0, 0.0, length / 2])
            along = 2
            size = [side, side, length]
        else:
            start = np.array([x, 0.0, 0.4])
            centre = start + np.array([length / 2, 0.0, 0.0])
            along = 0
            size = [length, side, side]
            x += length
        b.add_body(name, mass, _slender_inertia(mass, length, along, side), r=centre,
                   shapes=[{"type": "box", "size": size, "center": [0, 0, 0]}])
        b.add_joint("revolute", f"joint{k + 1}", prev, name, point=start, axis=axis)
        b.add_force("rotational_spring_damper", f"drive{k + 1}", joint=f"joint{k + 1}",
                    stiffness=stiff * stiffness_scale, damping=damp * damping_scale)
        prev = name
    return b


def slider_crank_iftomm() -> ModelBuilder:
    """Spatial slider-crank with the universal joint of the published IFToMM implementation
    whose energy is quoted for the IFToMM benchmark library (0.76643568 J).

    Same data as :func:`slider_crank` (driven=False, crank at 6 rad/s), except the universal
    joint's cross axes: on the slider the sliding direction x, on the rod (0, -2, 1)/sqrt 5
    (normal to the rod and to x). Only this choice reproduces the quoted energy: the joint
    orientation sets the rod's spin about its own axis (with slider_crank's axes, (1, 2, 0)/
    sqrt 5 on the rod and z on the slider, the same initial state has 0.76662000 J). Initial
    velocities made consistent with the joints at the crank speed 6 rad/s (simulate(...,
    hold={"crank": ["rx"]})): T = 0.08758368 J, V = 0.678852 J (datum z = 0).
    """
    b = slider_crank(driven=False, crank_speed=6.0)
    spec = b.joints.pop("C")
    b.add_joint("universal", "C", spec.body_i, spec.body_j, point=(0.2, 0, 0),
                axis=np.array([0.0, -2.0, 1.0]) / np.sqrt(5.0), axis2=(1, 0, 0))
    b.name = "slider_crank_iftomm"
    return b


EXAMPLES = {
    "simple_pendulum_a01": (simple_pendulum_a01, {},
                            dict(type="dynamic", t_end=10.0, output_step=0.01,
                                 method={"name": "projection"},
                                 integrator={"name": "rk45", "rtol": 1e-9, "atol": 1e-11})),
    "double_pendulum": (double_pendulum, {},
                        dict(type="dynamic", t_end=10.0, output_step=0.01,
                             method={"name": "projection"},
                             integrator={"name": "rk45", "rtol": 1e-9, "atol": 1e-11})),
    "heavy_top": (heavy_top, {}, dict(type="dynamic", t_end=5.0, output_step=0.01,
                                      method={"name": "projection"},
                                      integrator={"name": "rk45", "rtol": 1e-9,
                                                  "atol": 1e-11})),
    # rtol 1e-8: it passes the 14 flat (singular) positions of its 10 s; at 1e-9 a step
    # lands within round-off of one, where the multipliers are ill-determined, and the step
    # control stalls there (the failure is diagnosed); the error is set by the passages
    "n_four_bar": (n_four_bar, {"n": 2},
                   dict(type="dynamic", t_end=10.0, output_step=0.01,
                        method={"name": "projection"},
                        integrator={"name": "rk45", "rtol": 1e-8, "atol": 1e-10})),
    "flyball_governor": (flyball_governor, {},
                         dict(type="dynamic", t_end=10.0, output_step=0.01,
                              method={"name": "projection"},
                              integrator={"name": "scipy-radau", "rtol": 1e-6, "atol": 1e-8})),
    "robot_arm": (robot_arm, {}, dict(type="dynamic", t_end=5.0, output_step=0.01,
                                      method={"name": "projection"},
                                      integrator={"name": "rk45", "rtol": 1e-7,
                                                  "atol": 1e-9})),
}
