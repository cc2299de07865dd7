"""Spherical-spherical (distance) joint, Phi^(s-s,1) = d^T d - l^2, Eqs. (9.18)-(9.26).

D = [-2d^T, 2d^T s~_i, 2d^T, -2d^T s~_j] (9.23; ERRATA: (9.25) prints the signs wrongly) and
gamma = 2 d^T (omega~_i sdot_i - omega~_j sdot_j) - 2 ddot^T ddot (ERRATA for (9.26)).
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class SphericalSpherical(ConstraintType):
    name = "spherical_spherical"
    n_eq = 1
    eq_labels = ("distance",)

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))      # Eq. (9.19)
        phi, D, gamma = prim.dot(d, d)
        return self._scleronomic(phi - g.length**2, D, gamma)    # Eq. (9.18)
