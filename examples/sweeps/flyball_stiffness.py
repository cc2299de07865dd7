"""Flyball governor: how the spring stiffness sets the steady sleeve height and the fly-ball
swing (IFToMM A05 model of examples/flyball_governor.yaml, both springs changed together).

    python examples/sweeps/flyball_stiffness.py [--scheduler serial|processes|dask] [-o k.nc]
"""
import argparse
from pathlib import Path

import numpy as np

from spatialmbd.sweep import points, save_result, sweep

MODEL = Path(__file__).resolve().parents[1] / "flyball_governor.yaml"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheduler", default="serial")
    ap.add_argument("--t-end", type=float, default=0.5, help="simulated time [s]")
    ap.add_argument("-o", "--out", help="result file (.nc, .csv or .parquet)")
    ap.add_argument("--members", type=int, default=5)
    args = ap.parse_args(argv)
    k = np.geomspace(2e4, 8e5, args.members)          # N/m
    space = points({"forces.spring_A.stiffness": k, "forces.spring_B.stiffness": k})
    analysis = dict(type="dynamic", t_end=args.t_end, output_step=0.01,
                    method={"name": "projection"},
                    integrator={"name": "scipy-radau", "rtol": 1e-6, "atol": 1e-8})
    ds = sweep(MODEL, space, {"sleeve_final": "final(slider.z)", "sleeve_min": "min(slider.z)",
                              "ball_x_final": "final(rod_A.tip.x)"}, analysis, args.scheduler)
    print(f"{'k [N/m]':>10} {'sleeve z(T) [m]':>16} {'min z [m]':>10} "
          f"{'ball x(T) [m]':>15} status")
    for j in range(k.size):
        print(f"{k[j]:10.3g} {ds['sleeve_final'].values[j]:16.6f} "
              f"{ds['sleeve_min'].values[j]:10.6f} {ds['ball_x_final'].values[j]:15.6f} "
              f"{ds['status'].values[j]}")
    if args.out:
        save_result(ds, args.out)
    return 0 if (ds["status"] == "success").all() else 1


if __name__ == "__main__":
    raise SystemExit(main())
