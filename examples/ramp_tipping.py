"""A box sliding down a ramp, and tipping over when friction grips it hard enough.

A box of half width b and half height h stands on a ramp tilted by theta and is let go.
While it slides (mu < tan(theta)) the friction mu N acts up the slope at the base, h below the
centre of mass; for the box not to turn, the normal force must act mu h down-slope of the
centre's projection. It can only act inside the base, so the box slides flat while mu < b / h
and tips over forward (about its lower edge) once mu > b / h. A box that sticks
(mu > tan(theta)) tips when tan(theta) > b / h. Together (the friction-limited resultant
leaves the base):

    the box tips over  <=>  min(mu, tan(theta)) > b / h

Here b / h = 0.5 and theta = 35 deg (tan = 0.70), so boxes with mu between 0.5 and 0.7 slide
and tip, below 0.5 they slide flat:

    python examples/ramp_tipping.py            # mu = 0.45 and 0.55: the tilt after 0.6 s

tests/test_contact_examples.py checks the onset at mu = 0.47 (slides flat) and 0.53 (tips).
"""
import math

import numpy as np

from spatialmbd import ModelBuilder
from spatialmbd.simulate import simulate

G = 9.81
B, H = 0.05, 0.1             # half width (down the slope), half height, m
THETA = math.radians(35.0)
MASS, K = 1.0, 2e5           # kg; contact stiffness per corner, N/m


def ramp_box(mu: float, theta: float = THETA) -> ModelBuilder:
    """The box resting on the ramp (at its static compression), let go at t = 0."""
    n = np.array([-math.sin(theta), 0.0, math.cos(theta)])          # the ramp's normal
    up = np.array([math.cos(theta), 0.0, math.sin(theta)])          # up the slope
    A = np.column_stack([up, [0.0, 1.0, 0.0], n])                    # box axes on the ramp
    sink = MASS * G * math.cos(theta) / (4 * K)
    b = ModelBuilder("ramp_tipping", gravity=(0, 0, -G))
    inertia = MASS / 3 * np.array([0.05 ** 2 + H ** 2, B ** 2 + H ** 2, B ** 2 + 0.05 ** 2])
    b.add_body("box", MASS, tuple(inertia), r=tuple((H - sink) * n), A=A)
    zeta = 0.5
    b.add_force("contact", "ramp", body_i="ground", body_j="box",
                shape_i={"type": "plane", "normal": n.tolist()},
                shape_j={"type": "box", "half_extents": [B, 0.05, H]},
                law="linear", stiffness=K, damping=2 * zeta * math.sqrt(K * MASS / 4),
                friction="coulomb", mu=mu, creep_velocity=1e-3)
    return b


def tilt(res) -> np.ndarray:
    """The angle (rad) between the box's axis z and the ramp's normal at every output."""
    from spatialmbd.rotations import A_from_p
    n = np.array([-math.sin(THETA), 0.0, math.cos(THETA)])
    return np.array([math.acos(min(1.0, float(A_from_p(p)[:, 2] @ n)))
                     for p in res.q[:, 0, 3:]])


def run(mu: float, t_end: float = 0.6):
    return simulate(ramp_box(mu).compile(), t_end, output_step=0.01, rtol=1e-7, atol=1e-10)


def tips(mu: float, theta: float = THETA) -> bool:
    """The closed form: the box tips over iff min(mu, tan(theta)) > b / h."""
    return min(mu, math.tan(theta)) > B / H


if __name__ == "__main__":
    for mu in (0.45, 0.55):
        res = run(mu)
        print(f"mu = {mu}: tilt after {res.t[-1]:.1f} s = {math.degrees(tilt(res)[-1]):.1f} deg "
              f"(closed form: {'tips' if tips(mu) else 'slides flat'})")
