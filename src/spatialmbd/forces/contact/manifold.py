"""Contact manifolds of convex pairs (compiled): up to MAX_SLOTS points where faces touch, so a
box rests flat on a box without rocking, and the pair dispatcher :func:`convex_core_points`.

Narrow phase first: box-box by separating axes when they overlap (:mod:`.box_box`), GJK/EPA
otherwise (:mod:`.gjk`); it gives the normal n (from i to j) and the deepest witness points.
Then, if one side offers a *reference face* whose outward normal is n within 1e-9 (a box's face;
a hull's vertices coplanar to 1e-9 of its size), the other side's *incident feature* in the
opposite direction (a box's most anti-parallel face, a segment, a cylinder's side line or four
rim points of a cap, a hull's vertices within 0.05 rad of the extreme) is clipped against the
reference face's side planes (Sutherland-Hodgman), and every clipped point p gets the depth
delta = n_ref . (r_0 - p) below the reference plane. Slot s of the manifold (one contact
instance each) takes clipped point s when there are at most MAX_SLOTS (the incident polygon's
order: a face resting inside another keeps its corners in their slots); with more, slot s
takes the point furthest in the diagonal direction (+-u +-w)_s of the reference face (u, w
fixed on the reference body), a point already taken by a lower slot leaving the slot open.
Otherwise (vertex, edge-edge or curved
contact) slot 0 is the witness pair and the others are open. An open slot reports gap OPEN.

For a point that is a vertex of the incident body, n_ref a direction of the reference body and
(q_j - q_i) along n_ref, the gap rate is exactly n_ref . v_rel (as for .geometry's pairs).
"""
from __future__ import annotations

import math

import numpy as np

from ...constraints.primitives import v_add, v_cross, v_dot, v_scale, v_sub
from ...jit import njit
from . import box_box, gjk
from .support import (BOX, CYLINDER, HULL, S_D0, S_KIND, S_NV, S_VERTS, SEGMENT, support,
                      to_global, to_local, unit)

MAX_SLOTS = 4
BAND = 0.05          # rad: incident features within this angle of the extreme one
FACE_TOL = 1e-9      # a reference face: normal within this of n, hull vertices coplanar
OPEN = 1.0           # m: the gap reported by an open slot
MAX_POINTS = 64


@njit
def _feature(P, o, f, d, X, reference):
    """Feature of the core at P[o:] in direction d into X: (count, outward normal of the face,
    alignment with d, u, w); reference: only a face whose normal is d within FACE_TOL."""
    kind = int(P[o + S_KIND])
    dl = to_local(f, d)
    nothing = (0, d, 0.0, f[1], f[2])
    if kind == BOX:
        a = 0
        for k in (1, 2):
            if abs(dl[k]) > abs(dl[a]):
                a = k
        s = 1.0 if dl[a] >= 0.0 else -1.0
        if reference and abs(dl[a]) < 1.0 - FACE_TOL:
            return nothing
        b, c = (a + 1) % 3, (a + 2) % 3
        h = (P[o + S_D0], P[o + S_D0 + 1], P[o + S_D0 + 2])
        for m, (sb, sc) in enumerate(((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))):
            x = [0.0, 0.0, 0.0]
            x[a], x[b], x[c] = s * h[a], sb * h[b], sc * h[c]
            p = to_global(f, (x[0], x[1], x[2]))
            X[m, 0], X[m, 1], X[m, 2] = p[0], p[1], p[2]
        ax = (f[1], f[2], f[3])
        return 4, v_scale(s, ax[a]), abs(dl[a]), ax[b], ax[c]
    if reference and kind != HULL:
        return nothing
    if kind == SEGMENT:
        if abs(dl[2]) > math.sin(BAND):
            return nothing
        for m, z in enumerate((P[o + S_D0 + 2], -P[o + S_D0 + 2])):
            p = to_global(f, (0.0, 0.0, z))
            X[m, 0], X[m, 1], X[m, 2] = p[0], p[1], p[2]
        return 2, d, 0.0, f[1], f[2]
    if kind == CYLINDER:
        R, hz = P[o + S_D0], P[o + S_D0 + 2]
        rho = math.sqrt(dl[0] * dl[0] + dl[1] * dl[1])
        if abs(dl[2]) >= math.cos(BAND):            # a cap: four rim points
            z = hz if dl[2] > 0.0 else -hz
            for m, (x, y) in enumerate(((R, 0.0), (0.0, R), (-R, 0.0), (0.0, -R))):
                p = to_global(f, (x, y, z))
                X[m, 0], X[m, 1], X[m, 2] = p[0], p[1], p[2]
            return 4, d, 0.0, f[1], f[2]
        if abs(dl[2]) <= math.sin(BAND) and rho > 0.0:   # the side line
            for m, z in enumerate((hz, -hz)):
                p = to_global(f, (R * dl[0] / rho, R * dl[1] / rho, z))
                X[m, 0], X[m, 1], X[m, 2] = p[0], p[1], p[2]
            return 2, d, 0.0, f[1], f[2]
        return nothing
    if kind != HULL:
        return nothing
    v, nv = o + S_VERTS, int(P[o + S_NV])
    top, size = -math.inf, 0.0
    for m in range(nv):
        top = max(top, P[v + 3 * m] * dl[0] + P[v + 3 * m + 1] * dl[1] + P[v + 3 * m + 2] * dl[2])
        size = max(size, abs(P[v + 3 * m]), abs(P[v + 3 * m + 1]), abs(P[v + 3 * m + 2]))
    tol = 2.0 * size * (FACE_TOL if reference else math.sin(BAND))
    u, _ = unit(v_sub(f[1], v_scale(v_dot(f[1], d), d)))
    if abs(v_dot(f[1], d)) > 0.9:
        u, _ = unit(v_sub(f[2], v_scale(v_dot(f[2], d), d)))
    w = v_cross(d, u)
    count = 0
    cx, cy = 0.0, 0.0
    ang = np.empty(nv)
    for m in range(nv):
        x = (P[v + 3 * m], P[v + 3 * m + 1], P[v + 3 * m + 2])
        if x[0] * dl[0] + x[1] * dl[1] + x[2] * dl[2] >= top - tol:
            p = to_global(f, x)
            X[count, 0], X[count, 1], X[count, 2] = p[0], p[1], p[2]
            count += 1
    if count < (3 if reference else 1) or (count == 1 and not reference):
        return nothing
    for m in range(count):
        cx += (X[m, 0] * u[0] + X[m, 1] * u[1] + X[m, 2] * u[2]) / count
        cy += (X[m, 0] * w[0] + X[m, 1] * w[1] + X[m, 2] * w[2]) / count
    for m in range(count):                          # cyclic order: by angle about the centroid
        ang[m] = math.atan2(X[m, 0] * w[0] + X[m, 1] * w[1] + X[m, 2] * w[2] - cy,
                            X[m, 0] * u[0] + X[m, 1] * u[1] + X[m, 2] * u[2] - cx)
    for m in range(1, count):
        q = m
        while q > 0 and ang[q - 1] > ang[q]:
            ang[q - 1], ang[q] = ang[q], ang[q - 1]
            for c in range(3):
                X[q - 1, c], X[q, c] = X[q, c], X[q - 1, c]
            q -= 1
    return count, d, 1.0, u, w


@njit
def _clip(R, nr, nref, X, nx, Y):
    """Clip the incident polygon (or segment, nx = 2) X[:nx] by the side planes of the
    reference polygon R[:nr] (normal nref); the result into Y, returns its count."""
    cen = (0.0, 0.0, 0.0)
    for m in range(nr):
        cen = v_add(cen, v_scale(1.0 / nr, (R[m, 0], R[m, 1], R[m, 2])))
    for m in range(nx):
        Y[m] = X[m]
    ny = nx
    Z = np.empty_like(Y)
    for e in range(nr):
        r0 = (R[e, 0], R[e, 1], R[e, 2])
        r1 = (R[(e + 1) % nr, 0], R[(e + 1) % nr, 1], R[(e + 1) % nr, 2])
        pn = v_cross(v_sub(r1, r0), nref)
        if v_dot(pn, v_sub(cen, r0)) > 0.0:
            pn = v_scale(-1.0, pn)
        nz = 0
        edges = 0 if ny == 1 else (ny if ny > 2 else 1)     # a segment: one edge
        if ny == 1:
            if v_dot(pn, v_sub((Y[0, 0], Y[0, 1], Y[0, 2]), r0)) <= 0.0:
                Z[0] = Y[0]
                nz = 1
        for m in range(edges):
            p = (Y[m, 0], Y[m, 1], Y[m, 2])
            q = (Y[(m + 1) % ny, 0], Y[(m + 1) % ny, 1], Y[(m + 1) % ny, 2])
            dp, dq = v_dot(pn, v_sub(p, r0)), v_dot(pn, v_sub(q, r0))
            if dp <= 0.0:
                Z[nz, 0], Z[nz, 1], Z[nz, 2] = p[0], p[1], p[2]
                nz += 1
            if (dp <= 0.0) != (dq <= 0.0):
                t = dp / (dp - dq)
                x = v_add(p, v_scale(t, v_sub(q, p)))
                Z[nz, 0], Z[nz, 1], Z[nz, 2] = x[0], x[1], x[2]
                nz += 1
            if ny == 2 and dq <= 0.0:
                Z[nz, 0], Z[nz, 1], Z[nz, 2] = q[0], q[1], q[2]
                nz += 1
        for m in range(nz):
            Y[m] = Z[m]
        ny = nz
        if ny == 0:
            break
    return ny


@njit
def narrow(P, oi, fi, oj, fj):
    """(a, b, n): the deepest (or nearest) points of the cores and the normal from i to j."""
    if int(P[oi + S_KIND]) == BOX and int(P[oj + S_KIND]) == BOX:
        hit, depth, n, a, b, face = box_box.sat(P, oi, fi, oj, fj)
        if hit:
            return a, b, n
    a, b, n, ok = gjk.closest(P, oi, fi, oj, fj)
    return a, b, n


@njit
def face_manifold(P, oi, fi, oj, fj, n, Y):
    """The clipped incident points of a face contact of the pair whose narrow phase gave the
    normal n (i to j), into Y: (count, n_ref, ref_i, r_0, u, w) with n_ref the reference
    face's outward normal, r_0 a point of it, ref_i whether the face is side i's and (u, w) its
    in-plane axes; count 0: no face contact (the witness pair stands alone)."""
    R = np.empty((MAX_POINTS, 3))
    X = np.empty((MAX_POINTS, 3))
    # run-time flags: a constant True / False would compile _feature once for each
    YES, NO = np.bool_(True), np.bool_(False)
    ci, nri, ali, ui, wi = _feature(P, oi, fi, n, R, YES)
    cj, nrj, alj, uj, wj = _feature(P, oj, fj, v_scale(-1.0, n), X, YES)
    ref_i = ci >= 3 and (cj < 3 or ali >= alj)
    if ref_i:
        nref, nr, u, w = nri, ci, ui, wi
        nx = _feature(P, oj, fj, v_scale(-1.0, n), X, NO)[0]
    elif cj >= 3:
        for m in range(cj):
            R[m] = X[m]
        nref, nr, u, w = nrj, cj, uj, wj
        nx = _feature(P, oi, fi, n, X, NO)[0]
    else:
        nref, nr, nx, u, w = n, 0, 0, ui, wi
    r0 = (R[0, 0], R[0, 1], R[0, 2])
    if nx < 2:
        return 0, nref, ref_i, r0, u, w
    return _clip(R, nr, nref, X, nx, Y), nref, ref_i, r0, u, w


@njit
def face_pair(Y, at, nref, ref_i, r0):
    """(q_i, q_j, n) of clipped point ``at`` of a face manifold (:func:`face_manifold`)."""
    p = (Y[at, 0], Y[at, 1], Y[at, 2])
    depth = v_dot(nref, v_sub(r0, p))
    q = v_add(p, v_scale(depth, nref))
    if ref_i:
        return q, p, nref
    return p, q, v_scale(-1.0, nref)


@njit
def _picks(Y, ny, u, w):
    """The clipped points of slots 0 .. MAX_SLOTS - 1 when there are more than MAX_SLOTS: slot
    s takes the point furthest in the diagonal direction (+-u +-w)_s (module docstring)."""
    pick = np.empty(MAX_SLOTS, np.int64)
    for s in range(MAX_SLOTS):
        su = 1.0 if s in (0, 3) else -1.0
        sw = 1.0 if s in (0, 1) else -1.0
        best, pick[s] = -math.inf, 0
        for m in range(ny):
            p = (Y[m, 0], Y[m, 1], Y[m, 2])
            h = su * v_dot(p, u) + sw * v_dot(p, w)
            if m == 0 or h > best + 1e-12 * (1.0 + abs(best)):
                best, pick[s] = h, m
    return pick


@njit
def convex_core_points(P, oi, fi, oj, fj, slot):
    """(q_i, q_j, n) of manifold slot ``slot`` (module docstring); an open slot has
    n . (q_j - q_i) = OPEN."""
    a, b, n = narrow(P, oi, fi, oj, fj)
    Y = np.empty((MAX_POINTS, 3))
    ny, nref, ref_i, r0, u, w = face_manifold(P, oi, fi, oj, fj, n, Y)
    if ny == 0:
        if slot == 0:
            return a, b, n
        return a, v_add(a, v_scale(OPEN, n)), n
    if ny <= MAX_SLOTS:                             # every point has its slot
        if slot >= ny:
            return a, v_add(a, v_scale(OPEN, n)), n
        at = slot
    else:                                           # the extremes in 4 diagonal directions
        pick = _picks(Y, ny, u, w)
        for s in range(slot):
            if pick[s] == pick[slot]:
                return a, v_add(a, v_scale(OPEN, n)), n
        at = pick[slot]
    return face_pair(Y, at, nref, ref_i, r0)


@njit
def manifold_points(P, oi, fi, oj, fj, Q):
    """Every point of the pair's manifold at once (what :func:`convex_core_points` gives slot
    by slot, the open slots left out) into Q (MAX_SLOTS, 9), rows (q_i, q_j, n); returns their
    number. One narrow phase for the whole manifold."""
    a, b, n = narrow(P, oi, fi, oj, fj)
    Y = np.empty((MAX_POINTS, 3))
    ny, nref, ref_i, r0, u, w = face_manifold(P, oi, fi, oj, fj, n, Y)
    if ny == 0:
        _put(Q, 0, a, b, n)
        return 1
    if ny <= MAX_SLOTS:
        for s in range(ny):
            qi, qj, nn = face_pair(Y, s, nref, ref_i, r0)
            _put(Q, s, qi, qj, nn)
        return ny
    pick = _picks(Y, ny, u, w)
    count = 0
    for s in range(MAX_SLOTS):
        seen = False
        for t in range(s):
            seen = seen or pick[t] == pick[s]
        if not seen:
            qi, qj, nn = face_pair(Y, pick[s], nref, ref_i, r0)
            _put(Q, count, qi, qj, nn)
            count += 1
    return count


@njit(inline="always")
def _put(Q, m, qi, qj, n):
    for c in range(3):
        Q[m, c], Q[m, 3 + c], Q[m, 6 + c] = qi[c], qj[c], n[c]
