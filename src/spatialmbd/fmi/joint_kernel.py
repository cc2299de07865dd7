"""Joint coordinates of one state, compiled: the co-simulation's per-step outputs.

The same angle and translation as :func:`spatialmbd.outputs.joint_coordinates` (its module
docstring gives the conventions), for the joints with an axis (revolute, translational,
cylindrical, screw), evaluated on the state vector y = [q (7 nb), v (6 nb), ...] in one call
for all of them (no Python per joint and step):

    theta = atan2(b_i . a_j, a_i . a_j)          a, b the joint frame's normal axes
    d     = P_j - P_i,  s = u_i . d              u_i the axis of body i
    rates: e' = omega x e (every body-fixed vector e, omega global), Eq. (5.8)

Body index nb is the ground (identity orientation, at rest).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit

#: the joint types of the compiled path and their coordinates
AXIS_JOINTS = ("revolute", "translational", "cylindrical", "screw")


@njit
def _frame(y, nb, b, A, r, rdot, omega):
    """A (3, 3), r, rdot, omega (3,) of body b (b == nb: the ground)."""
    if b == nb:
        for i in range(3):
            r[i] = 0.0
            rdot[i] = 0.0
            omega[i] = 0.0
            for j in range(3):
                A[i, j] = 1.0 if i == j else 0.0
        return
    e0, e1, e2, e3 = y[7 * b + 3], y[7 * b + 4], y[7 * b + 5], y[7 * b + 6]
    n = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    e0, e1, e2, e3 = e0 / n, e1 / n, e2 / n, e3 / n
    # Eq. (4.21): A = 2 [(e0^2 - 1/2) I + e e^T + e0 e~]
    A[0, 0] = 2.0 * (e0 * e0 + e1 * e1 - 0.5)
    A[0, 1] = 2.0 * (e1 * e2 - e0 * e3)
    A[0, 2] = 2.0 * (e1 * e3 + e0 * e2)
    A[1, 0] = 2.0 * (e1 * e2 + e0 * e3)
    A[1, 1] = 2.0 * (e0 * e0 + e2 * e2 - 0.5)
    A[1, 2] = 2.0 * (e2 * e3 - e0 * e1)
    A[2, 0] = 2.0 * (e1 * e3 - e0 * e2)
    A[2, 1] = 2.0 * (e2 * e3 + e0 * e1)
    A[2, 2] = 2.0 * (e0 * e0 + e3 * e3 - 0.5)
    for i in range(3):
        r[i] = y[7 * b + i]
        rdot[i] = y[7 * nb + 6 * b + i]
        omega[i] = y[7 * nb + 6 * b + 3 + i]


@njit
def _rot(A, R, c, out):
    for i in range(3):
        out[i] = A[i, 0] * R[0, c] + A[i, 1] * R[1, c] + A[i, 2] * R[2, c]


@njit
def _cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit
def axis_joint_coordinates(y, nb, body_i, body_j, R_i, R_j, s_i, s_j, last, out):
    """out (n, 4) = [angle, angle rate, translation, translation rate] of n axis joints.
    body_i, body_j (n,); R_i, R_j (n, 3, 3) joint frames [u, a, b] in body axes; s_i, s_j
    (n, 3) joint points in body axes; last (n,): the previous angles (NaN: none), updated --
    each angle is taken on the branch nearest it (continuous over turns)."""
    Ai, Aj = np.empty((3, 3)), np.empty((3, 3))
    ri, rj, vi, vj = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    wi, wj = np.empty(3), np.empty(3)
    ui, ai, bi, aj = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    tmp, tmp2 = np.empty(3), np.empty(3)
    si, sj, d, dd = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(body_i.size):
        _frame(y, nb, body_i[k], Ai, ri, vi, wi)
        _frame(y, nb, body_j[k], Aj, rj, vj, wj)
        _rot(Ai, R_i[k], 0, ui)
        _rot(Ai, R_i[k], 1, ai)
        _rot(Ai, R_i[k], 2, bi)
        _rot(Aj, R_j[k], 1, aj)
        x, yy = _dot(ai, aj), _dot(bi, aj)
        _cross(wi, ai, tmp)
        _cross(wj, aj, tmp2)
        xd = _dot(tmp, aj) + _dot(ai, tmp2)
        _cross(wi, bi, tmp)
        yd = _dot(tmp, aj) + _dot(bi, tmp2)
        theta = math.atan2(yy, x)
        if not math.isnan(last[k]):
            step = theta - last[k]
            theta = last[k] + step - 2.0 * math.pi * math.floor((step + math.pi)
                                                                / (2.0 * math.pi))
        last[k] = theta
        out[k, 0] = theta
        out[k, 1] = (x * yd - yy * xd) / (x * x + yy * yy)
        for i in range(3):
            si[i] = Ai[i, 0] * s_i[k, 0] + Ai[i, 1] * s_i[k, 1] + Ai[i, 2] * s_i[k, 2]
            sj[i] = Aj[i, 0] * s_j[k, 0] + Aj[i, 1] * s_j[k, 1] + Aj[i, 2] * s_j[k, 2]
            d[i] = rj[i] + sj[i] - ri[i] - si[i]
        _cross(wj, sj, tmp)
        _cross(wi, si, tmp2)
        for i in range(3):
            dd[i] = vj[i] + tmp[i] - vi[i] - tmp2[i]
        _cross(wi, ui, tmp)
        out[k, 2] = _dot(ui, d)
        out[k, 3] = _dot(tmp, d) + _dot(ui, dd)
