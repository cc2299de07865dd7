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

from ..errors import ModelError
from ..rotations import cross, p_from_A, skew
from .base import ForceType, add_to_bodies, check_body, check_unknown, local_point, register

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


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """log of rotation matrices (n, 3, 3) -> rotation vectors (n, 3), robust at 0 and pi."""
    p = p_from_A(R)                                   # e0 >= 0: the angle is in [0, pi]
    e = p[:, 1:]
    s = np.linalg.norm(e, axis=1)
    angle = 2.0 * np.arctan2(s, p[:, 0])
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0 / p[:, 0])
    return e * scale[:, None]


def left_jacobian_inverse_T(theta: np.ndarray) -> np.ndarray:
    """J_l(theta)^-T = I + 1/2 theta~ + c theta~^2, c = 1/phi^2 - (1 + cos phi)/(2 phi sin phi)
    (n, 3, 3); the series c = 1/12 + phi^2/720 near phi = 0."""
    phi = np.linalg.norm(theta, axis=1)
    small = phi < 1e-4
    ph = np.where(small, 1.0, phi)
    sn = np.sin(ph)
    near_pi = np.abs(sn) < 1e-9                      # (1 + cos phi) / sin phi -> 0 at phi = pi
    ratio = np.where(near_pi, 0.0, (1.0 + np.cos(ph)) / np.where(near_pi, 1.0, sn))
    c = np.where(small, 1.0 / 12.0 + phi ** 2 / 720.0, 1.0 / ph ** 2 - ratio / (2.0 * ph))
    T = skew(theta)
    return np.eye(3) + 0.5 * T + c[:, None, None] * (T @ T)


@register
class Bushing(ForceType):
    """Bushing: six-component linear spring-damper between two body frames (translations and
    rotations, diagonal stiffness and damping in bushing axes)."""

    name = "bushing"
    parameters = {"body_i": "body", "body_j": "body", "point_i": "point", "point_j": "point",
                  "axes": "matrix", "stiffness": "any", "damping": "any",
                  "rotational_stiffness": "any", "rotational_damping": "any"}
    required = ("body_i", "body_j")
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

    def _deflections(self, state):
        """Global arms, frames and the deflections with their rates (one evaluation)."""
        A_i, A_j = state.A[self.bi], state.A[self.bj]
        si = np.einsum("nij,nj->ni", A_i, self.s_i)
        sj = np.einsum("nij,nj->ni", A_j, self.s_j)
        E_i = A_i @ self.F_i
        E_j = A_j @ self.F_j
        w_i, w_j = state.omega[self.bi], state.omega[self.bj]
        d = state.r[self.bj] + sj - state.r[self.bi] - si
        ddot = state.rdot[self.bj] + cross(w_j, sj) - state.rdot[self.bi] - cross(w_i, si)
        delta = np.einsum("nji,nj->ni", E_i, d)
        deltadot = np.einsum("nji,nj->ni", E_i, ddot - cross(w_i, d))
        theta = rotation_vector(np.swapaxes(E_i, 1, 2) @ E_j)
        w = np.einsum("nji,nj->ni", E_i, w_j - w_i)
        JinvT = left_jacobian_inverse_T(theta)
        thetadot = np.einsum("nji,nj->ni", JinvT, w)     # J_l^-1 w = (J_l^-T)^T w
        return si, d, E_i, delta, deltadot, theta, thetadot, JinvT

    def evaluate(self, state, t, g):
        si, d, E_i, delta, deltadot, theta, thetadot, JinvT = self._deflections(state)
        f = np.einsum("nij,nj->ni", E_i, self.Kt * delta + self.Ct * deltadot)
        tau = np.einsum("nij,nj->ni", E_i, np.einsum(
            "nij,nj->ni", JinvT, self.Kr * theta + self.Cr * thetadot))
        # on i: +f at P_j (arm s_i + d) and +tau; on j: -f at P_j and -tau
        add_to_bodies(g, self.bi, f, cross(si + d, f) + tau)
        sj = si + d - (state.r[self.bj] - state.r[self.bi])
        add_to_bodies(g, self.bj, -f, -cross(sj, f) - tau)

    def potential_energy(self, state, t):
        _, _, _, delta, _, theta, _, _ = self._deflections(state)
        return float(0.5 * np.sum(self.Kt * delta ** 2) + 0.5 * np.sum(self.Kr * theta ** 2))

    def nonconservative_power(self, state, t):
        _, _, _, _, deltadot, _, thetadot, _ = self._deflections(state)
        return float(-np.sum(self.Ct * deltadot ** 2) - np.sum(self.Cr * thetadot ** 2))
