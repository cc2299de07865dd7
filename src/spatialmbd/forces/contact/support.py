"""Convex shape cores and their support functions (compiled), the common ground of the
narrow phase (:mod:`.gjk`, :mod:`.box_box`, :mod:`.manifold`, :mod:`.plane_convex`).

Every convex contact shape is a *core* swept by a sphere of radius r (r = 0 but for the sphere
and the capsule):

    kind       core                                   dims (d0, d1, d2)        radius
    POINT      the centre                             -                        sphere R
    SEGMENT    the segment z in [-L, L]               (0, 0, L)                capsule R
    BOX        |x| <= a, |y| <= b, |z| <= c           (a, b, c)                0
    CYLINDER   x^2 + y^2 <= R^2, |z| <= h             (R, R, h)                0
    ELLIPSOID  (x/a)^2 + (y/b)^2 + (z/c)^2 <= 1       (a, b, c)                0
    HULL       the convex hull of nv vertices         (half sizes of the AABB) 0

in the shape's frame (centre c, axes e0, e1, e2 in global axes). The support point of a core in
direction d is s(d) = argmax_{x in core} d . x; the gap machinery needs nothing else.

Storage: a contact instance's parameter row holds, after the laws' columns (.laws), the slot of
the instance in the pair's contact manifold (C_SLOT), then one block per side (C_SIDE_I,
C_SIDE_J) of SIDE_WIDTH columns: kind, d0, d1, d2, radius, nv, and up to MAX_HULL_VERTICES
vertices (x, y, z in the shape frame); last the contact's margin (C_MARGIN, m).
"""
from __future__ import annotations

import math

from ...constraints.primitives import rotate, row3, v_add, v_dot, v_scale
from ...jit import njit
from . import laws as L

POINT, SEGMENT, BOX, CYLINDER, ELLIPSOID, HULL = 0, 1, 2, 3, 4, 5
KIND_OF = {"sphere": POINT, "capsule": SEGMENT, "box": BOX, "cylinder": CYLINDER,
           "ellipsoid": ELLIPSOID, "convex": HULL}
#: vertices a hull may keep per shape (they live in the force table's parameter rows)
MAX_HULL_VERTICES = 24
S_KIND, S_D0, S_D1, S_D2, S_RADIUS, S_NV, S_VERTS = range(7)
SIDE_WIDTH = S_VERTS + 3 * MAX_HULL_VERTICES
C_SLOT = L.N_COLUMNS
C_SIDE_I = C_SLOT + 1
C_SIDE_J = C_SIDE_I + SIDE_WIDTH
#: the contact's margin (m): the gap is the distance of the surfaces minus it
C_MARGIN = C_SIDE_J + SIDE_WIDTH
N_COLUMNS = C_MARGIN + 1


@njit(inline="always")
def frame(S, b, s, R, k):
    """(centre, e0, e1, e2) in global axes of the shape frame of instance k on body b."""
    A = S[1]
    c = v_add(row3(S[0], b), rotate(A, b, s[k, 0], s[k, 1], s[k, 2]))
    e0 = rotate(A, b, R[k, 0, 0], R[k, 1, 0], R[k, 2, 0])
    e1 = rotate(A, b, R[k, 0, 1], R[k, 1, 1], R[k, 2, 1])
    e2 = rotate(A, b, R[k, 0, 2], R[k, 1, 2], R[k, 2, 2])
    return c, e0, e1, e2


@njit(inline="always")
def to_local(f, d):
    return (v_dot(d, f[1]), v_dot(d, f[2]), v_dot(d, f[3]))


@njit(inline="always")
def to_global(f, x):
    return (f[0][0] + x[0] * f[1][0] + x[1] * f[2][0] + x[2] * f[3][0],
            f[0][1] + x[0] * f[1][1] + x[1] * f[2][1] + x[2] * f[3][1],
            f[0][2] + x[0] * f[1][2] + x[1] * f[2][2] + x[2] * f[3][2])


@njit(inline="always")
def _sgn(x):
    return 1.0 if x >= 0.0 else -1.0


@njit
def support_local(P, o, d):
    """The support point (shape frame) of the core stored at P[o:] in direction d (shape
    frame)."""
    kind = int(P[o + S_KIND])
    if kind == POINT:
        return (0.0, 0.0, 0.0)
    if kind == SEGMENT:
        return (0.0, 0.0, _sgn(d[2]) * P[o + S_D2])
    if kind == BOX:
        return (_sgn(d[0]) * P[o + S_D0], _sgn(d[1]) * P[o + S_D1], _sgn(d[2]) * P[o + S_D2])
    if kind == CYLINDER:
        rho = math.sqrt(d[0] * d[0] + d[1] * d[1])
        R = P[o + S_D0]
        if rho > 0.0:
            return (R * d[0] / rho, R * d[1] / rho, _sgn(d[2]) * P[o + S_D2])
        return (0.0, 0.0, _sgn(d[2]) * P[o + S_D2])
    if kind == ELLIPSOID:
        a, b, c = P[o + S_D0], P[o + S_D1], P[o + S_D2]
        x, y, z = a * a * d[0], b * b * d[1], c * c * d[2]
        m = math.sqrt(a * a * d[0] * d[0] + b * b * d[1] * d[1] + c * c * d[2] * d[2])
        if m > 0.0:
            return (x / m, y / m, z / m)
        return (0.0, 0.0, c)
    # HULL
    best, at = -math.inf, 0
    v = o + S_VERTS
    for m in range(int(P[o + S_NV])):
        h = P[v + 3 * m] * d[0] + P[v + 3 * m + 1] * d[1] + P[v + 3 * m + 2] * d[2]
        if h > best:
            best, at = h, m
    return (P[v + 3 * at], P[v + 3 * at + 1], P[v + 3 * at + 2])


@njit(inline="always")
def support(P, o, f, d):
    """The support point (global axes) of the core at P[o:] with frame f in direction d."""
    return to_global(f, support_local(P, o, to_local(f, d)))


@njit(inline="always")
def core_radius(P, o):
    return P[o + S_RADIUS]


@njit(inline="always")
def unit(x):
    n = math.sqrt(v_dot(x, x))
    if n > 0.0:
        return v_scale(1.0 / n, x), n
    return (0.0, 0.0, 1.0), 0.0
