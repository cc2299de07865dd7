"""Sliding joints and couplers: a cam and its follower, a bead on a wire
(constraints.point_curve) and a gear train (constraints.couplers)."""
from __future__ import annotations

import numpy as np

from ..model import ModelBuilder
from ..motion import ConstantVelocity
from .textbook import G_TEXT


# ------------------------------------------------------------------------------------------
# Sliding joints: a cam and its follower, a bead on a wire (constraints.point_curve)
# ------------------------------------------------------------------------------------------
def cam_profile(base_radius: float = 0.05, lift: float = 0.02, n: int = 36) -> list:
    """Radii (m) of a disc cam at n equal angles: cycloidal rise of ``lift`` over 120 deg,
    dwell 60 deg, cycloidal return over 120 deg, dwell 60 deg at the base radius."""
    theta = 2 * np.pi * np.arange(n) / n
    rise = 2 * np.pi / 3

    def cycloid(beta):
        return beta / rise - np.sin(2 * np.pi * beta / rise) / (2 * np.pi)
    s = np.where(theta < rise, cycloid(theta),
                 np.where(theta < np.pi, 1.0,
                          np.where(theta < np.pi + rise, 1.0 - cycloid(theta - np.pi), 0.0)))
    return [float(x) for x in base_radius + lift * s]


def cam_follower(speed: float = 20.0, preload: float = 10.0, stiffness: float = 500.0,
                 follower_mass: float = 0.5) -> ModelBuilder:
    """Disc cam turning at ``speed`` (rad/s) about global z, with a translating point follower
    along global y held on the profile (:func:`cam_profile`) by a compression spring.

    The cam's centre is at the origin; its profile angle 0 is along its body x axis, and at
    t = 0 the follower's tip is at profile angle 90 deg, so the tip height is
    y(t) = r(pi/2 - speed t). Spring (``stiffness`` N/m) between the ground point (0, 0.2, 0)
    and the tip, pushing with ``preload`` N at t = 0. The point_on_cam joint is bilateral: its
    normal reaction (constraints.point_curve.normal_force) turns negative where a real
    follower would lift off: with these values it does above a speed between 26 and 27 rad/s
    (where the decelerating half of the rise needs more than the spring gives).
    """
    radii = cam_profile()
    r0 = float(np.interp(np.pi / 2, 2 * np.pi * np.arange(36) / 36, radii))
    b = ModelBuilder("cam_follower", gravity=(0.0, 0.0, 0.0))
    b.add_body("cam", 1.0, (1e-3, 1e-3, 1.5e-3),
               shapes=[{"type": "cylinder", "radius": 0.06, "length": 0.02, "axis": [0, 0, 1],
                        "center": [0, 0, 0]}])
    b.add_body("follower", follower_mass, (2e-4, 1e-5, 2e-4), r=(0.0, r0, 0.0),
               shapes=[{"type": "cylinder", "radius": 0.004, "length": 0.1, "axis": [0, 1, 0],
                        "center": [0, 0.05, 0]}])
    b.add_joint("revolute", "cam_shaft", "ground", "cam", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "guide", "ground", "follower", point=(0, r0, 0),
                axis=(0, 1, 0))
    b.add_joint("point_on_cam", "contact", "cam", "follower", point=(0, 0, 0), axis=(0, 0, 1),
                reference=(1, 0, 0), point2=(0, r0, 0), radii=radii)
    b.add_driver("angle", "cam_speed", ConstantVelocity(speed), joint="cam_shaft")
    length = 0.2 - r0
    b.add_force("spring_damper", "spring", body_i="ground", point_i=(0, 0.2, 0),
                body_j="follower", point_j=(0, 0, 0), stiffness=stiffness,
                natural_length=length + preload / stiffness)
    return b


def bead_on_wire(x0: float = -0.6) -> ModelBuilder:
    """A 50 g bead sliding without friction on a wire z = h(x) in the vertical x-z plane (a
    natural cubic spline through h = x^2 / 2 at x = -1, -0.75, ..., 1, m), released at rest
    at x = x0. Gravity 9.81 m/s^2 along -z. Small oscillations about the bottom have
    omega^2 = g h''(0) (h''(0): the spline's, 0.97 here, not exactly 1)."""
    xs = np.linspace(-1.0, 1.0, 9)
    heights = [float(x) for x in 0.5 * xs ** 2]
    from ..constraints.point_curve import PointOnCurve, graph_eval
    block = PointOnCurve.resolve_parameters(dict(x_start=-1.0, x_step=0.25, heights=heights),
                                            None, None, "bead_on_wire")
    z0 = float(graph_eval(block, x0)[0])
    b = ModelBuilder("bead_on_wire", gravity=(0.0, 0.0, -G_TEXT))
    b.add_body("bead", 0.05, (2e-6, 2e-6, 2e-6), r=(x0, 0.0, z0),
               shapes=[{"type": "sphere", "radius": 0.01, "center": [0, 0, 0]}])
    b.add_joint("point_on_curve", "wire", "ground", "bead", point=(0, 0, 0), axis=(0, -1, 0),
                reference=(1, 0, 0), point2=(x0, 0.0, z0), x_start=-1.0, x_step=0.25,
                heights=heights)
    return b


EXAMPLES = {
    "cam_follower": (cam_follower, {}, dict(type="dynamic", t_end=2 * np.pi / 20.0,
                                             output_step=0.002,
                                             method={"name": "projection"},
                                             integrator={"name": "rk45", "rtol": 1e-8,
                                                         "atol": 1e-10})),
    "bead_on_wire": (bead_on_wire, {}, dict(type="dynamic", t_end=5.0, output_step=0.01,
                                             method={"name": "projection"},
                                             integrator={"name": "rk45", "rtol": 1e-9,
                                                         "atol": 1e-11})),
}


# ------------------------------------------------------------------------------------------
# Couplers (constraints.couplers)
# ------------------------------------------------------------------------------------------
def gear_train(torque: float = 2.0) -> ModelBuilder:
    """Two spur gears on fixed shafts (revolute joints about global z, 0.3 m apart), meshing
    with ratio -1/2 (gear 2 turns half as fast, the other way), and a rack on gear 2 (pitch
    radius 0.2 m) sliding along x; a constant motor torque ``torque`` (N m) on gear 1, no
    gravity. Gear 1 accelerates at torque / (I1 + (1/2)^2 I2 + (1/2)^2 (0.2)^2 m_rack)."""
    b = ModelBuilder("gear_train", gravity=(0.0, 0.0, 0.0))
    b.add_body("gear1", 1.0, (0.15, 0.15, 0.2),
               shapes=[{"type": "cylinder", "radius": 0.1, "length": 0.04, "axis": [0, 0, 1],
                        "center": [0, 0, 0]}])
    b.add_body("gear2", 2.0, (0.2, 0.2, 0.3), r=(0.3, 0.0, 0.0),
               shapes=[{"type": "cylinder", "radius": 0.2, "length": 0.04, "axis": [0, 0, 1],
                        "center": [0, 0, 0]}])
    b.add_body("rack", 1.5, (0.002, 0.05, 0.05), r=(0.3, -0.2, 0.0),
               shapes=[{"type": "box", "size": [0.6, 0.03, 0.04], "center": [0, 0, 0]}])
    b.add_joint("revolute", "shaft1", "ground", "gear1", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "shaft2", "ground", "gear2", point=(0.3, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "guide", "ground", "rack", point=(0.3, -0.2, 0),
                axis=(1, 0, 0))
    b.add_coupler("gear", "mesh", "shaft1", "shaft2", ratio=-0.5)
    b.add_coupler("rack_pinion", "teeth", "shaft2", "guide", radius=0.2)
    b.add_force("torque", "motor", body="gear1", direction=(0, 0, 1), magnitude=torque)
    return b


EXAMPLES.update({
    "gear_train": (gear_train, {}, dict(type="dynamic", t_end=3.0, output_step=0.01,
                                         method={"name": "projection"},
                                         integrator={"name": "rk45", "rtol": 1e-9,
                                                     "atol": 1e-11})),
})
