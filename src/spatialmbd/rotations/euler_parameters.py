"""Euler parameters and rotation matrices, G and L and their derivatives, angular velocity and
acceleration from the Euler parameters' rates (text ch. 4-5). Vectorized over a leading batch
shape."""
from __future__ import annotations

import numpy as np

from .compiled import _A_batch, _pdot_batch, _quat_batch, _rotvec_batch, _rotate_p_batch


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
    not A^T (ERRATA.md). p is used as given; callers keep it unit length. (Compiled:
    :func:`A_into`.)
    """
    p = np.asarray(p, dtype=float)
    flat = np.ascontiguousarray(p.reshape(-1, 4))
    A = np.empty((flat.shape[0], 3, 3))
    _A_batch(flat, A)
    return A.reshape(p.shape[:-1] + (3, 3))


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
    """pdot = 1/2 G^T omega, Eq. (5.12). p: (..., 4), omega (global): (..., 3) -> (..., 4).
    (Compiled: :func:`pdot_scalar`.)"""
    p, w = np.asarray(p, dtype=float), np.asarray(omega, dtype=float)
    shape = np.broadcast_shapes(p.shape[:-1], w.shape[:-1])
    p = np.ascontiguousarray(np.broadcast_to(p, shape + (4,)).reshape(-1, 4))
    w = np.ascontiguousarray(np.broadcast_to(w, shape + (3,)).reshape(-1, 3))
    out = np.empty((p.shape[0], 4))
    _pdot_batch(p, w, out)
    return out.reshape(shape + (4,))


def omega_from_pdot(p: np.ndarray, pdot: np.ndarray) -> np.ndarray:
    """omega = 2 G pdot, Eq. (5.10). p, pdot: (..., 4) -> (..., 3) global."""
    return 2.0 * np.einsum("...ij,...j->...i", G_matrix(p), pdot)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euler-parameter product a (x) b: A(a (x) b) = A(a) A(b). a, b: (..., 4) -> (..., 4).
    (Compiled: :func:`quat_multiply_scalar`.)"""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    out = np.empty(a.shape)
    _quat_batch(np.ascontiguousarray(a.reshape(-1, 4)), np.ascontiguousarray(b.reshape(-1, 4)),
                out.reshape(-1, 4))
    return out


def p_from_rotation_vector(theta: np.ndarray) -> np.ndarray:
    """Euler parameters of a rotation by |theta| about theta/|theta| (4.7)-(4.8).

    theta: (..., 3) rotation vector (radians) -> (..., 4). Exact for small angles too.
    (Compiled: :func:`p_from_rotation_vector_scalar`.)
    """
    theta = np.asarray(theta, dtype=float)
    out = np.empty(theta.shape[:-1] + (4,))
    _rotvec_batch(np.ascontiguousarray(theta.reshape(-1, 3)), out.reshape(-1, 4))
    return out


def rotate_p(p: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """Euler parameters after a finite rotation dtheta (global rotation vector) of orientation p.

    A_new = A(dtheta) A(p): the update used by Newton-Raphson and by coordinate projection, where
    corrections are computed in the 6-per-body velocity space (ERRATA (14.6)). Unit length kept.
    (Compiled: :func:`rotate_p_scalar`.)
    """
    p, d = np.asarray(p, dtype=float), np.asarray(dtheta, dtype=float)
    shape = p.shape[:-1]
    if d.shape[:-1] != shape:
        shape = np.broadcast_shapes(shape, d.shape[:-1])
        p, d = np.broadcast_to(p, shape + (4,)), np.broadcast_to(d, shape + (3,))
    p = np.ascontiguousarray(p.reshape(-1, 4))
    d = np.ascontiguousarray(d.reshape(-1, 3))
    out = np.empty((p.shape[0], 4))
    _rotate_p_batch(p, d, out)
    return out.reshape(shape + (4,))


def normalize_p(p: np.ndarray) -> np.ndarray:
    """p / |p|, rowwise."""
    p = np.asarray(p, dtype=float)
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


# ----------------------------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------------------------

def _mv(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched matrix-vector product M @ v."""
    return np.einsum("...ij,...j->...i", M, v)


def G_dot(pdot: np.ndarray) -> np.ndarray:
    """Time derivative of G (5.11): G is linear in p, so Gdot = G(pdot). (..., 4) -> (..., 3, 4).

    Gdot pdot = 0 identically (for any pdot), which is what makes (5.19) exact.
    """
    return G_matrix(pdot)


def L_dot(pdot: np.ndarray) -> np.ndarray:
    """Time derivative of L (5.15): Ldot = L(pdot); Ldot pdot = 0 identically.

    (..., 4) -> (..., 3, 4).
    """
    return L_matrix(pdot)


def omega_local_from_pdot(p: np.ndarray, pdot: np.ndarray) -> np.ndarray:
    """omega' = 2 L pdot, Eq. (5.14)-(5.15). p, pdot: (..., 4) -> (..., 3) body components."""
    return 2.0 * _mv(L_matrix(p), np.asarray(pdot, dtype=float))


def pdot_from_omega_local(p: np.ndarray, omega_local: np.ndarray) -> np.ndarray:
    """pdot = 1/2 L^T omega', Eq. (5.16)-(5.17). p: (..., 4), omega': (..., 3) -> (..., 4)."""
    return 0.5 * np.einsum("...ji,...j->...i", L_matrix(p), np.asarray(omega_local, dtype=float))


def omegadot_from_pddot(p: np.ndarray, pdot: np.ndarray, pddot: np.ndarray) -> np.ndarray:
    """Global angular acceleration omegadot = 2 G pddot, Eq. (5.19). (..., 4) x3 -> (..., 3).

    From (5.18) omegadot = 2 G pddot + 2 Gdot pdot and Gdot pdot = G(pdot) pdot = 0 identically,
    so pdot is not needed; it is accepted for a uniform signature.
    """
    del pdot
    return 2.0 * _mv(G_matrix(p), np.asarray(pddot, dtype=float))


def omegadot_local_from_pddot(p: np.ndarray, pdot: np.ndarray, pddot: np.ndarray) -> np.ndarray:
    """Body-component angular acceleration omegadot' = 2 L pddot, Eq. (5.20) (Ldot pdot = 0).

    omegadot' = d(omega')/dt = A^T omegadot. pdot is not needed (uniform signature).
    """
    del pdot
    return 2.0 * _mv(L_matrix(p), np.asarray(pddot, dtype=float))


def pddot_from_omegadot(p: np.ndarray, pdot: np.ndarray, omegadot: np.ndarray) -> np.ndarray:
    """pddot from the global angular acceleration (5.21): (..., 4), (..., 4), (..., 3) -> (..., 4).

    For unit p the 4x4 matrix [p^T; G] is orthogonal, so pddot = p (p^T pddot) + G^T (G pddot)
    with G pddot = omegadot/2 (5.19) and p^T pddot = -pdot^T pdot (second derivative of
    p^T p = 1). Hence pddot = 1/2 G^T omegadot - (pdot^T pdot) p, and with
    pdot^T pdot = 1/4 omega^T omega this is the printed (5.21). The pdot^T pdot form is used:
    it equals (5.21) whenever p^T pdot = 0 and keeps d^2(p^T p)/dt^2 = 0 exactly.
    """
    p = np.asarray(p, dtype=float)
    pdot = np.asarray(pdot, dtype=float)
    wd = np.asarray(omegadot, dtype=float)
    return (0.5 * np.einsum("...ji,...j->...i", G_matrix(p), wd)
            - np.sum(pdot * pdot, axis=-1, keepdims=True) * p)


def pddot_from_omegadot_local(p: np.ndarray, pdot: np.ndarray,
                              omegadot_local: np.ndarray) -> np.ndarray:
    """pddot from the body-component angular acceleration, Eq. (5.22).

    pddot = 1/2 L^T omegadot' - (pdot^T pdot) p  (= 1/2 L^T omegadot' - 1/4 (omega'^T omega') p).
    """
    p = np.asarray(p, dtype=float)
    pdot = np.asarray(pdot, dtype=float)
    wd = np.asarray(omegadot_local, dtype=float)
    return (0.5 * np.einsum("...ji,...j->...i", L_matrix(p), wd)
            - np.sum(pdot * pdot, axis=-1, keepdims=True) * p)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for (..., 3) arrays; much cheaper than np.cross on small batches."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out
