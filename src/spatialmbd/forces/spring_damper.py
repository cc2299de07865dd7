"""Spring-damper-actuator between two body points, Eqs. (11.5)-(11.12).

l = r_j^P - r_i^P (11.5), l = |l| (11.6), u = l / l (11.7), ldot = u^T ldot_vec (11.8),
f = k (l - l0) + c ldot + f_a(t) (11.10), f_i = f u, f_j = -f u (11.11): a positive f (tension)
pulls the two points towards each other. l0 defaults to the assembled length. With l0 = 0 the
points may coincide (a zero-length spring, f_i = k l_vec + c ldot u): there u is the limit
along the motion, the direction of the relative velocity.

A nonlinear spring (``nonlinear_stiffness = [k1, k2, k3]``) has the stiffness
k(d) = k + k1 |d| + k2 d^2 + k3 |d|^3 of the deflection d = l - l0 in place of k, so its force
k(d) d is odd in d (hardening for positive coefficients) and its potential is
k d^2/2 + k1 |d|^3/3 + k2 d^4/4 + k3 |d|^5/5.
"""
from __future__ import annotations

import numpy as np

from ..constraints.primitives import kin_sub, point, v_dot
from ..errors import ModelError
from ..jit import njit
from ..motion import MotionLawSet, make_law
from .base import (ForceType, check_body, check_unknown, local_point, nonlinear_stiffness,
                   register)
from .kernel_tools import add_wrench


@njit
def kernel(S, G, k, g, energy, power, D):
    """param = (k, c, l0, k1, k2, k3), law = actuator f_a(t)."""
    i, j = G.bi[k], G.bj[k]
    Pi, Pj = point(S, i, G.s_i, k, 0), point(S, j, G.s_j, k, 1)
    lv = kin_sub(Pj, Pi)                                                   # Eq. (11.5)
    x = lv[0]
    length = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) ** 0.5              # Eq. (11.6)
    stiffness, damping, l0 = G.param[k, 0], G.param[k, 1], G.param[k, 2]
    if length == 0.0 and l0 == 0.0:
        # coincident points of a spring of zero free length: the spring force k l u vanishes
        # and u is the limit l / |l| along the motion, ldot_vec / |ldot_vec| (the points part
        # along their relative velocity), so the damping force is c ldot_vec; at rest, none
        d = lv[1]
        speed = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) ** 0.5
        u = (d[0] / speed, d[1] / speed, d[2] / speed) if speed > 0.0 else (0.0, 0.0, 0.0)
    else:
        # with l0 > 0 a zero length leaves the direction undefined: the force becomes NaN and
        # the run stops with the element named (the right-hand side's finiteness check)
        u = (x[0] / length, x[1] / length, x[2] / length)                  # Eq. (11.7)
    ldot = v_dot(u, lv[1])                                                 # Eq. (11.8)
    fa = G.law[k, 0]
    d = length - l0
    a = abs(d)
    k1, k2, k3 = G.param[k, 3], G.param[k, 4], G.param[k, 5]
    stiff = stiffness + a * (k1 + a * (k2 + a * k3))                       # k(d)
    f = stiff * d + damping * ldot + fa                                    # Eq. (11.10)
    fi = (f * u[0], f * u[1], f * u[2])                                    # Eq. (11.11)
    si, sj = Pi[4], Pj[6]                                                  # arms, global
    add_wrench(g, i, fi[0], fi[1], fi[2], si[1] * fi[2] - si[2] * fi[1],   # Eq. (11.12)
               si[2] * fi[0] - si[0] * fi[2], si[0] * fi[1] - si[1] * fi[0])
    add_wrench(g, j, -fi[0], -fi[1], -fi[2], -(sj[1] * fi[2] - sj[2] * fi[1]),
               -(sj[2] * fi[0] - sj[0] * fi[2]), -(sj[0] * fi[1] - sj[1] * fi[0]))
    energy[k] = d * d * (0.5 * stiffness + a * (k1 / 3.0 + a * (0.25 * k2 + a * 0.2 * k3)))
    power[k] = -(damping * ldot + fa) * ldot


@register
class SpringDamper(ForceType):
    name = "spring_damper"
    drawn_as = "spring"
    kernel = staticmethod(kernel)
    n_param = 6
    required = ("body_i", "body_j")
    parameters = {"body_i": "body", "body_j": "body", "point_i": "point", "point_j": "point",
                  "stiffness": "number", "nonlinear_stiffness": "any", "damping": "number",
                  "natural_length": "number", "actuator": "law"}

    def __init__(self, names, bi, bj, s_i, s_j, k, c, l0, laws, nonlinear=None):
        super().__init__(names)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.s_i = np.asarray(s_i, dtype=float)
        self.s_j = np.asarray(s_j, dtype=float)
        self.k = np.asarray(k, dtype=float)
        self.c = np.asarray(c, dtype=float)
        self.l0 = np.asarray(l0, dtype=float)
        self.nonlinear = (np.zeros((len(self.names), 3)) if nonlinear is None
                          else np.asarray(nonlinear, dtype=float).reshape(-1, 3))
        self.laws = MotionLawSet(laws)

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        bi = check_body(spec, builder, "body_i", ground_ok=True)
        bj = check_body(spec, builder, "body_j", ground_ok=True)
        if bi == bj:
            raise ModelError(f"forces[{spec.name!r}]: connects body {bi!r} to itself")
        local_point(spec, builder, bi, "point_i")
        local_point(spec, builder, bj, "point_j")
        for key in ("stiffness", "damping"):
            value = float(spec.params.get(key, 0.0))
            if not (np.isfinite(value) and value >= 0):
                raise ModelError(f"forces[{spec.name!r}].{key}: must be >= 0, got {value}")
        nonlinear_stiffness(spec, "N/m^2, N/m^3, N/m^4")
        l0 = spec.params.get("natural_length")
        if l0 is not None and not float(l0) >= 0:
            raise ModelError(f"forces[{spec.name!r}].natural_length: must be >= 0, got {l0}")
        make_law(spec.params.get("actuator", 0.0))

    @classmethod
    def build(cls, specs, ctx):
        s_i, s_j, l0 = [], [], []
        for s in specs:
            pi = local_point(s, ctx.builder, s.params["body_i"], "point_i")
            pj = local_point(s, ctx.builder, s.params["body_j"], "point_j")
            s_i.append(pi)
            s_j.append(pj)
            if s.params.get("natural_length") is None:
                ri, Ai = ctx.pose(s.params["body_i"])
                rj, Aj = ctx.pose(s.params["body_j"])
                l0.append(float(np.linalg.norm(rj + Aj @ pj - ri - Ai @ pi)))
            else:
                l0.append(float(s.params["natural_length"]))
        return cls([s.name for s in specs], [ctx.index[s.params["body_i"]] for s in specs],
                   [ctx.index[s.params["body_j"]] for s in specs], s_i, s_j,
                   [float(s.params.get("stiffness", 0.0)) for s in specs],
                   [float(s.params.get("damping", 0.0)) for s in specs], l0,
                   [make_law(s.params.get("actuator", 0.0)) for s in specs],
                   [nonlinear_stiffness(s, "") for s in specs])

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, s_i=self.s_i, s_j=self.s_j,
                    param=np.column_stack([self.k, self.c, self.l0, self.nonlinear]))
