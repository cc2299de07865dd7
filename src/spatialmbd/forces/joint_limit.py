"""Joint limit: a unilateral end stop on the coordinate of a joint, with a contact law.

The coordinate x of the joint (``coordinate``):

* ``angle``: the joint angle theta of a revolute, cylindrical or screw joint (body j relative
  to body i about the joint axis u, as the angle driver measures it: atan2(b_i.a_j, a_i.a_j));
* ``translation``: the slide u_i . d of a translational, cylindrical or screw joint;
* ``cone`` (spherical joints): the angle acos(u_i . u_j) between an axis fixed in body i and
  one fixed in body j (``axis_i``, ``axis_j`` in body axes; default the joint axis of each
  body), limited by ``upper`` (the cone's half-angle): the swing only;
* ``rotation`` (spherical joints, never the default): the angle theta in [0, pi] of the whole
  relative rotation of body j from its assembled orientation relative to body i (swing and
  twist, :func:`.kernel_tools.rotation_angle`), limited by ``upper``: MuJoCo's ball-joint range.

A revolute, translational or spherical joint has one such coordinate (the default); a
cylindrical or screw joint needs ``coordinate``. With the stops ``lower`` and/or ``upper``
the gap is g = min(x - lower, upper - x) (m or rad) and the penetration delta = -g > 0 when
a stop is passed. The stop then applies the normal force f_N(delta, delta') of one of the
contact laws (:mod:`.contact.laws`: ``linear``, ``hertz``, ``hunt_crossley``,
``lankarani_nikravesh``, ``flores``, ``gonthier``, ``carvalho_martins``; the parameters and
their names are those of the contact element: ``stiffness`` K in N m/rad^n or N/m^n,
``exponent`` n, ``damping`` c, ``restitution`` e, ``min_impact_velocity``) as the generalized
force along the coordinate, through its exact Jacobian row D_x (as the rotational
spring-damper does):

    g_ij = Q D_x^T,   Q = +f_N at the lower stop, -f_N at the upper stop

so the stop is the moment Q u (angle), the force Q u (translation) between the two bodies
when the joint holds, and the exact gradient of the potential otherwise. An angle is read as
c + wrap(theta - c) about the middle c of the range (only one stop: a quarter turn inside
it), so a range narrower than a turn is seen without a jump.

Energy: the elastic part K delta^n is the gradient of the potential K delta^(n+1) / (n+1)
(``energy``); the rest (f_N - K delta^n) g' is the dissipated power (``power``), so the
energy balance closes. Restitution: a stop of the linear law on a free coordinate of inertia
I rebounds with e = exp(-zeta (pi - phi) / sqrt(1 - zeta^2)), zeta = c / (2 sqrt(K I)),
tan(phi) = 2 zeta sqrt(1 - zeta^2) / (1 - 2 zeta^2): the law's force falls to zero (it never
pulls) before the penetration does (phi = 0 gives the textbook exp(-zeta pi / sqrt(1 -
zeta^2)) of a dashpot that may pull); the hysteresis laws rebound with the restitution
:func:`.contact.laws.produced_restitution` of their chi (the given e for Carvalho-Martins,
docs/contact.md).

Impact events: a stop with a hysteresis law needs the approach speed v0 = -g' at the touch,
recorded by the contacts' memory (:mod:`.contact.memory`): the coordinate crossing a stop is
a located restart event of the run, and the records are kept in ``results.contact_log``.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..jit import njit
from .base import check_unknown, register
from .contact import laws as L
from .contact.element import law_params
from .joint_coordinate import JointCoordinateForce, joint_coordinate_kind
from .kernel_tools import (ANGLE, CONE, ROTATION_ANGLE, TRANSLATION, add_coordinate_force,
                           joint_coordinate)

#: parameter columns before the law's (C_LAW .. C_VMIN of :mod:`.contact.laws`)
C_KIND, C_LOWER, C_UPPER, C_HAS_LOWER, C_HAS_UPPER, C_CENTRE = range(6)
#: the details columns (:func:`details`); gap and gap rate first (the impact memory's)
DETAIL_COLUMNS = ("gap", "gap_rate", "impact_velocity", "coordinate", "coordinate_rate",
                  "force", "active", "energy", "power")
COORDINATES = {"angle": ANGLE, "translation": TRANSLATION, "cone": CONE,
               "rotation": ROTATION_ANGLE}


@njit(inline="always")
def evaluate_limit(S, G, k, D):
    """(x, x', gap, gap rate, v0, Q, elastic energy, dissipated power) of instance k; D[0]
    holds D_x afterwards."""
    p = G.param
    x, xd = joint_coordinate(S, G, k, D, p[k, C_CENTRE])
    gap, gd, side = math.inf, 0.0, 1.0
    if p[k, C_HAS_LOWER] > 0.0:
        gap, gd = x - p[k, C_LOWER], xd
    if p[k, C_HAS_UPPER] > 0.0 and p[k, C_UPPER] - x < gap:
        gap, gd, side = p[k, C_UPPER] - x, -xd, -1.0
    v0 = G.law[k, 0]
    if gap >= 0.0:
        return x, xd, gap, gd, v0, 0.0, 0.0, 0.0
    fN, el, energy = L.normal_force(p, k, -gap, -gd, v0)
    return x, xd, gap, gd, v0, side * fN, energy, (fN - el) * gd


@njit
def kernel(S, G, k, g, energy, power, D):
    """The stop's generalized force Q D_x^T, its elastic energy and dissipated power."""
    _, _, gap, _, _, Q, e, pw = evaluate_limit(S, G, k, D)
    energy[k] = e
    power[k] = pw
    if gap < 0.0:
        add_coordinate_force(g, G, k, D, Q)


@njit
def details(S, G, out):
    """out[k] = the :data:`DETAIL_COLUMNS` of every instance k."""
    D = np.zeros((1, 12))
    for k in range(out.shape[0]):
        x, xd, gap, gd, v0, Q, e, pw = evaluate_limit(S, G, k, D)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4] = gap, gd, v0, x, xd
        out[k, 5], out[k, 6], out[k, 7], out[k, 8] = Q, 1.0 if gap < 0.0 else 0.0, e, pw


def _stop(spec, key):
    value = spec.params.get(key)
    if value is None:
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not math.isfinite(x):
        raise ModelError(f"forces[{spec.name!r}].{key}: expected a finite number (rad or m), "
                         f"got {value!r}")
    return x


def _axis(spec, key, default):
    value = spec.params.get(key)
    if value is None:
        return np.asarray(default, dtype=float)
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.size != 3 or not np.all(np.isfinite(arr)) or not np.linalg.norm(arr) > 0:
        raise ModelError(f"forces[{spec.name!r}].{key}: expected a nonzero 3-vector in body "
                         f"axes, got {value!r}")
    return arr / np.linalg.norm(arr)


@register
class JointLimit(JointCoordinateForce):
    """Joint limit: a unilateral end stop on a joint coordinate with a contact law."""

    name = "joint_limit"
    kernel = staticmethod(kernel)
    n_param = L.C_VMIN + 1
    parameters = {"joint": "joint", "coordinate": "string", "lower": "number",
                  "upper": "number", "axis_i": "vector", "axis_j": "vector", "law": "string",
                  "stiffness": "number", "exponent": "number", "damping": "number",
                  "restitution": "number", "min_impact_velocity": "number"}
    #: the impact-velocity memory of :mod:`.contact.memory` (hysteresis laws)
    records_impacts = True
    details_kernel = staticmethod(details)
    n_details = len(DETAIL_COLUMNS)

    def __init__(self, names, bi, bj, s_i, s_j, R_i, R_j, param, coordinates):
        super().__init__(names, bi, bj, s_i, s_j, R_i, R_j, param, coordinates)
        self.element = self.names

    @classmethod
    def _row(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        rotation = spec.params.get("coordinate") == "rotation"   # never the default
        joint, coordinate = joint_coordinate_kind(
            spec, builder, ("angle", "translation", "cone") + (("rotation",) if rotation
                                                               else ()))
        lower, upper = _stop(spec, "lower"), _stop(spec, "upper")
        name = spec.name
        if lower is None and upper is None:
            raise ModelError(f"forces[{name!r}]: give a lower and/or an upper stop")
        if lower is not None and upper is not None and not lower < upper:
            raise ModelError(f"forces[{name!r}]: lower = {lower:g} must be less than upper = "
                             f"{upper:g}")
        if coordinate == "angle":
            if lower is not None and upper is not None and upper - lower >= 2 * math.pi:
                raise ModelError(f"forces[{name!r}]: the range upper - lower = "
                                 f"{upper - lower:g} rad must be less than a turn (2 pi)")
        if coordinate in ("cone", "rotation"):
            what = "the half-angle" if coordinate == "cone" else "the largest rotation angle"
            if lower is not None or not 0.0 < upper < math.pi:
                raise ModelError(f"forces[{name!r}]: a {coordinate} limit takes only upper, "
                                 f"{what} in (0, pi) rad; got lower={lower}, upper={upper}")
        elif any(k in spec.params for k in ("axis_i", "axis_j")):
            raise ModelError(f"forces[{name!r}]: axis_i / axis_j belong to a cone limit "
                             "(coordinate: cone on a spherical joint)")
        if "stiffness" not in spec.params:
            raise ModelError(f"forces[{name!r}].stiffness: give the stop's stiffness (N m/rad^n "
                             "or N/m^n)")
        law = law_params(spec, (0.0, 0.0), ("", ""))[:5]
        centre = 0.0
        if coordinate == "angle":
            centre = (0.5 * (lower + upper) if lower is not None and upper is not None
                      else (lower + 0.5 * math.pi if lower is not None
                            else upper - 0.5 * math.pi))
        row = np.zeros(cls.n_param)
        row[C_KIND] = COORDINATES[coordinate]
        row[C_LOWER] = 0.0 if lower is None else lower
        row[C_UPPER] = 0.0 if upper is None else upper
        row[C_HAS_LOWER], row[C_HAS_UPPER] = lower is not None, upper is not None
        row[C_CENTRE] = centre
        row[L.C_LAW:L.C_VMIN + 1] = law
        return joint, coordinate, row

    @classmethod
    def _triads(cls, spec, coordinate, geom):
        """The joint's triads; a cone limit's axis_i / axis_j replace their first columns."""
        R_i, R_j = geom.R_i[0].copy(), geom.R_j[0].copy()
        if coordinate == "cone":
            R_i[:, 0] = _axis(spec, "axis_i", R_i[:, 0])
            R_j[:, 0] = _axis(spec, "axis_j", R_j[:, 0])
        return R_i, R_j

    def needs_memory(self) -> np.ndarray:
        """The instances with a hysteresis law (they need the impact velocity)."""
        return self.param[:, L.C_LAW] > L.HERTZ

    def table(self, memory=None):
        from .kernels import ForceTable
        t = ForceTable([self], only_compiled=False)
        if memory is not None:
            t.law[:, 0] = memory
        return t

    def details(self, state, memory=None) -> np.ndarray:
        """(n, len(DETAIL_COLUMNS)) at ``state`` (memory: recorded impact speeds)."""
        out = np.zeros((self.n, len(DETAIL_COLUMNS)))
        details(state.arrays(), self.table(memory).G, out)
        return out

    # ------------------------------------------------------------------------- outputs
    #: output columns (spatialmbd.outputs); units of an angle / translation limit
    quantities = {"coordinate": ("rad", "m"), "coordinate_rate": ("rad/s", "m/s"),
                  "penetration": ("rad", "m"), "impact_velocity": ("rad/s", "m/s"),
                  "force": ("N m", "N"), "active": ("-", "-"), "power": ("W", "W"),
                  "energy": ("J", "J")}

    def output_units(self, k) -> dict:
        """{quantity: unit} of instance k (rad-based unless a translation limit)."""
        c = int(self.param[k, C_KIND] == TRANSLATION)
        return {q: u[c] for q, u in self.quantities.items()}

    def output_columns(self, results, k, states=None) -> dict:
        """The :attr:`quantities` of instance k at the output times: the coordinate and its
        rate, the penetration beyond the stop, the recorded impact velocity, the generalized
        force Q along the coordinate (N m or N; > 0 pushes towards larger x), active (0/1),
        the dissipated power and the elastic energy."""
        from ..state import BodyState
        from .kernels import ForceTable
        start = 0
        for g in ForceTable(results.model.force_groups).groups:
            if g is self:
                break
            start += g.n
        log = sorted(getattr(results, "contact_log", None) or [])
        nt = len(results.t)
        out = np.zeros((nt, len(DETAIL_COLUMNS)))
        memory = np.zeros(self.n)
        li = 0
        for it in range(nt):
            while li < len(log) and log[li][0] <= results.t[it]:
                if start <= log[li][1] < start + self.n:
                    memory[log[li][1] - start] = log[li][2]
                li += 1
            state = BodyState.from_qv(results.q[it], results.v[it], results.t[it])
            out[it] = self.details(state, memory)[k]
        col = {c: out[:, m] for m, c in enumerate(DETAIL_COLUMNS)}
        return dict(coordinate=col["coordinate"], coordinate_rate=col["coordinate_rate"],
                    penetration=np.maximum(-col["gap"], 0.0),
                    impact_velocity=col["impact_velocity"], force=col["force"],
                    active=col["active"], power=col["power"], energy=col["energy"])
