"""Self-stability of the benchmark bicycle: linearize the full multibody bicycle
(spatialmbd.models.whipple_bicycle: four bodies, three revolute joints, two knife-edge wheels
rolling without slip) about its straight run at forward speeds from 0 to 10 m/s, plot the lean
and steer eigenvalues against speed (the classic figure of Meijaard et al. 2007) and find the
speed range in which it balances itself:

    python examples/analyses/bicycle_stability.py        # writes bicycle_stability.png

Between the weave speed (the lean-steer oscillation stops growing) and the capsize speed (a
slow fall sets in) every eigenvalue has a negative real part. The published values are
4.29238253634111 and 6.02426201538837 m/s.
"""
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from spatialmbd.analyses import linearize
from spatialmbd.models import whipple_bicycle

WEAVE, CAPSIZE = 4.29238253634111, 6.02426201538837    # Meijaard et al. (2007)


def lean_steer_eigenvalues(speed: float) -> np.ndarray:
    """The four eigenvalues (1/s) of the lean and steer motion at ``speed``: those of the
    linear model's reduced state matrix, from which the ignorable position, heading, wheel
    angles and forward speed are deflated (their six zero eigenvalues are defective, resolved
    only to ~1e-7 1/s, and the capsize eigenvalue crosses zero among them)."""
    lin = linearize(whipple_bicycle(speed).compile(), steady=speed > 0)
    ev = lin.reduced().eigenvalues
    assert ev.size == 4, f"{ev.size} lean and steer eigenvalues at {speed} m/s"
    return ev


def weave_margin(speed: float) -> float:
    """Real part (1/s) of the oscillatory (weave) pair; negative: it dies out."""
    ev = lean_steer_eigenvalues(speed)
    return float(ev[np.abs(ev.imag) > 1e-6].real.max())


def capsize_margin(speed: float) -> float:
    """The real eigenvalue nearest zero (1/s); positive: the bicycle slowly falls over."""
    ev = lean_steer_eigenvalues(speed)
    real = ev[np.abs(ev.imag) <= 1e-9 * np.abs(ev)].real
    return float(real[np.argmin(np.abs(real))])


def main(out_dir: Path = Path("."), n_speeds: int = 101):
    speeds = np.linspace(0.0, 10.0, n_speeds)
    ev = np.array([np.sort_complex(lean_steer_eigenvalues(v)) for v in speeds])
    weave = brentq(weave_margin, 3.5, 5.0, xtol=1e-12)
    capsize = brentq(capsize_margin, 5.8, 6.3, xtol=1e-12)
    print(f"weave speed   {weave:.10f} m/s (published {WEAVE})")
    print(f"capsize speed {capsize:.10f} m/s (published {CAPSIZE})")
    print(f"self-stable from {weave:.3f} to {capsize:.3f} m/s")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(speeds, ev.real, "k.", ms=3)
    ax.plot(speeds, np.abs(ev.imag), ".", color="0.6", ms=3)
    ax.axvspan(weave, capsize, color="tab:green", alpha=0.15, label="self-stable")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylim(-10, 10)
    ax.set_xlabel("forward speed v (m/s)")
    ax.set_ylabel("eigenvalues (1/s): real (black), |imaginary| (grey)")
    ax.set_title("Benchmark bicycle, linearized from the multibody model")
    ax.legend(loc="lower left")
    path = Path(out_dir) / "bicycle_stability.png"
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    print(f"wrote {path}")
    return weave, capsize, path


if __name__ == "__main__":
    main()
