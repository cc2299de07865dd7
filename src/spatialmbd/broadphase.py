"""Broad phase for many spheres: the candidate pairs of N spheres in O(N) time (uniform grid).

Contact between N bodies must not cost N^2 pair tests per evaluation. :func:`sphere_pairs`
returns every pair (i < j) whose spheres are closer than a margin,

    |c_i - c_j| <= r_i + r_j + margin,

exactly (each candidate found by the grid is confirmed by this test), in time linear in N for
spheres of comparable size.

Method: a uniform grid of cell size h = 2 max(r) + margin, so the two spheres of any such pair
have their centres in the same or in adjacent cells, and a counting sort of the spheres by cell
(O(N)). When the spheres' bounding box has at most 4 N cells (spheres in a box) the grid is
dense: each sphere tests its own cell and the 13 cells of the forward half of its
neighbourhood, so every pair is met exactly once. Otherwise (far-flung outliers) the cells are
hashed into a table of 4 N buckets (three large primes; Teschner et al., "Optimized spatial
hashing for collision detection of deformable objects", VMV 2003): different cells may share a
bucket, which only adds candidates that the exact distance test rejects, and a bucket reached
from two of the 27 neighbour cells is visited once. A margin > 0 gives the pairs that may touch within a step (a Verlet
list): with every sphere moving less than margin / 2, the pairs of a list built with ``margin``
still contain every touching pair.

Spheres of very different sizes make the cells as large as the largest sphere: the cost grows
with the number of spheres per cell, not with N^2 unless every sphere shares one cell.

Mixed shapes (boxes, capsules, meshes, ... of any sizes): :func:`aabb_pairs` returns every pair
whose axis-aligned bounding boxes (lo, hi (N, 3), e.g. from the shapes' support functions,
:func:`spatialmbd.forces.contact.mesh_query.shape_box`) overlap within a margin, by sweep and
prune: the boxes sorted by lo_x (O(N log N)), each box tested against the following ones until
their lo_x passes its hi_x + margin, the y and z intervals deciding. The cost is
O(N log N + the pairs overlapping in x); :func:`aabb_pairs_brute_force` is its reference.
"""
from __future__ import annotations

import numpy as np

from .errors import ModelError
from .jit import njit

_P1, _P2, _P3 = 73856093, 19349663, 83492791


@njit
def _bucket(ix, iy, iz, nb):
    h = (ix * _P1) ^ (iy * _P2) ^ (iz * _P3)
    h = h % nb
    if h < 0:
        h += nb
    return h


@njit
def _emit(i, j, c, r, margin, out, count):
    d0 = c[j, 0] - c[i, 0]
    d1 = c[j, 1] - c[i, 1]
    d2 = c[j, 2] - c[i, 2]
    reach = r[i] + r[j] + margin
    if d0 * d0 + d1 * d1 + d2 * d2 <= reach * reach:
        if count < out.shape[0]:
            if i < j:
                out[count, 0], out[count, 1] = i, j
            else:
                out[count, 0], out[count, 1] = j, i
        count += 1
    return count


@njit
def _pairs_grid(c, r, margin, out, start, order, cell):
    """Candidate pairs into out (k, 2); returns the number of pairs (may exceed out's rows:
    then only the first rows are written and the caller retries with room for all).

    A dense grid over the spheres' bounding box when it has at most len(start) - 1 cells (no
    collisions: each sphere tests its own cell and the 13 cells of the forward half of its
    neighbourhood, so each pair is met once); otherwise cells hashed into the table."""
    n = c.shape[0]
    if n < 2:
        return 0
    rmax = 0.0
    lo0, lo1, lo2 = c[0, 0], c[0, 1], c[0, 2]
    hi0, hi1, hi2 = lo0, lo1, lo2
    for i in range(n):
        if r[i] > rmax:
            rmax = r[i]
        lo0, hi0 = min(lo0, c[i, 0]), max(hi0, c[i, 0])
        lo1, hi1 = min(lo1, c[i, 1]), max(hi1, c[i, 1])
        lo2, hi2 = min(lo2, c[i, 2]), max(hi2, c[i, 2])
    h = 2.0 * rmax + margin
    if not h > 0.0:
        h = 1.0
    nb = start.shape[0] - 1
    nx = (hi0 - lo0) / h + 1.0
    ny = (hi1 - lo1) / h + 1.0
    nz = (hi2 - lo2) / h + 1.0
    dense = nx * ny * nz <= nb
    mx, my, mz = int(nx), int(ny), int(nz)
    # cell of every sphere and the counting sort by cell (dense) or bucket (hashed)
    for k in range(nb + 1):
        start[k] = 0
    for i in range(n):
        ix = int((c[i, 0] - lo0) / h)
        iy = int((c[i, 1] - lo1) / h)
        iz = int((c[i, 2] - lo2) / h)
        cell[i, 0], cell[i, 1], cell[i, 2] = ix, iy, iz
        b = ix + mx * (iy + my * iz) if dense else _bucket(ix, iy, iz, nb)
        start[b + 1] += 1
    for k in range(nb):
        start[k + 1] += start[k]
    for i in range(n):
        b = cell[i, 0] + mx * (cell[i, 1] + my * cell[i, 2]) if dense else \
            _bucket(cell[i, 0], cell[i, 1], cell[i, 2], nb)
        order[start[b]] = i
        start[b] += 1
    for k in range(nb, 0, -1):             # start[b] is the end of b now: shift back
        start[k] = start[k - 1]
    start[0] = 0
    count = 0
    if dense:
        for i in range(n):
            ix, iy, iz = cell[i, 0], cell[i, 1], cell[i, 2]
            b = ix + mx * (iy + my * iz)
            for m in range(start[b], start[b + 1]):        # own cell: each pair once
                j = order[m]
                if j > i:
                    count = _emit(i, j, c, r, margin, out, count)
            for t in range(13):                             # the forward half-neighbourhood
                # offsets (dx, dy, dz) > (0, 0, 0) lexicographically, from t = 14 + code
                code = t + 14
                dx, dy, dz = code // 9 - 1, (code // 3) % 3 - 1, code % 3 - 1
                jx, jy, jz = ix + dx, iy + dy, iz + dz
                if jx < 0 or jy < 0 or jz < 0 or jx >= mx or jy >= my or jz >= mz:
                    continue
                b = jx + mx * (jy + my * jz)
                for m in range(start[b], start[b + 1]):
                    count = _emit(i, order[m], c, r, margin, out, count)
        return count
    seen = np.empty(27, np.int64)
    for i in range(n):
        ns = 0
        for dx in range(-1, 2):
            for dy in range(-1, 2):
                for dz in range(-1, 2):
                    b = _bucket(cell[i, 0] + dx, cell[i, 1] + dy, cell[i, 2] + dz, nb)
                    dup = False
                    for s in range(ns):
                        if seen[s] == b:
                            dup = True
                            break
                    if dup:
                        continue
                    seen[ns] = b
                    ns += 1
                    for m in range(start[b], start[b + 1]):
                        j = order[m]
                        if j > i:
                            count = _emit(i, j, c, r, margin, out, count)
    return count


@njit
def pairs_brute_force(c, r, margin, out):
    """The same pairs by testing all N (N - 1) / 2 (reference for tests and small N)."""
    n = c.shape[0]
    count = 0
    cap = out.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            d0 = c[j, 0] - c[i, 0]
            d1 = c[j, 1] - c[i, 1]
            d2 = c[j, 2] - c[i, 2]
            reach = r[i] + r[j] + margin
            if d0 * d0 + d1 * d1 + d2 * d2 <= reach * reach:
                if count < cap:
                    out[count, 0] = i
                    out[count, 1] = j
                count += 1
    return count


@njit
def _pairs_sap(lo, hi, margin, out):
    """Pairs of boxes overlapping within margin into out (k, 2) (i < j); returns their number
    (may exceed out's rows, as :func:`_pairs_grid`)."""
    n = lo.shape[0]
    order = np.argsort(lo[:, 0], kind="mergesort")
    count = 0
    for a in range(n):
        i = order[a]
        reach = hi[i, 0] + margin
        for b in range(a + 1, n):
            j = order[b]
            if lo[j, 0] > reach:
                break
            if lo[j, 1] <= hi[i, 1] + margin and lo[i, 1] <= hi[j, 1] + margin and \
                    lo[j, 2] <= hi[i, 2] + margin and lo[i, 2] <= hi[j, 2] + margin:
                if count < out.shape[0]:
                    out[count, 0], out[count, 1] = min(i, j), max(i, j)
                count += 1
    return count


@njit
def aabb_pairs_brute_force(lo, hi, margin, out):
    """The same pairs as :func:`_pairs_sap` by testing all N (N - 1) / 2 (reference)."""
    n = lo.shape[0]
    count = 0
    for i in range(n):
        for j in range(i + 1, n):
            ok = True
            for a in range(3):
                if lo[j, a] > hi[i, a] + margin or lo[i, a] > hi[j, a] + margin:
                    ok = False
            if ok:
                if count < out.shape[0]:
                    out[count, 0], out[count, 1] = i, j
                count += 1
    return count


def aabb_pairs(lo, hi, margin: float = 0.0) -> np.ndarray:
    """Every pair (i < j) of axis-aligned boxes (lo, hi (N, 3), m) overlapping within
    ``margin`` (m), as a (k, 2) int array sorted by (i, j), by sweep and prune (module doc)."""
    lo = np.ascontiguousarray(lo, dtype=float)
    hi = np.ascontiguousarray(hi, dtype=float)
    if lo.ndim != 2 or lo.shape[1] != 3 or hi.shape != lo.shape:
        raise ModelError(f"aabb_pairs: lo and hi must be (N, 3), got shapes {lo.shape} and "
                         f"{hi.shape}")
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ModelError("aabb_pairs: the boxes' corners must be finite")
    bad = np.flatnonzero(np.any(hi < lo, axis=1))
    if bad.size:
        raise ModelError(f"aabb_pairs: box {bad[0]} has hi < lo ({hi[bad[0]].tolist()} < "
                         f"{lo[bad[0]].tolist()})")
    if not (np.isfinite(margin) and margin >= 0):
        raise ModelError(f"aabb_pairs: margin must be >= 0 (m), got {margin}")
    out = np.zeros((max(4 * lo.shape[0], 16), 2), np.int64)
    count = _pairs_sap(lo, hi, float(margin), out)
    if count > out.shape[0]:
        out = np.zeros((count, 2), np.int64)
        count = _pairs_sap(lo, hi, float(margin), out)
    pairs = out[:count]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


class SpherePairs:
    """Reusable work arrays for :func:`sphere_pairs` on N spheres (no allocation per call
    once the pair buffer is large enough)."""

    def __init__(self, n: int, capacity: int = 0):
        self.n = int(n)
        self.start = np.zeros(max(4 * self.n, 1) + 1, np.int64)
        self.order = np.zeros(self.n, np.int64)
        self.cell = np.zeros((self.n, 3), np.int64)
        self.out = np.zeros((max(int(capacity), 4 * self.n, 16), 2), np.int64)

    def __call__(self, centers, radii, margin: float = 0.0) -> np.ndarray:
        """(k, 2) int array of the pairs (i < j), ordered by i."""
        count = _pairs_grid(centers, radii, float(margin), self.out, self.start, self.order,
                            self.cell)
        if count > self.out.shape[0]:
            self.out = np.zeros((2 * count, 2), np.int64)
            count = _pairs_grid(centers, radii, float(margin), self.out, self.start,
                                self.order, self.cell)
        return self.out[:count]


def sphere_pairs(centers, radii, margin: float = 0.0) -> np.ndarray:
    """Every pair (i < j) of spheres (centres (N, 3) m, radii (N,) m) with
    |c_i - c_j| <= r_i + r_j + margin, as an (k, 2) int array, in O(N) (see the module doc)."""
    c = np.ascontiguousarray(centers, dtype=float)
    r = np.ascontiguousarray(radii, dtype=float)
    if c.ndim != 2 or c.shape[1] != 3:
        raise ModelError(f"sphere_pairs: centres must be (N, 3), got shape {c.shape}")
    if r.shape != (c.shape[0],):
        raise ModelError(f"sphere_pairs: radii must be ({c.shape[0]},), got shape {r.shape}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(r))):
        raise ModelError("sphere_pairs: centres and radii must be finite")
    if np.any(r < 0):
        raise ModelError(f"sphere_pairs: radius {float(r.min())} < 0; radii must be >= 0")
    if not (np.isfinite(margin) and margin >= 0):
        raise ModelError(f"sphere_pairs: margin must be >= 0 (m), got {margin}")
    return SpherePairs(c.shape[0])(c, r, margin).copy()
