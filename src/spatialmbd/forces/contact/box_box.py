"""Box-box penetration by separating axes (closed form, compiled).

Two boxes overlap unless one of 15 axes separates them: the 3 face normals of each and the 9
cross products of their edge directions (Gottschalk, Lin & Manocha 1996). Along a unit axis L
the overlap of the projections is

    o(L) = sum_a h_i,a |L . e_i,a| + sum_b h_j,b |L . e_j,b| - |L . (c_j - c_i)|

and the penetration depth of two convex polyhedra is the least o over these axes (the
Minkowski difference's faces have exactly these normals). Face axes win ties (within 1e-9
relative), so a box resting on a box gets the face normal and a face manifold (.manifold).

Result of :func:`sat`: (overlap, depth, n, a, b, face): n from i to j, a on box i, b on box j
with b - a = -depth n; face = 1 (a face of i), 2 (a face of j), 0 (two edges). overlap False:
some axis separates the boxes (the distance then comes from GJK, :mod:`.gjk`).
"""
from __future__ import annotations

import math

from ...constraints.primitives import v_add, v_cross, v_dot, v_scale, v_sub
from ...jit import njit
from .support import S_D0, support, unit

TIE = 1e-9


@njit(inline="always")
def _axis(f, a):
    return f[1] if a == 0 else (f[2] if a == 1 else f[3])


@njit(inline="always")
def _radius(h, f, L):
    return h[0] * abs(v_dot(L, f[1])) + h[1] * abs(v_dot(L, f[2])) + h[2] * abs(v_dot(L, f[3]))


@njit
def _edge(h, f, a, d):
    """The edge of a box parallel to axis a that is extreme in direction d: (start, 2 h_a e_a)."""
    c = f[0]
    for k in range(3):
        if k != a:
            e = _axis(f, k)
            s = h[k] if v_dot(d, e) >= 0.0 else -h[k]
            c = v_add(c, v_scale(s, e))
    ea = _axis(f, a)
    return v_sub(c, v_scale(h[a], ea)), v_scale(2.0 * h[a], ea)


@njit
def _lines(p1, d1, p2, d2):
    """Parameters (s, t) in [0, 1] of the nearest points of segments p1 + s d1, p2 + t d2."""
    r = v_sub(p1, p2)
    a, e, f = v_dot(d1, d1), v_dot(d2, d2), v_dot(d2, r)
    c, b = v_dot(d1, r), v_dot(d1, d2)
    den = a * e - b * b
    s = min(1.0, max(0.0, (b * f - c * e) / den)) if den > 1e-14 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t, s = 0.0, min(1.0, max(0.0, -c / a))
    elif t > 1.0:
        t, s = 1.0, min(1.0, max(0.0, (b - c) / a))
    return s, t


@njit
def sat(P, oi, fi, oj, fj):
    hi = (P[oi + S_D0], P[oi + S_D0 + 1], P[oi + S_D0 + 2])
    hj = (P[oj + S_D0], P[oj + S_D0 + 1], P[oj + S_D0 + 2])
    D = v_sub(fj[0], fi[0])
    best, bestL, kind, ea, eb = math.inf, (0.0, 0.0, 1.0), 0, 0, 0
    for side in (1, 2):
        for a in range(3):
            L = _axis(fi, a) if side == 1 else _axis(fj, a)
            o = _radius(hi, fi, L) + _radius(hj, fj, L) - abs(v_dot(L, D))
            if o < 0.0:
                return False, 0.0, L, fi[0], fj[0], 0
            if o < best:
                best, bestL, kind, ea = o, L, side, a
    face_best = best
    for a in range(3):
        for b in range(3):
            L, ln = unit(v_cross(_axis(fi, a), _axis(fj, b)))
            if ln < 1e-9:
                continue
            o = _radius(hi, fi, L) + _radius(hj, fj, L) - abs(v_dot(L, D))
            if o < 0.0:
                return False, 0.0, L, fi[0], fj[0], 0
            if o < best and o < face_best * (1.0 - TIE) - TIE * 1e-3:
                best, bestL, kind, ea, eb = o, L, 0, a, b
    n = bestL if v_dot(bestL, D) >= 0.0 else v_scale(-1.0, bestL)
    if kind == 0:                                   # edge-edge: nearest points of the edges
        p1, d1 = _edge(hi, fi, ea, n)
        p2, d2 = _edge(hj, fj, eb, v_scale(-1.0, n))
        s, t = _lines(p1, d1, p2, d2)
        a_ = v_add(p1, v_scale(s, d1))
        b_ = v_add(p2, v_scale(t, d2))
        return True, best, n, a_, v_sub(a_, v_scale(best, n)), 0
    if kind == 1:                                   # a face of i: j's deepest vertex
        b_ = support(P, oj, fj, v_scale(-1.0, n))
        return True, best, n, v_add(b_, v_scale(best, n)), b_, 1
    a_ = support(P, oi, fi, n)                      # a face of j: i's deepest vertex
    return True, best, n, a_, v_sub(a_, v_scale(best, n)), 2
