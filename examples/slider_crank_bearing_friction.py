"""A slider-crank with bearing friction against its closed-form friction loss per cycle.

A crank (R = 0.1 m) turned at a constant 0.5 rad/s by a driver pushes a slider through a rod
(L = 0.3 m) against a Coulomb friction force P = 50 N on the slider's guide. The crank's
bearing (a pin of radius r = 20 mm, mu = 0.2) has a friction moment proportional to its radial
reaction, mu r |radial reaction| (joint_friction with ``mu`` and ``radius``), which the run
takes from the bearing's reaction at every evaluation. The links weigh 10 g and the crank turns
slowly, so the rod is a two-force member carrying F = P / cos(beta) (sin beta = (R/L) sin theta),
and the bearing's radial reaction is F: the friction losses per turn of the crank are

    crank bearing:  mu r P int_0^2pi dtheta / sqrt(1 - (R/L)^2 sin^2 theta) = 4 mu r P K(m),
                    m = (R/L)^2 (K the complete elliptic integral of the first kind);
    slider guide:   P x 4 R (the stroke 2 R, twice).

The script integrates the friction outputs' powers over one turn (midpoint rule), compares
them with these closed forms, checks the energy balance (the driver's work is what the two
frictions dissipate) and plots the bearing's friction moment and the two powers:

    python examples/slider_crank_bearing_friction.py [OUTDIR]

writes OUTDIR/slider_crank_bearing_friction.png (default: the current directory) and prints
the relative errors (about 4e-10 for the bearing and 1e-7 for the guide, whose power has kinks
at the dead centres: the midpoint rule's error there, and what the 10 g links' inertia adds to
the quasi-static forces).
"""
import math
import pathlib
import sys

import numpy as np
from scipy.special import ellipk

from spatialmbd import ModelBuilder
from spatialmbd.motion import ConstantVelocity
from spatialmbd.outputs import force_outputs
from spatialmbd.simulate import simulate

R, L, P = 0.1, 0.3, 50.0               # crank, rod (m), slider friction (N)
MU, PIN = 0.2, 0.02                    # the crank bearing's friction coefficient, pin radius (m)
OMEGA = 0.5                            # crank speed (rad/s)
MASS = 0.01                            # each link (kg)


def model():
    """The slider-crank in the x-y plane (gravity along -z, the joints' axes along z): a
    revolute bearing A (ground-crank), spherical B (crank-rod), universal C (rod-slider: the
    rod's cross axis y, the slider's z) and translational D (ground-slider along x): 1 DoF,
    no redundant equations, so the reactions are unique."""
    b = ModelBuilder("slider_crank_bearing_friction", gravity=(0, 0, -9.81))
    small = (1e-6, 1e-6, 1e-6)
    b.add_body("crank", MASS, small, r=(R / 2, 0, 0))
    b.add_body("rod", MASS, (1e-6, MASS * L * L / 12, MASS * L * L / 12), r=(R + L / 2, 0, 0))
    b.add_body("slider", MASS, small, r=(R + L, 0, 0))
    b.add_joint("revolute", "A", "ground", "crank", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("spherical", "B", "crank", "rod", point=(R, 0, 0))
    b.add_joint("universal", "C", "rod", "slider", point=(R + L, 0, 0), axis=(0, 1, 0),
                axis2=(0, 0, 1))
    b.add_joint("translational", "D", "ground", "slider", point=(R + L, 0, 0), axis=(1, 0, 0))
    b.add_driver("angle", "motor", ConstantVelocity(rate=OMEGA), joint="A")
    b.add_force("joint_friction", "bearing", joint="A", mu=MU, radius=PIN,
                creep_velocity=1e-6)
    b.add_force("joint_friction", "guide", joint="D", frictionloss=P, creep_velocity=1e-6)
    return b.compile()


def main(outdir="."):
    period = 2 * math.pi / OMEGA
    # the powers at the midpoints of 4000 intervals (the midpoint rule: O(h^2); no output on
    # a dead centre, where the slider's regularized friction passes through zero within
    # v_eps / (R omega) = 2e-5 rad)
    h = period / 4000
    res = simulate(model(), period, method="standard", rtol=1e-10, atol=1e-12,
                   t_eval=np.arange(4000) * h + h / 2)
    assert res.success, res.message
    bearing, guide = force_outputs(res, "bearing"), force_outputs(res, "guide")
    loss = {"bearing": -h * bearing["power"].sum(), "guide": -h * guide["power"].sum()}
    exact = {"bearing": 4 * MU * PIN * P * ellipk((R / L) ** 2), "guide": 4 * R * P}
    errors = {k: abs(loss[k] - exact[k]) / exact[k] for k in loss}
    kinetic = res.energy()["kinetic"]
    balance = abs(res.energy()["error"]).max()
    for k in loss:
        print(f"{k}: friction loss per turn {loss[k]:.6f} J, closed form {exact[k]:.6f} J, "
              f"relative error {errors[k]:.1e}")
    print(f"energy balance error {balance:.1e} J (kinetic energy {kinetic.max():.1e} J)")
    _plot(res, bearing, guide, pathlib.Path(outdir) / "slider_crank_bearing_friction.png")
    return dict(loss=loss, exact=exact, errors=errors, balance=balance)


def _plot(res, bearing, guide, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    angle = np.degrees(OMEGA * res.t)
    top.plot(angle, -bearing["friction"], label="bearing friction moment (N m)")
    top.plot(angle, bearing["level"], "--", label="mu r |radial reaction| (N m)")
    top.legend()
    bottom.plot(angle, -bearing["power"], label="bearing")
    bottom.plot(angle, -guide["power"], label="slider guide")
    bottom.set_xlabel("crank angle (deg)")
    bottom.set_ylabel("dissipated power (W)")
    bottom.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
