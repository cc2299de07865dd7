"""Spring-damper-actuator between two body points, Eqs. (11.5)-(11.12).

l = r_j^P - r_i^P (11.5), l = |l| (11.6), u = l / l (11.7), ldot = u^T ldot_vec (11.8),
f = k (l - l0) + c ldot + f_a(t) (11.10), f_i = f u, f_j = -f u (11.11): a positive f (tension)
pulls the two points towards each other. l0 defaults to the assembled length.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..motion import MotionLawSet, make_law
from ..rotations import cross
from .base import ForceType, add_to_bodies, check_body, check_unknown, local_point, register


@register
class SpringDamper(ForceType):
    name = "spring_damper"
    required = ("body_i", "body_j")
    parameters = {"body_i": "body", "body_j": "body", "point_i": "point", "point_j": "point",
                  "stiffness": "number", "damping": "number", "natural_length": "number",
                  "actuator": "law"}

    def __init__(self, names, bi, bj, s_i, s_j, k, c, l0, laws):
        super().__init__(names)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.s_i = np.asarray(s_i, dtype=float)
        self.s_j = np.asarray(s_j, dtype=float)
        self.k = np.asarray(k, dtype=float)
        self.c = np.asarray(c, dtype=float)
        self.l0 = np.asarray(l0, dtype=float)
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
        l0 = spec.params.get("natural_length")
        if l0 is not None and not float(l0) >= 0:
            raise ModelError(f"forces[{spec.name!r}].natural_length: must be >= 0, got {l0}")
        make_law(spec.params.get("actuator", 0.0))

    @classmethod
    def build(cls, specs, ctx):
        from ..rotations import A_from_p
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
                   [make_law(s.params.get("actuator", 0.0)) for s in specs])

    def _kinematics(self, state):
        si = np.einsum("nij,nj->ni", state.A[self.bi], self.s_i)
        sj = np.einsum("nij,nj->ni", state.A[self.bj], self.s_j)
        lvec = state.r[self.bj] + sj - state.r[self.bi] - si                     # Eq. (11.5)
        ldot_vec = (state.rdot[self.bj] + cross(state.omega[self.bj], sj)
                    - state.rdot[self.bi] - cross(state.omega[self.bi], si))    # Eq. (11.9)
        length = np.linalg.norm(lvec, axis=1)                                     # Eq. (11.6)
        if np.any(length < 1e-12):
            from ..errors import SimulationError
            bad = [self.names[k] for k in np.nonzero(length < 1e-12)[0]]
            raise SimulationError(f"spring-damper(s) {', '.join(bad)}: zero length, the force "
                                  "direction is undefined")
        u = lvec / length[:, None]                                                # Eq. (11.7)
        ldot = np.einsum("ni,ni->n", u, ldot_vec)                                 # Eq. (11.8)
        return si, sj, length, u, ldot

    def forces(self, state, t):
        si, sj, length, u, ldot = self._kinematics(state)
        fa = self.laws(t)[0]
        f = self.k * (length - self.l0) + self.c * ldot + fa                      # Eq. (11.10)
        return si, sj, f, u, ldot, fa

    def evaluate(self, state, t, g):
        si, sj, f, u, _, _ = self.forces(state, t)
        fi = f[:, None] * u                                                       # Eq. (11.11)
        add_to_bodies(g, self.bi, fi, cross(si, fi))                           # Eq. (11.12)
        add_to_bodies(g, self.bj, -fi, cross(sj, -fi))

    def potential_energy(self, state, t):
        _, _, length, _, _ = self._kinematics(state)
        return float(0.5 * np.sum(self.k * (length - self.l0) ** 2))

    def nonconservative_power(self, state, t):
        _, _, _, _, ldot, fa = self.forces(state, t)
        # power of the forces on the bodies: -(c ldot + f_a) ldot
        return float(-np.sum((self.c * ldot + fa) * ldot))
