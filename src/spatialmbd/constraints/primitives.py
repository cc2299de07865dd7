"""Vectorized building blocks of the constraint kernels (text ch. 8).

Every joint of the text is assembled from a few kinematic quantities of its two bodies i and j:
points fixed on a body (8.1), vectors fixed on a body (8.3) and the vector d between two points
(8.4). A :class:`Kin` carries, for n joint instances at once, such a 3-vector x with

    value  x              (n, 3)
    vel    xdot           (n, 3)      time derivative along the motion
    acc    x'' - J vdot   (n, 3)      the velocity-quadratic part of the second derivative
    terms                             how xdot depends on v_ij = [rdot_i, omega_i, rdot_j, omega_j]

For a vector a fixed on body b: adot = omega~ a (5.7) = -a~ omega and, with omegadot = 0,
a'' = omega~ adot. For a point P: r^P = r + s^P (8.1), rdot^P = rdot - s~ omega (5.9),
r''^P(quadratic) = omega~ omega~ s^P. A term (side, lever, translation, sign) stands for
sign * (translation ? rdot_side : 0) - sign * lever~ omega_side.

Scalar constraints built from two quantities x, y then follow from the product rule:
    Phi = x^T y,  D = y^T J_x + x^T J_y,  gamma = -(acc_x^T y + 2 xdot^T ydot + x^T acc_y),
which is exactly Eqs. (9.9)-(9.17) and (9.18)-(9.26) with the ERRATA corrections, for every
joint. The Jacobian row of y^T J_x is written directly: for a term of x, its translation columns
get sign * y and its rotation columns sign * (lever x y) -- no (n, 3, 12) arrays are formed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rotations import cross
from ..state import BodyState


@dataclass
class Kin:
    value: np.ndarray
    vel: np.ndarray
    acc: np.ndarray
    terms: tuple        # ((side, lever (n, 3), translation: bool, sign), ...)

    def __sub__(self, other: "Kin") -> "Kin":
        flipped = tuple((s, lev, tr, -sg) for s, lev, tr, sg in other.terms)
        return Kin(self.value - other.value, self.vel - other.vel, self.acc - other.acc,
                   self.terms + flipped)

    def row(self, y: np.ndarray) -> np.ndarray:
        """y^T J_x: (n, 12) for y (n, 3)."""
        D = np.zeros((y.shape[0], 12))
        for side, lever, translation, sign in self.terms:
            c = 6 * side
            if translation:
                D[:, c:c + 3] += sign * y
            D[:, c + 3:c + 6] += sign * cross(lever, y)
        return D

    def jacobian(self) -> np.ndarray:
        """J_x itself: (n, 3, 12) (for vector equations such as the spherical joint)."""
        n = self.value.shape[0]
        J = np.zeros((n, 3, 12))
        for side, lever, translation, sign in self.terms:
            c = 6 * side
            if translation:
                J[:, 0, c], J[:, 1, c + 1], J[:, 2, c + 2] = sign, sign, sign
            # -lever~ omega: rows of -lever~ = [[0, lz, -ly], [-lz, 0, lx], [ly, -lx, 0]]
            lx, ly, lz = lever[:, 0] * sign, lever[:, 1] * sign, lever[:, 2] * sign
            J[:, 0, c + 4] += lz
            J[:, 0, c + 5] -= ly
            J[:, 1, c + 3] -= lz
            J[:, 1, c + 5] += lx
            J[:, 2, c + 3] += ly
            J[:, 2, c + 4] -= lx
        return J


def _rotate(state: BodyState, body: np.ndarray, local: np.ndarray) -> np.ndarray:
    A = state.A[body]
    return np.einsum("nij,nj->ni", A, local)


def body_vector(state: BodyState, body: np.ndarray, local: np.ndarray, side: int) -> Kin:
    """A vector fixed on ``body`` (n,), given in body axes ``local`` (n, 3), Eq. (8.3).

    side: 0 if the body is body i of the joint, 1 if body j (selects the Jacobian columns).
    """
    a = _rotate(state, body, local)
    w = state.omega[body]
    ad = cross(w, a)
    return Kin(a, ad, cross(w, ad), ((side, a, False, 1.0),))


def body_point(state: BodyState, body: np.ndarray, local: np.ndarray, side: int) -> Kin:
    """Global position of a point fixed on ``body``, r^P = r + A s'^P, Eq. (8.1)."""
    s = _rotate(state, body, local)
    w = state.omega[body]
    sd = cross(w, s)
    return Kin(state.r[body] + s, state.rdot[body] + sd, cross(w, sd), ((side, s, True, 1.0),))


def dot(x: Kin, y: Kin):
    """Scalar constraint x^T y: returns (phi (n,), D (n, 12), gamma (n,))."""
    phi = np.einsum("ni,ni->n", x.value, y.value)
    D = x.row(y.value) + y.row(x.value)
    gamma = -(np.einsum("ni,ni->n", x.acc, y.value) + 2.0 * np.einsum("ni,ni->n", x.vel, y.vel)
              + np.einsum("ni,ni->n", x.value, y.acc))
    return phi, D, gamma


def vector_equation(x: Kin):
    """Three scalar constraints x = 0: returns (phi (n, 3), D (n, 3, 12), gamma (n, 3))."""
    return x.value, x.jacobian(), -x.acc


def stack(*parts):
    """Stack scalar / vector constraint parts (phi, D, gamma) along the equation axis."""
    phis, Ds, gammas = [], [], []
    for phi, D, gamma in parts:
        if phi.ndim == 1:
            phi, D, gamma = phi[:, None], D[:, None, :], gamma[:, None]
        phis.append(phi)
        Ds.append(D)
        gammas.append(gamma)
    return np.concatenate(phis, axis=1), np.concatenate(Ds, axis=1), np.concatenate(gammas, axis=1)


def velocities_ij(state: BodyState, body_i: np.ndarray, body_j: np.ndarray) -> np.ndarray:
    """v_ij = [rdot_i, omega_i, rdot_j, omega_j] of n instances: (n, 12)."""
    return np.concatenate([state.rdot[body_i], state.omega[body_i],
                           state.rdot[body_j], state.omega[body_j]], axis=1)


def relative_angle(state: BodyState, body_i, body_j, R_i, R_j):
    """Rotation angle of body j relative to body i about the joint axis u_i.

    theta = atan2(b_i . a_j, a_i . a_j) with the joint triads [u, a, b] of both bodies (zero
    when a_j = a_i). Returns theta (n,) in (-pi, pi], its Jacobian D (n, 12) with respect to
    v_ij, thetadot (n,) and the velocity-quadratic part of thetaddot (n,):
        thetadot = (x ydot - y xdot) / r^2, x = a_i.a_j, y = b_i.a_j, r^2 = x^2 + y^2,
        thetaddot = D vdot + (x y'' - y x'')_quad / r^2 - 2 thetadot (x xdot + y ydot) / r^2.
    """
    a_i = body_vector(state, body_i, R_i[:, :, 1], 0)
    b_i = body_vector(state, body_i, R_i[:, :, 2], 0)
    a_j = body_vector(state, body_j, R_j[:, :, 1], 1)
    x, Dx, gx = dot(a_i, a_j)
    y, Dy, gy = dot(b_i, a_j)
    r2 = x * x + y * y
    vij = velocities_ij(state, body_i, body_j)
    xd = np.einsum("nk,nk->n", Dx, vij)
    yd = np.einsum("nk,nk->n", Dy, vij)
    D = (x[:, None] * Dy - y[:, None] * Dx) / r2[:, None]
    thetad = (x * yd - y * xd) / r2
    quad = (x * (-gy) - y * (-gx)) / r2 - 2.0 * thetad * (x * xd + y * yd) / r2
    return np.arctan2(y, x), D, thetad, quad


def relative_translation(state: BodyState, body_i, body_j, s_i, s_j, R_i):
    """Translation of the joint point of j relative to that of i along the axis u_i: u_i . d.

    Returns (x (n,), D (n, 12), xdot (n,), quadratic part of xddot (n,)).
    """
    d = body_point(state, body_j, s_j, 1) - body_point(state, body_i, s_i, 0)
    u_i = body_vector(state, body_i, R_i[:, :, 0], 0)
    x, D, g = dot(u_i, d)
    vij = velocities_ij(state, body_i, body_j)
    return x, D, np.einsum("nk,nk->n", D, vij), -g
