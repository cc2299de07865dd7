"""Armature: the rotor inertia of a joint's coordinate (a geared motor's reflected inertia).

An armature of inertia J (``inertia``: kg m^2 on an ``angle``, kg on a ``translation``) on the
coordinate theta of a revolute, translational, cylindrical or screw joint (a cylindrical or
screw joint needs ``coordinate``) adds the kinetic energy T_a = J theta'^2 / 2 and nothing
else: a rotor geared to the joint whose own gyroscopic terms are neglected, or MJCF's
``armature`` (J added to the diagonal of the joint-space mass matrix).

In body coordinates theta' = B v, with B the coordinate's exact Jacobian row over the two
bodies' velocities (the row the angle and translation drivers use, and through which joint
limits and joint friction apply their forces), and theta'' = B v' + B' v. Virtual work gives
the generalized force B^T mu on the bodies with

    mu = -J theta'' = -J (B v' - gamma_B),      gamma_B = -B' v,

so an armature is a row of the multiplier solve (:mod:`..dynamics.system`) with the
compliance 1 / J instead of a constraint:

    M v' = g + D^T lam + B^T mu,    D v' = gamma,    B v' + mu / J = gamma_B,

exact, and for J -> infinity the joint is locked, for J -> 0 it has no effect. The penalty and
augmented Lagrangian methods put J B^T B into M + alpha D^T D; the recursive method adds J
to the joint's articulated inertia D = H^T I H. The armature rows live only in the solves:
the model's constraint rows, multipliers, reactions, violations, projections and rank
decisions do not see them.

Energy: T_a enters the kinetic energy (``Results.energy``), so the balance closes. The
element's kernel applies no force of its own (its force is the solve's B^T mu).
"""
from __future__ import annotations

import math

import numpy as np

from ..constraints.base import CONSTRAINT_TYPES, canonical_name
from ..constraints.primitives import angle_row, translation_row
from ..errors import ModelError
from ..jit import njit
from .base import check_unknown, register
from .joint_coordinate import JointCoordinateForce, joint_coordinate_kind
from .kernel_tools import ANGLE, TRANSLATION

#: parameter columns: the coordinate (kernel_tools.ANGLE or TRANSLATION) and J
C_KIND, C_INERTIA = 0, 1
COORDINATES = {"angle": ANGLE, "translation": TRANSLATION}


@njit(inline="always")
def armature_row(S, G, k, D, row):
    """(theta', velocity-quadratic part of theta'') of instance k's coordinate, its Jacobian
    B over v_ij into D[row] (the driver kernels' angle_row / translation_row)."""
    i, j = G.bi[k], G.bj[k]
    if int(G.param[k, C_KIND]) == ANGLE:
        _, rate, quad = angle_row(S, i, j, G.R_i, G.R_j, k, D, row)
    else:
        _, rate, quad = translation_row(S, i, j, G.s_i, G.s_j, G.R_i, k, D, row)
    return rate, quad


@njit(inline="always")
def armature_rows(S, G, index, D, gamma, rg, row0):
    """The rows row0 + a of every armature a (force-table instance index[a]): B into D,
    gamma_B = -B' v into gamma and rg (the right-hand side of the multiplier solve, which
    Baumgarte's stabilisation leaves alone)."""
    for a in range(index.size):
        _, quad = armature_row(S, G, index[a], D, row0 + a)
        gamma[row0 + a] = -quad
        rg[row0 + a] = -quad


@njit
def kernel(S, G, k, g, energy, power, D):
    """No force of its own (the solve applies B^T mu), no potential energy, no power."""
    energy[k] = 0.0
    power[k] = 0.0


@njit
def rotor_energy(S, G, out):
    """out[k] = (theta', J theta'^2 / 2) of every instance k."""
    D = np.zeros((1, 12))
    for k in range(out.shape[0]):
        rate, _ = armature_row(S, G, k, D, 0)
        out[k, 0] = rate
        out[k, 1] = 0.5 * G.param[k, C_INERTIA] * rate * rate


@njit
def details(S, G, vdot, out):
    """out[k] = (theta', theta'' = B vdot + B' v, J theta'^2 / 2) of every instance k; vdot
    (nb + 1, 6): the bodies' accelerations, the ground's row zero."""
    D = np.zeros((1, 12))
    for k in range(out.shape[0]):
        rate, quad = armature_row(S, G, k, D, 0)
        i, j = G.bi[k], G.bj[k]
        acc = quad
        for c in range(6):
            acc += D[0, c] * vdot[i, c] + D[0, 6 + c] * vdot[j, c]
        out[k, 0], out[k, 1] = rate, acc
        out[k, 2] = 0.5 * G.param[k, C_INERTIA] * rate * rate


@register
class Armature(JointCoordinateForce):
    """Armature: the rotor inertia J of a joint's coordinate (kinetic energy J theta'^2 / 2)."""

    name = "armature"
    kernel = staticmethod(kernel)
    n_param = 2
    parameters = {"joint": "joint", "coordinate": "string", "inertia": "number"}
    required = ("joint", "inertia")

    @classmethod
    def _row(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        name = spec.name
        joint = spec.params.get("joint")
        if joint in builder.joints:
            jtype = canonical_name(builder.joints[joint].type)
            kinds = [k for k in getattr(CONSTRAINT_TYPES.get(jtype), "driver_kinds", ())
                     if k in COORDINATES]
            if jtype == "spherical" or not kinds:
                raise ModelError(
                    f"forces[{name!r}]: an armature acts on the angle or translation of a "
                    f"revolute, translational, cylindrical or screw joint; {joint!r} is a "
                    f"{jtype} joint (give the rotor as a body with its own joint instead)")
        joint_spec, coordinate = joint_coordinate_kind(spec, builder, ("angle", "translation"))
        value = spec.params.get("inertia")
        try:
            J = float(value)
        except (TypeError, ValueError):
            J = math.nan
        if not (math.isfinite(J) and J > 0.0):
            unit = "kg m^2" if coordinate == "angle" else "kg"
            raise ModelError(f"forces[{name!r}].inertia: must be a finite number > 0 ({unit}, "
                             f"the rotor inertia reflected to the joint; leave the element out "
                             f"for none), got {value!r}")
        row = np.zeros(cls.n_param)
        row[C_KIND] = COORDINATES[coordinate]
        row[C_INERTIA] = J
        return joint_spec, coordinate, row

    @property
    def inertia(self) -> np.ndarray:
        """(n,) J of every instance (kg m^2 or kg)."""
        return self.param[:, C_INERTIA]

    def potential_energy(self, state, t, states=None) -> float:
        return 0.0

    # ------------------------------------------------------------------------- outputs
    #: output columns (spatialmbd.outputs); units on an angle / a translation
    quantities = {"coordinate_rate": ("rad/s", "m/s"),
                  "coordinate_acceleration": ("rad/s^2", "m/s^2"), "force": ("N m", "N"),
                  "energy": ("J", "J"), "power": ("W", "W")}

    def output_units(self, k) -> dict:
        """{quantity: unit} of instance k."""
        c = int(self.param[k, C_KIND] == TRANSLATION)
        return {q: u[c] for q, u in self.quantities.items()}

    def output_columns(self, results, k, states=None) -> dict:
        """Of instance k at the output times: the coordinate's rate and acceleration, the
        rotor's generalized force on the joint mu = -J theta'' (N m or N), its kinetic energy
        J theta'^2 / 2 and the power mu theta' (= -dT/dt) it takes from the bodies."""
        from ..state import BodyState
        from .kernels import ForceTable
        G = ForceTable([self], only_compiled=False).G
        nt, nb = len(results.t), results.model.nb
        out, row = np.zeros((nt, 3)), np.zeros((self.n, 3))
        vdot = np.zeros((nb + 1, 6))
        for it in range(nt):
            state = (BodyState.from_qv(results.q[it], results.v[it], results.t[it])
                     if states is None else states[it])
            vdot[:nb] = np.asarray(results.vdot[it]).reshape(nb, 6)
            details(state.arrays(), G, vdot, row)
            out[it] = row[k]
        force = -self.inertia[k] * out[:, 1]
        return dict(coordinate_rate=out[:, 0], coordinate_acceleration=out[:, 1], force=force,
                    energy=out[:, 2], power=force * out[:, 0])

    def kinetic_energy(self, state, t=0.0) -> float:
        """The rotors' kinetic energy sum J theta'^2 / 2 (J) at ``state``."""
        from .kernels import ForceTable
        out = np.zeros((self.n, 2))
        rotor_energy(state.arrays(), ForceTable([self], only_compiled=False).G, out)
        return float(out[:, 1].sum())


def refuse_armature(model, analysis: str) -> None:
    """ModelError if the model has armatures and ``analysis`` does not take them into account
    yet (its equations would silently leave the rotors out)."""
    names = [n for g in model.force_groups if g.name == Armature.name for n in g.names]
    if names:
        raise ModelError(f"{analysis}: the armature element(s) {', '.join(names)} (rotor "
                         f"inertia) are not taken into account by {analysis} yet; simulate "
                         "the model instead (every method of simulate has them), or leave "
                         "them out for this analysis")
