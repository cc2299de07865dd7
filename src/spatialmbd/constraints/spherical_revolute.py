"""Spherical-revolute composite joint (Nikravesh 1988): a massless link of length l, pinned to
body i by a revolute joint of axis u_i at P_i and to body j by a spherical joint at P_j. The
link stays normal to the axis (n2: u_i.d = 0) and keeps its length (d.d - l^2 = 0).
"""
from __future__ import annotations

from ..jit import njit
from .base import LINK_LENGTH, ConstraintType, register
from .primitives import kin_sub, point, put_dot, vector


@njit
def kernel(S, G, k, row, out):
    i, j = G.bi[k], G.bj[k]
    d = kin_sub(point(S, j, G.s_j, k, 1), point(S, i, G.s_i, k, 0))
    u_i = vector(S, i, G.R_i, k, 0, 0)
    put_dot(u_i, d, out, row)
    put_dot(d, d, out, row + 1)
    out[0][row + 1] -= G.param[k, 0] ** 2


@register
class SphericalRevolute(ConstraintType):
    name = "spherical_revolute"
    drawn_as = "link"
    n_eq = 2
    eq_labels = ("normal", "distance")
    inputs = frozenset({"point", "axis", "point2"})
    parameters = (LINK_LENGTH,)
    kernel = staticmethod(kernel)
