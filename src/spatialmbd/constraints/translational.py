"""Translational (prismatic) joint (Nikravesh 1988, sec. 9.4): five equations.

The axis u_i of body i stays parallel to the axis of body j (n1: u_i.a_j = 0, u_i.b_j = 0), the
vector d from the joint point of i to that of j stays along the axis (n2: a_j.d = 0, b_j.d = 0),
and the bodies do not rotate about the axis (n1: a_i.b_j = 0).
"""
from __future__ import annotations

from ..jit import njit
from .base import ConstraintType, register
from .primitives import kin_sub, point, put_dot, vector


@njit
def kernel(S, G, k, row, out):
    i, j = G.bi[k], G.bj[k]
    d = kin_sub(point(S, j, G.s_j, k, 1), point(S, i, G.s_i, k, 0))
    u_i = vector(S, i, G.R_i, k, 0, 0)
    a_i = vector(S, i, G.R_i, k, 1, 0)
    a_j = vector(S, j, G.R_j, k, 1, 1)
    b_j = vector(S, j, G.R_j, k, 2, 1)
    put_dot(u_i, a_j, out, row)
    put_dot(u_i, b_j, out, row + 1)
    put_dot(a_j, d, out, row + 2)
    put_dot(b_j, d, out, row + 3)
    put_dot(a_i, b_j, out, row + 4)


@register
class Translational(ConstraintType):
    name = "translational"
    n_eq = 5
    eq_labels = ("axis.a", "axis.b", "offset.a", "offset.b", "twist")
    driver_kinds = ("translation",)
    inputs = frozenset({"point", "axis"})
    kernel = staticmethod(kernel)
