"""Slider-crank counterweight: the mass that minimises the peak driving torque.

The crank of the IFToMM slider-crank (spatialmbd.models.slider_crank, driven at 6 rad/s) gets
a point counterweight at RADIUS below its pivot A, opposite the crank pin B. At constant crank
speed the counterweight adds only its weight's moment about the crank axis (its centripetal
force passes through the axis), -m_w g RADIUS sin(theta); optimize() chooses m_w to minimise
the peak |torque| over one revolution, as the minimax of the torque's peak and trough (the
epigraph form: no kink at the optimum). A dense scan of m_w checks the result.

Balanced case (closed form): with a massless rod (no inertia) and slider the crank's own
weight is the only load, T = m_c g r_c sin(theta) - m_w g RADIUS sin(theta), and the peak |T| is zero at
m_w = m_c r_c / RADIUS (0.12 kg x 0.04 m / 0.04 m = 0.12 kg).

    python examples/design/counterweight.py [--scan N]
"""
import argparse

import numpy as np

from spatialmbd.models import slider_crank

RADIUS = 0.04                       # m, counterweight below the crank pivot A
TORQUE = "crank_drive.crank.mx"     # N m, the driver's torque about the crank axis
ANALYSIS = dict(type="dynamic", t_end=2 * np.pi / 6.0, output_step=0.005,   # one revolution
                integrator=dict(name="rk45", rtol=1e-9, atol=1e-11))


def slider_crank_counterweight(counterweight=0.0, rod_mass=0.5, slider_mass=2.0,
                               rod_inertia=None):
    """The driven slider-crank (Model) with a point counterweight (kg) on the crank, RADIUS
    below the pivot A: the crank's mass, centre of mass and inertia (parallel axes) change;
    rod and slider masses in kg, the rod's centroidal inertia [Ixx, Iyy, Izz] kg m^2 (None:
    the benchmark's)."""
    from spatialmbd.io import load_model
    from spatialmbd.io.writer import model_to_dict
    data = model_to_dict(slider_crank(driven=True))
    bodies = {b["name"]: b for b in data["bodies"]}
    crank = bodies["crank"]
    m_c, z_c = crank["mass"], crank["position"][2]       # 0.12 kg at z = 0.16 m
    z_w = 0.12 - RADIUS                                   # the counterweight's height (m)
    m = m_c + counterweight
    z = (m_c * z_c + counterweight * z_w) / m
    extra = m_c * (z_c - z) ** 2 + counterweight * (z_w - z) ** 2   # about the new centre
    inertia = [float(v) for v in crank["inertia"]]
    crank.update(mass=m, position=[0.0, 0.1, z],
                 inertia=[inertia[0] + extra, inertia[1] + extra, inertia[2]],
                 points={"B": [0.0, 0.0, 0.2 - z]})
    bodies["rod"]["mass"] = rod_mass
    if rod_inertia is not None:
        bodies["rod"]["inertia"] = [float(v) for v in rod_inertia]
    bodies["slider"]["mass"] = slider_mass
    model, _ = load_model(data)
    return model


def main(argv=None):
    from spatialmbd.design import optimize
    from spatialmbd.sweep import sweep
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scan", type=int, default=41, help="members of the check scan")
    args = ap.parse_args(argv)
    best = optimize(slider_crank_counterweight, [f"peak({TORQUE})", f"-trough({TORQUE})"],
                    {"counterweight": 0.1}, bounds={"counterweight": (0.0, 2.0)},
                    analysis=ANALYSIS)
    print(best.report())
    masses = np.linspace(0.0, 2.0, args.scan)
    ds = sweep(slider_crank_counterweight, {"counterweight": masses},
               {"hi": f"peak({TORQUE})", "lo": f"trough({TORQUE})"}, ANALYSIS)
    peak = np.maximum(ds["hi"].values, -ds["lo"].values)
    k = int(np.argmin(peak))
    print(f"scan of {args.scan} masses: best {masses[k]:.4f} kg, peak |T| {peak[k]:.6f} N m "
          f"(optimize: {best.x[0]:.4f} kg, {best.objective:.6f} N m)")
    return 0 if best.success else 1


if __name__ == "__main__":
    raise SystemExit(main())
