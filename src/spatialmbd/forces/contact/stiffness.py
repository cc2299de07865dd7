"""Contact stiffness from materials, for every pair of shapes (docs/contact.md, table of pairs).

E* = 1 / ((1 - nu_i^2) / E_i + (1 - nu_j^2) / E_j) (a side without ``young_`` is rigid).

* Curved on curved or on flat (Hertz, a point contact): K = 4/3 E* sqrt(R*) (N/m^1.5,
  exponent 1.5), 1/R* = 1/R_i + 1/R_j, with R = the radius of a sphere, capsule or cylinder
  (its rim or side taken as a sphere of its radius: a documented choice, the line contact of a
  cylinder on its side is not modelled by Hertz), the equivalent-volume radius (a b c)^(1/3)
  of an ellipsoid, -R of a socket, and 0 curvature for planes, boxes and hulls.
* Flat on flat (box, hull or cylinder cap on a plane, box or hull -- the flat punch): a rigid
  circular punch of radius a pressed into an elastic half-space, K_face = 2 E* a (N/m,
  exponent 1, Johnson, Contact Mechanics, 1985, Eq. 3.33), with a = sqrt(A / pi) for the
  largest face area A of the smaller flat body (a box's largest face, a hull's largest face) or
  a = R for a cylinder's cap. The face's points share it: each of a box's or hull's contact
  points gets K_face / 4 (a face resting on four corners), each of a cylinder's rim points
  K_face / 3 (a tripod per cap on a plane; 4 rim points on a box or hull), so a face resting
  flat has the stiffness K_face.
"""
from __future__ import annotations

import math

from ...errors import ModelError

FLAT = ("plane", "box", "convex")


def _err(name, key, text):
    return ModelError(f"forces[{name!r}].{key}: {text}")


def effective_modulus(spec, number):
    name, p = spec.name, spec.params
    inv = 0.0
    for side in ("i", "j"):
        if f"young_{side}" in p:
            E = number(name, f"young_{side}", p[f"young_{side}"], 0.0, True)
            nu = number(name, f"poisson_{side}", p.get(f"poisson_{side}", 0.3), -1.0, True, 0.5)
            inv += (1.0 - nu * nu) / E
    if inv == 0.0:
        raise _err(name, "stiffness", "give a stiffness (N/m^n) or the materials (young_i / "
                                      "young_j in Pa, poisson_i / poisson_j)")
    return 1.0 / inv


def _radius(shape):
    """Radius of curvature (m) of a shape for Hertz: > 0 convex, < 0 concave, 0 flat."""
    kind, radius, half_length, half, verts = shape
    if kind in ("sphere", "capsule", "cylinder", "journal"):
        return radius
    if kind in ("socket", "bearing"):
        return -radius
    if kind == "ellipsoid":
        return float(half.prod()) ** (1.0 / 3.0)
    return 0.0


def _face_area(shape):
    kind, radius, half_length, half, verts = shape
    if kind == "box":
        a, b, c = sorted(2.0 * half)
        return b * c
    if kind == "convex":
        from .convex_shapes import largest_face_area
        return largest_face_area(verts)
    if kind == "cylinder":
        return math.pi * radius * radius
    return math.inf


def from_materials(spec, shape_i, shape_j, number):
    """(K per contact point, exponent) of a pair from the materials (module docstring);
    shape_*: (kind, radius, half_length, half extents, vertices)."""
    name = spec.name
    E = effective_modulus(spec, number)
    ki, kj = shape_i[0], shape_j[0]
    flat_i = ki in FLAT or (ki == "cylinder" and kj in FLAT)
    flat_j = kj in FLAT or (kj == "cylinder" and ki in FLAT)
    if flat_i and flat_j:
        area = min(_face_area(shape_i), _face_area(shape_j))
        if not math.isfinite(area):
            raise _err(name, "stiffness", "two planes cannot touch")
        points = 3 if {ki, kj} == {"plane", "cylinder"} else 4
        return 2.0 * E * math.sqrt(area / math.pi) / points, 1.0
    if (ki, kj) == ("socket", "socket"):
        raise _err(name, "stiffness", "a socket-socket pair has no contact")
    k = sum(1.0 / r for r in (_radius(shape_i), _radius(shape_j)) if r != 0.0)
    if not k > 0:
        raise _err(name, "stiffness", f"the {ki}-{kj} pair has no positive relative "
                                      "curvature: give a stiffness")
    return 4.0 / 3.0 * E * math.sqrt(1.0 / k), 1.5
