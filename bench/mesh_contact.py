"""Mesh and height-field contact queries: the median time of one query (the triangles near the
shape, the narrow phase per triangle and the merged manifold: what the ``mesh_contact`` kernel
runs per evaluation, before the laws) for shapes resting on a terrain of growing size, through
the AABB tree and through the height field's grid cells.

    PYTHONPATH=src python bench/mesh_contact.py

A terrain of n x n cells (2 n^2 triangles, heights +-2 cm over 4 m x 4 m); each shape is placed
at random points 5 mm into the surface with random orientations; a compiled loop repeats the
query REPEAT times per pose; the table gives the median over poses of the time per query and
the mean number of contacts kept.
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "forces"))

import contact_oracle as O  # noqa: E402
from spatialmbd.forces.contact import heightfield as HF  # noqa: E402
from spatialmbd.forces.contact import mesh_query as MQ  # noqa: E402
from spatialmbd.forces.contact import mesh_shape as MS  # noqa: E402
from spatialmbd.forces.contact import support as sup  # noqa: E402
from spatialmbd.jit import njit  # noqa: E402

REPEAT = 200


@njit
def _loop(P, fm, fs, repeat):
    s = 0
    for _ in range(repeat):
        C, keep, nk = MQ.collect_at(P, 0, fm, fs)
        s += nk
    return s


def rows(n, grid):
    H = 0.02 * np.random.default_rng(n).uniform(-1, 1, (n + 1, n + 1))
    V, F, g = HF.triangles(H, (4.0, 4.0))
    nb = MS.check_surface(V, F, "bench")
    return MS.mesh_rows(V, F, nb, None if grid else MS.build_bvh(V, F), g if grid else None)


def main():
    fm = O.frame(np.zeros(3), np.eye(3))
    print("| shape | triangles | tree (us) | grid (us) | contacts |")
    print("|---|---|---|---|---|")
    for n in (8, 32, 128):
        tables = {grid: rows(n, grid) for grid in (False, True)}
        for name in ("sphere", "box", "capsule", "cylinder", "convex"):
            rng = np.random.default_rng(1)
            times = {False: [], True: []}
            kept = []
            for _ in range(50):
                R = O.random_rotation(rng)
                c = np.array([*rng.uniform(-1.5, 1.5, 2), 0.0])
                for grid, P in tables.items():
                    P = P.copy()
                    P[0, MS.C_SIDE:MS.C_SIDE + sup.SIDE_WIDTH] = O.block(name)
                    W = np.zeros(2 * sup.SIDE_WIDTH)
                    W[sup.SIDE_WIDTH:] = O.block(name)
                    d = MQ.mesh_signed_distance(P, 0, fm, W, O.frame(c, R))[0]
                    cz = c - np.array([0, 0, d + 0.005])
                    fs = O.frame(cz, R)
                    nk = _loop(P, fm, fs, 1)
                    t0 = time.perf_counter()
                    _loop(P, fm, fs, REPEAT)
                    times[grid].append((time.perf_counter() - t0) / REPEAT * 1e6)
                    if grid:
                        kept.append(nk)
            print(f"| {name} | {2 * n * n} | {np.median(times[False]):.2f} | "
                  f"{np.median(times[True]):.2f} | {np.mean(kept):.1f} |")


if __name__ == "__main__":
    main()
