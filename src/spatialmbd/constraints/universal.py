"""Universal (Hooke) joint (Nikravesh 1988): a spherical joint plus one n1 constraint that keeps
the cross axis u_i of body i normal to the cross axis u_j of body j; four equations.
"""
from __future__ import annotations

from ..jit import njit
from .base import ConstraintType, register
from .primitives import kin_sub, point, put_dot, put_vector, vector


@njit
def kernel(S, G, k, row, out):
    bi, bj, s_i, s_j, R_i, R_j, length, law, coord = G
    i, j = bi[k], bj[k]
    d = kin_sub(point(S, j, s_j, k, 1), point(S, i, s_i, k, 0))
    u_i = vector(S, i, R_i, k, 0, 0)
    u_j = vector(S, j, R_j, k, 0, 1)
    put_vector(d, out, row)
    put_dot(u_i, u_j, out, row + 3)


@register
class Universal(ConstraintType):
    name = "universal"
    n_eq = 4
    eq_labels = ("x", "y", "z", "cross")
