"""Planar joint: body j slides and turns in a plane of body i whose normal is the joint axis u_i.
The plane of j (spanned by a_j, b_j) stays parallel to it (n1: u_i.a_j = 0, u_i.b_j = 0) and the
joint point of j stays in it (n2: u_i.d = 0); three equations.
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
    a_j = vector(S, j, G.R_j, k, 1, 1)
    b_j = vector(S, j, G.R_j, k, 2, 1)
    put_dot(u_i, a_j, out, row)
    put_dot(u_i, b_j, out, row + 1)
    put_dot(u_i, d, out, row + 2)


@register
class Planar(ConstraintType):
    name = "planar"
    n_eq = 3
    eq_labels = ("normal.a", "normal.b", "offset")
    inputs = frozenset({"point", "axis"})
    kernel = staticmethod(kernel)
