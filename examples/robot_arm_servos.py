"""A three-link arm under gravity following a joint trajectory with position servos.

Each joint (revolute, axes along y) has a PD position servo with velocity feedforward and a
torque limit; the references are quintic smooth steps (zero rate and acceleration at both
ends) from the hanging pose to a raised one. The script records each servo's command, effort
and power, checks the energy balance (the servos' work against the change of kinetic plus
gravitational energy) and plots the efforts and powers:

    python examples/robot_arm_servos.py [OUTDIR]

writes OUTDIR/robot_arm_servos.png (default: the current directory) and prints the largest
tracking error at the end of the move and the energy-balance error.
"""
import pathlib
import sys

import numpy as np

from spatialmbd import ModelBuilder
from spatialmbd.motion import SmoothStep
from spatialmbd.plotting import plot_results, save_figure
from spatialmbd.simulate import simulate

#: links: (name, length m, mass kg); joint targets (rad) reached at T_MOVE
LINKS = (("upper", 0.5, 4.0), ("fore", 0.4, 2.5), ("hand", 0.2, 1.0))
TARGETS = (-1.2, 0.9, 0.6)
GAINS = ((900.0, 60.0), (500.0, 30.0), (150.0, 8.0))      # (kp N m/rad, kv N m s/rad)
TORQUE_LIMIT = 80.0                                        # N m
T_MOVE, T_END = 1.0, 1.5


def arm():
    """The arm hanging along -z from a shoulder at the origin, a servo on every joint."""
    b = ModelBuilder("arm_servos", gravity=(0, 0, -9.81))
    top, parent = 0.0, "ground"
    for (name, length, mass), target, (kp, kv) in zip(LINKS, TARGETS, GAINS):
        inertia = mass * length ** 2 / 12
        b.add_body(name, mass, (inertia, inertia, 1e-3 * mass), position=(0, 0, top - length / 2))
        joint = f"{name}_joint"
        b.add_joint("revolute", joint, parent, name, point=(0, 0, top), axis=(0, 1, 0))
        b.add_force("position_servo", f"{name}_servo", joint=joint, kp=kp, kv=kv,
                    reference=SmoothStep(t0=0.0, t1=T_MOVE, f0=0.0, f1=target),
                    forcerange=[-TORQUE_LIMIT, TORQUE_LIMIT])
        top, parent = top - length, name
    return b.compile()


def main(outdir="."):
    model = arm()
    res = simulate(model, T_END, method="projection", rtol=1e-8, atol=1e-10,
                   output_step=0.005, outputs=["forces"])
    table = res.outputs()
    names = [f"{name}_servo" for name, _, _ in LINKS]
    end = res.t >= T_MOVE + 0.3
    tracking = max(np.abs(table[f"{n}.coordinate"].to_numpy()[end] - target).max()
                   for n, target in zip(names, TARGETS))
    energy_error = float(np.abs(res.energy()["error"]).max())
    print(f"largest tracking error 0.3 s after the move: {np.degrees(tracking):.3f} deg")
    print(f"energy balance (servo work against the energy change): largest error "
          f"{energy_error:.2e} J of {np.abs(res.work).max():.3e} J of work")
    fig = plot_results(table, [f"{n}.effort" for n in names] + [f"{n}.power" for n in names],
                       title="three-link arm following a joint trajectory with position servos")
    path = save_figure(fig, pathlib.Path(outdir) / "robot_arm_servos.png")
    print(f"figure written to {path}")
    return tracking, energy_error, res


if __name__ == "__main__":
    main(*sys.argv[1:2])
