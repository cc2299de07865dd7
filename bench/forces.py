#!/usr/bin/env python
"""Cost of force elements in the right-hand side: a model with its force elements against the
same model with them removed, in one run (issue: force elements compiled, goal <= 1.5x).

    python bench/forces.py            # flyball governor (2 spring-dampers), 3-link chain with
                                      # bushings, slider-crank with a rotational spring

Per-RHS time is the minimum over repetitions of a timed loop of many calls (the machine is
shared). Also runs the force elements through the Python path (a user force element that
calls the same kernels from Python), which is what every force element cost before they were
compiled. Writes bench/results/forces.md.
"""
from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from spatialmbd import ModelBuilder, models  # noqa: E402
from spatialmbd.simulate import right_hand_side  # noqa: E402


def per_call(rhs, y0, seconds=0.5):
    rhs(0.0, y0)
    best = np.inf
    for _ in range(5):
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds / 5:
            for _ in range(50):
                rhs(0.01, y0)
            n += 50
        best = min(best, (time.perf_counter() - t0) / n)
    return best


def without_forces(builder):
    b = builder.compile().to_builder()
    b.forces = {}
    return b


def as_python(builder):
    """The same forces, evaluated from Python between the compiled stages (a user force)."""
    model = builder.compile()
    groups = model.force_groups

    def push(t, q, v):
        from spatialmbd.state import BodyState
        state = BodyState.from_qv(q, v, t)
        g = np.zeros((model.nb + 1, 6))
        for gr in groups:
            gr.evaluate(state, t, g)
        return g[:model.nb, :3], g[:model.nb, 3:]
    b = without_forces(builder)
    b.add_force("user", "python_forces", function=push)
    return b


def chain_with_bushings(n=3):
    b = ModelBuilder("bushing_chain", gravity=(0, 0, -9.81))
    prev = "ground"
    for k in range(n):
        b.add_body(f"link{k}", 1.0, (0.01, 0.1, 0.1), r=(0.5 + k, 0, 0))
        b.add_force("bushing", f"bush{k}", body_i=prev, body_j=f"link{k}", point_i=(
            (0.0 if prev == "ground" else 0.5), 0, 0) if prev != "ground" else (0, 0, 0),
            stiffness=1e4, damping=10.0, rotational_stiffness=1e3, rotational_damping=1.0)
        prev = f"link{k}"
    return b


def slider_crank_spring():
    b = models.slider_crank()
    joint = next(n for n, j in b.joints.items() if j.type == "revolute")
    b.add_force("rotational_spring_damper", "crank_spring", joint=joint, stiffness=5.0,
                damping=0.1)
    return b


def main():
    rows = []
    for name, make in (("flyball governor (2 spring-dampers)", models.flyball_governor),
                       ("slider-crank + rotational spring", slider_crank_spring),
                       ("3 bodies on bushings (no joints)", chain_with_bushings)):
        b = make()
        rhs, y0 = right_hand_side(b.compile())
        rhs0, y00 = right_hand_side(without_forces(b).compile())
        rhsp, y0p = right_hand_side(as_python(b).compile())
        t_f, t_0, t_p = per_call(rhs, y0), per_call(rhs0, y00), per_call(rhsp, y0p)
        rows.append((name, t_0, t_f, t_p))
    lines = ["| model | RHS without forces | with compiled forces | ratio | forces through "
             "Python | ratio |", "|---|---|---|---|---|---|"]
    for name, t0, tf, tp in rows:
        lines.append(f"| {name} | {t0 * 1e6:.1f} us | {tf * 1e6:.1f} us | {tf / t0:.2f}x | "
                     f"{tp * 1e6:.1f} us | {tp / t0:.1f}x |")
    text = "\n".join(lines)
    print(text)
    out = os.path.join(os.path.dirname(__file__), "results", "forces.md")
    with open(out, "w") as fh:
        fh.write("# Force elements in the right-hand side\n\n`python bench/forces.py`, "
                 f"{time.strftime('%Y-%m-%d')}, {os.cpu_count()} cores, Python "
                 f"{sys.version.split()[0]}. Minimum over repetitions.\n\n" + text + "\n")


if __name__ == "__main__":
    main()
