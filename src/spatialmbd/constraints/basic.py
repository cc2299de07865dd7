"""The basic constraints between two vectors, usable on their own (text ch. 8).

    n1: s_i . s_j = 0           (8.5)   s_i = u_i on body i, s_j = u_j on body j
    n2: s_i . d = 0             (8.6)   d from P_i to P_j (8.4)
    p1: s_i || s_j              (8.9)   s_i . a_j = 0, s_i . b_j = 0 with a_j, b_j normal to s_j
    p2: s_i || d                        d . a_i = 0, d . b_i = 0 with a_i, b_i normal to s_i

p1 and p2 use two dot products rather than two rows of the cross product (8.7)-(8.8), which
avoids the critical case of vectors parallel to a global axis discussed after (8.8).
"""
from __future__ import annotations

from ..jit import njit
from .base import ConstraintType, register
from .primitives import kin_sub, point, put_dot, vector


@njit
def _d(S, G, k):
    return kin_sub(point(S, G.bj[k], G.s_j, k, 1), point(S, G.bi[k], G.s_i, k, 0))


@njit
def kernel_n1(S, G, k, row, out):
    put_dot(vector(S, G.bi[k], G.R_i, k, 0, 0), vector(S, G.bj[k], G.R_j, k, 0, 1), out, row)


@njit
def kernel_n2(S, G, k, row, out):
    put_dot(vector(S, G.bi[k], G.R_i, k, 0, 0), _d(S, G, k), out, row)


@njit
def kernel_p1(S, G, k, row, out):
    u_i = vector(S, G.bi[k], G.R_i, k, 0, 0)
    put_dot(u_i, vector(S, G.bj[k], G.R_j, k, 1, 1), out, row)
    put_dot(u_i, vector(S, G.bj[k], G.R_j, k, 2, 1), out, row + 1)


@njit
def kernel_p2(S, G, k, row, out):
    d = _d(S, G, k)
    put_dot(d, vector(S, G.bi[k], G.R_i, k, 1, 0), out, row)
    put_dot(d, vector(S, G.bi[k], G.R_i, k, 2, 0), out, row + 1)


@register
class Normal1(ConstraintType):
    """n1: the vector u_i of body i stays normal to u_j of body j, Eq. (8.5)."""

    name = "n1"
    n_eq = 1
    eq_labels = ("n1",)
    inputs = frozenset({"axis", "axis2"})
    kernel = staticmethod(kernel_n1)


@register
class Normal2(ConstraintType):
    """n2: the vector u_i of body i stays normal to d from P_i to P_j, Eq. (8.6)."""

    name = "n2"
    n_eq = 1
    eq_labels = ("n2",)
    inputs = frozenset({"axis", "point", "point2"})
    kernel = staticmethod(kernel_n2)


@register
class Parallel1(ConstraintType):
    """p1: the vector u_i of body i stays parallel to u_j of body j (two dot products), Eq. (8.9)."""

    name = "p1"
    n_eq = 2
    eq_labels = ("p1.a", "p1.b")
    inputs = frozenset({"axis", "axis2"})
    kernel = staticmethod(kernel_p1)


@register
class Parallel2(ConstraintType):
    """p2: the vector d from P_i to P_j stays parallel to u_i of body i (two dot products)."""

    name = "p2"
    n_eq = 2
    eq_labels = ("p2.a", "p2.b")
    inputs = frozenset({"axis", "point", "point2"})
    kernel = staticmethod(kernel_p2)
