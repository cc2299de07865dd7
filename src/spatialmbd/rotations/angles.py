"""zxz Euler angles, Bryant angles and axis-angle pairs to and from Euler parameters and
rotation matrices (text ch. 4)."""
from __future__ import annotations

import numpy as np

from .euler_parameters import p_from_A


_EPS = np.finfo(float).eps
# A half-angle factor (sin or cos of theta/2, or of the Bryant analogue) at or below this value
# is treated as exactly singular: the discarded information is below the rounding of p and A.
_SINGULAR_TOL = 2.0 * _EPS


def _wrap_angle(x: np.ndarray) -> np.ndarray:
    """Map angles to (-pi, pi]."""
    return np.pi - np.remainder(np.pi - x, 2.0 * np.pi)


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
