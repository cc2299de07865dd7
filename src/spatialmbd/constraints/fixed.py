"""Fixed (weld) joint: a spherical joint plus three n1 constraints that lock the relative
orientation (u_i.a_j = 0, u_i.b_j = 0, a_i.b_j = 0, with the triads coincident when assembled);
six equations.
"""
from __future__ import annotations

from ..jit import njit
from .base import ConstraintType, register
from .primitives import kin_sub, point, put_dot, put_vector, vector


@njit
def kernel(S, G, k, row, out):
    i, j = G.bi[k], G.bj[k]
    d = kin_sub(point(S, j, G.s_j, k, 1), point(S, i, G.s_i, k, 0))
    u_i = vector(S, i, G.R_i, k, 0, 0)
    a_i = vector(S, i, G.R_i, k, 1, 0)
    a_j = vector(S, j, G.R_j, k, 1, 1)
    b_j = vector(S, j, G.R_j, k, 2, 1)
    put_vector(d, out, row)
    put_dot(u_i, a_j, out, row + 3)
    put_dot(u_i, b_j, out, row + 4)
    put_dot(a_i, b_j, out, row + 5)


@register
class Fixed(ConstraintType):
    name = "fixed"
    n_eq = 6
    eq_labels = ("x", "y", "z", "axis.a", "axis.b", "twist")
    inputs = frozenset({"point"})
    kernel = staticmethod(kernel)
