"""Slider-crank driving torque and its sensitivity to the link masses.

The crank of examples/slider_crank.yaml is driven at 6 rad/s; a dynamic analysis of the driven
(zero degree-of-freedom) mechanism gives the driver's reaction, the torque that keeps the speed.
We sweep the rod mass, then differentiate the torque's extremes and RMS over the revolution
(what sizes the motor) with respect to every link mass by central differences
(Richardson-checked steps). The extremes are ``peak`` / ``trough``, located between the output
samples (the torque is smooth), so they and their derivatives do not carry the samples'
O(dt^2) error.

    python examples/sweeps/slider_crank_torque.py [--scheduler serial|processes|dask]
"""
import argparse
from pathlib import Path

from spatialmbd.sweep import sensitivities, sweep

MODEL = Path(__file__).resolve().parents[1] / "slider_crank.yaml"
TORQUE = "crank_drive.crank.mx"               # N m, about the crank axis (global x)
ANALYSIS = dict(type="dynamic", t_end=1.0471975511965976, output_step=0.01,   # one revolution
                integrator=dict(name="rk45", rtol=1e-9, atol=1e-11))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheduler", default="serial")
    ap.add_argument("--quick", action="store_true", help="a quarter revolution, fewer members")
    args = ap.parse_args(argv)
    analysis = dict(ANALYSIS, t_end=ANALYSIS["t_end"] / 4) if args.quick else ANALYSIS
    masses = [0.5, 1.0] if args.quick else [0.25, 0.5, 1.0, 2.0]
    steps = (1e-3,) if args.quick else (1e-2, 1e-3, 1e-4)
    measures = {"max": f"peak({TORQUE})", "min": f"trough({TORQUE})", "rms": f"rms({TORQUE})"}
    ds = sweep(MODEL, {"bodies.rod.mass": masses}, measures, analysis, args.scheduler)
    print(f"{'rod mass [kg]':>14} {'peak |T| [N m]':>15} {'max [N m]':>10} {'min [N m]':>10} "
          f"{'rms [N m]':>10}")
    for j, m in enumerate(ds["bodies.rod.mass"].values):
        hi, lo, rms = ds["max"].values[j], ds["min"].values[j], ds["rms"].values[j]
        print(f"{m:14.3g} {max(abs(hi), abs(lo)):15.6f} {hi:10.6f} {lo:10.6f} {rms:10.6f}")
    sens = sensitivities(MODEL, ["bodies.crank.mass", "bodies.rod.mass", "bodies.slider.mass"],
                         measures, analysis, args.scheduler, relative_steps=steps)
    print("\nd(output)/d(mass) [N m / kg] (error estimate)")
    for o in sens["output"].values:
        row = "  ".join(
            f"{p.split('.')[1]}: {float(sens.derivative.sel(output=o, parameter=p)):+.5f}"
            f" ({float(sens.error.sel(output=o, parameter=p)):.1e})"
            for p in sens["parameter"].values)
        print(f"{o:>5}: {row}")
    return 0 if (sens["status"] == "success").all() else 1


if __name__ == "__main__":
    raise SystemExit(main())
