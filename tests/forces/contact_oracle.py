"""The convex narrow phase against coal (the collision library of Pinocchio, a fork of FCL) on
random poses: signed distance, normal and witness points per pair. Shared by
tests/forces/test_contact_convex.py (1,000 poses per pair) and bench/contact_shapes.py (10,000).

Our side: spatialmbd.forces.contact.manifold.narrow on the parameter blocks the contact element
builds (convex_shapes.side_block); distance = n . (b - a) - r_i - r_j, surface points
a + r_i n, b - r_j n. Coal: coal.distance with enable_signed_distance, DualityGap/Absolute GJK
criterion at 1e-12 (coal's EPA may fail on curved shapes at that tolerance: it then answers
-DBL_MAX; the query is repeated at 1e-10, 1e-8 and 1e-6, the tolerance used is recorded).

A second, library-free check: the support-function certificate. For any unit n, the separation
of the shapes along n, s(n) = -h_i(n) - h_j(-n) (h the support function of the whole shape,
radius included), is a lower bound of the signed distance, reached at the true normal; so
|d - s(n)| bounds our distance's error for separated pairs and the suboptimality of our
penetration depth for penetrating ones.
"""
import numpy as np

from spatialmbd.forces.contact import convex_shapes as CS
from spatialmbd.forces.contact import manifold
from spatialmbd.forces.contact import support as sup

RNG_SHAPES = np.random.default_rng(2026)
HULL_POINTS = RNG_SHAPES.normal(size=(14, 3)) * (0.25, 0.2, 0.3)

#: name -> (kind, radius, half_length, half extents, vertices)
SHAPES = {
    "sphere": ("sphere", 0.2, 0.0, np.zeros(3), None),
    "capsule": ("capsule", 0.15, 0.3, np.zeros(3), None),
    "box": ("box", 0.0, 0.0, np.array([0.3, 0.2, 0.4]), None),
    "cylinder": ("cylinder", 0.25, 0.35, np.array([0.25, 0.25, 0.35]), None),
    "ellipsoid": ("ellipsoid", 0.0, 0.0, np.array([0.3, 0.2, 0.4]), None),
    "convex": CS.parse("oracle", "shape", "convex", {"vertices": HULL_POINTS}),
}
SHAPES["convex"] = ("convex",) + SHAPES["convex"]


def coal_shape(shape):
    import coal
    kind, radius, half_length, half, verts = shape
    if kind == "sphere":
        return coal.Sphere(radius)
    if kind == "capsule":
        return coal.Capsule(radius, 2 * half_length)
    if kind == "box":
        return coal.Box(*(2 * half))
    if kind == "cylinder":
        return coal.Cylinder(radius, 2 * half_length)
    if kind == "ellipsoid":
        return coal.Ellipsoid(*half)
    pts = coal.StdVec_Vec3s()
    for x in verts:
        pts.append(np.asarray(x, float))
    return coal.Convex.convexHull(pts, False, "")


def block(name):
    return CS.side_block(*SHAPES[name])


def frame(c, R):
    return (tuple(c), tuple(R[:, 0]), tuple(R[:, 1]), tuple(R[:, 2]))


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _coal_query(sa, Ta, sb, Tb):
    import coal
    for tol in (1e-12, 1e-10, 1e-8, 1e-6):
        req = coal.DistanceRequest()
        req.enable_signed_distance = True
        req.gjk_tolerance = tol
        req.epa_tolerance = tol
        req.gjk_max_iterations = 1000
        req.epa_max_iterations = 1000
        req.gjk_convergence_criterion = coal.GJKConvergenceCriterion.DualityGap
        req.gjk_convergence_criterion_type = coal.GJKConvergenceCriterionType.Absolute
        res = coal.DistanceResult()
        d = coal.distance(sa, Ta, sb, Tb, req, res)
        if abs(d) < 1e6:
            return d, np.array(res.normal), np.array(res.getNearestPoint1()), \
                np.array(res.getNearestPoint2()), tol
    return np.nan, np.full(3, np.nan), np.full(3, np.nan), np.full(3, np.nan), np.nan


def compare(name_i, name_j, n_poses, seed=0, spread=0.4):
    """Per pose: (ours d, coal d, |n - n_coal|, max point error, certificate gap, coal tol)."""
    import coal
    rng = np.random.default_rng(seed)
    P = np.concatenate([block(name_i), block(name_j)])
    oi, oj = 0, sup.SIDE_WIDTH
    ri, rj = SHAPES[name_i][1] * (name_i in ("sphere", "capsule")), \
        SHAPES[name_j][1] * (name_j in ("sphere", "capsule"))
    sa, sb = coal_shape(SHAPES[name_i]), coal_shape(SHAPES[name_j])
    out = np.empty((n_poses, 8))
    for k in range(n_poses):
        Ra, Rb = random_rotation(rng), random_rotation(rng)
        ca = rng.normal(size=3) * 0.05
        cb = ca + rng.normal(size=3) * spread
        fa, fb = frame(ca, Ra), frame(cb, Rb)
        a, b, n = manifold.narrow(P, oi, fa, oj, fb)
        n = np.array(n)
        d = n @ (np.subtract(b, a)) - ri - rj
        pa, pb = np.array(a) + ri * n, np.array(b) - rj * n
        dc, nc, p1, p2, tol = _coal_query(sa, coal.Transform3s(Ra, ca), sb,
                                          coal.Transform3s(Rb, cb))
        hi = n @ np.array(sup.support(P, oi, fa, tuple(n))) + ri
        hj = -n @ np.array(sup.support(P, oj, fb, tuple(-n))) + rj
        cert = -hi - hj
        if np.all(np.isfinite(nc)):
            nu = nc / np.linalg.norm(nc)
            hci = nu @ np.array(sup.support(P, oi, fa, tuple(nu))) + ri
            hcj = -nu @ np.array(sup.support(P, oj, fb, tuple(-nu))) + rj
            better = -hci - hcj - d      # > 0: coal's normal shows a smaller penetration
        else:
            better = np.nan
        out[k] = (d, dc, np.linalg.norm(n - nc),
                  max(np.linalg.norm(pa - p1), np.linalg.norm(pb - p2)), abs(d - cert), tol,
                  better, max(abs(n @ (pa - p1)), abs(n @ (pb - p2))))
    return out


def summary(out):
    """Worst figures of a comparison: separated and penetrating poses apart."""
    sep = out[:, 0] > 0
    both = np.isfinite(out[:, 1])

    def worst(mask, col):
        m = mask & both
        return float(np.abs(out[m, col]).max()) if np.any(m) else 0.0

    dd = np.abs(out[:, 0] - out[:, 1])
    return dict(separated=int(sep.sum()), penetrating=int((~sep).sum()),
                coal_failed=int((~both).sum()),
                distance=float(dd[sep & both].max()) if np.any(sep & both) else 0.0,
                depth=float(dd[~sep & both].max()) if np.any(~sep & both) else 0.0,
                normal_sep=worst(sep, 2), normal_pen=worst(~sep, 2),
                points_sep=worst(sep, 3), points_pen=worst(~sep, 3),
                certificate_sep=float(out[sep, 4].max()) if np.any(sep) else 0.0,
                certificate_pen=float(out[~sep, 4].max()) if np.any(~sep) else 0.0,
                coal_normal_better=float(np.nanmax(out[:, 6])),
                verified_sep=float(np.fmin(dd, out[:, 4])[sep].max()) if np.any(sep) else 0.0,
                points_along_n=worst(np.ones_like(sep), 7))
