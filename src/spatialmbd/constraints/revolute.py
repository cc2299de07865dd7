"""Revolute joint, Phi^(r,5): a spherical joint at the joint point plus two n1 constraints that
keep the axis u_i of body i normal to a_j and b_j of body j, Eqs. (9.9)-(9.17).

D rows (9.13): [-I, s~_i, I, -s~_j]; [0, (u_i x a_j)^T, 0, -(u_i x a_j)^T]; same with b_j.
(The text's -a_j^T s~_i equals (s_i x a_j)^T: the same row written with s_i = u_i.)
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Revolute(ConstraintType):
    name = "revolute"
    n_eq = 5
    eq_labels = ("x", "y", "z", "axis.a", "axis.b")
    driver_kinds = ("angle",)

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        a_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 1], 1)
        b_j = prim.body_vector(state, self.body_j, g.R_j[:, :, 2], 1)
        return self._scleronomic(*prim.stack(prim.vector_equation(d),   # Eq. (9.1)
                                             prim.dot(u_i, a_j),         # Eq. (9.9) n1
                                             prim.dot(u_i, b_j)))        # Eq. (9.9) n1
