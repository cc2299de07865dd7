"""Translational (prismatic) joint (Nikravesh 1988, sec. 9.4): five equations.

The axis u_i of body i stays parallel to the axis of body j (n1: u_i.a_j = 0, u_i.b_j = 0), the
vector d from the joint point of i to that of j stays along the axis (n2: a_j.d = 0, b_j.d = 0),
and the bodies do not rotate about the axis (n1: a_i.b_j = 0).
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Translational(ConstraintType):
    name = "translational"
    n_eq = 5
    eq_labels = ("axis.a", "axis.b", "offset.a", "offset.b", "twist")
    driver_kinds = ("translation",)

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        a_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 1], 0)
        a_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 1], 1)
        b_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 2], 1)
        return self._scleronomic(*prim.stack(prim.dot(u_i, a_j), prim.dot(u_i, b_j),
                                             prim.dot(a_j, d), prim.dot(b_j, d),
                                             prim.dot(a_i, b_j)))
