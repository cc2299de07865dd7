"""Pendulum period against amplitude: a sweep of a model factory, checked against the exact
period of the compound pendulum, T = 4 sqrt(L_eq / g) K(sin(theta0 / 2)), L_eq = I_pivot / (m d).

    python examples/sweeps/pendulum_period.py [--members 24] [--scheduler serial|processes|dask]
                                              [--plot period.png]

The pendulum is the 1 m solid cylinder of chapter 15 (pivot at one end), released at rest
theta0 from the downward vertical. The members are integrated together by the batch engine.
"""
import argparse

import numpy as np
from scipy.special import ellipk

from spatialmbd import ModelBuilder
from spatialmbd.sweep import sweep

MASS, I_CM, D, G = 7.02, 0.5855265, 0.5, 9.81           # kg, kg m^2, m, m/s^2


def pendulum(amplitude_deg):
    """The pendulum released at rest amplitude_deg (degrees) from the downward vertical."""
    th = np.radians(amplitude_deg)
    a = th - np.pi / 2                  # rotation about x that turns body y onto the rod
    A = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("rod", mass=MASS, inertia=(I_CM, 0.001053, I_CM),
               r=D * np.array([0.0, np.sin(th), -np.cos(th)]), A=A)
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    return b.compile()


def exact_period(amplitude_deg):
    L_eq = (I_CM + MASS * D**2) / (MASS * D)
    k = np.sin(np.radians(amplitude_deg) / 2)
    return 4 * np.sqrt(L_eq / G) * ellipk(k**2)          # scipy's ellipk takes m = k^2


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=24)
    ap.add_argument("--scheduler", default="serial")
    ap.add_argument("--plot", help="write a figure (.png)")
    args = ap.parse_args(argv)
    amplitudes = np.linspace(5.0, 175.0, args.members)
    analysis = dict(type="dynamic", t_end=2.6 * exact_period(amplitudes.max()),
                    output_step=0.01, integrator=dict(name="rk45", rtol=1e-10, atol=1e-12))
    ds = sweep(pendulum, {"amplitude_deg": amplitudes}, {"period": "period(rod.wx)"},
               analysis, args.scheduler, engine="batch")
    T, Te = ds["period"].values, exact_period(amplitudes)
    print(f"{'amplitude [deg]':>16} {'period [s]':>12} {'exact [s]':>12} {'rel. error':>11}")
    for a, t, te in zip(amplitudes, T, Te):
        print(f"{a:16.1f} {t:12.8f} {te:12.8f} {abs(t - te) / te:11.2e}")
    print(f"{int(ds.attrs['n_members'])} members in {ds.attrs['wall_time']:.3g} s; max relative "
          f"error {np.max(np.abs(T - Te) / Te):.2e}")
    if args.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.plot(amplitudes, Te, "-", label="exact (elliptic integral)")
        ax.plot(amplitudes, T, "o", ms=4, label="sweep (zero crossings)")
        ax.set_xlabel("amplitude [deg]")
        ax.set_ylabel("period [s]")
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
    return 0 if np.max(np.abs(T - Te) / Te) < 1e-6 else 1


if __name__ == "__main__":
    raise SystemExit(main())
