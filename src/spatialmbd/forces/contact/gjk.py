"""The general convex narrow phase: GJK for the distance of two separated cores and EPA for the
penetration of two overlapping ones, both on the Minkowski difference A - B of the cores
(:mod:`.support`), compiled.

GJK (Gilbert, Johnson & Keerthi 1988; the closest point of a simplex by Voronoi regions,
Ericson, Real-Time Collision Detection 5.1.5): v_k, the point of the simplex nearest the
origin, converges to the point of A - B nearest the origin; it stops when the duality gap
|v|^2 - v . w (w the support point of A - B in -v) is below EPS_GJK |v|^2, so the distance it
returns is within EPS_GJK |v| of the exact one (1e-12 relative). Polytopes terminate exactly.

EPA (van den Bergen 2001): starting from GJK's simplex holding the origin, the polytope is grown
towards the face nearest the origin until that face lies on the boundary of A - B within
EPS_EPA (relative); the face's distance is the penetration depth, its normal the direction of
least penetration. Depth, normal and witness points are exact for polytopes, iterative for
curved cores (ellipsoids, cylinders).

Result (:func:`closest`): the witness points a on core i and b on core j and the normal n from
i to j such that n . (b - a) is the signed core distance (negative: penetration) and b - a is
along n; ok = False if EPA met a degenerate polytope (then n . (b - a) is the GJK estimate).
"""
from __future__ import annotations

import math

import numpy as np

from ...constraints.primitives import v_add, v_cross, v_dot, v_scale, v_sub
from ...jit import njit
from .support import support, unit

EPS_GJK = 1e-13
EPS_EPA = 1e-10
MAX_GJK = 128
MAX_EPA = 160
MAX_V = MAX_EPA + 8
MAX_F = 8 * MAX_V


@njit(inline="always")
def _row(X, m):
    return (X[m, 0], X[m, 1], X[m, 2])


@njit(inline="always")
def _set(X, m, x):
    X[m, 0], X[m, 1], X[m, 2] = x[0], x[1], x[2]


@njit
def triangle_weights(a, b, c):
    """Barycentric weights (u, v, w) of the point of triangle abc nearest the origin (Ericson
    5.1.5, p = 0)."""
    ab, ac = v_sub(b, a), v_sub(c, a)
    ap = v_scale(-1.0, a)
    d1, d2 = v_dot(ab, ap), v_dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0
    bp = v_scale(-1.0, b)
    d3, d4 = v_dot(ab, bp), v_dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        t = d1 / (d1 - d3)
        return 1.0 - t, t, 0.0
    cp = v_scale(-1.0, c)
    d5, d6 = v_dot(ab, cp), v_dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return 1.0 - t, 0.0, t
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - t, t
    den = va + vb + vc
    if den == 0.0:
        return 1.0, 0.0, 0.0
    v, w = vb / den, vc / den
    return 1.0 - v - w, v, w


@njit(inline="always")
def _segment_t(p, q):
    d = v_sub(q, p)
    den = v_dot(d, d)
    return 0.0 if den <= 0.0 else min(1.0, max(0.0, -v_dot(p, d) / den))


@njit
def triangle_weights_sv(a, b, c):
    """Barycentric weights of the point of triangle abc nearest the origin by signed areas in
    the best-conditioned coordinate plane (Montanari, Petrinic & Barbieri, ACM TOG 36, 2017):
    robust where GJK's triangles degenerate (curved cores, converged simplices)."""
    n = v_cross(v_sub(b, a), v_sub(c, a))
    nn = v_dot(n, n)
    inside = False
    if nn > 0.0:
        h = v_dot(a, n) / nn
        p0 = (h * n[0], h * n[1], h * n[2])
        ax = 0
        if abs(n[1]) > abs(n[ax]):
            ax = 1
        if abs(n[2]) > abs(n[ax]):
            ax = 2
        x, y = (ax + 1) % 3, (ax + 2) % 3
        mu = (b[x] - a[x]) * (c[y] - a[y]) - (b[y] - a[y]) * (c[x] - a[x])
        c1 = (b[x] - p0[x]) * (c[y] - p0[y]) - (b[y] - p0[y]) * (c[x] - p0[x])
        c2 = (p0[x] - a[x]) * (c[y] - a[y]) - (p0[y] - a[y]) * (c[x] - a[x])
        c3 = (b[x] - a[x]) * (p0[y] - a[y]) - (b[y] - a[y]) * (p0[x] - a[x])
        inside = mu != 0.0 and c1 * mu > 0.0 and c2 * mu > 0.0 and c3 * mu > 0.0
        if inside:
            return c1 / mu, c2 / mu, c3 / mu
    # the nearest point is on an edge: the best of the three
    best = (1.0, 0.0, 0.0)
    bd = v_dot(a, a)
    t = _segment_t(a, b)
    p = v_add(v_scale(1.0 - t, a), v_scale(t, b))
    if v_dot(p, p) < bd:
        bd, best = v_dot(p, p), (1.0 - t, t, 0.0)
    t = _segment_t(a, c)
    p = v_add(v_scale(1.0 - t, a), v_scale(t, c))
    if v_dot(p, p) < bd:
        bd, best = v_dot(p, p), (1.0 - t, 0.0, t)
    t = _segment_t(b, c)
    p = v_add(v_scale(1.0 - t, b), v_scale(t, c))
    if v_dot(p, p) < bd:
        bd, best = v_dot(p, p), (0.0, 1.0 - t, t)
    return best


@njit
def _reduce(W, A, B, lam, m):
    """Keep the simplex vertices of positive weight (in place); returns (count, v)."""
    n = 0
    v = (0.0, 0.0, 0.0)
    for q in range(m):
        if lam[q] > 0.0:
            v = v_add(v, v_scale(lam[q], _row(W, q)))
            if n != q:
                W[n], A[n], B[n] = W[q], A[q], B[q]
            lam[n] = lam[q]
            n += 1
    return n, v


@njit
def _closest_on_simplex(W, A, B, lam, m):
    """Reduce the simplex W[:m] to the smallest face holding its point nearest the origin;
    returns (count, v, inside) -- inside: the tetrahedron holds the origin."""
    if m == 1:
        lam[0] = 1.0
        return 1, _row(W, 0), False
    if m == 2:
        a, b = _row(W, 0), _row(W, 1)
        ab = v_sub(b, a)
        den = v_dot(ab, ab)
        t = 0.0 if den <= 0.0 else min(1.0, max(0.0, -v_dot(a, ab) / den))
        lam[0], lam[1] = 1.0 - t, t
        n, v = _reduce(W, A, B, lam, 2)
        return n, v, False
    if m == 3:
        u, v_, w = triangle_weights_sv(_row(W, 0), _row(W, 1), _row(W, 2))
        lam[0], lam[1], lam[2] = u, v_, w
        n, v = _reduce(W, A, B, lam, 3)
        return n, v, False
    # tetrahedron: the origin inside (on the inner side of every face), or the nearest of the
    # nearest points of its faces (all four: a sign test alone fails when the new vertex lies
    # in the plane of the old triangle, which is how GJK converges)
    best, bestd = -1, math.inf
    faces = ((0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 3, 1), (1, 2, 3, 0))
    keep = (0.0, 0.0, 0.0)
    inside = True
    for f in range(4):
        i0, i1, i2, i3 = faces[f]
        a, b, c, d = _row(W, i0), _row(W, i1), _row(W, i2), _row(W, i3)
        nrm = v_cross(v_sub(b, a), v_sub(c, a))
        if -v_dot(nrm, a) * v_dot(nrm, v_sub(d, a)) <= 0.0:
            inside = False
        u, v_, w = triangle_weights_sv(a, b, c)
        p = v_add(v_add(v_scale(u, a), v_scale(v_, b)), v_scale(w, c))
        dd = v_dot(p, p)
        if dd < bestd:
            best, bestd, keep = f, dd, (u, v_, w)
    if inside:
        return 4, (0.0, 0.0, 0.0), True
    i0, i1, i2, i3 = faces[best]
    lam[i0], lam[i1], lam[i2], lam[i3] = keep[0], keep[1], keep[2], 0.0
    n, v = _reduce(W, A, B, lam, 4)
    return n, v, False


@njit(inline="always")
def _support_pair(P, oi, fi, oj, fj, d):
    a = support(P, oi, fi, d)
    b = support(P, oj, fj, v_scale(-1.0, d))
    return v_sub(a, b), a, b


@njit
def gjk(P, oi, fi, oj, fj, W, A, B, lam, d):
    """GJK on the cores at P[oi:], P[oj:] (frames fi, fj) from the search direction -d.
    Returns (count, v, overlap): the simplex W[:count] (A, B: the cores' points of each
    vertex, lam its weights) and v, the point of A - B nearest the origin (overlap: the
    simplex holds the origin)."""
    if v_dot(d, d) == 0.0:
        d = (1.0, 0.0, 0.0)
    w, a, b = _support_pair(P, oi, fi, oj, fj, v_scale(-1.0, d))
    _set(W, 0, w)
    _set(A, 0, a)
    _set(B, 0, b)
    lam[0] = 1.0
    m, v = 1, w
    vv = v_dot(v, v)
    Wk = np.empty((4, 3))
    Ak = np.empty((4, 3))
    Bk = np.empty((4, 3))
    lamk = np.empty(4)
    for _ in range(MAX_GJK):
        if vv <= 1e-30:
            return m, v, True
        w, a, b = _support_pair(P, oi, fi, oj, fj, v_scale(-1.0, v))
        if vv - v_dot(v, w) <= EPS_GJK * vv + 1e-24:
            return m, v, False
        repeat = False
        for q in range(m):
            if W[q, 0] == w[0] and W[q, 1] == w[1] and W[q, 2] == w[2]:
                repeat = True
        if repeat:
            return m, v, False
        for q in range(m):
            Wk[q], Ak[q], Bk[q], lamk[q] = W[q], A[q], B[q], lam[q]
        _set(W, m, w)
        _set(A, m, a)
        _set(B, m, b)
        mk = m
        m, v_new, inside = _closest_on_simplex(W, A, B, lam, m + 1)
        if inside:
            return m, (0.0, 0.0, 0.0), True
        vv_new = v_dot(v_new, v_new)
        if vv_new >= vv:                # no progress (round-off): keep the previous simplex
            for q in range(mk):
                W[q], A[q], B[q], lam[q] = Wk[q], Ak[q], Bk[q], lamk[q]
            return mk, v, False
        v, vv = v_new, vv_new
    return m, v, False


@njit
def _witness(A, B, lam, m):
    a = (0.0, 0.0, 0.0)
    b = (0.0, 0.0, 0.0)
    for q in range(m):
        a = v_add(a, v_scale(lam[q], _row(A, q)))
        b = v_add(b, v_scale(lam[q], _row(B, q)))
    return a, b


@njit
def _face(V, F, N, Dst, f):
    a, b, c = _row(V, F[f, 0]), _row(V, F[f, 1]), _row(V, F[f, 2])
    n, ln = unit(v_cross(v_sub(b, a), v_sub(c, a)))
    if ln <= 1e-300:
        Dst[f] = math.inf
    else:
        Dst[f] = v_dot(n, a)
    _set(N, f, n)


@njit
def _blow_up(P, oi, fi, oj, fj, W, A, B, m):
    """Grow a degenerate simplex holding the origin (a point, a segment or a triangle: shapes
    touching) into a tetrahedron; returns the new count (< 4: no volume to be found)."""
    dirs = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
            (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))
    for t in range(6):
        if m >= 4:
            break
        d = dirs[t]
        if m == 3:
            d, _ = unit(v_cross(v_sub(_row(W, 1), _row(W, 0)), v_sub(_row(W, 2), _row(W, 0))))
            if t % 2 == 1:
                d = v_scale(-1.0, d)
        w, a, b = _support_pair(P, oi, fi, oj, fj, d)
        ok = True
        for q in range(m):
            e = v_sub(w, _row(W, q))
            if v_dot(e, e) < 1e-24:
                ok = False
        if ok and m == 2:
            c = v_cross(v_sub(_row(W, 1), _row(W, 0)), v_sub(w, _row(W, 0)))
            ok = v_dot(c, c) > 1e-24
        if ok and m == 3:
            nrm = v_cross(v_sub(_row(W, 1), _row(W, 0)), v_sub(_row(W, 2), _row(W, 0)))
            ok = abs(v_dot(nrm, v_sub(w, _row(W, 0)))) > 1e-18
        if ok:
            _set(W, m, w)
            _set(A, m, a)
            _set(B, m, b)
            m += 1
    return m


@njit
def _link(Adj, AdjE, f, e, g, eg):
    Adj[f, e], AdjE[f, e], Adj[g, eg], AdjE[g, eg] = g, eg, f, e


@njit
def epa(P, oi, fi, oj, fj, W, A, B, m):
    """EPA from the simplex W[:m] holding the origin. Returns (depth, n, a, b, ok). The faces
    seen from a new support point are found by walking across edges from the nearest face
    (van den Bergen 2001, the silhouette), so the removed region is connected and its horizon
    one loop: the polytope stays closed and convex under round-off."""
    if m < 4:
        m = _blow_up(P, oi, fi, oj, fj, W, A, B, m)
        if m < 4:
            return 0.0, (0.0, 0.0, 1.0), _row(A, 0), _row(B, 0), False
    V = np.empty((MAX_V, 3))
    VA = np.empty((MAX_V, 3))
    F = np.empty((MAX_F, 3), np.int64)
    Adj = np.empty((MAX_F, 3), np.int64)
    AdjE = np.empty((MAX_F, 3), np.int64)
    N = np.empty((MAX_F, 3))
    Dst = np.empty(MAX_F)
    alive = np.zeros(MAX_F, np.bool_)
    for q in range(4):
        V[q], VA[q] = W[q], A[q]
    a, b, c, d = _row(V, 0), _row(V, 1), _row(V, 2), _row(V, 3)
    if v_dot(v_cross(v_sub(b, a), v_sub(c, a)), v_sub(d, a)) > 0.0:   # orient: 0,1,2 outward
        V[1], V[2] = W[2], W[1]
        VA[1], VA[2] = A[2], A[1]
    for f, (i0, i1, i2) in enumerate(((0, 1, 2), (0, 3, 1), (1, 3, 2), (2, 3, 0))):
        F[f, 0], F[f, 1], F[f, 2] = i0, i1, i2
        alive[f] = True
        _face(V, F, N, Dst, f)
    # edges: face 0 (0,1)(1,2)(2,0); 1 (0,3)(3,1)(1,0); 2 (1,3)(3,2)(2,1); 3 (2,3)(3,0)(0,2)
    _link(Adj, AdjE, 0, 0, 1, 2)
    _link(Adj, AdjE, 0, 1, 2, 2)
    _link(Adj, AdjE, 0, 2, 3, 2)
    _link(Adj, AdjE, 1, 0, 3, 1)
    _link(Adj, AdjE, 1, 1, 2, 0)
    _link(Adj, AdjE, 2, 1, 3, 0)
    nv, nf = 4, 4
    stack = np.empty((MAX_F, 2), np.int64)
    hf = np.empty(MAX_F, np.int64)          # horizon: the kept face and its edge index
    he = np.empty(MAX_F, np.int64)
    ok = False
    for _ in range(MAX_EPA):
        best, bd = -1, math.inf
        for f in range(nf):
            if alive[f] and Dst[f] < bd:
                best, bd = f, Dst[f]
        if best < 0:
            break
        n = _row(N, best)
        w, a, b = _support_pair(P, oi, fi, oj, fj, n)
        if v_dot(n, w) - bd <= EPS_EPA * max(1.0, abs(bd)):
            ok = True
            break
        if nv >= MAX_V or nf + 64 > MAX_F:
            break
        _set(V, nv, w)
        _set(VA, nv, a)
        alive[best] = False
        top, nh = 0, 0
        for e in (2, 1, 0):
            stack[top, 0], stack[top, 1] = Adj[best, e], AdjE[best, e]
            top += 1
        while top > 0:
            top -= 1
            g, eg = stack[top, 0], stack[top, 1]
            if not alive[g]:
                continue
            if v_dot(_row(N, g), v_sub(w, _row(V, F[g, 0]))) > 0.0:
                alive[g] = False
                for e in ((eg + 2) % 3, (eg + 1) % 3):
                    stack[top, 0], stack[top, 1] = Adj[g, e], AdjE[g, e]
                    top += 1
            else:
                hf[nh], he[nh] = g, eg
                nh += 1
        first = nf
        for h in range(nh):
            g, eg = hf[h], he[h]
            f = nf
            F[f, 0], F[f, 1], F[f, 2] = F[g, (eg + 1) % 3], F[g, eg], nv
            alive[f] = True
            _face(V, F, N, Dst, f)
            _link(Adj, AdjE, f, 0, g, eg)
            nf += 1
        for h in range(nh):
            _link(Adj, AdjE, first + h, 1, first + (h + 1) % nh, 2)
        nv += 1
    best, bd = -1, math.inf             # the nearest face of the final polytope
    for f in range(nf):
        if alive[f] and Dst[f] < bd:
            best, bd = f, Dst[f]
    if best < 0:
        return 0.0, (0.0, 0.0, 1.0), _row(A, 0), _row(B, 0), False
    n, depth = _row(N, best), Dst[best]
    u, v_, w_ = triangle_weights(v_sub(_row(V, F[best, 0]), v_scale(depth, n)),
                                 v_sub(_row(V, F[best, 1]), v_scale(depth, n)),
                                 v_sub(_row(V, F[best, 2]), v_scale(depth, n)))
    a = v_add(v_add(v_scale(u, _row(VA, F[best, 0])), v_scale(v_, _row(VA, F[best, 1]))),
              v_scale(w_, _row(VA, F[best, 2])))
    b = v_sub(a, v_scale(depth, n))
    return depth, n, a, b, ok


@njit
def closest(P, oi, fi, oj, fj):
    """(a, b, n, ok) of the cores at P[oi:], P[oj:] (module docstring)."""
    W = np.empty((4, 3))
    A = np.empty((4, 3))
    B = np.empty((4, 3))
    lam = np.empty(4)
    m, v, overlap = gjk(P, oi, fi, oj, fj, W, A, B, lam, v_sub(fi[0], fj[0]))
    for _ in range(3):
        # a simplex degenerated on a curved core stalls short of EPS_GJK: restart from the
        # direction reached (a fresh, well-conditioned simplex) while that gains
        vv = v_dot(v, v)
        if overlap or vv <= 1e-24:
            break
        w, a, b = _support_pair(P, oi, fi, oj, fj, v_scale(-1.0, v))
        if vv - v_dot(v, w) <= EPS_GJK * vv + 1e-24:
            break
        W2, A2, B2, lam2 = W.copy(), A.copy(), B.copy(), lam.copy()
        m2, v2, overlap2 = gjk(P, oi, fi, oj, fj, W2, A2, B2, lam2, v)
        if overlap2 or v_dot(v2, v2) >= vv:
            break
        m, v = m2, v2
        W[:], A[:], B[:], lam[:] = W2, A2, B2, lam2
    if not overlap:
        a, b = _witness(A, B, lam, m)
        n, dist = unit(v_sub(b, a))
        if dist > 1e-12:
            return a, b, n, True
    depth, n, a, b, ok = epa(P, oi, fi, oj, fj, W, A, B, m)
    return a, b, n, ok
