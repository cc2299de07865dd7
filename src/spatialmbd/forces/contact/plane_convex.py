"""A plane against a cylinder or an ellipsoid (closed forms, compiled). A plane against a convex
hull is one plane-point contact per vertex (like the box's eight, .geometry's PLANE_POINT).

Cylinder (radius R, half height h, axis e2) under the plane (outward normal n, frame i): the
deepest point of the rim of cap z = +-h is at angle theta_0, the direction of -n in the cap's
plane (e0, e1), theta_0 = atan2(-n . e1, -n . e0), which is where the plane meets the rim first
whichever way the cylinder leans: a cylinder on its side touches along a line whose ends are the
two caps' deepest points. Each cap carries three rim points, theta_0 and theta_0 +- 120 deg,
so a cylinder standing on its cap rests on a tripod that does not rock (slots 0-2: cap +h,
3-5: cap -h). theta_0 of an upright cap is undefined; there (|n x e2| < 1e-12) theta_0 = 0, and
every rim point has the same gap, so the gaps stay continuous. The gap rate is exactly
n . v_rel for the deepest points (stationary on the rim); for the other two points it is exact
when the cap is flat and off by R sin(tilt) sin(120 deg) theta_0' otherwise.

Ellipsoid (semi-axes a, b, c): the deepest point is the support point in -n,
s = -D^2 n' / |D n'| (D = diag(a, b, c), n' = n in the ellipsoid's axes): one contact point,
stationary, so the gap rate is exact.
"""
from __future__ import annotations

import math

from ...constraints.primitives import v_dot, v_scale, v_sub
from ...jit import njit
from .support import CYLINDER, S_D0, S_KIND, support, to_global, to_local

#: rim points per cap
RIM = 3


@njit
def plane_core_points(P, o, fp, fj, slot):
    """(q_i on the plane, q_j on the shape, n) of slot ``slot`` for the shape block P[o:]
    (frame fj) under the plane of frame fp (normal: its third axis)."""
    n = fp[3]
    if int(P[o + S_KIND]) == CYLINDER:
        R, h = P[o + S_D0], P[o + S_D0 + 2]
        dl = to_local(fj, v_scale(-1.0, n))
        rho = math.sqrt(dl[0] * dl[0] + dl[1] * dl[1])
        theta = math.atan2(dl[1], dl[0]) if rho > 1e-12 else 0.0
        theta += (slot % RIM) * 2.0 * math.pi / RIM
        z = h if slot < RIM else -h
        p = to_global(fj, (R * math.cos(theta), R * math.sin(theta), z))
    else:
        p = support(P, o, fj, v_scale(-1.0, n))
    depth = v_dot(n, v_sub(p, fp[0]))
    return v_sub(p, v_scale(depth, n)), p, n
