"""Planar joint: body j slides and turns in a plane of body i whose normal is the joint axis u_i.
The plane of j (spanned by a_j, b_j) stays parallel to it (n1: u_i.a_j = 0, u_i.b_j = 0) and the
joint point of j stays in it (n2: u_i.d = 0); three equations.
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Planar(ConstraintType):
    name = "planar"
    n_eq = 3
    eq_labels = ("normal.a", "normal.b", "offset")

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        a_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 1], 1)
        b_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 2], 1)
        return self._scleronomic(*prim.stack(prim.dot(u_i, a_j), prim.dot(u_i, b_j),
                                             prim.dot(u_i, d)))
