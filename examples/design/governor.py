"""Governor spring: the stiffness that holds the fly-ball at its set angle at the target speed.

A one-arm governor: a vertical shaft driven at SPEED rad/s about z; a fly-ball arm (mass M,
centre of mass D from the pivot, centroidal inertia isotropic and small) pinned to the shaft
at (0, 0, 1) about the shaft's y axis; a rotational spring-damper at the pin (stiffness k,
damping DAMPING) whose rest position is the arm hanging straight down. Released at 0.3 rad
from the vertical, the arm settles where the spring, gravity and the centrifugal moment
balance. optimize() chooses k so that the settled arm angle is PHI (the sleeve's set point):
the objective is the squared error of the ball's settled height z = 1 - D cos(PHI).

Closed form (moments about the pin in the shaft's rotating frame, phi from the downward
vertical): k phi = M D^2 SPEED^2 sin(phi) cos(phi) - M g D sin(phi), so
k* = M D sin(PHI) (D SPEED^2 cos(PHI) - g) / PHI.

    python examples/design/governor.py
"""
import numpy as np

from spatialmbd import ModelBuilder
from spatialmbd.motion import ConstantVelocity

SPEED = 6.0                   # rad/s, the target shaft speed
M, D, G = 1.0, 0.5, 9.81      # kg, m, m/s^2
PHI = 0.6                     # rad, the set angle of the arm at SPEED
PHI0 = 0.3                    # rad, the release angle
DAMPING = 1.25                # N m s/rad (damping ratio about 0.7 near the set point)
ANALYSIS = dict(type="dynamic", t_end=8.0, output_step=0.02,
                integrator=dict(name="rk45", rtol=1e-10, atol=1e-12))


def exact_stiffness(speed=SPEED, phi=PHI):
    """k* (N m/rad) that holds the arm at phi at the shaft speed."""
    return M * D * np.sin(phi) * (D * speed**2 * np.cos(phi) - G) / phi


def governor(stiffness=2.0, speed=SPEED):
    """The one-arm governor (Model) with the pin spring's stiffness (N m/rad)."""
    b = ModelBuilder("governor_arm", gravity=(0.0, 0.0, -G))
    w = np.array([0.0, 0.0, speed])
    b.add_body("shaft", 0.5, (0.04, 0.04, 1e-3), r=(0.0, 0.0, 0.5), omega=w)
    r = np.array([D * np.sin(PHI0), 0.0, 1.0 - D * np.cos(PHI0)])
    b.add_body("arm", M, (1e-4, 1e-4, 1e-4), r=r, omega=w, rdot=np.cross(w, r))
    b.add_joint("revolute", "bearing", "ground", "shaft", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "pin", "shaft", "arm", point=(0, 0, 1.0), axis=(0, 1, 0))
    b.add_driver("angle", "drive", ConstantVelocity(rate=speed), joint="bearing")
    b.add_force("rotational_spring_damper", "pin_spring", joint="pin", stiffness=stiffness,
                damping=DAMPING, rest_angle=PHI0)
    return b.compile()


def height_error(results):
    """(settled ball height - set height)^2, m^2."""
    k = results.model.body_names.index("arm")
    return float((results.q[-1, k, 2] - (1.0 - D * np.cos(PHI))) ** 2)


def main(argv=None):
    from spatialmbd.design import optimize
    best = optimize(governor, height_error, {"stiffness": 2.0},
                    bounds={"stiffness": (0.5, 10.0)}, analysis=ANALYSIS, tol=1e-14)
    print(best.report())
    print(f"closed form k* = {exact_stiffness():.6f} N m/rad")
    return 0 if best.success else 1


if __name__ == "__main__":
    raise SystemExit(main())
