"""Convex contact queries: the median time of one query per pair, and (--oracle) the agreement
with coal on 10,000 random poses per pair (tests/forces/contact_oracle.py does the comparing).

    PYTHONPATH=src python bench/contact_shapes.py [--poses 1000] [--oracle 10000]

Timing: for each random pose, a compiled loop repeats the query REPEAT times; the time per
query of that pose is the loop's wall time / REPEAT; the table gives the median and the 90th
percentile over the poses. "box-box (SAT)" are penetrating poses (separating axes and a
4-point face manifold: what a resting box costs per contact point), "box-box (GJK)" separated
ones. "manifold slot" is the whole per-instance geometry of .manifold (narrow phase and
clipping), which the contact kernel runs once per slot.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "forces"))

import contact_oracle as O  # noqa: E402
from spatialmbd.forces.contact import manifold  # noqa: E402
from spatialmbd.forces.contact import support as sup  # noqa: E402
from spatialmbd.jit import njit  # noqa: E402

REPEAT = 200


@njit
def _narrow_loop(P, fa, fb, repeat):
    s = 0.0
    for _ in range(repeat):
        a, b, n = manifold.narrow(P, 0, fa, sup.SIDE_WIDTH, fb)
        s += n[0]
    return s


@njit
def _slot_loop(P, fa, fb, repeat):
    s = 0.0
    for _ in range(repeat):
        qi, qj, n = manifold.convex_core_points(P, 0, fa, sup.SIDE_WIDTH, fb, 0)
        s += n[0]
    return s


def time_pair(a, b, poses, want, loop=_narrow_loop, seed=1):
    """Median and 90th percentile (s) of one query over poses with want(d) True."""
    rng = np.random.default_rng(seed)
    P = np.concatenate([O.block(a), O.block(b)])
    times = []
    tries = 0
    while len(times) < poses and tries < 100 * poses:
        tries += 1
        Ra, Rb = O.random_rotation(rng), O.random_rotation(rng)
        ca = rng.normal(size=3) * 0.05
        cb = ca + rng.normal(size=3) * 0.4
        fa, fb = O.frame(ca, Ra), O.frame(cb, Rb)
        qa, qb, n = manifold.narrow(P, 0, fa, sup.SIDE_WIDTH, fb)
        if not want(np.dot(n, np.subtract(qb, qa))):
            continue
        loop(P, fa, fb, 2)
        t = time.perf_counter()
        loop(P, fa, fb, REPEAT)
        times.append((time.perf_counter() - t) / REPEAT)
    return np.median(times), np.percentile(times, 90)


def timing_table(poses):
    rows = []
    pen, sep = (lambda d: d < 0), (lambda d: d > 0)
    for label, a, b, want, loop in [
            ("box-box (SAT, penetrating)", "box", "box", pen, _narrow_loop),
            ("box-box (GJK, separated)", "box", "box", sep, _narrow_loop),
            ("box-box manifold slot (penetrating)", "box", "box", pen, _slot_loop),
            ("box-capsule (EPA, penetrating)", "box", "capsule", pen, _narrow_loop),
            ("convex-convex (GJK, separated)", "convex", "convex", sep, _narrow_loop),
            ("convex-convex (EPA, penetrating)", "convex", "convex", pen, _narrow_loop),
            ("convex-convex manifold slot (penetrating)", "convex", "convex", pen, _slot_loop),
            ("ellipsoid-ellipsoid (GJK, separated)", "ellipsoid", "ellipsoid", sep,
             _narrow_loop),
            ("ellipsoid-ellipsoid (EPA, penetrating)", "ellipsoid", "ellipsoid", pen,
             _narrow_loop),
            ("cylinder-box (EPA, penetrating)", "cylinder", "box", pen, _narrow_loop)]:
        med, p90 = time_pair(a, b, poses, want, loop)
        rows.append(f"| {label} | {med * 1e6:.2f} | {p90 * 1e6:.2f} |")
    return ["| query | median (us) | 90th percentile (us) |", "|---|---|---|"] + rows


def oracle_table(poses):
    names = sorted(O.SHAPES)
    rows = ["| pair | separated / penetrating | distance vs coal (m) | certificate, "
            "separated (m) | depth vs coal (m) | certificate, penetrating (m) | coal's normal "
            "better by (m) | normal vs coal, separated | normal vs coal, penetrating |",
            "|---|---|---|---|---|---|---|---|---|"]
    for k, a in enumerate(names):
        for b in names[k:]:
            s = O.summary(O.compare(a, b, poses, seed=10 + sum(map(ord, a + b))))
            rows.append(f"| {a}-{b} | {s['separated']} / {s['penetrating']} | "
                        f"{s['distance']:.1e} | {s['certificate_sep']:.1e} | {s['depth']:.1e} |"
                        f" {s['certificate_pen']:.1e} | {s['coal_normal_better']:.1e} | "
                        f"{s['normal_sep']:.1e} | {s['normal_pen']:.1e} |")
            print(rows[-1], flush=True)
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=1000)
    ap.add_argument("--oracle", type=int, default=0, help="poses per pair against coal")
    args = ap.parse_args()
    lines = timing_table(args.poses)
    print("\n".join(lines))
    if args.oracle:
        lines += ["", f"Oracle (coal {__import__('coal').__version__}), {args.oracle} poses "
                      "per pair:", ""] + oracle_table(args.oracle)
    return lines


if __name__ == "__main__":
    main()
