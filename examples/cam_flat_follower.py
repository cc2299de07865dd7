"""An eccentric disc cam lifting a flat-faced follower held down by a spring: the follower
jumps off the cam above a closed-form cam speed.

The cam, a disc of radius R whose centre is e off its shaft (global x), turns at the
constant speed omega; the follower slides along global z on a guide, its flat face pressed on
the disc by gravity and a compression spring of stiffness k and preload F0 (at the lowest
position). A flat face touches a circle at its top point, so while they touch the face is at
z = R - e cos(omega t) and

    N = m z'' + m g + F0 + k (z - z_min) = m g + F0 + k e (1 - cos) + m e omega^2 cos

(cos = cos(omega t)). With m omega^2 > k the smallest N is at the top (cos = -1):
N_min = m g + F0 + 2 k e - m e omega^2, so the follower leaves the cam above

    omega_jump = sqrt((m g + F0 + 2 k e) / (m e))

    python examples/cam_flat_follower.py       # the smallest contact force at 0.97 and 1.03

tests/test_contact_examples.py checks the contact holds at 0.97 omega_jump (smallest force
against N_min) and opens at 1.03 omega_jump.
"""
import math

import numpy as np

from spatialmbd import ModelBuilder
from spatialmbd.motion import ConstantVelocity
from spatialmbd.simulate import simulate

G = 9.81
M, E, R = 0.5, 0.01, 0.04          # follower mass kg; eccentricity, disc radius m
SPRING, PRELOAD = 200.0, 5.0       # N/m, N (at the lowest position)
K = 1e6                            # contact stiffness per point, N/m
POINTS = 2                         # the disc's side on a flat face: two contact points
OMEGA_JUMP = math.sqrt((M * G + PRELOAD + 2 * SPRING * E) / (M * E))


def cam_follower(omega: float) -> ModelBuilder:
    b = ModelBuilder("cam_flat_follower", gravity=(0, 0, -G))
    b.add_body("cam", 2.0, (2e-3, 1e-3, 1e-3), omega=(omega, 0, 0))
    sink = (M * G + PRELOAD) / (POINTS * K)
    z0 = R - E - sink                                  # the face, at the bottom of the lift
    b.add_body("follower", M, (1e-4, 1e-4, 1e-4), r=(0, 0, z0))
    b.add_joint("revolute", "shaft", "ground", "cam", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_driver("angle", "motor", ConstantVelocity(rate=omega), joint="shaft")
    b.add_joint("translational", "guide", "ground", "follower", point=(0, 0, z0),
                axis=(0, 0, 1))
    top = 0.5                                          # the spring's upper end, m
    length = top - (R - E)
    b.add_force("spring_damper", "spring", body_i="ground", body_j="follower",
                point_i=(0, 0, top), point_j=(0, 0, 0), stiffness=SPRING,
                natural_length=length + PRELOAD / SPRING)
    zeta = 0.3
    b.add_force("contact", "face", body_i="follower", body_j="cam",
                shape_i={"type": "plane", "normal": [0, 0, -1]},
                shape_j={"type": "cylinder", "radius": R, "half_length": 0.01,
                         "axis": [1, 0, 0], "center": [0, 0, -E]},
                law="linear", stiffness=K, damping=2 * zeta * math.sqrt(K * M / POINTS))
    return b


def run(omega: float, turns: float = 2.0):
    model = cam_follower(omega).compile()
    return model, simulate(model, turns * 2 * math.pi / omega, output_step=2e-5, rtol=1e-8,
                           atol=1e-11)


def normal_force(res) -> np.ndarray:
    """The cam's total force on the face at every output, N."""
    table = res.contacts()
    return sum(c["normal_force"] for name, c in table.items() if name != "n_active")


def n_min(omega: float) -> float:
    """The closed form: the smallest contact force of a follower that stays on, N."""
    return M * G + PRELOAD + 2 * SPRING * E - M * E * omega ** 2


if __name__ == "__main__":
    print(f"omega_jump = {OMEGA_JUMP:.3f} rad/s")
    for f in (0.97, 1.03):
        _, res = run(f * OMEGA_JUMP)
        print(f"{f} omega_jump: smallest contact force {normal_force(res).min():.4f} N "
              f"(closed form {n_min(f * OMEGA_JUMP):.4f} N)")
