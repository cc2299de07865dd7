"""Compiled hot-path helpers of the rotations (one instance; the vectorized functions of
:mod:`.euler_parameters` call them): A(p), pdot, quaternion products and rotation vectors."""
from __future__ import annotations

import math

from ..jit import njit


@njit
def A_into(p, b, A):
    """A[b] = A(p[b]), Eq. (4.13) (see :func:`A_from_p`)."""
    e0, e1, e2, e3 = p[b, 0], p[b, 1], p[b, 2], p[b, 3]
    A[b, 0, 0] = 2.0 * (e0 * e0 + e1 * e1) - 1.0
    A[b, 0, 1] = 2.0 * (e1 * e2 - e0 * e3)
    A[b, 0, 2] = 2.0 * (e1 * e3 + e0 * e2)
    A[b, 1, 0] = 2.0 * (e1 * e2 + e0 * e3)
    A[b, 1, 1] = 2.0 * (e0 * e0 + e2 * e2) - 1.0
    A[b, 1, 2] = 2.0 * (e2 * e3 - e0 * e1)
    A[b, 2, 0] = 2.0 * (e1 * e3 - e0 * e2)
    A[b, 2, 1] = 2.0 * (e2 * e3 + e0 * e1)
    A[b, 2, 2] = 2.0 * (e0 * e0 + e3 * e3) - 1.0


@njit
def pdot_scalar(p, w):
    """pdot = 1/2 G^T omega, Eq. (5.12), for one body: p (4-tuple), omega (3-tuple, global)."""
    e0, e1, e2, e3 = p[0], p[1], p[2], p[3]
    wx, wy, wz = w[0], w[1], w[2]
    return (0.5 * (-e1 * wx - e2 * wy - e3 * wz),
            0.5 * (e0 * wx + e3 * wy - e2 * wz),
            0.5 * (-e3 * wx + e0 * wy + e1 * wz),
            0.5 * (e2 * wx - e1 * wy + e0 * wz))


@njit
def quat_multiply_scalar(a, b):
    """a (x) b for 4-tuples (see :func:`quat_multiply`)."""
    return (a[0] * b[0] - (a[1] * b[1] + a[2] * b[2] + a[3] * b[3]),
            a[0] * b[1] + b[0] * a[1] + (a[2] * b[3] - a[3] * b[2]),
            a[0] * b[2] + b[0] * a[2] + (a[3] * b[1] - a[1] * b[3]),
            a[0] * b[3] + b[0] * a[3] + (a[1] * b[2] - a[2] * b[1]))


@njit
def p_from_rotation_vector_scalar(t0, t1, t2):
    """Euler parameters of the rotation vector (t0, t1, t2), Eqs. (4.7)-(4.8)."""
    angle = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    half = 0.5 * angle
    if angle < 1e-8:                   # sin(half)/angle by its Taylor series near zero
        factor = 0.5 - angle ** 2 / 48.0
    else:
        factor = math.sin(half) / angle
    return (math.cos(half), factor * t0, factor * t1, factor * t2)


@njit
def rotate_p_scalar(p, t0, t1, t2):
    """p (4-tuple) rotated by the global rotation vector (t0, t1, t2), unit length kept."""
    q = quat_multiply_scalar(p_from_rotation_vector_scalar(t0, t1, t2), p)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@njit
def _A_batch(p, A):
    for b in range(p.shape[0]):
        A_into(p, b, A)


@njit
def _pdot_batch(p, w, out):
    for b in range(p.shape[0]):
        pd = pdot_scalar((p[b, 0], p[b, 1], p[b, 2], p[b, 3]), (w[b, 0], w[b, 1], w[b, 2]))
        for c in range(4):
            out[b, c] = pd[c]


@njit
def _quat_batch(a, b, out):
    for k in range(a.shape[0]):
        q = quat_multiply_scalar((a[k, 0], a[k, 1], a[k, 2], a[k, 3]),
                                 (b[k, 0], b[k, 1], b[k, 2], b[k, 3]))
        for c in range(4):
            out[k, c] = q[c]


@njit
def _rotvec_batch(theta, out):
    for k in range(theta.shape[0]):
        q = p_from_rotation_vector_scalar(theta[k, 0], theta[k, 1], theta[k, 2])
        for c in range(4):
            out[k, c] = q[c]


@njit
def _rotate_p_batch(p, d, out):
    for k in range(p.shape[0]):
        q = rotate_p_scalar((p[k, 0], p[k, 1], p[k, 2], p[k, 3]), d[k, 0], d[k, 1], d[k, 2])
        for c in range(4):
            out[k, c] = q[c]
