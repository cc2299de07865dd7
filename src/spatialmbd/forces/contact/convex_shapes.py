"""The convex contact shapes beyond spheres and capsules: their keys, checks, the parameter-row
blocks of their cores (:mod:`.support`) and the instances (manifold slots, rim points,
vertices) of the pairs they form.

* ``{"type": "cylinder", "radius": R, "half_length": h, "axis": u}``  solid cylinder, |z| <= h
* ``{"type": "ellipsoid", "semi_axes": (a, b, c)}``  along the shape axes
* ``{"type": "convex", "vertices": [[x, y, z], ...]}``  the convex hull of the points (shape
  frame), at most MAX_HULL_VERTICES hull vertices (a convex mesh: give its vertices)
* ``{"type": "box", "half_extents": (a, b, c)}`` (parsed in .element)
"""
from __future__ import annotations

import numpy as np

from ...errors import ModelError
from . import support as sup
from .manifold import MAX_SLOTS

#: shapes the general convex machinery (.manifold) takes
CONVEX_KINDS = ("sphere", "capsule", "box", "cylinder", "ellipsoid", "convex")
#: pairs kept by their closed forms in .geometry (unordered)
CLOSED_FORMS = {frozenset(("sphere",)), frozenset(("capsule",)),
                frozenset(("capsule", "sphere")), frozenset(("box", "sphere"))}


def _err(name, key, text):
    return ModelError(f"forces[{name!r}].{key}: {text}")


def _positive(name, key, value):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise _err(name, key, f"expected a positive number (m), got {value!r}") from None
    if not np.isfinite(x) or not x > 0:
        raise _err(name, key, f"must be a positive size (m), got {value!r}; a shape of zero "
                              "size cannot touch anything")
    return x


def parse(name, key, kind, shape):
    """(radius, half_length, half (3,), vertices (nv, 3) or None) of a cylinder, ellipsoid or
    convex shape dict (checked, errors naming forces[name].key)."""
    half = np.zeros(3)
    if kind == "cylinder":
        R = _positive(name, key + ".radius", shape.get("radius"))
        h = _positive(name, key + ".half_length", shape.get("half_length"))
        return R, h, np.array([R, R, h]), None
    if kind == "ellipsoid":
        axes = shape.get("semi_axes")
        arr = np.array(axes if axes is not None else [np.nan] * 3, dtype=float).reshape(-1)
        if arr.size != 3 or not np.all(np.isfinite(arr)) or not np.all(arr > 0):
            raise _err(name, key + ".semi_axes", f"expected 3 positive semi-axes (m), got "
                                                 f"{axes!r}")
        return 0.0, 0.0, arr, None
    pts = shape.get("vertices")
    try:
        arr = np.array(pts, dtype=float)
    except (TypeError, ValueError):
        arr = np.zeros((0,))
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < 4:
        raise _err(name, key + ".vertices", f"a convex shape needs at least 4 points "
                                            f"[[x, y, z], ...] (m), got {pts!r:.80}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=1))[0])
        raise _err(name, key + f".vertices[{bad}]", f"must be finite, got {list(arr[bad])}")
    from scipy.spatial import ConvexHull, QhullError
    scale = float(np.ptp(arr, axis=0).max())
    try:
        hull = ConvexHull(arr)
        ok = scale > 0 and hull.volume > 1e-12 * scale ** 3
    except (QhullError, ValueError):
        ok = False
    if not ok:
        raise _err(name, key + ".vertices", f"the {arr.shape[0]} points span no volume (all "
                                            "on a plane, a line or one point): a degenerate "
                                            "hull; give points of a solid")
    verts = arr[hull.vertices]
    if len(verts) > sup.MAX_HULL_VERTICES:
        raise _err(name, key + ".vertices", f"the hull has {len(verts)} vertices; a contact "
                                            f"shape keeps at most {sup.MAX_HULL_VERTICES}: "
                                            "simplify the mesh (or split it into convex parts)")
    half = np.abs(verts).max(axis=0)
    return 0.0, 0.0, half, verts


def largest_face_area(verts) -> float:
    """Area (m^2) of the largest face of the hull of ``verts`` (coplanar facets merged)."""
    from scipy.spatial import ConvexHull
    hull = ConvexHull(verts)
    key = np.round(hull.equations / max(np.ptp(verts, axis=0).max(), 1e-300) * 1e9)
    areas: dict = {}
    for simplex, k in zip(hull.simplices, map(tuple, key)):
        a, b, c = verts[simplex]
        areas[k] = areas.get(k, 0.0) + 0.5 * np.linalg.norm(np.cross(b - a, c - a))
    return max(areas.values())


def side_block(kind, radius, half_length, half, verts):
    """The SIDE_WIDTH columns of one shape's core (.support)."""
    block = np.zeros(sup.SIDE_WIDTH)
    block[sup.S_KIND] = sup.KIND_OF[kind]
    block[sup.S_RADIUS] = radius if kind in ("sphere", "capsule") else 0.0
    if kind == "capsule":
        block[sup.S_D0:sup.S_D0 + 3] = (0.0, 0.0, half_length)
    elif kind != "sphere":
        block[sup.S_D0:sup.S_D0 + 3] = half
    if verts is not None:
        block[sup.S_NV] = len(verts)
        block[sup.S_VERTS:sup.S_VERTS + verts.size] = verts.ravel()
    return block


def size(kind, radius, half_length, half, verts) -> float:
    """The smallest dimension (m) of a shape: deep-penetration checks use half of it."""
    if kind in ("sphere", "capsule"):
        return radius
    if kind == "cylinder":
        return min(radius, half_length)
    return float(half.min())


def slots(ki, kj) -> int:
    """Contact instances of a convex pair: one manifold slot each."""
    if "sphere" in (ki, kj) or "ellipsoid" in (ki, kj):
        return 1
    if "capsule" in (ki, kj):
        return 2
    return MAX_SLOTS
