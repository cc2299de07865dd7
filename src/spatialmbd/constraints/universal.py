"""Universal (Hooke) joint (Nikravesh 1988): a spherical joint plus one n1 constraint that keeps
the cross axis u_i of body i normal to the cross axis u_j of body j; four equations.
"""
from __future__ import annotations

from ..errors import ModelError
from ..jit import njit
from .base import ConstraintType, register
from .primitives import kin_sub, point, put_dot, put_vector, vector


@njit
def kernel(S, G, k, row, out):
    i, j = G.bi[k], G.bj[k]
    d = kin_sub(point(S, j, G.s_j, k, 1), point(S, i, G.s_i, k, 0))
    u_i = vector(S, i, G.R_i, k, 0, 0)
    u_j = vector(S, j, G.R_j, k, 0, 1)
    put_vector(d, out, row)
    put_dot(u_i, u_j, out, row + 3)


@register
class Universal(ConstraintType):
    name = "universal"
    n_eq = 4
    eq_labels = ("x", "y", "z", "cross")
    inputs = frozenset({"point", "axis", "axis2"})
    kernel = staticmethod(kernel)

    @classmethod
    def check_assembled(cls, what, axis_i, axis_j):
        cos = float(axis_i @ axis_j)
        if abs(cos) > 1e-6:
            raise ModelError(f"{what}: the two cross axes of a universal joint must be "
                             f"perpendicular when assembled (cos of their angle = {cos:.3g})")
