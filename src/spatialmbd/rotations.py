"""Rotations: Euler parameters, rotation matrices, G and L (text ch. 4-5).

Every function is vectorized: a leading batch shape ``...`` is allowed on every argument.

Conventions
-----------
* Euler parameters p = [e0, e1, e2, e3] (4.11), e0 = cos(phi/2), e = u sin(phi/2) (4.7)-(4.8).
* A maps body (local, primed) components to global ones: s = A s' (5.4).
* omega is the angular velocity in global components, omega_local in body components.
* zxz Euler angles (psi, theta, sigma): A = Rz(psi) Rx(theta) Rz(sigma) (4.1)-(4.2).
  Bryant angles (phi1, phi2, phi3): A = Rx(phi1) Ry(phi2) Rz(phi3) (4.4)-(4.5).
  At the singularities (sin theta = 0, cos phi2 = 0) the third angle is returned as 0 and the
  first carries the combined rotation.
* Unit Euler parameters are assumed by the chapter 5 maps (p^T p = 1, p^T pdot = 0).
"""
from __future__ import annotations

import math

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

_EPS = np.finfo(float).eps
# A half-angle factor (sin or cos of theta/2, or of the Bryant analogue) at or below this value
# is treated as exactly singular: the discarded information is below the rounding of p and A.
_SINGULAR_TOL = 2.0 * _EPS


def _wrap_angle(x: np.ndarray) -> np.ndarray:
    """Map angles to (-pi, pi]."""
    return np.pi - np.remainder(np.pi - x, 2.0 * np.pi)


def _mv(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched matrix-vector product M @ v."""
    return np.einsum("...ij,...j->...i", M, v)


def _norm3(v: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis (length 3) without underflow/overflow of the squares."""
    return np.hypot(np.hypot(v[..., 0], v[..., 1]), v[..., 2])


def _angles3(angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    angles = np.asarray(angles, dtype=float)
    if angles.shape[-1:] != (3,):
        raise ValueError(f"angles must have shape (..., 3), got {angles.shape}")
    return angles[..., 0], angles[..., 1], angles[..., 2]


# ----------------------------------------------------------------------------------------------
# Euler angles, zxz convention (4.1)-(4.3)
# ----------------------------------------------------------------------------------------------

def A_from_euler_zxz(angles: np.ndarray) -> np.ndarray:
    """Rotation matrix of zxz Euler angles (psi, theta, sigma), Eq. (4.2): (..., 3) -> (..., 3, 3).

    A = D C B (4.1) with D = Rz(psi), C = Rx(theta), B = Rz(sigma) (counterclockwise elementary
    rotations; the axis labels in the chapter 4 prose are garbled, the matrices define the
    convention).
    """
    psi, theta, sigma = _angles3(angles)
    cps, sps = np.cos(psi), np.sin(psi)
    cth, sth = np.cos(theta), np.sin(theta)
    csg, ssg = np.cos(sigma), np.sin(sigma)
    A = np.empty(psi.shape + (3, 3))
    A[..., 0, 0] = cps * csg - sps * cth * ssg
    A[..., 0, 1] = -cps * ssg - sps * cth * csg
    A[..., 0, 2] = sps * sth
    A[..., 1, 0] = sps * csg + cps * cth * ssg
    A[..., 1, 1] = -sps * ssg + cps * cth * csg
    A[..., 1, 2] = -cps * sth
    A[..., 2, 0] = sth * ssg
    A[..., 2, 1] = sth * csg
    A[..., 2, 2] = cth
    return A


def p_from_euler_zxz(angles: np.ndarray) -> np.ndarray:
    """Euler parameters of zxz Euler angles (psi, theta, sigma): (..., 3) -> (..., 4).

    p = p_z(psi) (x) p_x(theta) (x) p_z(sigma), i.e.
    e0 = cos(theta/2) cos((psi+sigma)/2), e1 = sin(theta/2) cos((psi-sigma)/2),
    e2 = sin(theta/2) sin((psi-sigma)/2), e3 = cos(theta/2) sin((psi+sigma)/2);
    A_from_p of the result equals A_from_euler_zxz(angles).
    """
    psi, theta, sigma = _angles3(angles)
    ch, sh = np.cos(0.5 * theta), np.sin(0.5 * theta)
    s, d = 0.5 * (psi + sigma), 0.5 * (psi - sigma)
    return np.stack([ch * np.cos(s), sh * np.cos(d), sh * np.sin(d), ch * np.sin(s)], axis=-1)


def euler_zxz_from_p(p: np.ndarray) -> np.ndarray:
    """zxz Euler angles (psi, theta, sigma) of Euler parameters p: (..., 4) -> (..., 3).

    Ranges: theta in [0, pi], psi and sigma in (-pi, pi]. p need not be unit (only its direction
    is used) and p, -p give the same angles.

    Computed from half-angle atan2 forms, well conditioned everywhere:
    theta = 2 atan2(|(e1, e2)|, |(e0, e3)|), psi + sigma = 2 atan2(e3, e0),
    psi - sigma = 2 atan2(e2, e1). Near the singularity only the ill-defined combination is
    inaccurate, and it enters p (and A) multiplied by the small factor, so the angles reproduce
    p and A to rounding.

    Singular configurations (sin theta = 0): if sin(theta/2) <= 2 eps (theta = 0, only
    psi + sigma is defined) or cos(theta/2) <= 2 eps (theta = pi, only psi - sigma is defined)
    the convention is sigma = 0 and psi carries the combined rotation (psi + sigma, resp.
    psi - sigma). theta itself is returned as computed (0 or pi to rounding).
    """
    p = np.asarray(p, dtype=float)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    sh = np.hypot(e1, e2)  # |sin(theta/2)| * |p|
    ch = np.hypot(e0, e3)  # |cos(theta/2)| * |p|
    norm = np.hypot(sh, ch)
    theta = 2.0 * np.arctan2(sh, ch)
    S = 2.0 * np.arctan2(e3, e0)  # psi + sigma
    D = 2.0 * np.arctan2(e2, e1)  # psi - sigma
    sing0 = sh <= _SINGULAR_TOL * norm
    singpi = (ch <= _SINGULAR_TOL * norm) & ~sing0
    psi = np.where(sing0, S, np.where(singpi, D, 0.5 * (S + D)))
    sigma = np.where(sing0 | singpi, 0.0, 0.5 * (S - D))
    return np.stack([_wrap_angle(psi), theta, _wrap_angle(sigma)], axis=-1)


def euler_zxz_from_A(A: np.ndarray) -> np.ndarray:
    """zxz Euler angles (psi, theta, sigma) of a rotation matrix (4.2): (..., 3, 3) -> (..., 3).

    Goes through the robust p_from_A (Shepperd) and euler_zxz_from_p, so it is well conditioned
    near the singularities as well; same ranges and singular convention as euler_zxz_from_p
    (theta = 0 or pi: sigma = 0, psi = combined rotation).
    """
    return euler_zxz_from_p(p_from_A(A))


# ----------------------------------------------------------------------------------------------
# Bryant angles, xyz convention (4.4)-(4.6)
# ----------------------------------------------------------------------------------------------

def A_from_bryant(angles: np.ndarray) -> np.ndarray:
    """Rotation matrix of Bryant angles (phi1, phi2, phi3), Eq. (4.5): (..., 3) -> (..., 3, 3).

    A = D C B (4.4) with D = Rx(phi1), C = Ry(phi2), B = Rz(phi3).
    """
    f1, f2, f3 = _angles3(angles)
    c1, s1 = np.cos(f1), np.sin(f1)
    c2, s2 = np.cos(f2), np.sin(f2)
    c3, s3 = np.cos(f3), np.sin(f3)
    A = np.empty(f1.shape + (3, 3))
    A[..., 0, 0] = c2 * c3
    A[..., 0, 1] = -c2 * s3
    A[..., 0, 2] = s2
    A[..., 1, 0] = c1 * s3 + s1 * s2 * c3
    A[..., 1, 1] = c1 * c3 - s1 * s2 * s3
    A[..., 1, 2] = -s1 * c2
    A[..., 2, 0] = s1 * s3 - c1 * s2 * c3
    A[..., 2, 1] = s1 * c3 + c1 * s2 * s3
    A[..., 2, 2] = c1 * c2
    return A


def p_from_bryant(angles: np.ndarray) -> np.ndarray:
    """Euler parameters of Bryant angles (phi1, phi2, phi3): (..., 3) -> (..., 4).

    p = p_x(phi1) (x) p_y(phi2) (x) p_z(phi3); A_from_p of the result equals A_from_bryant.
    """
    f1, f2, f3 = _angles3(angles)
    ca, sa = np.cos(0.5 * f1), np.sin(0.5 * f1)
    cb, sb = np.cos(0.5 * f2), np.sin(0.5 * f2)
    cc, sc = np.cos(0.5 * f3), np.sin(0.5 * f3)
    return np.stack([
        ca * cb * cc - sa * sb * sc,
        sa * cb * cc + ca * sb * sc,
        ca * sb * cc - sa * cb * sc,
        ca * cb * sc + sa * sb * cc,
    ], axis=-1)


def bryant_from_p(p: np.ndarray) -> np.ndarray:
    """Bryant angles (phi1, phi2, phi3) of Euler parameters p: (..., 4) -> (..., 3).

    Ranges: phi2 in [-pi/2, pi/2], phi1 and phi3 in (-pi, pi]. p need not be unit; p and -p
    give the same angles.

    With b = phi2/2, p_from_bryant gives
    e0 + e2 = (cos b + sin b) cos((phi1+phi3)/2),  e1 + e3 = (cos b + sin b) sin((phi1+phi3)/2),
    e0 - e2 = (cos b - sin b) cos((phi3-phi1)/2),  e3 - e1 = (cos b - sin b) sin((phi3-phi1)/2),
    so u = |(e0+e2, e1+e3)| = cos b + sin b, v = |(e0-e2, e3-e1)| = cos b - sin b, and
    phi2 = atan2(2 (e0 e2 + e1 e3), u v) (sin phi2 = A[0, 2], cos phi2 = u v), while
    phi1 + phi3 and phi3 - phi1 follow from half-angle atan2's. All forms are well conditioned;
    near cos phi2 = 0 the ill-defined combination enters p multiplied by the small factor, so
    the angles reproduce p and A to rounding.

    Singular configurations (cos phi2 = 0): if v <= 2 eps |p| (phi2 = +pi/2, only phi1 + phi3
    is defined) or u <= 2 eps |p| (phi2 = -pi/2, only phi1 - phi3 is defined) the convention is
    phi3 = 0 and phi1 carries the combined rotation (phi1 + phi3, resp. phi1 - phi3).
    """
    p = np.asarray(p, dtype=float)
    e0, e1, e2, e3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    u = np.hypot(e0 + e2, e1 + e3)
    v = np.hypot(e0 - e2, e3 - e1)
    n2 = e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3
    norm = np.sqrt(n2)
    phi2 = np.arctan2(2.0 * (e0 * e2 + e1 * e3), u * v)
    S = 2.0 * np.arctan2(e1 + e3, e0 + e2)  # phi1 + phi3
    D = 2.0 * np.arctan2(e3 - e1, e0 - e2)  # phi3 - phi1
    sing_p = v <= _SINGULAR_TOL * norm
    sing_m = (u <= _SINGULAR_TOL * norm) & ~sing_p
    phi1 = np.where(sing_p, S, np.where(sing_m, -D, 0.5 * (S - D)))
    phi3 = np.where(sing_p | sing_m, 0.0, 0.5 * (S + D))
    return np.stack([_wrap_angle(phi1), phi2, _wrap_angle(phi3)], axis=-1)


def bryant_from_A(A: np.ndarray) -> np.ndarray:
    """Bryant angles (phi1, phi2, phi3) of a rotation matrix (4.5): (..., 3, 3) -> (..., 3).

    Goes through the robust p_from_A and bryant_from_p; same ranges and singular convention
    (cos phi2 = 0: phi3 = 0, phi1 = combined rotation, cf. (4.6)).
    """
    return bryant_from_p(p_from_A(A))


# ----------------------------------------------------------------------------------------------
# Axis and angle (4.7)-(4.8)
# ----------------------------------------------------------------------------------------------

def p_from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Euler parameters of a rotation by `angle` about `axis`, Eqs. (4.7)-(4.8).

    axis: (..., 3), need not be unit (it is normalised); angle: (...) radians. Shapes broadcast.
    Returns (..., 4) = [cos(angle/2), u sin(angle/2)]. A zero axis raises ValueError.
    """
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    if axis.shape[-1:] != (3,):
        raise ValueError(f"axis must have shape (..., 3), got {axis.shape}")
    n = _norm3(axis)[..., None]
    if np.any(n == 0.0) or not np.all(np.isfinite(n)):
        raise ValueError("rotation axis must be a finite, non-zero vector")
    u = axis / n
    half = 0.5 * angle[..., None]
    vec = u * np.sin(half)
    scal = np.broadcast_to(np.cos(half), vec.shape[:-1] + (1,))
    return np.concatenate([scal, vec], axis=-1)


def axis_angle_from_p(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit axis and angle of p (inverse of (4.7)-(4.8)): (..., 4) -> ((..., 3), (...)).

    angle = 2 atan2(|e|, |e0|) in [0, pi], accurate for small angles and near pi; the axis is
    sign(e0) e / |e| (so p and -p give the same result). For angle 0 (e = 0) the axis is
    undefined and the x axis [1, 0, 0] is returned. At exactly pi (e0 = 0) the axis is e/|e|
    (u and -u describe the same rotation). p need not be unit.
    """
    p = np.asarray(p, dtype=float)
    e0, e = p[..., 0], p[..., 1:]
    ne = _norm3(e)
    angle = 2.0 * np.arctan2(ne, np.abs(e0))
    sign = np.where(e0 < 0.0, -1.0, 1.0)
    zero = ne == 0.0
    axis = sign[..., None] * e / np.where(zero, 1.0, ne)[..., None]
    axis = np.where(zero[..., None], np.array([1.0, 0.0, 0.0]), axis)
    return axis, angle


# ----------------------------------------------------------------------------------------------
# Angular velocity and acceleration (5.10)-(5.22)
# ----------------------------------------------------------------------------------------------

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


# ----------------------------------------------------------------------------------------------
# Compiled hot-path helpers (one instance; the vectorized functions above call them)
# ----------------------------------------------------------------------------------------------
from .jit import njit  # noqa: E402


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
