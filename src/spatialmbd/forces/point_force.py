"""A force at a body point, Eqs. (11.2)-(11.3): g_i = [f; s~^P f].

f = magnitude(t) * direction, the direction fixed in space (frame="global") or in the body
(frame="body"), magnitude a motion law of time (N) or a number.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..constraints.primitives import rotate, row3, v_add, v_cross, v_dot
from ..jit import njit
from ..motion import MotionLawSet, make_law
from .base import ForceType, check_body, check_unknown, local_point, register
from .kernel_tools import add_wrench

FRAMES = ("global", "body")


def _direction(spec, key="direction"):
    d = np.array(spec.params.get(key, (0, 0, 0)), dtype=float).reshape(-1)
    if d.size != 3 or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise ModelError(f"forces[{spec.name!r}].{key}: give a non-zero 3-vector, got "
                         f"{spec.params.get(key)!r}")
    return d


def _frame(spec):
    frame = spec.params.get("frame", "global")
    if frame not in FRAMES:
        raise ModelError(f"forces[{spec.name!r}].frame: {frame!r} is not one of {FRAMES}")
    return frame == "body"


@njit
def _vector(S, G, k):
    """magnitude(t) * direction, the direction in global axes (param[k, 0] = 1: body axes)."""
    A = S[1]
    b = G.bi[k]
    d0, d1, d2 = G.R_i[k, 0, 0], G.R_i[k, 1, 0], G.R_i[k, 2, 0]
    if G.param[k, 0] != 0.0:
        d0, d1, d2 = rotate(A, b, d0, d1, d2)
    m = G.law[k, 0]
    return (m * d0, m * d1, m * d2)


@njit
def kernel_point_force(S, G, k, g, energy, power, D):
    A, rdot, omega = S[1], S[2], S[3]
    b = G.bi[k]
    f = _vector(S, G, k)
    s = rotate(A, b, G.s_i[k, 0], G.s_i[k, 1], G.s_i[k, 2])
    n = v_cross(s, f)                                                  # Eq. (11.2)
    add_wrench(g, b, f[0], f[1], f[2], n[0], n[1], n[2])
    w = row3(omega, b)
    vP = v_add(row3(rdot, b), v_cross(w, s))
    energy[k] = 0.0
    power[k] = v_dot(f, vP)


@njit
def kernel_torque(S, G, k, g, energy, power, D):
    b = G.bi[k]
    n = _vector(S, G, k)                                               # Eq. (11.4)
    add_wrench(g, b, 0.0, 0.0, 0.0, n[0], n[1], n[2])
    energy[k] = 0.0
    power[k] = v_dot(n, row3(S[3], b))


class _Directed(ForceType):
    """Shared by point forces and torques: vector = magnitude(t) * direction (global or body)."""

    n_param = 1

    def __init__(self, names, body, direction, in_body, laws, point=None):
        super().__init__(names)
        self.body = np.asarray(body, dtype=np.intp)
        self.direction = np.asarray(direction, dtype=float)
        self.in_body = np.asarray(in_body, dtype=bool)
        self.point = np.zeros((self.n, 3)) if point is None else np.asarray(point, dtype=float)
        self.laws = MotionLawSet(laws)

    def columns(self):
        R = np.zeros((self.n, 3, 3))
        R[:, :, 0] = self.direction
        return dict(bi=self.body, s_i=self.point, R_i=R,
                    param=self.in_body.astype(float)[:, None])


@register
class PointForce(_Directed):
    name = "point_force"
    required = ("body", "direction")
    parameters = {"body": "body", "point": "point", "direction": "vector", "magnitude": "law",
                  "frame": "string"}
    kernel = staticmethod(kernel_point_force)

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        body = check_body(spec, builder)
        local_point(spec, builder, body, "point")
        _direction(spec)
        _frame(spec)
        make_law(spec.params.get("magnitude", 1.0))

    @classmethod
    def build(cls, specs, ctx):
        return cls([s.name for s in specs], [ctx.index[s.params["body"]] for s in specs],
                   [_direction(s) for s in specs], [_frame(s) for s in specs],
                   [make_law(s.params.get("magnitude", 1.0)) for s in specs],
                   point=[local_point(s, ctx.builder, s.params["body"], "point") for s in specs])


@register
class Torque(_Directed):
    """A pure moment, Eq. (11.4): g_i = [0; n]."""

    name = "torque"
    required = ("body", "direction")
    parameters = {"body": "body", "direction": "vector", "magnitude": "law", "frame": "string"}
    kernel = staticmethod(kernel_torque)

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        check_body(spec, builder)
        _direction(spec)
        _frame(spec)
        make_law(spec.params.get("magnitude", 1.0))

    @classmethod
    def build(cls, specs, ctx):
        return cls([s.name for s in specs], [ctx.index[s.params["body"]] for s in specs],
                   [_direction(s) for s in specs], [_frame(s) for s in specs],
                   [make_law(s.params.get("magnitude", 1.0)) for s in specs])
