"""Spherical-revolute composite joint (Nikravesh 1988): a massless link of length l, pinned to
body i by a revolute joint of axis u_i at P_i and to body j by a spherical joint at P_j. The
link stays normal to the axis (n2: u_i.d = 0) and keeps its length (d.d - l^2 = 0).
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class SphericalRevolute(ConstraintType):
    name = "spherical_revolute"
    n_eq = 2
    eq_labels = ("normal", "distance")

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))
        u_i = prim.body_vector(state, self.body_i, g.R_i[:, :, 0], 0)
        phi_d, D_d, gamma_d = prim.dot(d, d)
        return self._scleronomic(*prim.stack(prim.dot(u_i, d),
                                             (phi_d - g.length**2, D_d, gamma_d)))
