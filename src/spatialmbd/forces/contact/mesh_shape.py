"""Triangle meshes as contact shapes (non-convex: a terrain, a bowl, a part): their checks, their
topology and the bounding-volume hierarchy built once, packed into the parameter rows of a
``mesh_contact`` element (:mod:`.mesh_contact`; queried by :mod:`.mesh_query`).

``{"type": "mesh", "vertices": [[x, y, z], ...], "faces": [[a, b, c], ...]}`` (m, vertex
indices counter-clockwise seen from outside), or ``{"type": "mesh", "file": "part.stl"}`` with
an optional ``scale`` (read by :func:`spatialmbd.meshes.mesh_arrays`, as display meshes are).
A mesh is *one-sided*: its outside is where the faces' normals (right-hand rule) point.

Checks (ModelError naming forces[name].shape_i.faces[k] and the value): finite vertices and
indices in range (:mod:`spatialmbd.meshes`), no face with a repeated vertex or zero area, every
edge shared by at most two faces, neighbouring faces wound consistently (a shared edge runs
opposite ways in the two), and every vertex's faces one fan (a manifold surface; a terrain's
border is allowed).

Topology per triangle: its vertex indices, the triangle across each edge (edge m joins vertex m
to vertex m + 1; -1 on a border) and the outward unit normal. The hierarchy: an AABB tree over
the triangles, split at the median of the centroids along the longest axis of the node's box
(top-down, built once), 2 nf - 1 nodes (lo (3), hi (3), left, right; a leaf has left = -1 - t).

Parameter row t of the element (triangle t; the law columns of :mod:`.laws` first):

    C_FIRST t,  C_COUNT nf,  C_GRID 1 for a height field (:mod:`.heightfield`) else 0,
    C_HF (nx, ny, x0, y0, dx, dy) of a height field (row 0),
    C_V the vertices (9, mesh frame),  C_NRM the normal,  C_VID vertex ids,  C_NB neighbours,
    C_NODE nodes 2 t and 2 t + 1 (8 columns each),  C_OWN 1 where t owns its vertex m
    (columns 0-2: t is the lowest-numbered face of the vertex's fan) or its edge m (columns
    3-5: t is the lower-numbered of the edge's faces, or its only one),  C_SIDE the convex
    shape's core block (:mod:`.support`, row 0).
"""
from __future__ import annotations

import numpy as np

from ...errors import ModelError
from . import laws as L
from . import support as sup

C_FIRST, C_COUNT, C_GRID = L.N_COLUMNS, L.N_COLUMNS + 1, L.N_COLUMNS + 2
C_HF = C_GRID + 1
C_V = C_HF + 6
C_NRM = C_V + 9
C_VID = C_NRM + 3
C_NB = C_VID + 3
C_NODE = C_NB + 3
NODE_WIDTH = 8
C_OWN = C_NODE + 2 * NODE_WIDTH
C_SIDE = C_OWN + 6
N_COLUMNS = C_SIDE + sup.SIDE_WIDTH


def _err(what, text):
    return ModelError(f"{what}: {text}")


def check_surface(V, F, what) -> np.ndarray:
    """The triangles' neighbours (nf, 3) (-1 on a border) of a checked mesh; ModelError naming
    ``what``.faces[k] for a degenerate face, a non-manifold or inconsistently wound edge, or a
    non-manifold vertex."""
    nf = F.shape[0]
    for k in np.flatnonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) |
                            (F[:, 0] == F[:, 2]))[:1]:
        raise _err(f"{what}.faces[{k}]", f"{F[k].tolist()} repeats a vertex: a face needs "
                                         "three different vertices")
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    scale = max(float(np.ptp(V, axis=0).max()), 1e-300)
    for k in np.flatnonzero(~(area > 1e-14 * scale * scale))[:1]:
        raise _err(f"{what}.faces[{k}]", f"{F[k].tolist()} has zero area ({area[k]:.3g} m^2: "
                                         "its vertices lie on a line); remove it")
    # directed edges (face k, edge m: F[k, m] -> F[k, m + 1])
    start = F.reshape(-1)
    end = F[:, [1, 2, 0]].reshape(-1)
    face = np.repeat(np.arange(nf), 3)
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    key = lo * (V.shape[0] + 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    bounds = np.flatnonzero(np.diff(ks)) + 1
    groups = np.split(order, bounds)
    nb = np.full(3 * nf, -1, dtype=np.int64)
    for g in groups:
        if len(g) > 2:
            fk = sorted(set(face[g].tolist()))
            raise _err(f"{what}.faces[{fk[2]}]", f"the edge {lo[g[0]]}-{hi[g[0]]} is shared by "
                                                 f"{len(g)} faces ({fk}): a non-manifold edge; "
                                                 "a mesh surface has at most two faces per edge")
        if len(g) == 2:
            e, f = g
            if start[e] == start[f]:
                raise _err(f"{what}.faces[{face[f]}]",
                           f"{F[face[f]].tolist()} is wound the same way as its neighbour "
                           f"faces[{face[e]}] {F[face[e]].tolist()} along their edge "
                           f"{start[e]}-{end[e]}: flip it (vertices counter-clockwise seen "
                           "from outside)")
            nb[e], nb[f] = face[f], face[e]
    nb = nb.reshape(nf, 3)
    # a manifold vertex: its faces form one fan (walk across the edges at the vertex)
    incident = [[] for _ in range(V.shape[0])]
    for k in range(nf):
        for m in range(3):
            incident[F[k, m]].append(k)
    for v, faces in enumerate(incident):
        if len(faces) < 2:
            continue
        seen = {faces[0]}
        todo = [faces[0]]
        while todo:
            k = todo.pop()
            for m in range(3):
                if v in (F[k, m], F[k, (m + 1) % 3]) and nb[k, m] >= 0 and nb[k, m] not in seen:
                    seen.add(nb[k, m])
                    todo.append(nb[k, m])
        if len(seen) != len(faces):
            raise _err(f"{what}.vertices[{v}]", f"{V[v].tolist()} joins {len(faces)} faces that "
                                                "are not one fan (two surfaces touching at a "
                                                "point): a non-manifold vertex; split it")
    return nb


def build_bvh(V, F) -> np.ndarray:
    """(2 nf - 1, NODE_WIDTH) nodes of the AABB tree (module docstring), root first."""
    nf = F.shape[0]
    tri = V[F]                                     # (nf, 3, 3)
    tlo, thi, cen = tri.min(axis=1), tri.max(axis=1), tri.mean(axis=1)
    nodes = np.zeros((2 * nf - 1, NODE_WIDTH))
    free = 1
    stack = [(0, np.arange(nf))]
    while stack:
        node, idx = stack.pop()
        nodes[node, 0:3] = tlo[idx].min(axis=0)
        nodes[node, 3:6] = thi[idx].max(axis=0)
        if idx.size == 1:
            nodes[node, 6] = -1 - idx[0]
            nodes[node, 7] = -1
            continue
        c = cen[idx]
        axis = int(np.argmax(np.ptp(c, axis=0)))
        half = idx.size // 2
        part = np.argpartition(c[:, axis], half - 1)
        left, right = idx[part[:half]], idx[part[half:]]
        nodes[node, 6], nodes[node, 7] = free, free + 1
        stack.append((free, left))
        stack.append((free + 1, right))
        free += 2
    return nodes


def mesh_rows(V, F, nb, nodes=None, grid=None) -> np.ndarray:
    """(nf, N_COLUMNS) rows of a mesh (the law and shape columns left zero; module
    docstring). nodes: the BVH (:func:`build_bvh`), or None with ``grid`` = (nx, ny, x0, y0,
    dx, dy) of a height field."""
    nf = F.shape[0]
    rows = np.zeros((nf, N_COLUMNS))
    rows[:, C_FIRST] = np.arange(nf)
    rows[:, C_COUNT] = nf
    tri = V[F]
    rows[:, C_V:C_V + 9] = tri.reshape(nf, 9)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    rows[:, C_NRM:C_NRM + 3] = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    rows[:, C_VID:C_VID + 3] = F
    rows[:, C_NB:C_NB + 3] = nb
    first = np.full(V.shape[0], nf, dtype=np.int64)
    np.minimum.at(first, F.reshape(-1), np.repeat(np.arange(nf), 3))
    rows[:, C_OWN:C_OWN + 3] = first[F] == np.arange(nf)[:, None]
    rows[:, C_OWN + 3:C_OWN + 6] = (nb < 0) | (np.arange(nf)[:, None] < nb)
    if grid is not None:
        rows[:, C_GRID] = 1.0
        rows[0, C_HF:C_HF + 6] = grid
    else:
        flat = np.zeros((2 * nf, NODE_WIDTH))
        flat[:nodes.shape[0]] = nodes
        rows[:, C_NODE:C_NODE + 2 * NODE_WIDTH] = flat.reshape(nf, 2 * NODE_WIDTH)
    return rows


def parse_mesh(shape, what) -> tuple:
    """(vertices (n, 3), faces (m, 3), neighbours (m, 3)) of a mesh shape dict, checked."""
    from ...meshes import mesh_arrays
    V, F = mesh_arrays(shape, what)
    nb = check_surface(V, F, what)
    return V, F, nb
