#!/usr/bin/env python
"""Broad phase cost per sphere against N (issue: contact, "N spheres in a box cost linear time
per step"): spatialmbd.broadphase.sphere_pairs (uniform grid, spatial hashing) on N spheres of
radius r packed at a fixed volume fraction, N = 100 ... 100,000, and the all-pairs test for
N <= 3,000 to show where it stops scaling.

    python bench/broadphase.py [--quick]

Per-call time: minimum over repetitions (the machine is shared). Writes
bench/results/broadphase.md.
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

from spatialmbd.broadphase import SpherePairs, pairs_brute_force


def cloud(n, fraction=0.3, r=0.05, seed=0):
    """n spheres of radius r at a volume fraction (overlaps allowed) in a cube."""
    side = (n * 4.0 / 3.0 * np.pi * r**3 / fraction) ** (1.0 / 3.0)
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, side, (n, 3)), np.full(n, r)


def best_time(fn, budget=0.4):
    fn()
    best, spent = np.inf, 0.0
    while spent < budget:
        t0 = time.perf_counter()
        fn()
        dt = time.perf_counter() - t0
        best, spent = min(best, dt), spent + dt
    return best


def main(argv=None):
    quick = "--quick" in (argv or sys.argv[1:])
    sizes = [100, 1000, 10000] if quick else [100, 1000, 10000, 100000]
    rows = []
    for n in sizes:
        c, r = cloud(n)
        finder = SpherePairs(n)
        t_grid = best_time(lambda: finder(c, r, 0.005))
        pairs = len(finder(c, r, 0.005))
        t_all = np.nan
        if n <= 3000:
            out = np.zeros((n * 8, 2), np.int64)
            t_all = best_time(lambda: pairs_brute_force(c, r, 0.005, out))
        rows.append((n, pairs, t_grid, t_all))
        print(f"N = {n:>7}: {pairs:>7} pairs, grid {t_grid * 1e3:9.3f} ms "
              f"({t_grid / n * 1e9:6.0f} ns/sphere), all pairs "
              + ("-" if np.isnan(t_all) else f"{t_all * 1e3:9.3f} ms"), flush=True)
    lines = ["# Broad phase: cost per call against N", "",
             f"load average at start: {os.getloadavg()[0]:.2f} (2 cores)", "",
             "| N | pairs | grid (ms) | per sphere (ns) | all pairs (ms) |", "|---|---|---|---|---|"]
    for n, pairs, tg, ta in rows:
        lines.append(f"| {n} | {pairs} | {tg * 1e3:.3f} | {tg / n * 1e9:.0f} | "
                     + ("-" if np.isnan(ta) else f"{ta * 1e3:.3f}") + " |")
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    path = os.path.join(os.path.dirname(__file__), "results", "broadphase.md")
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    os.replace(tmp, path)


if __name__ == "__main__":
    main()
