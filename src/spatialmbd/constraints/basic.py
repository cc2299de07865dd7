"""The basic constraints between two vectors, usable on their own (text ch. 8).

    n1: s_i . s_j = 0           (8.5)   s_i = u_i on body i, s_j = u_j on body j
    n2: s_i . d = 0             (8.6)   d from P_i to P_j (8.4)
    p1: s_i || s_j              (8.9)   s_i . a_j = 0, s_i . b_j = 0 with a_j, b_j normal to s_j
    p2: s_i || d                        d . a_i = 0, d . b_i = 0 with a_i, b_i normal to s_i

p1 and p2 use two dot products rather than two rows of the cross product (8.7)-(8.8), which
avoids the critical case of vectors parallel to a global axis discussed after (8.8).
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


def _d(self, state):
    g = self.geometry
    return (prim.body_point(state, self.body_j, g.s_j, 1)
            - prim.body_point(state, self.body_i, g.s_i, 0))


@register
class Normal1(ConstraintType):
    name = "n1"
    n_eq = 1
    eq_labels = ("n1",)

    def evaluate(self, state, t):
        g = self.geometry
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        u_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 0], 1)
        return self._scleronomic(*prim.dot(u_i, u_j))


@register
class Normal2(ConstraintType):
    name = "n2"
    n_eq = 1
    eq_labels = ("n2",)

    def evaluate(self, state, t):
        u_i = prim.body_vector(state, self.body_i, self.geometry.R_i[:, :, 0], 0)
        return self._scleronomic(*prim.dot(u_i, _d(self, state)))


@register
class Parallel1(ConstraintType):
    name = "p1"
    n_eq = 2
    eq_labels = ("p1.a", "p1.b")

    def evaluate(self, state, t):
        g = self.geometry
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        a_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 1], 1)
        b_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 2], 1)
        return self._scleronomic(*prim.stack(prim.dot(u_i, a_j), prim.dot(u_i, b_j)))


@register
class Parallel2(ConstraintType):
    name = "p2"
    n_eq = 2
    eq_labels = ("p2.a", "p2.b")

    def evaluate(self, state, t):
        g = self.geometry
        a_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 1], 0)
        b_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 2], 0)
        d = _d(self, state)
        return self._scleronomic(*prim.stack(prim.dot(d, a_i), prim.dot(d, b_i)))
