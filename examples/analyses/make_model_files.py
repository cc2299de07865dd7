"""Writes the model files of this folder (run from the repository root):

    python examples/analyses/make_model_files.py

slider_crank_torque.yaml   inverse dynamics: motor torque of the driven slider-crank over a cycle
hanging_chain.yaml         static equilibrium of five rods hanging between two pins
double_pendulum_modes.yaml modes of a double pendulum of two uniform rods
spinning_top_modes.yaml    modes of a sleeping top (steady spin above the stability threshold)
bicycle_modes.yaml         modes of the benchmark bicycle running straight at 5 m/s (rolling wheels)
"""
from pathlib import Path

import numpy as np

from spatialmbd import ModelBuilder, models
from spatialmbd.io.modelfile import Analysis, save_model

HERE = Path(__file__).resolve().parent
G = 9.81


def hanging_chain(n=5, length=1.0, mass=1.0):
    """n uniform rods (length m, mass kg) joined by spherical joints, hanging between two
    spherical pins at the same height; assembled from a guessed symmetric polygon whose span
    fixes the pins (the equilibrium shape is the discrete catenary)."""
    phi = np.linspace(-0.9, 0.9, n)
    nodes = np.zeros((n + 1, 3))
    for k in range(n):
        nodes[k + 1] = nodes[k] + length * np.array([np.cos(phi[k]), 0, np.sin(phi[k])])
    b = ModelBuilder("hanging_chain", gravity=(0, 0, -G))
    for k in range(n):
        d = (nodes[k + 1] - nodes[k]) / length
        A = np.column_stack([d, [0, 1, 0], np.cross(d, [0, 1, 0])])
        b.add_body(f"rod{k}", mass, (1e-4, mass * length**2 / 12, mass * length**2 / 12),
                   r=(nodes[k] + nodes[k + 1]) / 2, A=A,
                   shapes=[{"type": "box", "size": [length, 0.03, 0.03], "center": [0, 0, 0]}])
    prev = "ground"
    for k in range(n + 1):
        nxt = f"rod{k}" if k < n else "ground"
        b.add_joint("spherical", f"pin{k}", prev, nxt, point=nodes[k])
        prev = nxt
    return b


def double_pendulum_rods(mass=1.0, length=1.0):
    """Two uniform rods hanging along -z, revolute joints about global x."""
    b = ModelBuilder("double_pendulum_rods", gravity=(0, 0, -G))
    inertia = (mass * length**2 / 12, mass * length**2 / 12, 1e-6)
    for k in range(2):
        b.add_body(f"bar{k + 1}", mass, inertia, r=(0, 0, -(k + 0.5) * length),
                   shapes=[{"type": "box", "size": [0.03, 0.03, length], "center": [0, 0, 0]}])
    b.add_joint("revolute", "shoulder", "ground", "bar1", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_joint("revolute", "elbow", "bar1", "bar2", point=(0, 0, -length), axis=(1, 0, 0))
    return b


FILES = {
    "slider_crank_torque": (models.slider_crank(crank_speed=6.0),
                            Analysis(type="inverse", t_end=2 * np.pi / 6.0, output_step=0.01),
                            "Motor torque of the driven slider-crank (models.slider_crank) over "
                            "one crank revolution at 6 rad/s: spatialmbd run <file>"),
    "hanging_chain": (hanging_chain(), Analysis(type="static"),
                      "Five rods hanging between two pins: equilibrium shape, pin forces and "
                      "stability (each rod spins freely: zero-stiffness directions)"),
    "double_pendulum_modes": (double_pendulum_rods(), Analysis(type="modal"),
                              "Natural frequencies of a double pendulum of two uniform 1 m, "
                              "1 kg rods (closed form 0.4266 and 1.1441 Hz)"),
    "spinning_top_modes": (models.heavy_top(theta=0.0, spin=50.0, precession=0.0),
                           Analysis(type="modal", steady=True),
                           "Sleeping top spinning at 50 rad/s about the vertical (threshold "
                           "29.3 rad/s): modes of the steady motion"),
    "bicycle_modes": (models.whipple_bicycle(speed=5.0), Analysis(type="modal", steady=True),
                      "The Meijaard et al. (2007) benchmark bicycle running straight at 5 m/s "
                      "(self-stable from 4.29 to 6.02 m/s): weave -0.775 +- 4.465i, capsize "
                      "-0.323 and castering -14.08 1/s"),
}


if __name__ == "__main__":
    for name, (builder, analysis, text) in FILES.items():
        save_model(builder, HERE / f"{name}.yaml", analysis=analysis,
                   header=f"{name}: {text}.\nWritten by examples/analyses/make_model_files.py.")
        print(f"wrote {name}.yaml")
