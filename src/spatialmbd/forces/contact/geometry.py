"""Contact geometry: one compiled kernel per pair type (gap, normal, contact point, relative
velocity at the contact).

Every pair is reduced to two *core* witness points Q_i, Q_j (the closest points of the shapes'
cores: a point, a segment, a box surface, an axis), a unit normal n and two radii r_i, r_j
(r_i < 0 for a concave inner surface: a socket, a bearing). Then

    gap    g = n . (Q_j - Q_i) - r_i - r_j          (m; < 0: penetration delta = -g)
    point  P = (Q_i + r_i n + Q_j - r_j n) / 2       (midway between the two surfaces)
    v_rel    = v_j(P) - v_i(P),  v_b(P) = rdot_b + omega_b x (P - r_b)   (5.9)

n points from shape i to shape j: the normal force on body j is +f_N n. For every pair below
the gap rate is exactly g' = n . v_rel (the closest-point parameters are stationary, and
P - Q lies along n, so the spins about the witness points drop out); tests/test_contact.py
checks it against finite differences of g.

Shape frames: centre s and axes R (columns) in body axes; the plane's outward normal, a
capsule's and a bearing's axis are the frame's z column.

The convex pairs (boxes, cylinders, ellipsoids, hulls with each other and with spheres and
capsules) go to :mod:`.manifold` (CONVEX, one instance per manifold slot), a plane against a
cylinder or an ellipsoid to :mod:`.plane_convex` (PLANE_CONVEX); their shapes live in the
parameter row's side blocks (:mod:`.support`).
"""
from __future__ import annotations

import math

from ...constraints.primitives import rotate, row3, v_add, v_cross, v_dot, v_scale, v_sub
from ...jit import njit
from . import manifold, plane_convex
from . import support as sup

#: pair kinds (param column 0)
PLANE_POINT, SEGMENTS, BOX_SPHERE, SOCKET_BALL, BEARING_JOURNAL = 0, 1, 2, 3, 4
CONVEX, PLANE_CONVEX = 5, 6
PAIR_NAMES = {PLANE_POINT: "plane-sphere", SEGMENTS: "sphere/capsule pair",
              BOX_SPHERE: "box-sphere", SOCKET_BALL: "socket-ball",
              BEARING_JOURNAL: "bearing-journal", CONVEX: "convex pair",
              PLANE_CONVEX: "plane-cylinder/ellipsoid"}
#: parameter columns of the geometry
C_PAIR, C_RI, C_RJ, C_LI, C_LJ, C_HX, C_HY, C_HZ = 0, 1, 2, 3, 4, 5, 6, 7
EZ = (0.0, 0.0, 1.0)


@njit(inline="always")
def shape_centre(S, b, s, k):
    r, A = S[0], S[1]
    return v_add(row3(r, b), rotate(A, b, s[k, 0], s[k, 1], s[k, 2]))


@njit(inline="always")
def shape_axis(S, b, R, k, col):
    return rotate(S[1], b, R[k, 0, col], R[k, 1, col], R[k, 2, col])


@njit(inline="always")
def _unit(x):
    n = math.sqrt(v_dot(x, x))
    if n > 0.0:
        return v_scale(1.0 / n, x), n
    return EZ, 0.0


@njit(inline="always")
def _clamp(x, lo, hi):
    return lo if x < lo else (hi if x > hi else x)


@njit
def segment_closest(p1, d1, p2, d2):
    """Parameters s, t in [0, 1] of the closest points p1 + s d1, p2 + t d2 of two segments
    (Ericson, Real-Time Collision Detection, 5.1.9); parallel segments take s = 0."""
    r = v_sub(p1, p2)
    a, e, f = v_dot(d1, d1), v_dot(d2, d2), v_dot(d2, r)
    tiny = 1e-300
    if a <= tiny and e <= tiny:
        return 0.0, 0.0
    if a <= tiny:
        return 0.0, _clamp(f / e, 0.0, 1.0)
    c = v_dot(d1, r)
    if e <= tiny:
        return _clamp(-c / a, 0.0, 1.0), 0.0
    b = v_dot(d1, d2)
    denom = a * e - b * b
    s = _clamp((b * f - c * e) / denom, 0.0, 1.0) if denom > 1e-14 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = _clamp(-c / a, 0.0, 1.0)
    elif t > 1.0:
        t = 1.0
        s = _clamp((b - c) / a, 0.0, 1.0)
    return s, t


@njit
def core_points(S, G, k):
    """(Q_i, Q_j, n, r_i, r_j) of pair k (see the module docstring)."""
    bi, bj = G.bi[k], G.bj[k]
    P = G.param
    kind = int(P[k, C_PAIR])
    if kind == CONVEX or kind == PLANE_CONVEX:
        row = P[k]
        fj = sup.frame(S, bj, G.s_j, G.R_j, k)
        fi = sup.frame(S, bi, G.s_i, G.R_i, k)
        slot = int(row[sup.C_SLOT])
        if kind == CONVEX:
            qi, qj, n = manifold.convex_core_points(row, sup.C_SIDE_I, fi, sup.C_SIDE_J, fj, slot)
            return qi, qj, n, row[sup.C_SIDE_I + sup.S_RADIUS], row[sup.C_SIDE_J + sup.S_RADIUS]
        qi, qj, n = plane_convex.plane_core_points(row, sup.C_SIDE_J, fi, fj, slot)
        return qi, qj, n, 0.0, 0.0
    ci = shape_centre(S, bi, G.s_i, k)
    cj = shape_centre(S, bj, G.s_j, k)
    ri, rj = P[k, C_RI], P[k, C_RJ]
    if kind == PLANE_POINT:                     # half-space z <= 0 of frame i, sphere on j
        nz = shape_axis(S, bi, G.R_i, k, 2)
        h = v_dot(nz, v_sub(cj, ci))
        return v_sub(cj, v_scale(h, nz)), cj, nz, 0.0, rj
    if kind == SEGMENTS:                        # sphere (half length 0) / capsule pairs
        ai = v_scale(P[k, C_LI], shape_axis(S, bi, G.R_i, k, 2))
        aj = v_scale(P[k, C_LJ], shape_axis(S, bj, G.R_j, k, 2))
        p1, p2 = v_sub(ci, ai), v_sub(cj, aj)
        s, t = segment_closest(p1, v_scale(2.0, ai), p2, v_scale(2.0, aj))
        qi = v_add(p1, v_scale(2.0 * s, ai))
        qj = v_add(p2, v_scale(2.0 * t, aj))
        n, _ = _unit(v_sub(qj, qi))
        return qi, qj, n, ri, rj
    if kind == BOX_SPHERE:                      # box (half extents hx, hy, hz) on i
        e0, e1, e2 = (shape_axis(S, bi, G.R_i, k, 0), shape_axis(S, bi, G.R_i, k, 1),
                      shape_axis(S, bi, G.R_i, k, 2))
        d = v_sub(cj, ci)
        x = (v_dot(d, e0), v_dot(d, e1), v_dot(d, e2))
        hh = (P[k, C_HX], P[k, C_HY], P[k, C_HZ])
        q = (_clamp(x[0], -hh[0], hh[0]), _clamp(x[1], -hh[1], hh[1]),
             _clamp(x[2], -hh[2], hh[2]))
        if q[0] != x[0] or q[1] != x[1] or q[2] != x[2]:     # centre outside the box
            nl, _ = _unit(v_sub(x, q))
        else:                                   # inside: the nearest face
            best, a = hh[0] - abs(x[0]), 0
            for c in range(1, 3):
                if hh[c] - abs(x[c]) < best:
                    best, a = hh[c] - abs(x[c]), c
            sgn = 1.0 if x[a] >= 0.0 else -1.0
            nl = (sgn if a == 0 else 0.0, sgn if a == 1 else 0.0, sgn if a == 2 else 0.0)
            q = (sgn * hh[0] if a == 0 else x[0], sgn * hh[1] if a == 1 else x[1],
                 sgn * hh[2] if a == 2 else x[2])
        qi = v_add(ci, v_add(v_add(v_scale(q[0], e0), v_scale(q[1], e1)), v_scale(q[2], e2)))
        n = v_add(v_add(v_scale(nl[0], e0), v_scale(nl[1], e1)), v_scale(nl[2], e2))
        return qi, cj, n, 0.0, rj
    if kind == SOCKET_BALL:                     # spherical socket (radius ri) on i
        u, _ = _unit(v_sub(cj, ci))
        return ci, cj, v_scale(-1.0, u), -ri, rj
    # BEARING_JOURNAL: cylindrical bearing (radius ri, axis z of frame i), journal centre cj
    a = shape_axis(S, bi, G.R_i, k, 2)
    d = v_sub(cj, ci)
    qi = v_add(ci, v_scale(v_dot(a, d), a))
    u, _ = _unit(v_sub(cj, qi))
    return qi, cj, v_scale(-1.0, u), -ri, rj


@njit(inline="always")
def point_velocity(S, b, P):
    """v_b(P) = rdot_b + omega_b x (P - r_b), Eq. (5.9)."""
    return v_add(row3(S[2], b), v_cross(row3(S[3], b), v_sub(P, row3(S[0], b))))


@njit
def pair_geometry(S, G, k):
    """(gap g (m), normal n, contact point P, relative velocity v_j(P) - v_i(P)) of pair k
    (the gap less the contact's margin, param C_MARGIN)."""
    qi, qj, n, ri, rj = core_points(S, G, k)
    gap = v_dot(n, v_sub(qj, qi)) - ri - rj - G.param[k, sup.C_MARGIN]
    P = v_scale(0.5, v_add(v_add(qi, v_scale(ri, n)), v_sub(qj, v_scale(rj, n))))
    vrel = v_sub(point_velocity(S, G.bj[k], P), point_velocity(S, G.bi[k], P))
    return gap, n, P, vrel
