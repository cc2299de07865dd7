"""Engineering outputs of the spatial slider-crank: stroke against crank angle, driver torque.

Runs the kinematic analysis (stroke against the closed form) and a dynamic one in which the
crank is driven at 6 rad/s against gravity, records the joint coordinates and the driver's
effort, and plots them against the crank angle:

    python examples/outputs_slider_crank.py [OUTDIR]

writes OUTDIR/slider_crank_outputs.png (default: the current directory) and prints the
largest stroke error, and the driver's work (the integral of its power) against the change of
kinetic plus potential energy along the turn.
"""
import pathlib
import sys

import numpy as np

from spatialmbd import models
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.outputs import compute_outputs
from spatialmbd.plotting import plot_results, save_figure
from spatialmbd.simulate import simulate

OMEGA = 6.0                                             # crank speed, rad/s


def main(outdir="."):
    model = models.slider_crank(crank_speed=OMEGA).compile()
    t = np.linspace(0.0, 2 * np.pi / OMEGA, 145)        # one turn
    kin = kinematic_analysis(model, t)
    out = compute_outputs(kin, ["joints", "drivers"])
    # closed form: B = A + 0.08 (0, -sin th, cos th), |C - B| = 0.3 with C = (x, 0, 0)
    th = OMEGA * t
    x = np.sqrt(0.09 - (0.1 - 0.08 * np.sin(th)) ** 2 - (0.12 + 0.08 * np.cos(th)) ** 2)
    stroke_error = np.abs(out["D.translation"] - (x - 0.2)).max()
    print(f"stroke along the translational joint D: largest error {stroke_error:.2e} m")

    res = simulate(model, 2 * np.pi / OMEGA, output_step=2e-3, rtol=1e-9, atol=1e-11,
                   outputs=["joints", "drivers"])
    table = res.outputs()
    power = table["crank_drive.power"].to_numpy()
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(res.t))])
    energy = res.energy()
    change = energy["kinetic"] + energy["gravitational"]
    change = change - change[0]
    print(f"driver work so far against the energy change (frictionless): largest difference "
          f"{np.abs(work - change).max():.2e} J, largest change {np.abs(change).max():.3e} J")
    fig = plot_results(table, ["D.translation", "crank_drive.effort"],
                       x="crank_drive.coordinate", title="slider-crank, crank at 6 rad/s")
    path = save_figure(fig, pathlib.Path(outdir) / "slider_crank_outputs.png")
    print(f"figure written to {path}")
    return stroke_error, work, change


if __name__ == "__main__":
    main(*sys.argv[1:2])
