"""A force at a body point, Eqs. (11.2)-(11.3): g_i = [f; s~^P f].

f = magnitude(t) * direction, the direction fixed in space (frame="global") or in the body
(frame="body"), magnitude a motion law of time (N) or a number.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..motion import MotionLawSet, make_law
from ..rotations import cross
from .base import ForceType, add_to_bodies, check_body, check_unknown, local_point, register

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


class _Directed(ForceType):
    """Shared by point forces and torques: vector = magnitude(t) * direction (global or body)."""

    def __init__(self, names, body, direction, in_body, laws):
        super().__init__(names)
        self.body = np.asarray(body, dtype=np.intp)
        self.direction = np.asarray(direction, dtype=float)
        self.in_body = np.asarray(in_body, dtype=bool)
        self.laws = MotionLawSet(laws)

    def _vectors(self, state, t):
        mag = self.laws(t)[0]
        dirs = np.where(self.in_body[:, None],
                        np.einsum("nij,nj->ni", state.A[self.body], self.direction),
                        self.direction)
        return mag[:, None] * dirs


@register
class PointForce(_Directed):
    name = "point_force"
    required = ("body", "direction")
    parameters = {"body": "body", "point": "point", "direction": "vector", "magnitude": "law",
                  "frame": "string"}

    def __init__(self, names, body, point, direction, in_body, laws):
        super().__init__(names, body, direction, in_body, laws)
        self.point = np.asarray(point, dtype=float)

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
                   [local_point(s, ctx.builder, s.params["body"], "point") for s in specs],
                   [_direction(s) for s in specs], [_frame(s) for s in specs],
                   [make_law(s.params.get("magnitude", 1.0)) for s in specs])

    def evaluate(self, state, t, g):
        f = self._vectors(state, t)
        s = np.einsum("nij,nj->ni", state.A[self.body], self.point)
        add_to_bodies(g, self.body, f, cross(s, f))            # Eq. (11.2)

    def nonconservative_power(self, state, t):
        f = self._vectors(state, t)
        s = np.einsum("nij,nj->ni", state.A[self.body], self.point)
        vP = state.rdot[self.body] + cross(state.omega[self.body], s)
        return float(np.sum(f * vP))


@register
class Torque(_Directed):
    """A pure moment, Eq. (11.4): g_i = [0; n]."""

    name = "torque"
    required = ("body", "direction")
    parameters = {"body": "body", "direction": "vector", "magnitude": "law", "frame": "string"}

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

    def evaluate(self, state, t, g):
        n = self._vectors(state, t)
        add_to_bodies(g, self.body, np.zeros_like(n), n)

    def nonconservative_power(self, state, t):
        return float(np.sum(self._vectors(state, t) * state.omega[self.body]))
