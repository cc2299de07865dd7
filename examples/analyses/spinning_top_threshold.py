"""Spinning-top stability threshold: linearize the sleeping top (axis vertical, spin Omega
about it) at a range of spins, find where the largest real part of the eigenvalues of A
reaches zero by bisection, and compare with the gyroscopic closed form
C^2 Omega^2 = 4 A m g l (A = I1 + m l^2 about the tip, C = I3).

    python examples/analyses/spinning_top_threshold.py
"""
import numpy as np

from spatialmbd.analyses import linearize, modes
from spatialmbd.models import HEAVY_TOP, heavy_top


def growth_rate(spin: float) -> float:
    """Largest real part (1/s) of the eigenvalues of the linearized sleeping top (its
    reduced system: the spin angle and rate, ignorable, deflated)."""
    model = heavy_top(theta=0.0, spin=spin, precession=0.0).compile()
    lin = linearize(model, steady=True)
    return float(lin.reduced().eigenvalues.real.max())


def main():
    p = HEAVY_TOP
    A = p["I1"] + p["mass"] * p["l"] ** 2
    closed_form = np.sqrt(4 * A * p["mass"] * 9.81 * p["l"]) / p["I3"]
    for spin in (10.0, 20.0, 28.0, 31.0, 40.0, 60.0):
        print(f"spin {spin:5.1f} rad/s: largest growth rate {growth_rate(spin):9.4f} 1/s")
    lo, hi = 10.0, 60.0                      # unstable at lo, stable at hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if growth_rate(mid) > 1e-6:
            lo = mid
        else:
            hi = mid
    print(f"threshold by linearization: {hi:.6f} rad/s; closed form: {closed_form:.6f} rad/s")
    print(modes(heavy_top(theta=0.0, spin=50.0, precession=0.0).compile(), steady=True)
          .summary())
    return hi, closed_form


if __name__ == "__main__":
    main()
