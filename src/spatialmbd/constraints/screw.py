"""Screw (helical) joint: a cylindrical joint whose translation follows its rotation,
x = h theta / (2 pi), with the pitch h (m per revolution; h > 0 a right-handed thread: body j
advances along +u_i when it turns positively about u_i). Five equations, one degree of freedom.

Rows 0-3 are the cylindrical joint's. Row 4 uses the joint angle theta of
:func:`.primitives.angle_row` and the translation x = u_i . d of
:func:`.primitives.translation_row`, with the lead l = h / (2 pi):

    Phi_4   = l wrap(x / l - theta)        (wrap to [-pi, pi): every turn of the thread fits)
    D_4     = D_x - l D_theta
    gamma_4 = -(x''_quad - l theta''_quad)
"""
from __future__ import annotations

import math

from ..jit import njit
from .base import ConstraintType, Param, register
from .cylindrical import kernel as cylindrical_kernel
from .drivers import wrap_angle
from .primitives import angle_row, translation_row


@njit
def kernel(S, G, k, row, out):
    phi, D, nu, gamma = out
    i, j = G.bi[k], G.bj[k]
    lead = G.param[k, 0] / (2.0 * math.pi)
    # the angle's row is written to row (scratch, overwritten by the cylindrical rows below)
    theta, thetad, quad_theta = angle_row(S, i, j, G.R_i, G.R_j, k, D, row)
    x, xd, quad_x = translation_row(S, i, j, G.s_i, G.s_j, G.R_i, k, D, row + 4)
    for c in range(12):
        D[row + 4, c] -= lead * D[row, c]
    phi[row + 4] = lead * wrap_angle(x / lead - theta)
    nu[row + 4] = 0.0
    gamma[row + 4] = -(quad_x - lead * quad_theta)
    cylindrical_kernel(S, G, k, row, out)


@register
class Screw(ConstraintType):
    """Screw (helical) joint: rotation about and translation along a common axis, coupled by
    the pitch."""

    name = "screw"
    aliases = ("helical",)
    n_eq = 5
    eq_labels = ("axis.a", "axis.b", "offset.a", "offset.b", "thread")
    inputs = frozenset({"point", "axis"})
    parameters = (Param("pitch", "m/rev", "advance along the axis per revolution (negative: "
                        "left-handed thread)", nonzero=True),)
    driver_kinds = ("angle", "translation")
    angle_based = True
    kernel = staticmethod(kernel)
