"""Rolling without slip (constraints.rolling): a disc in steady motion and a ball on a
turntable."""
from __future__ import annotations

import math

import numpy as np

from ..model import ModelBuilder


# ------------------------------------------------------------------------------------------
# Rolling without slip (constraints.rolling)
# ------------------------------------------------------------------------------------------
def rolling_disc_steady(tilt: float = 0.3, path_radius: float = 0.5, radius: float = 0.1,
                        mass: float = 0.5):
    """The precession rate Omega (rad/s) of a thin uniform disc rolling without slip in steady
    circular motion: its centre on a horizontal circle of radius ``path_radius`` (m), its face
    leaning inward by ``tilt`` (rad from the vertical). From the balance of angular momentum
    about the centre, with I_a = m R^2 / 2 about the axis and I_d = m R^2 / 4 across:

        Omega^2 = m g R sin(tilt) / (cos(tilt) (m R b + I_a b / R + I_d sin(tilt)))

    and the spin about the axis is -Omega (b + R sin(tilt)) / R (the rim point at the contact
    at rest). Returns (Omega, spin)."""
    g, R, b, m, th = 9.81, radius, path_radius, mass, tilt
    Ia, Id = m * R * R / 2.0, m * R * R / 4.0
    omega = math.sqrt(m * g * R * math.sin(th) /
                      (math.cos(th) * (m * R * b + Ia * b / R + Id * math.sin(th))))
    return omega, -omega * (b + R * math.sin(th)) / R


def rolling_disc(tilt: float = 0.3, path_radius: float = 0.5, radius: float = 0.1,
                 mass: float = 0.5) -> ModelBuilder:
    """A coin rolling without slip on the ground plane z = 0, started in its steady circular
    motion (:func:`rolling_disc_steady`): centre at (path_radius, 0, R cos(tilt)), face leaning
    toward the z axis by ``tilt``, axis along body x. It keeps its tilt and its circle, one
    revolution every 2 pi / Omega s."""
    omega, spin = rolling_disc_steady(tilt, path_radius, radius, mass)
    R, th = radius, tilt
    u = np.array([math.cos(th), 0.0, math.sin(th)])              # the disc's axis
    e_phi = np.array([0.0, 1.0, 0.0])
    A = np.column_stack([u, e_phi, np.cross(u, e_phi)])
    centre = (path_radius, 0.0, R * math.cos(th))
    b = ModelBuilder("rolling_disc", gravity=(0.0, 0.0, -9.81))
    b.add_body("coin", mass, (mass * R * R / 2.0, mass * R * R / 4.0, mass * R * R / 4.0),
               r=centre, A=A, rdot=(0.0, omega * path_radius, 0.0),
               omega=tuple(omega * np.array([0.0, 0.0, 1.0]) + spin * u),
               shapes=[{"type": "cylinder", "radius": R, "length": 0.01,
                        "axis": [1.0, 0.0, 0.0]}])
    b.add_joint("rolling_disc", "roll", "coin", "ground", point=centre, axis=tuple(u),
                point2=(0.0, 0.0, 0.0), axis2=(0.0, 0.0, 1.0), radius=R)
    return b


def ball_on_turntable(speed: float = 2.0, radius: float = 0.1, mass: float = 1.0,
                      start: float = 0.5) -> ModelBuilder:
    """A solid ball rolling without slip on a turntable driven at ``speed`` rad/s about the
    vertical: started at rest on the table at distance ``start`` (m) from the axis, its centre
    circles at 2/7 of the table's speed (k / (1 + k) with k = I / (m R^2) = 2/5)."""
    W, R = speed, radius
    b = ModelBuilder("ball_on_turntable", gravity=(0.0, 0.0, -9.81))
    b.add_body("table", 10.0, (1.25, 1.25, 2.5), r=(0.0, 0.0, 0.0), omega=(0.0, 0.0, W),
               shapes=[{"type": "cylinder", "radius": 1.0, "length": 0.02,
                        "axis": [0.0, 0.0, 1.0], "center": [0.0, 0.0, -0.01]}])
    b.add_joint("revolute", "axle", "ground", "table", point=(0.0, 0.0, 0.0),
                axis=(0.0, 0.0, 1.0))
    b.add_driver("angle", "motor", {"type": "polynomial", "coefficients": [0.0, W]},
                 joint="axle")
    b.add_body("ball", mass, (0.4 * mass * R * R,) * 3, r=(start, 0.0, R),
               rdot=(0.0, W * start, 0.0), omega=(0.0, 0.0, W),
               shapes=[{"type": "sphere", "radius": R}])
    b.add_joint("rolling_sphere", "roll", "ball", "table", point=(start, 0.0, R),
                point2=(0.0, 0.0, 0.0), axis2=(0.0, 0.0, 1.0), radius=R)
    return b


EXAMPLES = {
    "rolling_disc": (rolling_disc, {}, dict(
        type="dynamic", t_end=2 * math.pi / rolling_disc_steady()[0], output_step=0.01,
        method={"name": "projection"}, integrator={"name": "rk45", "rtol": 1e-10,
                                                   "atol": 1e-12})),
    "ball_on_turntable": (ball_on_turntable, {}, dict(
        type="dynamic", t_end=2 * math.pi / (2.0 * 2.0 / 7.0), output_step=0.02,
        method={"name": "projection"}, integrator={"name": "rk45", "rtol": 1e-10,
                                                   "atol": 1e-12})),
}
