"""Cylindrical joint (Nikravesh 1988): the translational joint without its twist equation,
four equations leaving a rotation about and a translation along the common axis.
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
    put_dot(a_j, d, out, row + 2)
    put_dot(b_j, d, out, row + 3)


@register
class Cylindrical(ConstraintType):
    name = "cylindrical"
    n_eq = 4
    eq_labels = ("axis.a", "axis.b", "offset.a", "offset.b")
    driver_kinds = ("angle", "translation")
    inputs = frozenset({"point", "axis"})
    kernel = staticmethod(kernel)
