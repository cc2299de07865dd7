"""Fixed (weld) joint: a spherical joint plus three n1 constraints that lock the relative
orientation (u_i.a_j = 0, u_i.b_j = 0, a_i.b_j = 0, with the triads coincident when assembled);
six equations.
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Fixed(ConstraintType):
    name = "fixed"
    n_eq = 6
    eq_labels = ("x", "y", "z", "axis.a", "axis.b", "twist")

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        a_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 1], 0)
        a_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 1], 1)
        b_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 2], 1)
        return self._scleronomic(*prim.stack(prim.vector_equation(d), prim.dot(u_i, a_j),
                                             prim.dot(u_i, b_j), prim.dot(a_i, b_j)))
