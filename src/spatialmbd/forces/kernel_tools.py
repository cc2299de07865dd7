"""Compiled helpers shared by the force-element kernels."""
from __future__ import annotations

import math

import numpy as np

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


#: the joint coordinates a joint-limit or joint-friction element acts on (param column 0);
#: ROTATION_ANGLE: the angle of a spherical joint's whole relative rotation (a joint limit)
ANGLE, TRANSLATION, CONE, ROTATION, ROTATION_ANGLE = 0, 1, 2, 3, 4


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
    if kind == ROTATION_ANGLE:
        return rotation_angle(S, G, k, D)
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


@njit
def rotation_angle(S, G, k, D):
    """(theta, theta') of the relative rotation C = F_i^T F_j of the joint frames F = A R
    (C = I as assembled): theta = atan2(|vee(C - C^T)| / 2, (tr C - 1) / 2) in [0, pi], MuJoCo's
    ball-joint angle |quat2vel|; theta' = n . (omega_j - omega_i) with the rotation axis n
    (global), so D[0] = [0, -n, 0, n] (zero at theta = 0, where n is undefined)."""
    A, w = S[1], S[3]
    i, j = G.bi[k], G.bj[k]
    Fi = np.empty((3, 3))
    Fj = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            Fi[a, b] = A[i, a, 0] * G.R_i[k, 0, b] + A[i, a, 1] * G.R_i[k, 1, b] \
                + A[i, a, 2] * G.R_i[k, 2, b]
            Fj[a, b] = A[j, a, 0] * G.R_j[k, 0, b] + A[j, a, 1] * G.R_j[k, 1, b] \
                + A[j, a, 2] * G.R_j[k, 2, b]
    C = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            C[a, b] = Fi[0, a] * Fj[0, b] + Fi[1, a] * Fj[1, b] + Fi[2, a] * Fj[2, b]
    s0, s1, s2 = 0.5 * (C[2, 1] - C[1, 2]), 0.5 * (C[0, 2] - C[2, 0]), 0.5 * (C[1, 0] - C[0, 1])
    sn = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    theta = math.atan2(sn, 0.5 * (C[0, 0] + C[1, 1] + C[2, 2] - 1.0))
    clear_row(D, 0)
    if sn < 1e-12:
        return theta, 0.0
    n = (Fi[0, 0] * s0 + Fi[0, 1] * s1 + Fi[0, 2] * s2,
         Fi[1, 0] * s0 + Fi[1, 1] * s1 + Fi[1, 2] * s2,
         Fi[2, 0] * s0 + Fi[2, 1] * s1 + Fi[2, 2] * s2)
    rate = 0.0
    for c in range(3):
        nc = n[c] / sn
        D[0, 3 + c] = -nc
        D[0, 9 + c] = nc
        rate += nc * (w[j, c] - w[i, c])
    return theta, rate


@njit(inline="always")
def add_coordinate_force(g, G, k, D, Q):
    """g_ij += Q D[0]^T: the generalized force Q (N or N m) along the coordinate of D[0]."""
    i, j = G.bi[k], G.bj[k]
    add_wrench(g, i, Q * D[0, 0], Q * D[0, 1], Q * D[0, 2], Q * D[0, 3], Q * D[0, 4],
               Q * D[0, 5])
    add_wrench(g, j, Q * D[0, 6], Q * D[0, 7], Q * D[0, 8], Q * D[0, 9], Q * D[0, 10],
               Q * D[0, 11])
