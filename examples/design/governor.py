"""Flyball governor: the spring stiffness that lifts the sleeve to its set height at the
target speed.

The IFToMM A05 governor (spatialmbd.models.flyball_governor) with its shaft driven at the
target speed SPEED; both springs get the stiffness k (softer than the benchmark's 8e5 N/m, so
the balls swing out) and the damping DAMPING (the swing settles within the run). optimize()
chooses k so that the settled sleeve height final(slider.z) equals the set height: the
objective is the squared error, its gradient by central differences; a scan of k checks it.

    python examples/design/governor.py
"""
import argparse

import numpy as np

from spatialmbd.models import flyball_governor

SPEED = 2 * np.pi              # rad/s, the target shaft speed
DAMPING = 3000.0               # N s/m, each spring
SET_HEIGHT = 0.56              # m, the sleeve's set height at the target speed
ANALYSIS = dict(type="dynamic", t_end=3.0, output_step=0.01, method={"name": "projection"},
                integrator={"name": "scipy-radau", "rtol": 1e-8, "atol": 1e-10})


def governor(stiffness=5000.0):
    """The governor (Model) with the shaft driven at SPEED and both springs of stiffness
    ``stiffness`` (N/m) and damping DAMPING."""
    from spatialmbd.io import load_model
    from spatialmbd.io.writer import model_to_dict
    data = model_to_dict(flyball_governor())
    for force in data["forces"]:
        force["stiffness"] = float(stiffness)
        force["damping"] = DAMPING
    data["drivers"] = [dict(name="shaft_drive", kind="angle", joint="shaft_pivot",
                            law=dict(type="constant_velocity", rate=SPEED, initial=0.0))]
    model, _ = load_model(data)
    return model


def sleeve_error(results):
    """(settled sleeve height - set height)^2, m^2."""
    k = results.model.body_names.index("slider")
    return float((results.q[-1, k, 2] - SET_HEIGHT) ** 2)


def main(argv=None):
    from spatialmbd.design import optimize
    from spatialmbd.sweep import sweep
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.parse_args(argv)
    best = optimize(governor, sleeve_error, {"stiffness": 5000.0},
                    bounds={"stiffness": (100.0, 1e5)}, analysis=ANALYSIS, tol=1e-14)
    print(best.report())
    ks = np.geomspace(1e3, 3e4, 9)
    ds = sweep(governor, {"stiffness": ks}, {"z": "final(slider.z)", "z_before":
               "min(slider.z)"}, ANALYSIS)
    for k, z in zip(ks, ds["z"].values):
        print(f"k = {k:9.1f} N/m: sleeve {z:.5f} m")
    return 0 if best.success else 1


if __name__ == "__main__":
    raise SystemExit(main())
