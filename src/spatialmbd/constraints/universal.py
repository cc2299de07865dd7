"""Universal (Hooke) joint (Nikravesh 1988): a spherical joint plus one n1 constraint that keeps
the cross axis u_i of body i normal to the cross axis u_j of body j; four equations.
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Universal(ConstraintType):
    name = "universal"
    n_eq = 4
    eq_labels = ("x", "y", "z", "cross")

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        u_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 0], 1)
        return self._scleronomic(*prim.stack(prim.vector_equation(d), prim.dot(u_i, u_j)))
