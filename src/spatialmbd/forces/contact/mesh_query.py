"""Contacts of a convex shape with a triangle mesh or a height field (compiled): the triangles
near the shape (the AABB tree of :mod:`.mesh_shape`, or the grid cells of :mod:`.heightfield`),
the narrow phase per triangle and the merged contact manifold.

Per triangle t (outward unit normal N_t; the triangle a flat convex core, :mod:`.support`'s
HULL of 3 vertices) the narrow phase of :mod:`.manifold` (GJK/EPA) gives the signed distance
d_t of the shape to the triangle, the normal and the witness points; triangles with d_t >= 0
add nothing. Then the *rule* (so that a shape resting or rolling across edges gets one set of
consistent normals, every piece of contact counted once):

1. Faces (the prism rule): the shape's feature facing -N_t (a box face, a capsule's segment, a
   cylinder's cap or side line, a hull's face; :func:`.manifold.face_manifold`) clipped by the
   side planes of t, each point below the plane of t a contact with normal N_t and depth its
   distance below the plane; a shape without such a feature (a sphere, an ellipsoid, a tilted
   cylinder) contributes its support point in -N_t when it lies in the closed prism over t.
   The prisms over the faces of a flat or concave region tile it: a point on a shared edge
   belongs to both prisms and is found twice, once per face, with the same normal and depth;
   step 3 keeps one.
2. Edges and vertices: each edge and each vertex of the mesh is tried once, by the triangle
   that owns it (the lower-numbered face of an edge, the lowest-numbered face of a vertex's
   fan; only triangles that overlap the shape try theirs): the narrow phase of the feature
   alone (a segment, a point) against the shape gives its contact, kept only if its normal
   lies strictly inside the feature's normal cone, i.e. n . (w - x) < -1e-9 |w - x| for every
   mesh vertex w adjacent to the feature (for an edge: the far vertices of its two faces; for
   a vertex: the vertices of its fan). Such a normal exists only at a convex edge or vertex
   and is no face's normal, so this contact is none of step 1's. A border edge or vertex also
   needs n . N_t > 0 (one-sided). The contact carries the face manifold along its normal (a
   box lying on a ridge touches along the ridge's segment) or the witness pair.
3. Merging: contacts whose normals agree within 1.4e-6 rad form a patch; a patch keeps at most
   five points: the farthest from the patch's centroid, the farthest from that one, the one
   spanning the largest triangle with these two and the largest on the other side (all on
   the patch's convex hull), and the deepest if it is deeper than all of these by more than
   1e-9 of the shape's size (points closer than that to a kept one are the same point,
   counted once). A box resting across triangles keeps its four corners whatever the
   tessellation under it.

The gap rate of a contact point that is a vertex of the shape over a face is exactly
N_t . v_rel (as for :mod:`.manifold`).
"""
from __future__ import annotations

import math

import numpy as np

from ...constraints.primitives import v_add, v_cross, v_dot, v_scale, v_sub
from ...jit import njit
from . import manifold
from . import mesh_shape as MS
from . import support as sup
from .gjk import triangle_weights

TOL_FEATURE = 1e-9        # barycentric weight of an edge or a vertex; cone strictness
TOL_PATCH = 1e-12         # 1 - cos(angle) of one patch's normals (angle ~ 1.4e-6 rad)
N_OUT = 10                # contact columns: q_i (3), q_j (3), n (3), gap
SW = sup.SIDE_WIDTH
# _OFFSETS: the blocks' offsets (0 and SW) and flags go to the narrow phase as run-time values
# (np.int64(...), np.bool_(...)): Numba compiles a call with a constant argument as a
# specialization of its own (a Literal type), which compiled the whole narrow phase -- GJK, EPA,
# the face manifolds -- twice, once for the mesh path and once for the convex pairs


@njit(inline="always")
def _vertex(P, k0, t, m):
    o = MS.C_V + 3 * m
    return (P[k0 + t, o], P[k0 + t, o + 1], P[k0 + t, o + 2])


@njit(inline="always")
def _local(f, x):
    """Coordinates in frame f of the global point x."""
    return sup.to_local(f, v_sub(x, f[0]))


@njit
def shape_box(P, o, fs, fm, r):
    """(lo, hi) of the shape's AABB (core block P[o:], frame fs, radius r) in mesh axes."""
    lo, hi = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    for a in range(3):
        e = fm[1 + a]
        hi[a] = v_dot(e, v_sub(sup.support(P, o, fs, e), fm[0])) + r
        lo[a] = v_dot(e, v_sub(sup.support(P, o, fs, v_scale(-1.0, e)), fm[0])) - r
    return lo, hi


@njit
def candidates(P, k0, lo, hi, out):
    """Triangles whose bounding boxes (tree) or cells (height field) meet [lo, hi] (mesh
    axes), into out; returns their count (may exceed out's size: then call again with room)."""
    count = 0
    if P[k0, MS.C_GRID] != 0.0:
        c = MS.C_HF
        nx, ny = int(P[k0, c]), int(P[k0, c + 1])
        x0, y0, dx, dy = P[k0, c + 2], P[k0, c + 3], P[k0, c + 4], P[k0, c + 5]
        i0 = max(0, int(math.floor((lo[0] - x0) / dx)))
        i1 = min(nx - 1, int(math.floor((hi[0] - x0) / dx)))
        j0 = max(0, int(math.floor((lo[1] - y0) / dy)))
        j1 = min(ny - 1, int(math.floor((hi[1] - y0) / dy)))
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                for s in range(2):
                    if count < out.size:
                        out[count] = 2 * (i + nx * j) + s
                    count += 1
        return count
    stack = np.empty(128, np.int64)
    stack[0] = 0
    top = 1
    while top > 0:
        top -= 1
        m = stack[top]
        row, col = k0 + m // 2, MS.C_NODE + MS.NODE_WIDTH * (m % 2)
        if (P[row, col] > hi[0] or P[row, col + 3] < lo[0] or P[row, col + 1] > hi[1] or
                P[row, col + 4] < lo[1] or P[row, col + 2] > hi[2] or P[row, col + 5] < lo[2]):
            continue
        left = int(P[row, col + 6])
        if left < 0:
            if count < out.size:
                out[count] = -1 - left
            count += 1
        else:
            stack[top] = left
            stack[top + 1] = int(P[row, col + 7])
            top += 2
    return count


@njit
def triangle_block(P, k0, t, fm, W, first=0, nv=3):
    """The core block of triangle t into W[0:SW] (a HULL of its nv vertices from vertex
    ``first`` on -- the triangle, an edge or a vertex -- about the triangle's centroid, mesh
    axes) and its frame."""
    c = [0.0, 0.0, 0.0]
    for m in range(3):
        x = _vertex(P, k0, t, m)
        for a in range(3):
            c[a] += x[a] / 3.0
    for a in range(SW):
        W[a] = 0.0
    W[sup.S_KIND] = sup.HULL
    W[sup.S_NV] = nv
    for m in range(nv):
        x = _vertex(P, k0, t, (first + m) % 3)
        for a in range(3):
            W[sup.S_VERTS + 3 * m + a] = x[a] - c[a]
            W[sup.S_D0 + a] = max(W[sup.S_D0 + a], abs(x[a] - c[a]))
    ft = (sup.to_global(fm, (c[0], c[1], c[2])), fm[1], fm[2], fm[3])
    return ft


@njit
def _push(C, count, qi, qj, n, gap):
    if count < C.shape[0]:
        for a in range(3):
            C[count, a], C[count, 3 + a], C[count, 6 + a] = qi[a], qj[a], n[a]
        C[count, 9] = gap
    return count + 1


@njit
def _outside(nl, x, w):
    """True unless n . (w - x) < -TOL |w - x| (mesh axes)."""
    d = v_sub(w, x)
    return v_dot(nl, d) >= -TOL_FEATURE * math.sqrt(v_dot(d, d))


@njit
def _in_cone(P, k0, t, nl, wts):
    """Step 2 of the rule: is the witness (barycentric weights wts in t) on an edge or a
    vertex of t whose normal cone holds nl (mesh axes) strictly?"""
    zero = 0
    for m in range(3):
        if wts[m] < TOL_FEATURE:
            zero += 1
    if zero == 0:
        return False
    N = (P[k0 + t, MS.C_NRM], P[k0 + t, MS.C_NRM + 1], P[k0 + t, MS.C_NRM + 2])
    if zero == 1:                                   # the edge opposite the zero weight m
        m = 0 if wts[0] < TOL_FEATURE else (1 if wts[1] < TOL_FEATURE else 2)
        x = _vertex(P, k0, t, (m + 1) % 3)
        e = v_sub(_vertex(P, k0, t, (m + 2) % 3), x)
        if abs(v_dot(nl, e)) > TOL_FEATURE * math.sqrt(v_dot(e, e)):
            return False                            # the nearest point is an end: a vertex's
        if _outside(nl, x, _vertex(P, k0, t, m)):
            return False
        u = int(P[k0 + t, MS.C_NB + (m + 1) % 3])   # edge m + 1 joins vertices m + 1, m + 2
        if u < 0:
            return v_dot(nl, N) > TOL_FEATURE
        a, b = int(P[k0 + t, MS.C_VID + (m + 1) % 3]), int(P[k0 + t, MS.C_VID + (m + 2) % 3])
        for s in range(3):                          # the far vertex of the neighbour
            vid = int(P[k0 + u, MS.C_VID + s])
            if vid != a and vid != b and _outside(nl, x, _vertex(P, k0, u, s)):
                return False
        return True
    best = 0                                        # the vertex: the largest weight
    for s in range(3):
        if wts[s] > wts[best]:
            best = s
    vid = int(P[k0 + t, MS.C_VID + best])
    x = _vertex(P, k0, t, best)
    border = False
    for direction in range(2):                      # walk the vertex's fan both ways from t
        prev, cur = -1, t
        for _ in range(1024):
            at = 0
            for s in range(3):
                if int(P[k0 + cur, MS.C_VID + s]) == vid:
                    at = s
                elif _outside(nl, x, _vertex(P, k0, cur, s)):
                    return False
            # the edges at the vertex: at (from it) and at + 2 (to it)
            a1 = int(P[k0 + cur, MS.C_NB + at])
            a2 = int(P[k0 + cur, MS.C_NB + (at + 2) % 3])
            if prev < 0:
                nxt = a1 if direction == 0 else a2
            else:
                nxt = a2 if a1 == prev else a1
            if nxt < 0:
                border = True
                break
            if nxt == t:
                break
            prev, cur = cur, nxt
        if not border:
            break
    if border:
        return v_dot(nl, N) > TOL_FEATURE
    return True


@njit(inline="always")
def _rotate(f, x):
    return v_add(v_add(v_scale(x[0], f[1]), v_scale(x[1], f[2])), v_scale(x[2], f[3]))


@njit
def triangle_contacts(P, k0, t, fm, W, fs, r, C, count, Y):
    """The contacts of triangle t with the shape (block W[SW:], frame fs, radius r) by the rule
    (module docstring, steps 1 and 2) appended to C; returns the new count."""
    T0, S0 = np.int64(0), np.int64(SW)     # offsets as run-time values: see _OFFSETS
    ft = triangle_block(P, k0, t, fm, W)
    a, b, n = manifold.narrow(W, T0, ft, S0, fs)
    if v_dot(n, v_sub(b, a)) - r >= 0.0:
        return count
    Nl = (P[k0 + t, MS.C_NRM], P[k0 + t, MS.C_NRM + 1], P[k0 + t, MS.C_NRM + 2])
    N = _rotate(fm, Nl)
    ab = (_vertex(P, k0, t, 0), _vertex(P, k0, t, 1), _vertex(P, k0, t, 2))
    # step 1: the prism over the face
    ny, nref, ref_i, r0, u, w = manifold.face_manifold(W, T0, ft, S0, fs, N, Y)
    if ny > 0 and ref_i:
        for m in range(ny):
            qi, qj, nn = manifold.face_pair(Y, m, nref, ref_i, r0)
            gap = v_dot(nn, v_sub(qj, qi)) - r
            if gap < 0.0:
                count = _push(C, count, qi, qj, nn, gap)
    else:
        s = sup.support(W, S0, fs, v_scale(-1.0, N))
        sl = _local(fm, s)
        wts = triangle_weights(v_sub(ab[0], sl), v_sub(ab[1], sl), v_sub(ab[2], sl))
        x = v_add(v_add(v_scale(wts[0], ab[0]), v_scale(wts[1], ab[1])),
                  v_scale(wts[2], ab[2]))
        d = v_sub(sl, x)
        # in the closed prism: the nearest point of t lies straight below (or above) s
        inside = abs(v_dot(d, Nl)) >= math.sqrt(v_dot(d, d)) * (1.0 - 1e-12)
        depth = v_dot(Nl, v_sub(ab[0], sl))
        if inside and depth + r > 0.0:
            count = _push(C, count, v_add(s, v_scale(depth, N)), s, N, -depth - r)
    # step 2: the vertices and edges t owns, each against the shape (a canonical contact of
    # the feature, computed once), kept where the normal lies strictly in the feature's cone
    for f in range(6):
        if P[k0 + t, MS.C_OWN + f] == 0.0:
            continue
        first, nv = (f, 1) if f < 3 else (f - 3, 2)
        ft = triangle_block(P, k0, t, fm, W, first, nv)
        a, b, n = manifold.narrow(W, T0, ft, S0, fs)
        if v_dot(n, v_sub(b, a)) - r >= 0.0:
            continue
        wts = [0.0, 0.0, 0.0]                        # the feature's barycentric weights
        for m in range(nv):
            wts[(first + m) % 3] = 1.0 / nv
        if not _in_cone(P, k0, t, sup.to_local(fm, n), (wts[0], wts[1], wts[2])):
            continue
        ny, nref, ref_i, r0, u, w = manifold.face_manifold(W, T0, ft, S0, fs, n, Y)
        if ny > 0:
            for m in range(ny):
                qi, qj, nn = manifold.face_pair(Y, m, nref, ref_i, r0)
                gap = v_dot(nn, v_sub(qj, qi)) - r
                if gap < 0.0:
                    count = _push(C, count, qi, qj, nn, gap)
        else:
            count = _push(C, count, a, b, n, v_dot(n, v_sub(b, a)) - r)
    return count


@njit(inline="always")
def _point(C, m):
    return (0.5 * (C[m, 0] + C[m, 3]), 0.5 * (C[m, 1] + C[m, 4]), 0.5 * (C[m, 2] + C[m, 5]))


@njit
def merge(C, count, size, keep):
    """Step 3 of the rule: the indices of the kept contacts of C[:count] into keep; returns
    their number."""
    patch = np.full(count, -1, np.int64)
    tol = 1e-9 * size
    nk = 0
    for c in range(count):
        if patch[c] >= 0:
            continue
        nc = (C[c, 6], C[c, 7], C[c, 8])
        members = 0
        for m in range(c, count):
            if patch[m] < 0 and C[m, 6] * nc[0] + C[m, 7] * nc[1] + C[m, 8] * nc[2] > \
                    1.0 - TOL_PATCH:
                patch[m] = c
                members += 1
        cen = (0.0, 0.0, 0.0)
        for m in range(c, count):
            if patch[m] == c:
                cen = v_add(cen, v_scale(1.0 / members, _point(C, m)))
        a, best = c, -1.0                           # the farthest from the centroid
        for m in range(c, count):
            if patch[m] == c:
                d = v_sub(_point(C, m), cen)
                if v_dot(d, d) > best:
                    a, best = m, v_dot(d, d)
        first = nk
        keep[nk] = a
        nk += 1
        pa = _point(C, a)
        b, best = -1, tol
        for m in range(c, count):                   # the farthest from it
            if patch[m] == c:
                d = v_sub(_point(C, m), pa)
                dist = math.sqrt(v_dot(d, d))
                if dist > best:
                    b, best = m, dist
        if b < 0:
            continue
        keep[nk] = b
        nk += 1
        ab = v_sub(_point(C, b), pa)
        side = v_cross(nc, ab)                      # in-plane normal of the line a-b
        for sgn in (1.0, -1.0):                     # the largest triangle on either side
            e, best = -1, tol * best
            for m in range(c, count):
                if patch[m] == c:
                    h = sgn * v_dot(side, v_sub(_point(C, m), pa))
                    if h > best:
                        e, best = m, h
            if e >= 0:
                keep[nk] = e
                nk += 1
        deep = c                                    # the deepest, if deeper than those kept
        for m in range(c, count):
            if patch[m] == c and C[m, 9] < C[deep, 9]:
                deep = m
        for m in range(first, nk):
            if C[keep[m], 9] <= C[deep, 9] + tol:
                deep = -1
                break
        if deep >= 0:
            keep[nk] = deep
            nk += 1
    return nk


@njit
def collect(S, G, k0):
    """(C, kept indices, count kept) of the mesh-shape pair of element row k0."""
    fm = sup.frame(S, G.bi[k0], G.s_i, G.R_i, k0)
    fs = sup.frame(S, G.bj[k0], G.s_j, G.R_j, k0)
    return collect_at(G.param, k0, fm, fs)


@njit
def collect_at(P, k0, fm, fs):
    """:func:`collect` for the mesh of rows P[k0:] at frame fm and its shape at frame fs."""
    W = np.empty(2 * SW)
    for a in range(SW):
        W[SW + a] = P[k0, MS.C_SIDE + a]
    r = W[SW + sup.S_RADIUS]
    lo, hi = shape_box(W, np.int64(SW), fs, fm, r)
    nf = int(P[k0, MS.C_COUNT])
    cand = np.empty(min(nf, 256), np.int64)
    nc = candidates(P, k0, lo, hi, cand)
    if nc > cand.size:
        cand = np.empty(nc, np.int64)
        nc = candidates(P, k0, lo, hi, cand)
    C = np.empty((16 * nc + 16, N_OUT))
    Y = np.empty((manifold.MAX_POINTS, 3))
    count = np.int64(0)
    for m in range(nc):
        count = triangle_contacts(P, k0, cand[m], fm, W, fs, r, C, count, Y)
    count = min(count, C.shape[0])
    size = 0.0
    for a in range(3):
        size = max(size, hi[a] - lo[a])
    keep = np.empty(max(count, 1), np.int64)
    nk = merge(C, count, size, keep)
    return C, keep, nk


@njit
def mesh_signed_distance(P, k0, fm, W, fs):
    """(d, n, a, b, t): the least signed distance d of the shape (block W[SW:], frame fs) to
    any triangle of the mesh of rows P[k0:] (frame fm) -- the narrow phase alone, as a
    collision library answers for a mesh (coal's BVHModel) --, its normal from the triangle to
    the shape, the surface points and the triangle (every triangle tried: tests, benchmarks)."""
    r = W[SW + sup.S_RADIUS]
    T0, S0 = np.int64(0), np.int64(SW)     # offsets as run-time values: see _OFFSETS
    best = (math.inf, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), -1)
    for t in range(int(P[k0, MS.C_COUNT])):
        ft = triangle_block(P, k0, t, fm, W)
        a, b, n = manifold.narrow(W, T0, ft, S0, fs)
        d = v_dot(n, v_sub(b, a)) - r
        if d < best[0]:
            best = (d, n, a, v_sub(b, v_scale(r, n)), t)
    return best
