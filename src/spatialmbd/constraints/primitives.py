"""Building blocks of the constraint kernels (text ch. 8), compiled with Numba (``..jit``).

Every joint of the text is assembled from a few kinematic quantities of its two bodies i and j:
points fixed on a body (8.1), vectors fixed on a body (8.3) and the vector d between two points
(8.4). For one joint instance such a 3-vector x is carried as a *Kin*, the tuple

    (x, xd, xa, ci, li, cj, lj)
    x    value                                   (3-tuple)
    xd   time derivative along the motion        (3-tuple)
    xa   x'' - J vdot, the velocity-quadratic part of the second derivative (3-tuple)
    ci, li, cj, lj   how xd depends on v_ij = [rdot_i, omega_i, rdot_j, omega_j]:
         xd = ci rdot_i + omega_i x li + cj rdot_j + omega_j x lj

For a vector a fixed on body b: adot = omega~ a (5.7), so c = 0 and l = a, and with
omegadot = 0, a'' = omega~ adot. For a point P: r^P = r + s^P (8.1), rdot^P = rdot + omega~ s^P
(5.9): c = 1, l = s^P, r''^P(quadratic) = omega~ omega~ s^P. Differences of Kins subtract all
seven entries (xd is linear in them).

Scalar constraints built from two quantities x, y then follow from the product rule:
    Phi = x^T y,  D = y^T J_x + x^T J_y,  gamma = -(xa^T y + 2 xd^T yd + x^T ya),
which is exactly Eqs. (9.9)-(9.17) and (9.18)-(9.26) with the ERRATA corrections, for every
joint: the translation columns of side i get ci y (+ the same from y), the rotation columns
li x y, since y^T (omega x l) = omega^T (l x y). A vector equation x = 0 (the spherical joint,
(9.1)-(9.8)) has the rows [ci I, -li~, cj I, -lj~] and gamma = -xa.

The joint kernels (one per type, in the type's module) call these functions for one instance k
and write its rows into the output arrays ``out = (phi (m,), D (m, 12), nu (m,), gamma (m,))``
at row ``row``. ``S = (r, A, rdot, omega, p)`` are the state arrays of the bodies plus the
ground (last row); ``G`` the joint table of :mod:`.kernels`. All of it is compiled; the
vectorized functions at the end of this module (``body_point``, ``body_vector``,
``relative_angle``) call the same code for all instances of a group.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..jit import njit
from ..rotations import pdot_scalar

ZERO3 = (0.0, 0.0, 0.0)


# ------------------------------------------------------------------------------ 3-vectors
@njit
def v_add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit
def v_sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit
def v_scale(c, a):
    return (c * a[0], c * a[1], c * a[2])


@njit
def v_dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit
def v_cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit
def rotate(A, b, x0, x1, x2):
    """A[b] @ (x0, x1, x2): body axes to global axes (5.4)."""
    return (A[b, 0, 0] * x0 + A[b, 0, 1] * x1 + A[b, 0, 2] * x2,
            A[b, 1, 0] * x0 + A[b, 1, 1] * x1 + A[b, 1, 2] * x2,
            A[b, 2, 0] * x0 + A[b, 2, 1] * x1 + A[b, 2, 2] * x2)


@njit
def row3(X, b):
    return (X[b, 0], X[b, 1], X[b, 2])


# ------------------------------------------------------------------------------ Kins
@njit
def point(S, b, s, k, side):
    """Kin of the point s[k] (body axes) of body b, Eq. (8.1); side 0 = body i, 1 = body j."""
    return point_at(S, b, s[k, 0], s[k, 1], s[k, 2], side)


@njit
def point_at(S, b, s0, s1, s2, side):
    """Kin of the point (s0, s1, s2) (body axes) of body b; side 0 = body i, 1 = body j, -1 =
    neither (a constant of the row: its Jacobian is left out, e.g. a point of the ground)."""
    r, A, rdot, omega = S[0], S[1], S[2], S[3]
    sg = rotate(A, b, s0, s1, s2)
    w = row3(omega, b)
    sd = v_cross(w, sg)                                        # (5.9)
    x = v_add(row3(r, b), sg)
    xd = v_add(row3(rdot, b), sd)
    xa = v_cross(w, sd)
    if side == 0:
        return (x, xd, xa, 1.0, sg, 0.0, ZERO3)
    if side == 1:
        return (x, xd, xa, 0.0, ZERO3, 1.0, sg)
    return (x, xd, xa, 0.0, ZERO3, 0.0, ZERO3)


@njit
def vector(S, b, R, k, col, side):
    """Kin of the vector R[k][:, col] (body axes) fixed on body b, Eq. (8.3)."""
    return vector_at(S, b, R[k, 0, col], R[k, 1, col], R[k, 2, col], side)


@njit
def vector_at(S, b, a0, a1, a2, side):
    """Kin of the vector (a0, a1, a2) (body axes) fixed on body b; sides as :func:`point_at`."""
    A, omega = S[1], S[3]
    a = rotate(A, b, a0, a1, a2)
    w = row3(omega, b)
    ad = v_cross(w, a)                                         # (5.7)
    aa = v_cross(w, ad)
    if side == 0:
        return (a, ad, aa, 0.0, a, 0.0, ZERO3)
    if side == 1:
        return (a, ad, aa, 0.0, ZERO3, 0.0, a)
    return (a, ad, aa, 0.0, ZERO3, 0.0, ZERO3)


@njit
def kin_sub(x, y):
    """The Kin of x - y (e.g. d = r_j^P - r_i^P, Eq. 8.4)."""
    return (v_sub(x[0], y[0]), v_sub(x[1], y[1]), v_sub(x[2], y[2]), x[3] - y[3],
            v_sub(x[4], y[4]), x[5] - y[5], v_sub(x[6], y[6]))


# ------------------------------------------------------------------------------ scalar x^T y
@njit
def dot_value(x, y):
    return v_dot(x[0], y[0])


@njit
def dot_rate(x, y):
    """d(x^T y)/dt."""
    return v_dot(x[1], y[0]) + v_dot(x[0], y[1])


@njit
def dot_gamma(x, y):
    """gamma of x^T y: -(xa^T y + 2 xd^T yd + x^T ya)."""
    return -(v_dot(x[2], y[0]) + 2.0 * v_dot(x[1], y[1]) + v_dot(x[0], y[2]))


@njit
def add_dot_row(x, y, c, D, row):
    """D[row] += c (y^T J_x + x^T J_y) (12 columns over v_ij)."""
    xv, yv = x[0], y[0]
    ti = v_add(v_scale(x[3], yv), v_scale(y[3], xv))
    ri = v_add(v_cross(x[4], yv), v_cross(y[4], xv))
    tj = v_add(v_scale(x[5], yv), v_scale(y[5], xv))
    rj = v_add(v_cross(x[6], yv), v_cross(y[6], xv))
    for a in range(3):
        D[row, a] += c * ti[a]
        D[row, 3 + a] += c * ri[a]
        D[row, 6 + a] += c * tj[a]
        D[row, 9 + a] += c * rj[a]


@njit
def clear_row(D, row):
    for c in range(12):
        D[row, c] = 0.0


@njit
def put_dot(x, y, out, row):
    """Row ``row`` of a scalar constraint x^T y = 0 (nu = 0)."""
    phi, D, nu, gamma = out
    phi[row] = dot_value(x, y)
    clear_row(D, row)
    add_dot_row(x, y, 1.0, D, row)
    nu[row] = 0.0
    gamma[row] = dot_gamma(x, y)


@njit
def put_vector(x, out, row):
    """Rows row..row+2 of a vector constraint x = 0: D = [ci I, -li~, cj I, -lj~]."""
    phi, D, nu, gamma = out
    ci, li, cj, lj = x[3], x[4], x[5], x[6]
    for a in range(3):
        clear_row(D, row + a)
        phi[row + a] = x[0][a]
        nu[row + a] = 0.0
        gamma[row + a] = -x[2][a]
        D[row + a, a] = ci
        D[row + a, 6 + a] = cj
    _put_minus_skew(D, row, 3, li)
    _put_minus_skew(D, row, 9, lj)


@njit
def _put_minus_skew(D, row, c, l):
    """D[row:row+3, c:c+3] = -l~ = [[0, l2, -l1], [-l2, 0, l0], [l1, -l0, 0]]."""
    D[row, c + 1] = l[2]
    D[row, c + 2] = -l[1]
    D[row + 1, c] = -l[2]
    D[row + 1, c + 2] = l[0]
    D[row + 2, c] = l[1]
    D[row + 2, c + 1] = -l[0]


# ------------------------------------------------------------------------------ joint coordinates
@njit
def angle_row(S, i, j, R_i, R_j, k, D, row):
    """Rotation angle of body j relative to body i about the joint axis u_i.

    theta = atan2(b_i . a_j, a_i . a_j) with the joint triads [u, a, b] of both bodies (zero
    when a_j = a_i). Writes its Jacobian with respect to v_ij into D[row] and returns
    (theta in (-pi, pi], thetadot, velocity-quadratic part of thetaddot):
        thetadot = (x ydot - y xdot) / r^2, x = a_i.a_j, y = b_i.a_j, r^2 = x^2 + y^2,
        thetaddot = D vdot + (x y'' - y x'')_quad / r^2 - 2 thetadot (x xdot + y ydot) / r^2.
    """
    a_i = vector(S, i, R_i, k, 1, 0)
    b_i = vector(S, i, R_i, k, 2, 0)
    a_j = vector(S, j, R_j, k, 1, 1)
    x, y = dot_value(a_i, a_j), dot_value(b_i, a_j)
    xd, yd = dot_rate(a_i, a_j), dot_rate(b_i, a_j)
    gx, gy = dot_gamma(a_i, a_j), dot_gamma(b_i, a_j)
    r2 = x * x + y * y
    clear_row(D, row)
    add_dot_row(b_i, a_j, x / r2, D, row)
    add_dot_row(a_i, a_j, -y / r2, D, row)
    thetad = (x * yd - y * xd) / r2
    quad = (x * (-gy) - y * (-gx)) / r2 - 2.0 * thetad * (x * xd + y * yd) / r2
    return math.atan2(y, x), thetad, quad


@njit
def translation_row(S, i, j, s_i, s_j, R_i, k, D, row):
    """Translation u_i . d of the joint point of j relative to that of i along the axis u_i.

    Writes its Jacobian into D[row]; returns (x, xdot, velocity-quadratic part of xddot).
    """
    d = kin_sub(point(S, j, s_j, k, 1), point(S, i, s_i, k, 0))
    u_i = vector(S, i, R_i, k, 0, 0)
    clear_row(D, row)
    add_dot_row(u_i, d, 1.0, D, row)
    return dot_value(u_i, d), dot_rate(u_i, d), -dot_gamma(u_i, d)


@njit
def coordinate_row(S, b, c, D, row):
    """Body coordinate c (0..2: x, y, z of r; 3..6: e0..e3 of p) of body b.

    Writes its Jacobian into D[row] (rdot_c, or the row of pdot = 1/2 G^T omega, Eq. 5.12);
    returns (value, velocity-quadratic part of its second derivative: 1/2 G(pdot)^T omega)."""
    r, omega, p = S[0], S[3], S[4]
    clear_row(D, row)
    if c < 3:
        D[row, c] = 1.0
        return r[b, c], 0.0
    e = c - 3
    pb = (p[b, 0], p[b, 1], p[b, 2], p[b, 3])
    for a in range(3):                 # pdot is linear in omega: its rows are pdot(p, e_a)
        unit = (1.0 if a == 0 else 0.0, 1.0 if a == 1 else 0.0, 1.0 if a == 2 else 0.0)
        D[row, 3 + a] = pdot_scalar(pb, unit)[e]
    w = row3(omega, b)
    return pb[e], pdot_scalar(pdot_scalar(pb, w), w)[e]


# ------------------------------------------------------------------------------ vectorized forms
@dataclass
class Kin:
    """Value, velocity and quadratic acceleration (n, 3) of n instances of a Kin."""

    value: np.ndarray
    vel: np.ndarray
    acc: np.ndarray


@njit
def _store(x, k, out):
    for a in range(3):
        out[0, k, a] = x[0][a]
        out[1, k, a] = x[1][a]
        out[2, k, a] = x[2][a]


@njit
def _points(S, body, local, side, out):
    for k in range(body.size):
        _store(point(S, body[k], local, k, side), k, out)


@njit
def _vectors(S, body, local, side, out):
    for k in range(body.size):
        _store(vector(S, body[k], local, k, 0, side), k, out)


def _state(state):
    return (state.r, state.A, state.rdot, state.omega, state.p)


def _kin(state, body, local, side, is_point):
    body = np.ascontiguousarray(body, dtype=np.int64)
    local = np.ascontiguousarray(local, dtype=float).reshape(-1, 3)
    out = np.empty((3, body.size, 3))
    if is_point:
        _points(_state(state), body, local, side, out)
    else:                              # a vector is read as column 0 of a (n, 3, 1) triad
        _vectors(_state(state), body, local.reshape(-1, 3, 1), side, out)
    return Kin(out[0], out[1], out[2])


def body_point(state, body: np.ndarray, local: np.ndarray, side: int) -> Kin:
    """Global position (value), velocity and quadratic acceleration of the points ``local``
    (n, 3, body axes) of the bodies ``body`` (n,), Eq. (8.1)."""
    return _kin(state, body, local, side, True)


def body_vector(state, body: np.ndarray, local: np.ndarray, side: int) -> Kin:
    """The same for vectors fixed on the bodies, Eq. (8.3)."""
    return _kin(state, body, local, side, False)


@njit
def _angles(S, bi, bj, R_i, R_j, theta, D, thetad, quad):
    for k in range(bi.size):
        theta[k], thetad[k], quad[k] = angle_row(S, bi[k], bj[k], R_i, R_j, k, D, k)


def relative_angle(state, body_i, body_j, R_i, R_j):
    """Rotation angle of body j relative to body i about u_i for n instances (see angle_row).

    Returns theta (n,) in (-pi, pi], its Jacobian D (n, 12) with respect to v_ij, thetadot (n,)
    and the velocity-quadratic part of thetaddot (n,)."""
    bi = np.ascontiguousarray(body_i, dtype=np.int64)
    n = bi.size
    theta, thetad, quad = np.empty(n), np.empty(n), np.empty(n)
    D = np.empty((n, 12))
    _angles(_state(state), bi, np.ascontiguousarray(body_j, dtype=np.int64),
            np.ascontiguousarray(R_i, dtype=float), np.ascontiguousarray(R_j, dtype=float),
            theta, D, thetad, quad)
    return theta, D, thetad, quad


def velocities_ij(state, body_i: np.ndarray, body_j: np.ndarray) -> np.ndarray:
    """v_ij = [rdot_i, omega_i, rdot_j, omega_j] of n instances: (n, 12)."""
    return np.concatenate([state.rdot[body_i], state.omega[body_i],
                           state.rdot[body_j], state.omega[body_j]], axis=1)
