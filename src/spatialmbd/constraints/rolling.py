"""Rolling without slip on a plane: a sphere and a disc (the nonholonomic constraints the text
mentions in ch. 7), exact, as one holonomic and two velocity-level rows.

Body i rolls on a plane fixed to body j (the ground or any moving body): the plane passes
through the point p (``point2``) with unit normal n (``axis2``, the first column of R_j; its
other columns t1, t2 span the plane). The rolling body has its centre c at ``point`` (on body
i) and radius R (``radius``); the disc also has its axis u (``axis``, normal to its face).

The contact point P is the point of the body nearest the plane:

    sphere  P = c - R n
    disc    P = c - R e,  e = (n - w u) / s,  w = n^T u,  s = sqrt(1 - w^2)

(e is the unit vector in the disc's plane pointing down the slope of the plane; the disc is
singular when it lies flat, s = 0).

Equations (rows of one instance):

    height   Phi = n^T (c - p) - R       (sphere)
             Phi = n^T (c - p) - R s     (disc: n^T (c - P) = R s)
    slip_a   t1^T (v_P,i - v_P,j) = 0    nonholonomic: no Phi, D v = 0 only
    slip_b   t2^T (v_P,i - v_P,j) = 0

where v_P,b = rdot_b + omega_b x (P - r_b) is the velocity of the material point of body b at
P. The height row's D and gamma follow from the product rule of :mod:`.primitives`, with the
disc's -R s(w) by the chain rule: D += g'(w) D_w, gamma += g'(w) gamma_w - g''(w) wdot^2,
g' = R w / s, g'' = R / s^3. A slip row's D is [t, rho_i x t, -t, -rho_j x t] (rho_b = P - r_b)
and gamma = -Ddot v, Ddot the rate of those entries along the motion: tdot = omega_j x t,
rhodot_b = Pdot - rdot_b, Pdot the rate of the geometric contact point (not of a material
point): c' - R n' (sphere), c' - R e' with e' = (n' - w' u - w u') / s + (n - w u) w w' / s^3
(disc).

Rows without Phi (``velocity_rows``) have phi = 0 and nu = 0: position solves (assembly,
projection) carry them with zero residual, so their corrections keep the contact point from
slipping to first order; velocity solves and the dynamics use them in full. Their multipliers
are the friction force the rolling needs (``reactions()``), so the friction coefficient a
rolling motion needs can be read off. The degrees of freedom the mobility analysis reports are
velocity degrees of freedom (a sphere rolling on a plane: 3; a disc: 3).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..jit import njit
from .base import ConstraintType, Param, register
from .primitives import (add_dot_row, dot_gamma, dot_rate, dot_value, kin_sub, point, put_dot,
                         row3, v_add, v_cross, v_dot, v_scale, v_sub, vector)

RADIUS = Param("radius", "m", "radius of the rolling sphere or disc", positive=True)


@njit
def _no_slip(S, bi, bj, P, Pd, t, td, out, row):
    """A slip row: t^T (v_P,i - v_P,j) = 0 (phi = nu = 0)."""
    phi, D, nu, gamma = out
    ri, rdi, wi = row3(S[0], bi), row3(S[2], bi), row3(S[3], bi)
    rj, rdj, wj = row3(S[0], bj), row3(S[2], bj), row3(S[3], bj)
    rho_i, rho_j = v_sub(P, ri), v_sub(P, rj)
    ci, cj = v_cross(rho_i, t), v_cross(rho_j, t)
    phi[row] = 0.0
    nu[row] = 0.0
    for a in range(3):
        D[row, a] = t[a]
        D[row, 3 + a] = ci[a]
        D[row, 6 + a] = -t[a]
        D[row, 9 + a] = -cj[a]
    rhod_i, rhod_j = v_sub(Pd, rdi), v_sub(Pd, rdj)
    ddot_v = (v_dot(td, rdi) + v_dot(v_add(v_cross(rhod_i, t), v_cross(rho_i, td)), wi)
              - v_dot(td, rdj) - v_dot(v_add(v_cross(rhod_j, t), v_cross(rho_j, td)), wj))
    gamma[row] = -ddot_v


@njit
def _slip_rows(S, G, k, P, Pd, out, row):
    bj = G.bj[k]
    t1 = vector(S, bj, G.R_j, k, 1, 1)
    t2 = vector(S, bj, G.R_j, k, 2, 1)
    _no_slip(S, G.bi[k], bj, P, Pd, t1[0], t1[1], out, row + 1)
    _no_slip(S, G.bi[k], bj, P, Pd, t2[0], t2[1], out, row + 2)


@njit
def sphere_kernel(S, G, k, row, out):
    R = G.param[k, 0]
    c = point(S, G.bi[k], G.s_i, k, 0)
    n = vector(S, G.bj[k], G.R_j, k, 0, 1)
    d = kin_sub(c, point(S, G.bj[k], G.s_j, k, 1))
    put_dot(d, n, out, row)                                   # n^T (c - p)
    out[0][row] -= R                                          # - R
    P = v_sub(c[0], v_scale(R, n[0]))
    Pd = v_sub(c[1], v_scale(R, n[1]))
    _slip_rows(S, G, k, P, Pd, out, row)


@njit
def disc_kernel(S, G, k, row, out):
    R = G.param[k, 0]
    c = point(S, G.bi[k], G.s_i, k, 0)
    u = vector(S, G.bi[k], G.R_i, k, 0, 0)
    n = vector(S, G.bj[k], G.R_j, k, 0, 1)
    d = kin_sub(c, point(S, G.bj[k], G.s_j, k, 1))
    w, wd = dot_value(n, u), dot_rate(n, u)
    s = math.sqrt(max(1.0 - w * w, 1e-300))
    g1, g2 = R * w / s, R / (s * s * s)
    put_dot(d, n, out, row)                                   # n^T (c - p)
    phi, D, nu, gamma = out
    phi[row] -= R * s                                         # - R s(w)
    add_dot_row(n, u, g1, D, row)                             # + g'(w) D_w
    gamma[row] += g1 * dot_gamma(n, u) - g2 * wd * wd         # chain rule
    nwu = v_sub(n[0], v_scale(w, u[0]))                       # n - w u
    e = v_scale(1.0 / s, nwu)
    ed = v_add(v_scale(1.0 / s, v_sub(v_sub(n[1], v_scale(wd, u[0])), v_scale(w, u[1]))),
               v_scale(w * wd / (s * s * s), nwu))
    P = v_sub(c[0], v_scale(R, e))
    Pd = v_sub(c[1], v_scale(R, ed))
    _slip_rows(S, G, k, P, Pd, out, row)


class _Rolling(ConstraintType):
    n_eq = 3
    eq_labels = ("height", "slip_a", "slip_b")
    velocity_rows = (1, 2)
    parameters = (RADIUS,)


@register
class RollingSphere(_Rolling):
    """Sphere rolling without slip on a plane: centre height and two nonholonomic no-slip rows
    (point: sphere centre on body i; point2, axis2: a point of the plane and its normal, on
    body j)."""

    name = "rolling_sphere"
    inputs = frozenset({"point", "point2", "axis2"})
    kernel = staticmethod(sphere_kernel)


@register
class RollingDisc(_Rolling):
    """Disc (coin, wheel) rolling without slip on a plane: rim contact height and two
    nonholonomic no-slip rows (point, axis: disc centre and axis on body i; point2, axis2: a
    point of the plane and its normal, on body j)."""

    name = "rolling_disc"
    aliases = ("rolling_wheel",)
    inputs = frozenset({"point", "axis", "point2", "axis2"})
    kernel = staticmethod(disc_kernel)

    @classmethod
    def check_assembled(cls, what: str, axis_i: np.ndarray, axis_j: np.ndarray) -> None:
        w = abs(float(np.dot(axis_i, axis_j)))
        if w > 1.0 - 1e-9:
            raise ModelError(f"{what}: the disc lies flat on the plane (its axis along the "
                             "plane normal), where its contact point is undefined; tilt it "
                             "or use a cylinder contact")
