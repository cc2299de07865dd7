"""Revolute joint, Phi^(r,5): a spherical joint at the joint point plus two n1 constraints that
keep the axis u_i of body i normal to a_j and b_j of body j, Eqs. (9.9)-(9.17).

D rows (9.13): [-I, s~_i, I, -s~_j]; [0, (u_i x a_j)^T, 0, -(u_i x a_j)^T]; same with b_j.
(The text's -a_j^T s~_i equals (s_i x a_j)^T: the same row written with s_i = u_i.)
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
    a_j = vector(S, j, G.R_j, k, 1, 1)
    b_j = vector(S, j, G.R_j, k, 2, 1)
    put_vector(d, out, row)                  # Eq. (9.1)
    put_dot(u_i, a_j, out, row + 3)          # Eq. (9.9) n1
    put_dot(u_i, b_j, out, row + 4)          # Eq. (9.9) n1


@register
class Revolute(ConstraintType):
    name = "revolute"
    n_eq = 5
    eq_labels = ("x", "y", "z", "axis.a", "axis.b")
    driver_kinds = ("angle",)
    inputs = frozenset({"point", "axis"})
    kernel = staticmethod(kernel)
