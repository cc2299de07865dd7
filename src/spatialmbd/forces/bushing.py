"""Bushing: a six-component linear spring-damper between two body frames.

A frame E is fixed on each body at its point (P_i on body i, P_j on body j); both coincide when
the model is assembled (no preload). With E_i, E_j their global axes (3x3, columns the bushing
axes) and d = r_j^P - r_i^P:

    translation   delta = E_i^T d,                deltadot = E_i^T (ddot - omega_i x d)
    rotation      theta = log(E_i^T E_j)          (rotation vector, bushing axes of i)
                  w = E_i^T (omega_j - omega_i),  thetadot = J_l(theta)^-1 w
    potential     V = 1/2 delta^T K_t delta + 1/2 theta^T K_r theta
    force         f = E_i (K_t delta + C_t deltadot)          on j: -f at P_j; on i: +f at P_j
    torque        tau = E_i J_l(theta)^-T (K_r theta + C_r thetadot)   on j: -tau; on i: +tau

K_t, C_t, K_r, C_r are diagonal (three values each, in bushing axes). J_l is the left Jacobian
of the rotation group, so the elastic torque is the exact gradient of V for any deflection
(the power of the elastic forces is -dV/dt to round-off) and the damping dissipates
deltadot^T C_t deltadot + thetadot^T C_r thetadot >= 0. For small deflections this is the
usual linear bushing (Adams BUSHING, Exudyn's CartesianSpringDamper plus its rotational part).
"""
from __future__ import annotations

import numpy as np

import math

from ..constraints.primitives import point, rotate, row3, v_add, v_cross, v_dot, v_scale, v_sub
from ..errors import ModelError
from ..jit import njit
from .base import ForceType, check_body, check_unknown, local_point, register
from .kernel_tools import add_wrench

_PAIRS = (("stiffness", "N/m"), ("damping", "N s/m"), ("rotational_stiffness", "N m/rad"),
          ("rotational_damping", "N m s/rad"))


def _three(spec, key) -> np.ndarray:
    value = spec.params.get(key, 0.0)
    arr = np.array(value, dtype=float).reshape(-1) if not np.isscalar(value) else \
        np.full(3, float(value))
    if arr.size != 3 or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ModelError(f"forces[{spec.name!r}].{key}: expected one or three finite values "
                         f">= 0 (bushing axes), got {value!r}")
    return arr


@njit
def log_rotation(R00, R01, R02, R10, R11, R12, R20, R21, R22):
    """The rotation vector theta of a rotation matrix R = exp(theta~) (|theta| <= pi), through
    its Euler parameters (Shepperd's method, e0 >= 0), robust at 0 and pi."""
    tr = R00 + R11 + R22
    c0, c1, c2, c3 = 1.0 + tr, 1.0 + 2.0 * R00 - tr, 1.0 + 2.0 * R11 - tr, 1.0 + 2.0 * R22 - tr
    if c0 >= c1 and c0 >= c2 and c0 >= c3:
        e0 = 0.5 * math.sqrt(c0)
        e1, e2, e3 = (R21 - R12) / (4 * e0), (R02 - R20) / (4 * e0), (R10 - R01) / (4 * e0)
    elif c1 >= c2 and c1 >= c3:
        e1 = 0.5 * math.sqrt(c1)
        e0, e2, e3 = (R21 - R12) / (4 * e1), (R01 + R10) / (4 * e1), (R02 + R20) / (4 * e1)
    elif c2 >= c3:
        e2 = 0.5 * math.sqrt(c2)
        e0, e1, e3 = (R02 - R20) / (4 * e2), (R01 + R10) / (4 * e2), (R12 + R21) / (4 * e2)
    else:
        e3 = 0.5 * math.sqrt(c3)
        e0, e1, e2 = (R10 - R01) / (4 * e3), (R02 + R20) / (4 * e3), (R12 + R21) / (4 * e3)
    if e0 < 0.0:
        e0, e1, e2, e3 = -e0, -e1, -e2, -e3
    s = math.sqrt(e1 * e1 + e2 * e2 + e3 * e3)
    scale = 2.0 * math.atan2(s, e0) / s if s > 1e-12 else 2.0 / e0
    return (scale * e1, scale * e2, scale * e3)


@njit
def jl_inv_T(theta, x):
    """J_l(theta)^-T x = x + 1/2 theta x x + c theta x (theta x x), with
    c = 1/phi^2 - (1 + cos phi) / (2 phi sin phi) (series 1/12 + phi^2/720 near 0, and
    (1 + cos phi) / sin phi -> 0 at phi = pi). With -theta it applies J_l(theta)^-1."""
    phi = math.sqrt(v_dot(theta, theta))
    if phi < 1e-4:
        c = 1.0 / 12.0 + phi * phi / 720.0
    else:
        sn = math.sin(phi)
        ratio = 0.0 if abs(sn) < 1e-9 else (1.0 + math.cos(phi)) / sn
        c = 1.0 / (phi * phi) - ratio / (2.0 * phi)
    tx = v_cross(theta, x)
    ttx = v_cross(theta, tx)
    return (x[0] + 0.5 * tx[0] + c * ttx[0], x[1] + 0.5 * tx[1] + c * ttx[1],
            x[2] + 0.5 * tx[2] + c * ttx[2])


@njit
def _logs(R, out):
    for k in range(R.shape[0]):
        out[k] = log_rotation(R[k, 0, 0], R[k, 0, 1], R[k, 0, 2], R[k, 1, 0], R[k, 1, 1],
                              R[k, 1, 2], R[k, 2, 0], R[k, 2, 1], R[k, 2, 2])


@njit
def _jl(theta, x, out):
    for k in range(theta.shape[0]):
        out[k] = jl_inv_T((theta[k, 0], theta[k, 1], theta[k, 2]), (x[k, 0], x[k, 1], x[k, 2]))


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """log of rotation matrices (n, 3, 3) -> rotation vectors (n, 3) (the kernel's code)."""
    R = np.ascontiguousarray(R, dtype=float).reshape(-1, 3, 3)
    out = np.empty((R.shape[0], 3))
    _logs(R, out)
    return out


def left_jacobian_inverse_T_apply(theta: np.ndarray, x: np.ndarray) -> np.ndarray:
    """J_l(theta)^-T x for (n, 3) arrays (the kernel's code)."""
    theta = np.ascontiguousarray(theta, dtype=float).reshape(-1, 3)
    x = np.ascontiguousarray(x, dtype=float).reshape(-1, 3)
    out = np.empty_like(theta)
    _jl(theta, x, out)
    return out


@njit
def _columns(A, b, F, k):
    return (rotate(A, b, F[k, 0, 0], F[k, 1, 0], F[k, 2, 0]),
            rotate(A, b, F[k, 0, 1], F[k, 1, 1], F[k, 2, 1]),
            rotate(A, b, F[k, 0, 2], F[k, 1, 2], F[k, 2, 2]))


@njit
def kernel(S, G, k, g, energy, power, D):
    """R_i, R_j = the bushing frames in body axes; param = (K_t, C_t, K_r, C_r), 3 each."""
    A, omega = S[1], S[3]
    i, j = G.bi[k], G.bj[k]
    Pi, Pj = point(S, i, G.s_i, k, 0), point(S, j, G.s_j, k, 1)
    d, ddot = v_sub(Pj[0], Pi[0]), v_sub(Pj[1], Pi[1])
    w_i, w_j = row3(omega, i), row3(omega, j)
    Ei = _columns(A, i, G.R_i, k)
    Ej = _columns(A, j, G.R_j, k)
    dd = v_sub(ddot, v_cross(w_i, d))
    w = v_sub(w_j, w_i)
    theta = log_rotation(v_dot(Ei[0], Ej[0]), v_dot(Ei[0], Ej[1]), v_dot(Ei[0], Ej[2]),
                         v_dot(Ei[1], Ej[0]), v_dot(Ei[1], Ej[1]), v_dot(Ei[1], Ej[2]),
                         v_dot(Ei[2], Ej[0]), v_dot(Ei[2], Ej[1]), v_dot(Ei[2], Ej[2]))
    wl = (v_dot(Ei[0], w), v_dot(Ei[1], w), v_dot(Ei[2], w))
    thetad = jl_inv_T((-theta[0], -theta[1], -theta[2]), wl)       # J_l^-1 w
    P = G.param
    f = (0.0, 0.0, 0.0)
    tau = (0.0, 0.0, 0.0)
    e, pw = 0.0, 0.0
    ml = (0.0, 0.0, 0.0)
    for c in range(3):
        delta, deltad = v_dot(Ei[c], d), v_dot(Ei[c], dd)
        fc = P[k, c] * delta + P[k, 3 + c] * deltad
        f = v_add(f, v_scale(fc, Ei[c]))
        e += 0.5 * P[k, c] * delta * delta + 0.5 * P[k, 6 + c] * theta[c] * theta[c]
        pw -= P[k, 3 + c] * deltad * deltad + P[k, 9 + c] * thetad[c] * thetad[c]
    ml = (P[k, 6] * theta[0] + P[k, 9] * thetad[0], P[k, 7] * theta[1] + P[k, 10] * thetad[1],
          P[k, 8] * theta[2] + P[k, 11] * thetad[2])
    tl = jl_inv_T(theta, ml)
    for c in range(3):
        tau = v_add(tau, v_scale(tl[c], Ei[c]))
    si, sj = Pi[4], Pj[6]
    ni = v_add(v_cross(v_add(si, d), f), tau)          # on i: +f at P_j, +tau
    nj = v_cross(sj, f)                                  # on j: -f at P_j, -tau
    add_wrench(g, i, f[0], f[1], f[2], ni[0], ni[1], ni[2])
    add_wrench(g, j, -f[0], -f[1], -f[2], -nj[0] - tau[0], -nj[1] - tau[1], -nj[2] - tau[2])
    energy[k] = e
    power[k] = pw


@register
class Bushing(ForceType):
    """Bushing: six-component linear spring-damper between two body frames (translations and
    rotations, diagonal stiffness and damping in bushing axes)."""

    name = "bushing"
    parameters = {"body_i": "body", "body_j": "body", "point_i": "point", "point_j": "point",
                  "axes": "matrix", "stiffness": "any", "damping": "any",
                  "rotational_stiffness": "any", "rotational_damping": "any"}
    required = ("body_i", "body_j")
    kernel = staticmethod(kernel)
    n_param = 12
    # stiffness and damping: one number (all three axes) or three (checked by _three)

    def __init__(self, names, bi, bj, s_i, s_j, F_i, F_j, Kt, Ct, Kr, Cr):
        super().__init__(names)
        self.bi, self.bj = np.asarray(bi, np.intp), np.asarray(bj, np.intp)
        self.s_i, self.s_j = np.asarray(s_i, float), np.asarray(s_j, float)
        self.F_i, self.F_j = np.asarray(F_i, float), np.asarray(F_j, float)
        self.Kt, self.Ct = np.asarray(Kt, float), np.asarray(Ct, float)
        self.Kr, self.Cr = np.asarray(Kr, float), np.asarray(Cr, float)

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        bi = check_body(spec, builder, "body_i", ground_ok=True)
        bj = check_body(spec, builder, "body_j", ground_ok=True)
        if bi == bj:
            raise ModelError(f"forces[{spec.name!r}]: connects body {bi!r} to itself")
        local_point(spec, builder, bi, "point_i")
        if spec.params.get("point_j") is not None:
            local_point(spec, builder, bj, "point_j")
        for key, _ in _PAIRS:
            _three(spec, key)
        cls._axes(spec)

    @staticmethod
    def _axes(spec) -> np.ndarray:
        value = spec.params.get("axes")
        if value is None:
            return np.eye(3)
        E = np.array(value, dtype=float)
        if E.shape != (3, 3) or not np.all(np.isfinite(E)) or \
                np.abs(E.T @ E - np.eye(3)).max() > 1e-6 or np.linalg.det(E) < 0:
            raise ModelError(f"forces[{spec.name!r}].axes: expected a rotation matrix (3x3, "
                             "orthonormal, det +1; columns the bushing axes in global axes as "
                             f"assembled), got {value!r}")
        return E

    @classmethod
    def build(cls, specs, ctx):
        cols = {k: [] for k in ("s_i", "s_j", "F_i", "F_j")}
        for s in specs:
            ri, Ai = ctx.pose(s.params["body_i"])
            rj, Aj = ctx.pose(s.params["body_j"])
            pi = local_point(s, ctx.builder, s.params["body_i"], "point_i")
            P = ri + Ai @ pi
            if s.params.get("point_j") is None:
                pj = Aj.T @ (P - rj)                  # the same point, as assembled
            else:
                pj = local_point(s, ctx.builder, s.params["body_j"], "point_j")
            E = cls._axes(s)
            cols["s_i"].append(pi)
            cols["s_j"].append(pj)
            cols["F_i"].append(Ai.T @ E)
            cols["F_j"].append(Aj.T @ E)
        return cls([s.name for s in specs], [ctx.index[s.params["body_i"]] for s in specs],
                   [ctx.index[s.params["body_j"]] for s in specs], cols["s_i"], cols["s_j"],
                   cols["F_i"], cols["F_j"], *([_three(s, key) for s in specs]
                                               for key, _ in _PAIRS))

    def deflections(self, state, i: int):
        """Instance i: delta, deltadot, theta, thetadot and the force and moment in bushing
        axes of i, fl = K_t delta + C_t deltadot and ml = J_l^-T (K_r theta + C_r thetadot)
        (the kernel's quantities, for outputs)."""
        b_i, b_j = self.bi[i], self.bj[i]
        E_i, E_j = state.A[b_i] @ self.F_i[i], state.A[b_j] @ self.F_j[i]
        si, sj = state.A[b_i] @ self.s_i[i], state.A[b_j] @ self.s_j[i]
        w_i, w_j = state.omega[b_i], state.omega[b_j]
        d = state.r[b_j] + sj - state.r[b_i] - si
        ddot = state.rdot[b_j] + np.cross(w_j, sj) - state.rdot[b_i] - np.cross(w_i, si)
        delta, deltadot = E_i.T @ d, E_i.T @ (ddot - np.cross(w_i, d))
        theta = rotation_vector(E_i.T @ E_j)[0]
        thetadot = left_jacobian_inverse_T_apply(-theta, E_i.T @ (w_j - w_i))[0]
        fl = self.Kt[i] * delta + self.Ct[i] * deltadot
        ml = left_jacobian_inverse_T_apply(theta, self.Kr[i] * theta + self.Cr[i] * thetadot)[0]
        return delta, deltadot, theta, thetadot, fl, ml

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, s_i=self.s_i, s_j=self.s_j, R_i=self.F_i,
                    R_j=self.F_j, param=np.concatenate([self.Kt, self.Ct, self.Kr, self.Cr],
                                                        axis=1))
