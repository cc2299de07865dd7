"""Rotations: Euler parameters, rotation matrices, G and L (text ch. 4-5).

Every function is vectorized: a leading batch shape ``...`` is allowed on every argument.

Conventions
-----------
* Euler parameters p = [e0, e1, e2, e3] (4.11), e0 = cos(phi/2), e = u sin(phi/2) (4.7)-(4.8).
* A maps body (local, primed) components to global ones: s = A s' (5.4).
* omega is the angular velocity in global components, omega_local in body components.
"""
from __future__ import annotations

import numpy as np


def skew(v: np.ndarray) -> np.ndarray:
    """The skew-symmetric matrix v~ (4.15) such that skew(a) @ b = a x b. v: (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def A_from_p(p: np.ndarray) -> np.ndarray:
    """Rotation matrix from Euler parameters, Eq. (4.13). p: (..., 4) -> (..., 3, 3).

    Uses A = (2 e0^2 - 1) I + 2 (e e^T + e0 e~): the right-hand side of the printed (4.14) is A,
    not A^T (ERRATA.md). p is used as given; callers keep it unit length.
    """
    p = np.asarray(p, dtype=float)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    A = np.empty(p.shape[:-1] + (3, 3))
    A[..., 0, 0] = 2.0 * (e0 * e0 + e1 * e1) - 1.0
    A[..., 0, 1] = 2.0 * (e1 * e2 - e0 * e3)
    A[..., 0, 2] = 2.0 * (e1 * e3 + e0 * e2)
    A[..., 1, 0] = 2.0 * (e1 * e2 + e0 * e3)
    A[..., 1, 1] = 2.0 * (e0 * e0 + e2 * e2) - 1.0
    A[..., 1, 2] = 2.0 * (e2 * e3 - e0 * e1)
    A[..., 2, 0] = 2.0 * (e1 * e3 - e0 * e2)
    A[..., 2, 1] = 2.0 * (e2 * e3 + e0 * e1)
    A[..., 2, 2] = 2.0 * (e0 * e0 + e3 * e3) - 1.0
    return A


def p_from_A(A: np.ndarray) -> np.ndarray:
    """Euler parameters from a rotation matrix, robust for every rotation (180 degrees included).

    Shepperd's method: of the four candidate squared parameters (from the trace and the diagonal)
    the largest is computed from a square root and the others from off-diagonal sums, so no
    division by a small number occurs. The sign is chosen so that e0 >= 0.
    A: (..., 3, 3) -> (..., 4).
    """
    A = np.asarray(A, dtype=float)
    batch = A.shape[:-2]
    A = A.reshape((-1, 3, 3))
    tr = np.trace(A, axis1=1, axis2=2)
    d = np.stack([tr, A[:, 0, 0], A[:, 1, 1], A[:, 2, 2]], axis=1)
    # 4 e_k^2 = 1 + 2 A_kk - tr (k = 1..3), 4 e0^2 = 1 + tr
    sq = np.stack([1.0 + tr, 1.0 + 2 * d[:, 1] - tr, 1.0 + 2 * d[:, 2] - tr,
                   1.0 + 2 * d[:, 3] - tr], axis=1)
    k = np.argmax(sq, axis=1)
    p = np.empty((A.shape[0], 4))
    s = np.sqrt(np.maximum(sq[np.arange(A.shape[0]), k], 0.0))  # = 2 |e_k|
    # off-diagonal combinations: 4 e0 e1 = A21 - A12, 4 e0 e2 = A02 - A20, 4 e0 e3 = A10 - A01,
    # 4 e1 e2 = A10 + A01, 4 e1 e3 = A02 + A20, 4 e2 e3 = A21 + A12
    a01, a10 = A[:, 0, 1], A[:, 1, 0]
    a02, a20 = A[:, 0, 2], A[:, 2, 0]
    a12, a21 = A[:, 1, 2], A[:, 2, 1]
    m = k == 0
    p[m, 0] = 0.5 * s[m]
    p[m, 1] = (a21[m] - a12[m]) / (2 * s[m])
    p[m, 2] = (a02[m] - a20[m]) / (2 * s[m])
    p[m, 3] = (a10[m] - a01[m]) / (2 * s[m])
    m = k == 1
    p[m, 1] = 0.5 * s[m]
    p[m, 0] = (a21[m] - a12[m]) / (2 * s[m])
    p[m, 2] = (a10[m] + a01[m]) / (2 * s[m])
    p[m, 3] = (a02[m] + a20[m]) / (2 * s[m])
    m = k == 2
    p[m, 2] = 0.5 * s[m]
    p[m, 0] = (a02[m] - a20[m]) / (2 * s[m])
    p[m, 1] = (a10[m] + a01[m]) / (2 * s[m])
    p[m, 3] = (a21[m] + a12[m]) / (2 * s[m])
    m = k == 3
    p[m, 3] = 0.5 * s[m]
    p[m, 0] = (a10[m] - a01[m]) / (2 * s[m])
    p[m, 1] = (a02[m] + a20[m]) / (2 * s[m])
    p[m, 2] = (a21[m] + a12[m]) / (2 * s[m])
    p *= np.where(p[:, :1] < 0, -1.0, 1.0)
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return p.reshape(batch + (4,))


def G_matrix(p: np.ndarray) -> np.ndarray:
    """G of Eq. (5.11): omega = 2 G pdot (global angular velocity). p: (..., 4) -> (..., 3, 4)."""
    p = np.asarray(p, dtype=float)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    G = np.empty(p.shape[:-1] + (3, 4))
    G[..., 0, :] = np.stack([-e1, e0, -e3, e2], axis=-1)
    G[..., 1, :] = np.stack([-e2, e3, e0, -e1], axis=-1)
    G[..., 2, :] = np.stack([-e3, -e2, e1, e0], axis=-1)
    return G


def L_matrix(p: np.ndarray) -> np.ndarray:
    """L of Eq. (5.15): omega_local = 2 L pdot (body angular velocity). p: (..., 4) -> (..., 3, 4)."""
    p = np.asarray(p, dtype=float)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    L = np.empty(p.shape[:-1] + (3, 4))
    L[..., 0, :] = np.stack([-e1, e0, e3, -e2], axis=-1)
    L[..., 1, :] = np.stack([-e2, -e3, e0, e1], axis=-1)
    L[..., 2, :] = np.stack([-e3, e2, -e1, e0], axis=-1)
    return L


def pdot_from_omega(p: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """pdot = 1/2 G^T omega, Eq. (5.12). p: (..., 4), omega (global): (..., 3) -> (..., 4)."""
    p = np.asarray(p, dtype=float)
    w = np.asarray(omega, dtype=float)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
    return 0.5 * np.stack([
        -e1 * wx - e2 * wy - e3 * wz,
        e0 * wx + e3 * wy - e2 * wz,
        -e3 * wx + e0 * wy + e1 * wz,
        e2 * wx - e1 * wy + e0 * wz,
    ], axis=-1)


def omega_from_pdot(p: np.ndarray, pdot: np.ndarray) -> np.ndarray:
    """omega = 2 G pdot, Eq. (5.10). p, pdot: (..., 4) -> (..., 3) global."""
    return 2.0 * np.einsum("...ij,...j->...i", G_matrix(p), pdot)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euler-parameter product a (x) b: A(a (x) b) = A(a) A(b). a, b: (..., 4) -> (..., 4)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a0, av = a[..., :1], a[..., 1:]
    b0, bv = b[..., :1], b[..., 1:]
    return np.concatenate([a0 * b0 - np.sum(av * bv, axis=-1, keepdims=True),
                           a0 * bv + b0 * av + np.cross(av, bv)], axis=-1)


def p_from_rotation_vector(theta: np.ndarray) -> np.ndarray:
    """Euler parameters of a rotation by |theta| about theta/|theta| (4.7)-(4.8).

    theta: (..., 3) rotation vector (radians) -> (..., 4). Exact for small angles too.
    """
    theta = np.asarray(theta, dtype=float)
    angle = np.linalg.norm(theta, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(half)/angle with its Taylor series near zero
    small = angle < 1e-8
    factor = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([np.cos(half), factor * theta], axis=-1)


def rotate_p(p: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """Euler parameters after a finite rotation dtheta (global rotation vector) of orientation p.

    A_new = A(dtheta) A(p): the update used by Newton-Raphson and by coordinate projection, where
    corrections are computed in the 6-per-body velocity space (ERRATA (14.6)). Unit length kept.
    """
    out = quat_multiply(p_from_rotation_vector(dtheta), p)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def normalize_p(p: np.ndarray) -> np.ndarray:
    """p / |p|, rowwise."""
    p = np.asarray(p, dtype=float)
    return p / np.linalg.norm(p, axis=-1, keepdims=True)
