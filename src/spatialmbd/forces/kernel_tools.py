"""Compiled helpers shared by the force-element kernels."""
from __future__ import annotations

import math

from ..constraints.drivers import wrap_angle
from ..constraints.primitives import (add_dot_row, angle_row, clear_row, dot_rate, dot_value,
                                      translation_row, vector)
from ..jit import njit


@njit(inline="always")
def add_wrench(g, b, f0, f1, f2, n0, n1, n2):
    """g[6 b : 6 b + 6] += [f, n] unless b is the ground (index nb, beyond g)."""
    o = 6 * b
    if o + 5 < g.size:
        g[o] += f0
        g[o + 1] += f1
        g[o + 2] += f2
        g[o + 3] += n0
        g[o + 4] += n1
        g[o + 5] += n2


#: the joint coordinates a joint-limit or joint-friction element acts on (param column 0)
ANGLE, TRANSLATION, CONE, ROTATION = 0, 1, 2, 3


@njit(inline="always")
def joint_coordinate(S, G, k, D, centre):
    """(x, xdot) of the scalar coordinate of instance k (kind G.param[k, 0]), its Jacobian
    over v_ij into D[0]:

    * ANGLE: the joint angle of :func:`~spatialmbd.constraints.primitives.angle_row`, as
      centre + wrap(theta - centre) (continuous except half a turn away from ``centre``);
    * TRANSLATION: u_i . d of :func:`~spatialmbd.constraints.primitives.translation_row`;
    * CONE: the angle acos(u_i . u_j) between the first columns of R_i and R_j (its Jacobian
      -D(u_i . u_j) / sin(angle); zero rate and row at the singular angles 0 and pi)."""
    i, j = G.bi[k], G.bj[k]
    kind = int(G.param[k, 0])
    if kind == ANGLE:
        theta, thetad, _ = angle_row(S, i, j, G.R_i, G.R_j, k, D, 0)
        return centre + wrap_angle(theta - centre), thetad
    if kind == TRANSLATION:
        x, xd, _ = translation_row(S, i, j, G.s_i, G.s_j, G.R_i, k, D, 0)
        return x, xd
    u_i = vector(S, i, G.R_i, k, 0, 0)
    u_j = vector(S, j, G.R_j, k, 0, 1)
    c = dot_value(u_i, u_j)
    c = 1.0 if c > 1.0 else (-1.0 if c < -1.0 else c)
    angle = math.acos(c)
    s = math.sqrt(1.0 - c * c)
    clear_row(D, 0)
    if s < 1e-12:
        return angle, 0.0
    add_dot_row(u_i, u_j, -1.0 / s, D, 0)
    return angle, -dot_rate(u_i, u_j) / s


@njit(inline="always")
def add_coordinate_force(g, G, k, D, Q):
    """g_ij += Q D[0]^T: the generalized force Q (N or N m) along the coordinate of D[0]."""
    i, j = G.bi[k], G.bj[k]
    add_wrench(g, i, Q * D[0, 0], Q * D[0, 1], Q * D[0, 2], Q * D[0, 3], Q * D[0, 4],
               Q * D[0, 5])
    add_wrench(g, j, Q * D[0, 6], Q * D[0, 7], Q * D[0, 8], Q * D[0, 9], Q * D[0, 10],
               Q * D[0, 11])
