"""The broad phase (spatialmbd.broadphase): exactly the pairs within reach, as brute force finds
them, for random sets, clusters, coincident centres, far outliers and grid-cell hash
collisions. Its linear cost is measured in bench/broadphase.py (no timed unit tests)."""
import numpy as np
import pytest

from spatialmbd.broadphase import SpherePairs, pairs_brute_force, sphere_pairs
from spatialmbd.errors import ModelError


def _brute(c, r, margin):
    n = len(c)
    out = np.zeros((n * (n - 1) // 2 + 1, 2), np.int64)
    k = pairs_brute_force(np.asarray(c, float), np.asarray(r, float), margin, out)
    return {tuple(p) for p in out[:k]}


def _exact(c, r, margin):
    """Independent reference in NumPy: all pairs i < j with |ci - cj| <= ri + rj + margin."""
    c, r = np.asarray(c, float), np.asarray(r, float)
    d = np.linalg.norm(c[:, None] - c[None], axis=2)
    i, j = np.nonzero(np.triu(d <= r[:, None] + r[None] + margin, 1))
    return set(zip(i.tolist(), j.tolist()))


@pytest.mark.parametrize("seed", range(6))
def test_grid_pairs_equal_brute_force(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 400))
    c = rng.uniform(-3, 3, (n, 3)) * rng.uniform(0.1, 1.0, 3)     # anisotropic clouds
    r = rng.uniform(0.0, 0.2, n)
    margin = float(rng.choice([0.0, 0.01, 0.3]))
    pairs = sphere_pairs(c, r, margin)
    found = {tuple(p) for p in pairs}
    assert len(found) == len(pairs)                     # no pair reported twice
    assert np.all(pairs[:, 0] < pairs[:, 1])
    assert found == _exact(c, r, margin) == _brute(c, r, margin)


def test_degenerate_sets():
    # coincident centres, zero radii, a far outlier, a single sphere, none
    c = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0.1], [1e6, -1e6, 3e5], [1e6, -1e6, 3e5 + 0.05]])
    r = np.array([0.0, 0.0, 0.05, 0.03, 0.03])
    assert {tuple(p) for p in sphere_pairs(c, r)} == {(0, 1), (3, 4)}
    assert {tuple(p) for p in sphere_pairs(c, r, 0.06)} == _exact(c, r, 0.06)
    assert sphere_pairs(c[:1], r[:1]).shape == (0, 2)
    assert sphere_pairs(np.zeros((0, 3)), np.zeros(0)).shape == (0, 2)


def test_dense_cluster_grows_the_pair_buffer():
    rng = np.random.default_rng(7)
    c = rng.uniform(0, 0.1, (300, 3))                    # all 300 spheres overlap each other
    r = np.full(300, 0.2)
    finder = SpherePairs(300, capacity=16)
    pairs = finder(c, r)
    assert len(pairs) == 300 * 299 // 2 and finder.out.shape[0] >= len(pairs)


def test_hash_collisions_do_not_duplicate_or_lose_pairs():
    # a lattice of touching spheres: every bucket holds several cells (about 2 buckets per
    # sphere), and each sphere's 27 neighbour cells hit repeated buckets
    g = np.arange(8) * 0.1
    c = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    r = np.full(len(c), 0.05)
    pairs = sphere_pairs(c, r, 1e-9)                      # (the lattice spacing has round-off)
    found = {tuple(p) for p in pairs}
    assert len(found) == len(pairs) == 3 * 8 * 8 * 7     # face neighbours of an 8^3 lattice
    assert found == _exact(c, r, 1e-9)


@pytest.mark.parametrize("args, match", [
    ((np.zeros((3, 2)), np.zeros(3)), r"\(N, 3\)"),
    ((np.zeros((3, 3)), np.zeros(2)), r"radii must be \(3,\)"),
    ((np.zeros((3, 3)), -np.ones(3)), "radius"),
    ((np.full((3, 3), np.nan), np.ones(3)), "finite"),
])
def test_bad_input(args, match):
    with pytest.raises(ModelError, match=match):
        sphere_pairs(*args)
    with pytest.raises(ModelError, match="margin"):
        sphere_pairs(np.zeros((2, 3)), np.ones(2), -1.0)


@pytest.mark.parametrize("buckets", [1, 7, 64])
def test_hashed_path_with_a_small_table_equals_brute_force(buckets):
    # a table with fewer buckets than cells forces the hashed path, with many collisions
    rng = np.random.default_rng(buckets)
    c = rng.uniform(0, 1.5, (250, 3))
    r = rng.uniform(0.01, 0.08, 250)
    finder = SpherePairs(250)
    finder.start = np.zeros(buckets + 1, np.int64)
    pairs = finder(c, r, 0.02)
    found = {tuple(p) for p in pairs}
    assert len(found) == len(pairs) and found == _exact(c, r, 0.02)


@pytest.mark.parametrize("seed", range(4))
def test_aabb_pairs_of_mixed_shapes_equal_brute_force(seed):
    """Sweep and prune over the bounding boxes of random boxes, capsules, cylinders,
    ellipsoids, hulls and spheres of sizes over two decades (from their support functions):
    exactly the pairs the all-pairs test and an independent NumPy check return."""
    from spatialmbd.broadphase import aabb_pairs, aabb_pairs_brute_force
    from spatialmbd.forces.contact import convex_shapes as CS
    from spatialmbd.forces.contact import support as sup
    from spatialmbd.forces.contact.mesh_query import shape_box
    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 400))
    kinds = ["sphere", "capsule", "box", "cylinder", "ellipsoid", "convex"]
    world = (np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))
    world = tuple(tuple(x) for x in world)
    lo, hi = np.zeros((n, 3)), np.zeros((n, 3))
    for k in range(n):
        kind = kinds[k % len(kinds)]
        s = 10 ** rng.uniform(-2, 0)
        if kind == "convex":
            verts = CS.parse("b", "s", "convex", {"vertices": rng.normal(size=(10, 3)) * s})[3]
            block = CS.side_block(kind, 0.0, 0.0, np.abs(verts).max(axis=0), verts)
        else:
            block = CS.side_block(kind, s, s, np.array([s, 0.7 * s, 0.4 * s]), None)
        Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        Q *= np.sign(np.linalg.det(Q))
        f = (tuple(rng.uniform(-3, 3, 3)), tuple(Q[:, 0]), tuple(Q[:, 1]), tuple(Q[:, 2]))
        l, h = shape_box(block, 0, f, world, block[sup.S_RADIUS])
        lo[k], hi[k] = l, h
    margin = float(rng.choice([0.0, 0.05]))
    pairs = aabb_pairs(lo, hi, margin)
    out = np.zeros((n * (n - 1) // 2 + 1, 2), np.int64)
    count = aabb_pairs_brute_force(lo, hi, margin, out)
    ref = np.all((lo[:, None] <= hi[None] + margin) & (lo[None] <= hi[:, None] + margin), axis=2)
    i, j = np.nonzero(np.triu(ref, 1))
    assert {tuple(p) for p in pairs} == {tuple(p) for p in out[:count]} == set(zip(i, j))
    assert len(pairs) == count > 0
    with pytest.raises(ModelError, match="hi < lo"):
        aabb_pairs(hi, lo)
