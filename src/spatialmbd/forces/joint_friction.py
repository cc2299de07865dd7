"""Joint friction: a friction force or moment on a joint's coordinate, of constant level.

The slip (``coordinate``) is the rate of the joint angle of a revolute or cylindrical joint
(``angle``, rad/s), of the slide of a translational or cylindrical joint (``translation``,
m/s), or the relative angular velocity omega_j - omega_i of a spherical joint (``rotation``,
a vector, rad/s). A cylindrical joint needs ``coordinate``.

The friction laws are the contact element's (:mod:`.contact.laws`) with the normal load
replaced by a constant level F (MJCF ``frictionloss``: N on a translation, N m on an angle or
a rotation), slip velocity v and slip speed s = |v|:

* ``coulomb`` (default): Q = -F tanh(s / v_eps) v / s - c_v v, ``frictionloss`` F,
  ``creep_velocity`` v_eps (default 1e-4), ``viscous`` c_v (default 0);
* ``stribeck``: F(s) = F_d + (F_s - F_d) exp(-(s / v_s)^2) in place of F, with F_d =
  ``frictionloss``, F_s = ``static_frictionloss``, v_s = ``stribeck_velocity``;
* ``viscous``: Q = -c_v v only;
* ``lugre``: bristles of stiffness sigma_0 (``bristle_stiffness``, N/m or N m/rad) and
  damping sigma_1 (``bristle_damping``) with the deflection z (an internal state integrated
  with the bodies), z' = v - sigma_0 s z / F(s), Q = -(sigma_0 z + sigma_1 z' + c_v v): a joint
  loaded below the static level sticks with no creep (z settles at the load / sigma_0).

Q is applied through the coordinate's exact Jacobian row D_x (g_ij = Q D_x^T, as the
rotational spring-damper does; for ``rotation`` the moment Q on body j and -Q on body i). The
regularized laws dissipate the power Q v <= 0; LuGre's bristles store sigma_0 z^2 / 2
(``energy``), and the power Q v + sigma_0 z z' is what the friction dissipates, so the energy
balance closes.

With ``mu`` (a friction coefficient) in place of ``frictionloss`` the level is proportional to
the joint's reaction (``C_MODE`` = :data:`REACTION`): F = mu N with N = |normal reaction| on a
translational joint (the reaction force across the slide), r |radial reaction| + r_a |axial
reaction| on a revolute joint (``radius`` r of the pin, ``axial_radius`` r_a of a thrust
collar, default 0), r |radial reaction| on a cylindrical joint's angle (|radial reaction| on its
translation) and r |reaction| on a spherical joint (``radius`` of the ball); ``mu_static`` is the
static coefficient of the stribeck and lugre laws. The kernel reads N (the "load", N or N m)
from the law column 0 of the instance, which :mod:`spatialmbd.dynamics.reaction_friction`
sets from the multipliers, iterated to a fixed point in every evaluation; a LuGre instance
keeps its deflection in column 1 so that the loop can evaluate it again at a new load.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..jit import njit
from .base import check_unknown, register
from .contact import laws as L
from .contact.element import friction_params
from .joint_coordinate import JointCoordinateForce, joint_coordinate_kind
from .kernel_tools import ANGLE, ROTATION, TRANSLATION, add_coordinate_force, add_wrench
from .kernel_tools import joint_coordinate

C_KIND, C_LOAD = 0, 1
#: reaction mode: C_MODE = REACTION, radii r and r_a, and which reaction (NORMAL, RADIAL, TOTAL)
C_MODE, C_RADIUS, C_AXIAL, C_REACTION = 2, 3, 4, 5
CONSTANT, REACTION = 0, 1
NORMAL, RADIAL, TOTAL = 0, 1, 2
COORDINATES = {"angle": ANGLE, "translation": TRANSLATION, "rotation": ROTATION}
#: the details columns (:func:`details`)
DETAIL_COLUMNS = ("slip_x", "slip_y", "slip_z", "friction_x", "friction_y", "friction_z",
                  "bristle_x", "bristle_y", "bristle_z", "energy", "power")


@njit(inline="always")
def evaluate_friction(S, G, k, D):
    """(v, Q, z, bristle energy, power) of instance k: the slip velocity v and the friction
    Q (3-tuples; a scalar coordinate in component 0, its Jacobian row in D[0]), the LuGre
    deflection z (its rate written into G.law[k, 3:])."""
    p = G.param
    if int(p[k, C_KIND]) == ROTATION:
        w = S[3]
        i, j = G.bi[k], G.bj[k]
        v = (w[j, 0] - w[i, 0], w[j, 1] - w[i, 1], w[j, 2] - w[i, 2])
    else:
        v = (joint_coordinate(S, G, k, D, 0.0)[1], 0.0, 0.0)
    load = p[k, C_LOAD]
    if p[k, C_MODE] == REACTION:
        load = G.law[k, 0]
    if p[k, L.C_FRICTION] == L.LUGRE:
        z = (G.law[k, 3], G.law[k, 4], G.law[k, 5])
        G.law[k, 1] = z[0]                    # kept for an evaluation at another load
        Q, zd, pb, eb = L.lugre(p, k, load, v, z)
        for c in range(3):
            G.law[k, 3 + c] = zd[c]
        return v, Q, z, eb, Q[0] * v[0] + Q[1] * v[1] + Q[2] * v[2] + pb
    s = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    a, cv = L.friction_factor(p, k, load, s)
    Q = (-(a + cv) * v[0], -(a + cv) * v[1], -(a + cv) * v[2])
    return v, Q, (0.0, 0.0, 0.0), 0.0, Q[0] * v[0] + Q[1] * v[1] + Q[2] * v[2]


@njit
def kernel(S, G, k, g, energy, power, D):
    """The friction's generalized force, the bristles' energy and the friction's power."""
    _, Q, _, eb, pw = evaluate_friction(S, G, k, D)
    energy[k] = eb
    power[k] = pw
    if int(G.param[k, C_KIND]) == ROTATION:
        add_wrench(g, G.bj[k], 0.0, 0.0, 0.0, Q[0], Q[1], Q[2])
        add_wrench(g, G.bi[k], 0.0, 0.0, 0.0, -Q[0], -Q[1], -Q[2])
    else:
        add_coordinate_force(g, G, k, D, Q[0])


@njit
def details(S, G, out):
    """out[k] = the :data:`DETAIL_COLUMNS` of every instance k."""
    D = np.zeros((1, 12))
    for k in range(out.shape[0]):
        v, Q, z, eb, pw = evaluate_friction(S, G, k, D)
        for c in range(3):
            out[k, c], out[k, 3 + c], out[k, 6 + c] = v[c], Q[c], z[c]
        out[k, 9], out[k, 10] = eb, pw


def _nonnegative(spec, key, required, missing, got_suffix):
    """spec.params[key] as a finite float >= 0 (None when absent and not ``required``);
    ModelError naming the element and the key: ``missing`` says what an absent required value
    is for, ``got_suffix`` what to give instead of a bad one."""
    value = spec.params.get(key)
    if value is None:
        if required:
            raise ModelError(f"forces[{spec.name!r}].{key}: {missing}")
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and x >= 0.0):
        raise ModelError(f"forces[{spec.name!r}].{key}: must be a finite number >= 0"
                         f"{got_suffix[0]}, got {value!r}{got_suffix[1]}")
    return x


def _level(spec, key, required):
    law = spec.params.get("friction", "coulomb")
    return _nonnegative(spec, key, required,
                        f"the {law} law needs a friction level (N, or N m on an angle or a "
                        "rotation)", (" (N or N m)", ""))


def _coefficient(spec, key, required, what="a friction coefficient"):
    return _nonnegative(spec, key, required,
                        f"the friction proportional to the joint's reaction needs {what}",
                        ("", f"; give {what} (0 for none)"))


def _reaction_levels(spec, builder, joint, coordinate, law):
    """(mu, mu_static, (r, r_a, reaction kind)) of an element whose level is proportional to
    its joint's reaction; ModelError naming the element, the value and the fix."""
    from ..constraints.base import canonical_name
    name, p = spec.name, spec.params
    for key in ("frictionloss", "static_frictionloss"):
        if key in p:
            raise ModelError(f"forces[{name!r}].{key}: a constant friction level, and 'mu' "
                             "makes the level proportional to the joint's reaction; give "
                             "one of them")
    jtype = canonical_name(joint.type)
    if jtype not in ("revolute", "translational", "cylindrical", "spherical"):
        raise ModelError(f"forces[{name!r}].mu: friction proportional to the reaction acts on "
                         f"revolute, translational, cylindrical and spherical joints; "
                         f"{p.get('joint')!r} is a {jtype} joint (give 'frictionloss' instead)")
    if law == "viscous":
        raise ModelError(f"forces[{name!r}].mu: the viscous law has no friction level; use "
                         "friction 'coulomb', 'stribeck' or 'lugre' with 'mu'")
    mu = _coefficient(spec, "mu", True)
    mus = _coefficient(spec, "mu_static", law == "stribeck", "a static friction coefficient")
    if law in ("coulomb",) and mus is not None:
        raise ModelError(f"forces[{name!r}].mu_static: a parameter of the stribeck and lugre "
                         "laws, not of 'coulomb'")
    lever = coordinate != "translation"
    radius = _coefficient(spec, "radius", lever, "the radius of the pin or ball (m, > 0)")
    if lever and radius == 0.0:
        raise ModelError(f"forces[{name!r}].radius: must be > 0 (m), got 0; the radius of the "
                         "pin or ball on which the friction acts")
    if not lever and radius is not None:
        raise ModelError(f"forces[{name!r}].radius: a friction force on a translation is mu x "
                         "|normal reaction|, with no radius; drop 'radius'")
    axial = _coefficient(spec, "axial_radius", False, "the mean radius of the thrust collar "
                         "(m)") or 0.0
    if axial and jtype != "revolute":
        raise ModelError(f"forces[{name!r}].axial_radius: only a revolute joint carries an "
                         f"axial reaction with a thrust collar; {jtype} joints do not")
    if law == "lugre" and coordinate == "rotation":
        raise ModelError(f"forces[{name!r}]: LuGre friction proportional to the reaction of a "
                         "spherical joint is not supported; use friction 'coulomb' or "
                         "'stribeck' with 'mu', or a constant 'frictionloss'")
    kind = {"translational": NORMAL, "spherical": TOTAL}.get(jtype, RADIAL)
    return mu, (mus if mus is not None else None), (radius or 1.0, axial, kind)


@register
class JointFriction(JointCoordinateForce):
    """Joint friction: Coulomb, Stribeck, viscous or LuGre friction on a joint coordinate, of a
    constant level or one proportional to the joint's reaction."""

    name = "joint_friction"
    kernel = staticmethod(kernel)
    n_param = L.N_COLUMNS
    parameters = {"joint": "joint", "coordinate": "string", "friction": "string",
                  "frictionloss": "number", "static_frictionloss": "number",
                  "stribeck_velocity": "number", "creep_velocity": "number",
                  "viscous": "number", "bristle_stiffness": "number",
                  "bristle_damping": "number", "mu": "number", "mu_static": "number",
                  "radius": "number", "axial_radius": "number"}

    @classmethod
    def _row(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        joint, coordinate = joint_coordinate_kind(spec, builder,
                                                  ("angle", "translation", "rotation"))
        p = spec.params
        law = p.get("friction", "coulomb")
        if law not in ("coulomb", "stribeck", "viscous", "lugre"):
            raise ModelError(f"forces[{spec.name!r}].friction: unknown friction law {law!r}; "
                             "valid: coulomb, stribeck, viscous, lugre")
        reaction = "mu" in p or "mu_static" in p
        if reaction:
            F, Fs, geometry = _reaction_levels(spec, builder, joint, coordinate, law)
        else:
            for key in ("radius", "axial_radius"):
                if key in p:
                    raise ModelError(f"forces[{spec.name!r}].{key}: a parameter of the "
                                     "friction proportional to the joint's reaction; give "
                                     "'mu' (the friction coefficient) with it, or drop it")
            F = _level(spec, "frictionloss", law != "viscous")
            Fs = _level(spec, "static_frictionloss", law == "stribeck")
        if law in ("coulomb", "viscous") and Fs is not None:
            raise ModelError(f"forces[{spec.name!r}].static_frictionloss: a parameter of the "
                             f"stribeck and lugre laws, not of {law!r}")
        if law == "viscous" and F is not None:
            raise ModelError(f"forces[{spec.name!r}].frictionloss: the viscous law has only "
                             "'viscous' (N s/m or N m s/rad)")
        # the contact's friction parameters with the normal load 1: the mu are the levels
        q = {key: p[key] for key in ("stribeck_velocity", "creep_velocity", "viscous",
                                     "bristle_stiffness", "bristle_damping") if key in p}
        q["friction"] = law
        if Fs is not None:
            q["mu_dynamic"], q["mu_static"] = F, Fs
        elif F is not None:
            q["mu"] = F
        elif "stribeck_velocity" in p:
            raise ModelError(f"forces[{spec.name!r}].stribeck_velocity: a parameter of the "
                             "stribeck and lugre laws (with static_frictionloss)")
        row = np.zeros(cls.n_param)
        row[C_KIND] = COORDINATES[coordinate]
        row[C_LOAD] = 1.0
        row[L.C_MUD:] = friction_params(spec.name, q)
        if reaction:
            row[C_MODE] = REACTION
            row[C_RADIUS], row[C_AXIAL], row[C_REACTION] = geometry
        return joint, coordinate, row

    def state_rows(self) -> np.ndarray:
        """The LuGre instances carry their bristle deflection z as an internal state."""
        return self.param[:, L.C_FRICTION] == L.LUGRE

    @classmethod
    def build(cls, specs, ctx):
        group = super().build(specs, ctx)
        group.joints = tuple(spec.params["joint"] for spec in specs)
        return group

    @property
    def reaction_dependent(self) -> bool:
        """Whether some instance has a level proportional to its joint's reaction."""
        return bool(np.any(self.param[:, C_MODE] == REACTION))

    def loads(self, force_i, A_i) -> np.ndarray:
        """(n,) the loads N of the reaction-proportional instances (0 for the others) from the
        joints' reaction forces on body i, ``force_i`` (n, 3) global axes, and body i's
        rotation matrices ``A_i`` (n, 3, 3) (the ground's: the identity)."""
        u = np.einsum("nij,nj->ni", A_i, self.R_i[:, :, 0])
        axial = np.einsum("ni,ni->n", force_i, u)
        radial = np.linalg.norm(force_i - axial[:, None] * u, axis=1)
        p = self.param
        kind = p[:, C_REACTION]
        load = np.where(kind == TOTAL, p[:, C_RADIUS] * np.linalg.norm(force_i, axis=1),
                        p[:, C_RADIUS] * radial + p[:, C_AXIAL] * np.abs(axial))
        return np.where(p[:, C_MODE] == REACTION, load, 0.0)

    def details(self, state, states=None, loads=None) -> np.ndarray:
        """(n, len(DETAIL_COLUMNS)) at ``state`` (states: (n, 3) LuGre deflections; loads:
        (n,) the loads N of the reaction-proportional instances, :meth:`loads`)."""
        from .kernels import ForceTable
        table = ForceTable([self], only_compiled=False)
        if states is not None:
            states = np.asarray(states, dtype=float)
            table.law[:, 3:3 + states.shape[1]] = states
        if loads is not None:
            table.law[:, 0] = loads
        out = np.zeros((self.n, len(DETAIL_COLUMNS)))
        details(state.arrays(), table.G, out)
        return out

    # ------------------------------------------------------------------------- outputs
    #: output columns (spatialmbd.outputs); units on an angle or rotation / a translation
    quantities = {"slip": ("rad/s", "m/s"), "friction": ("N m", "N"),
                  "bristle": ("rad", "m"), "power": ("W", "W"), "energy": ("J", "J"),
                  "level": ("N m", "N")}

    def output_loads(self, results):
        """(nt, n) the loads N at the output times, from the results' joint reactions (the
        multipliers of the run); None without reaction-proportional instances."""
        if not self.reaction_dependent:
            return None
        from ..rotations import A_from_p
        reactions = results.reactions()
        nb = results.model.nb
        nt = len(results.t)
        A = np.empty((nt, nb + 1, 3, 3))
        A[:, :nb] = A_from_p(results.q[:, :, 3:])
        A[:, nb] = np.eye(3)
        force_i = np.stack([reactions[j].force_i for j in self.joints], axis=1)
        return np.stack([self.loads(force_i[it], A[it, self.bi]) for it in range(nt)])

    def output_units(self, k) -> dict:
        c = int(self.param[k, C_KIND] == TRANSLATION)
        return {q: u[c] for q, u in self.quantities.items()}

    def output_columns(self, results, k, states=None) -> dict:
        """The :attr:`quantities` of instance k at the output times: the slip (the coordinate
        rate; for ``rotation`` |omega_j - omega_i|), the friction Q (for ``rotation`` |Q|;
        else signed, opposing the slip), the LuGre deflection (0 for the other laws), the
        friction's power (<= 0 for the regularized laws), the bristles' energy and the friction
        level (``frictionloss``, or mu N with the load N from the joint's reaction)."""
        from ..state import BodyState
        from .kernels import states_by_group
        z = getattr(results, "force_states", None)
        nt = len(results.t)
        out = np.zeros((nt, len(DETAIL_COLUMNS)))
        loads = self.output_loads(results)
        for it in range(nt):
            st = None if z is None else states_by_group(results.model.force_groups,
                                                         z[it]).get(id(self))
            state = BodyState.from_qv(results.q[it], results.v[it], results.t[it])
            out[it] = self.details(state, st, None if loads is None else loads[it])[k]
        if int(self.param[k, C_KIND]) == ROTATION:
            slip, fr, br = (np.linalg.norm(out[:, c:c + 3], axis=1) for c in (0, 3, 6))
        else:
            slip, fr, br = out[:, 0], out[:, 3], out[:, 6]
        loads = self.output_loads(results)
        level = (self.param[k, L.C_MUD] * loads[:, k] if loads is not None
                 else np.full(nt, self.param[k, L.C_MUD] * self.param[k, C_LOAD]))
        return dict(slip=slip, friction=fr, bristle=br, power=out[:, 10], energy=out[:, 9],
                    level=level)
