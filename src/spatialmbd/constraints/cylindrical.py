"""Cylindrical joint (Nikravesh 1988): the translational joint without its twist equation,
four equations leaving a rotation about and a translation along the common axis.
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Cylindrical(ConstraintType):
    name = "cylindrical"
    n_eq = 4
    eq_labels = ("axis.a", "axis.b", "offset.a", "offset.b")
    driver_kinds = ("angle", "translation")

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        a_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 1], 1)
        b_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 2], 1)
        return self._scleronomic(*prim.stack(prim.dot(u_i, a_j), prim.dot(u_i, b_j),
                                             prim.dot(a_j, d), prim.dot(b_j, d)))
