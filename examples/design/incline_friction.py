"""Friction coefficients of a block on an incline, identified from its motion.

A 2 kg block (0.2 x 0.16 x 0.1 m box) slides down a plane inclined at ALPHA = 25 degrees
(the plane horizontal, gravity tilted: g = 9.81 [sin a, 0, -cos a]), launched at 1 m/s down
the slope. Its contact with the plane (examples/design/incline.yaml: a stiff linear law,
Coulomb friction regularised at 1e-4 m/s plus viscous friction, the box's four bottom corners
in contact) has two unknown friction coefficients: mu (Coulomb) and c_v (viscous, N s/m at
each of the 4 contact points). The "measurement" is the exact motion of a rigid block with
those laws, x(t) along the slope, plus 1 mm noise; identify() recovers mu and c_v.

Closed form (answers known in advance): with N = m g cos a and c = 4 c_v,
    m x'' = m g (sin a - mu cos a) - c x',
    v_inf = m g (sin a - mu cos a) / c,   tau = m / c,
    x(t) = v_inf t + (v0 - v_inf) tau (1 - exp(-t / tau)).
The block keeps sliding for tan a > mu (no sticking, so both coefficients show in x(t): mu in
the acceleration, c_v in its decay).

    python examples/design/incline_friction.py [--seed N]
"""
import argparse
from pathlib import Path

import numpy as np

MODEL = Path(__file__).resolve().parent / "incline.yaml"
ALPHA = np.radians(25.0)
MASS, G, V0 = 2.0, 9.81, 1.0
TRUTH = {"contacts.floor.mu": 0.3, "contacts.floor.viscous": 2.0}
START = {"contacts.floor.mu": 0.2, "contacts.floor.viscous": 1.0}
SIGMA = 1e-3                                       # m, noise of the recorded position
T = np.linspace(0.0, 1.5, 151)


def exact_position(t, mu, viscous, points=4):
    """x(t) (m) of the rigid block: Coulomb mu and viscous c_v at each of ``points``."""
    c = points * viscous
    v_inf = MASS * G * (np.sin(ALPHA) - mu * np.cos(ALPHA)) / c
    tau = MASS / c
    return v_inf * t + (V0 - v_inf) * tau * (1.0 - np.exp(-t / tau))


def recorded(seed=0):
    """The measured motion: exact x(t) at the truth plus SIGMA noise (a DataFrame)."""
    import pandas as pd
    x = exact_position(T, TRUTH["contacts.floor.mu"], TRUTH["contacts.floor.viscous"])
    return pd.DataFrame({"t": T, "block.x": x + SIGMA *
                         np.random.default_rng(seed).standard_normal(T.size)})


def fit(seed=0):
    """identify() of mu and c_v from the recorded position (central-difference Jacobian:
    contact runs on simulate())."""
    from spatialmbd.design import identify
    return identify(MODEL, recorded(seed), START, noise=SIGMA,
                    bounds={"contacts.floor.mu": (0.0, 0.46), "contacts.floor.viscous":
                            (0.01, 20.0)})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    result = fit(args.seed)
    print(result.report())
    for (name, truth), est, se in zip(TRUTH.items(), result.estimates,
                                      result.standard_errors):
        print(f"{name}: truth {truth:g}, estimate {est:.5f} +- {se:.5f} "
              f"({(est - truth) / se:+.2f} standard errors)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
