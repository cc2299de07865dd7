"""Spherical (ball) joint, Phi^(s,3): r_j^P - r_i^P = 0, Eqs. (9.1)-(9.8).

D = [-I, s~_i^P, I, -s~_j^P] (9.5); gamma = omega~_i sdot_i - omega~_j sdot_j (ERRATA for (9.8):
the printed -s~_i omega_i + s~_j omega_j is a velocity, not an acceleration term).
"""
from __future__ import annotations

from ..jit import njit
from .base import ConstraintType, register
from .primitives import kin_sub, point, put_vector


@njit
def kernel(S, G, k, row, out):
    d = kin_sub(point(S, G.bj[k], G.s_j, k, 1), point(S, G.bi[k], G.s_i, k, 0))     # Eq. (9.1)
    put_vector(d, out, row)


@register
class Spherical(ConstraintType):
    name = "spherical"
    n_eq = 3
    eq_labels = ("x", "y", "z")
    inputs = frozenset({"point"})
    kernel = staticmethod(kernel)
