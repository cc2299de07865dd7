"""Rotational spring-damper-actuator about a revolute (or cylindrical) joint.

With theta the joint angle (body j relative to body i about the joint axis u, as measured by the
angle driver: atan2(b_i.a_j, a_i.a_j)), the element applies the generalized force
    g_ij = tau D_theta^T,   tau = -(k (theta - theta0) + c thetadot + tau_a(t)),
with D_theta the Jacobian of theta with respect to v_ij. When the joint holds this is the moment
tau u on body j and -tau u on body i; when it is violated it is still the exact gradient of the
potential k (theta - theta0)^2 / 2, so energy is balanced in every state. theta - theta0 is wrapped to (-pi, pi], so the spring
acts on the shortest angle (use it for oscillations, not for windings of several turns).
"""
from __future__ import annotations

import numpy as np

from ..constraints import primitives as prim
from ..errors import ModelError
from ..motion import MotionLawSet, make_law
from .base import ForceType, add_to_bodies, check_unknown, register


@register
class RotationalSpringDamper(ForceType):
    name = "rotational_spring_damper"
    required = ("joint",)
    parameters = {"joint": "joint", "stiffness": "number", "damping": "number",
                  "rest_angle": "number", "actuator": "law"}

    def __init__(self, names, bi, bj, R_i, R_j, k, c, theta0, laws):
        super().__init__(names)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.R_i = np.asarray(R_i)
        self.R_j = np.asarray(R_j)
        self.k = np.asarray(k, dtype=float)
        self.c = np.asarray(c, dtype=float)
        self.theta0 = np.asarray(theta0, dtype=float)
        self.laws = MotionLawSet(laws)

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        joint = spec.params.get("joint")
        if joint not in builder.joints:
            raise ModelError(f"forces[{spec.name!r}].joint: unknown joint {joint!r}")
        if builder.joints[joint].type not in ("revolute", "cylindrical"):
            raise ModelError(f"forces[{spec.name!r}]: acts about a revolute or cylindrical "
                             f"joint; {joint!r} is a {builder.joints[joint].type} joint")
        for key in ("stiffness", "damping"):
            value = float(spec.params.get(key, 0.0))
            if not (np.isfinite(value) and value >= 0):
                raise ModelError(f"forces[{spec.name!r}].{key}: must be >= 0, got {value}")
        make_law(spec.params.get("actuator", 0.0))

    @classmethod
    def build(cls, specs, ctx):
        geoms = [ctx.joint_geometry(s.params["joint"]) for s in specs]
        joints = [ctx.builder.joints[s.params["joint"]] for s in specs]
        return cls([s.name for s in specs], [ctx.index[j.body_i] for j in joints],
                   [ctx.index[j.body_j] for j in joints], [g.R_i[0] for g in geoms],
                   [g.R_j[0] for g in geoms],
                   [float(s.params.get("stiffness", 0.0)) for s in specs],
                   [float(s.params.get("damping", 0.0)) for s in specs],
                   [float(s.params.get("rest_angle", 0.0)) for s in specs],
                   [make_law(s.params.get("actuator", 0.0)) for s in specs])

    def _torque(self, state, t):
        theta, D, thetad, _ = prim.relative_angle(state, self.bi, self.bj, self.R_i, self.R_j)
        dtheta = np.remainder(theta - self.theta0 + np.pi, 2 * np.pi) - np.pi
        ta = self.laws(t)[0]
        tau = -(self.k * dtheta + self.c * thetad + ta)
        return tau, D, dtheta, thetad, ta

    def evaluate(self, state, t, g):
        tau, D, _, _, _ = self._torque(state, t)
        gen = tau[:, None] * D                                   # (n, 12) over v_i, v_j
        add_to_bodies(g, self.bi, gen[:, 0:3], gen[:, 3:6])
        add_to_bodies(g, self.bj, gen[:, 6:9], gen[:, 9:12])

    def potential_energy(self, state, t):
        _, _, dtheta, _, _ = self._torque(state, t)
        return float(0.5 * np.sum(self.k * dtheta**2))

    def nonconservative_power(self, state, t):
        _, _, _, thetad, ta = self._torque(state, t)
        return float(-np.sum((self.c * thetad + ta) * thetad))
