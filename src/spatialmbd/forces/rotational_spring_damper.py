"""Rotational spring-damper-actuator about a revolute (or cylindrical) joint.

With theta the joint angle (body j relative to body i about the joint axis u, as measured by the
angle driver: atan2(b_i.a_j, a_i.a_j)), the element applies the generalized force
    g_ij = tau D_theta^T,   tau = -(k (theta - theta0) + c thetadot + tau_a(t)),
with D_theta the Jacobian of theta with respect to v_ij. When the joint holds this is the moment
tau u on body j and -tau u on body i; when it is violated it is still the exact gradient of the
potential k (theta - theta0)^2 / 2, so energy is balanced in every state. theta - theta0 is
wrapped to (-pi, pi], so the spring acts on the shortest angle (use it for oscillations, not
for windings of several turns).

A nonlinear spring (``nonlinear_stiffness = [k1, k2, k3]``) has the stiffness
k(d) = k + k1 |d| + k2 d^2 + k3 |d|^3 of d = theta - theta0 in place of k (torque k(d) d,
potential k d^2/2 + k1 |d|^3/3 + k2 d^4/4 + k3 |d|^5/5), as in Chrono's spring modulation.
"""
from __future__ import annotations

import numpy as np

from ..constraints.drivers import wrap_angle
from ..constraints.primitives import angle_row
from ..errors import ModelError
from ..jit import njit
from ..motion import MotionLawSet, make_law
from .base import ForceType, check_unknown, nonlinear_stiffness, register
from .kernel_tools import add_wrench


@njit
def kernel(S, G, k, g, energy, power, D):
    """param = (k, c, theta0, k1, k2, k3), law = actuator tau_a(t); D: the (1, 12) scratch
    row."""
    i, j = G.bi[k], G.bj[k]
    theta, thetad, _ = angle_row(S, i, j, G.R_i, G.R_j, k, D, 0)   # D[0] = D_theta over v_ij
    stiffness, damping = G.param[k, 0], G.param[k, 1]
    dtheta = wrap_angle(theta - G.param[k, 2])
    ta = G.law[k, 0]
    a = abs(dtheta)
    k1, k2, k3 = G.param[k, 3], G.param[k, 4], G.param[k, 5]
    stiff = stiffness + a * (k1 + a * (k2 + a * k3))                   # k(d)
    tau = -(stiff * dtheta + damping * thetad + ta)
    add_wrench(g, i, tau * D[0, 0], tau * D[0, 1], tau * D[0, 2], tau * D[0, 3],
               tau * D[0, 4], tau * D[0, 5])                        # g_ij = tau D_theta^T
    add_wrench(g, j, tau * D[0, 6], tau * D[0, 7], tau * D[0, 8], tau * D[0, 9],
               tau * D[0, 10], tau * D[0, 11])
    energy[k] = dtheta * dtheta * (0.5 * stiffness
                                   + a * (k1 / 3.0 + a * (0.25 * k2 + a * 0.2 * k3)))
    power[k] = -(damping * thetad + ta) * thetad


@register
class RotationalSpringDamper(ForceType):
    name = "rotational_spring_damper"
    kernel = staticmethod(kernel)
    n_param = 6
    required = ("joint",)
    parameters = {"joint": "joint", "stiffness": "number", "nonlinear_stiffness": "any",
                  "damping": "number", "rest_angle": "number", "actuator": "law"}

    def __init__(self, names, bi, bj, R_i, R_j, k, c, theta0, laws, nonlinear=None):
        super().__init__(names)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.R_i = np.asarray(R_i)
        self.R_j = np.asarray(R_j)
        self.k = np.asarray(k, dtype=float)
        self.c = np.asarray(c, dtype=float)
        self.theta0 = np.asarray(theta0, dtype=float)
        self.nonlinear = (np.zeros((len(self.names), 3)) if nonlinear is None
                          else np.asarray(nonlinear, dtype=float).reshape(-1, 3))
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
        nonlinear_stiffness(spec, "N m/rad^2, N m/rad^3, N m/rad^4")
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
                   [make_law(s.params.get("actuator", 0.0)) for s in specs],
                   [nonlinear_stiffness(s, "") for s in specs])

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, R_i=self.R_i, R_j=self.R_j,
                    param=np.column_stack([self.k, self.c, self.theta0, self.nonlinear]))
