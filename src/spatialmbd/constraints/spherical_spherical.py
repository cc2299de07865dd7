"""Spherical-spherical (distance) joint, Phi^(s-s,1) = d^T d - l^2, Eqs. (9.18)-(9.26).

D = [-2d^T, 2d^T s~_i, 2d^T, -2d^T s~_j] (9.23; ERRATA: (9.25) prints the signs wrongly) and
gamma = 2 d^T (omega~_i sdot_i - omega~_j sdot_j) - 2 ddot^T ddot (ERRATA for (9.26)).
"""
from __future__ import annotations

from ..jit import njit
from .base import LINK_LENGTH, ConstraintType, register
from .primitives import kin_sub, point, put_dot


@njit
def kernel(S, G, k, row, out):
    d = kin_sub(point(S, G.bj[k], G.s_j, k, 1), point(S, G.bi[k], G.s_i, k, 0))     # Eq. (9.19)
    put_dot(d, d, out, row)
    out[0][row] -= G.param[k, 0] ** 2                                            # Eq. (9.18)


@register
class SphericalSpherical(ConstraintType):
    name = "spherical_spherical"
    drawn_as = "link"
    n_eq = 1
    eq_labels = ("distance",)
    inputs = frozenset({"point", "point2"})
    parameters = (LINK_LENGTH,)
    kernel = staticmethod(kernel)
