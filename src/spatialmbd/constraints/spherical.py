"""Spherical (ball) joint, Phi^(s,3): r_j^P - r_i^P = 0, Eqs. (9.1)-(9.8).

D = [-I, s~_i^P, I, -s~_j^P] (9.5); gamma = omega~_i sdot_i - omega~_j sdot_j (ERRATA for (9.8):
the printed -s~_i omega_i + s~_j omega_j is a velocity, not an acceleration term).
"""
from __future__ import annotations

from . import primitives as prim
from .base import ConstraintType, register


@register
class Spherical(ConstraintType):
    name = "spherical"
    n_eq = 3
    eq_labels = ("x", "y", "z")

    def evaluate(self, state, t):
        g = self.geometry
        d = (prim.body_point(state, self.body_j, g.s_j, 1)
             - prim.body_point(state, self.body_i, g.s_i, 0))      # Eq. (9.1)
        return self._scleronomic(*prim.vector_equation(d))
