"""Fixed tendon: a spring, damper and actuator on a linear combination of joint coordinates
(MJCF ``<tendon><fixed>`` with its stiffness, damping and the actuators that pull it).

The tendon's length is a linear combination of the coordinates q_m of one to four joints,

    L = sum_m c_m q_m,        L' = sum_m c_m q_m',

each q_m the angle (revolute, cylindrical, screw) or the translation (translational,
cylindrical, screw) of its joint, zero as assembled, measured exactly as the couplers measure it
(:func:`spatialmbd.constraints.couplers.joint_coordinate`: the angle atan2(b_i . a_j, a_i . a_j),
the translation u_i . d). The joints may sit anywhere: on the ground, on a moving carrier, on
other joints' bodies. The tendon's force is

    F = -k (L - L0) - c L' + f,   f = clamp(gain u + b0 + b1 L + b2 L', forcerange),
    u = clamp(command, ctrlrange),

(k ``stiffness``, c ``damping``, L0 ``rest_length``; ``rest_length: [a, b]`` is a dead band:
the spring acts on L - b above b, on L - a below a, and not between (MJCF ``springlength`` with
two values); the actuator part as MuJoCo's affine
actuators: ``gain``, ``bias = [b0, b1, b2]``), plus, with ``range = [lo, hi]``, the tendon's
limit: a linear stop of ``limit_stiffness`` K and ``limit_damping`` C on the penetration
delta = lo - L (or L - hi) > 0, pushing with Q = max(K delta + C delta', 0) (it never pulls),
+Q at the lower and -Q at the upper end (MJCF ``limited`` / ``range`` of a fixed tendon,
its soft limit mapped as a joint's: docs/import.md), and with ``frictionloss`` F_f the
regularized Coulomb friction -F_f tanh(L' / v_eps) of the joint friction's law (``creep_velocity``
v_eps, default 1e-4; MJCF ``frictionloss`` of a fixed tendon). Each joint m receives the effort c_m F as the
generalized force c_m F D_qm^T, D_qm the exact Jacobian row of q_m over its two bodies (the
gradient of L: the potential k (L - L0)^2 / 2 is exact in every state). Power of the
non-conservative parts: (f - c L') L', the friction's, and the limit's (Q -/+ K delta) L'; its
elastic energy
K delta^2 / 2. An angle is read within half a turn of its assembled value (atan2), enough for
tendons that do not wind.

MuJoCo's tendon length is measured from qpos = 0; ours from the assembly: the import shifts
``rest_length`` and the bias b0 by sum_m c_m qpos0_m (docs/import.md).
"""
from __future__ import annotations

import math

import numpy as np

from ..constraints.couplers import JOINT_BLOCK, KIND_TRANSLATION, joint_coordinate
from ..errors import ModelError
from ..jit import njit
from ..motion import MotionLawSet, make_law
from .actuators.common import _number, _range
from .base import ForceType, check_unknown, register
from .kernel_tools import add_wrench

#: the most joints one tendon combines
MAX_JOINTS = 4
#: parameter columns: the tendon's numbers, then one coupler joint block per joint
STIFF, DAMP, REST, GAIN, B0, B1, B2, CTRL_LO, CTRL_HI, FORCE_LO, FORCE_HI, N_JOINTS = range(12)
COEF = 12                                 # c_1 .. c_4
BLOCKS = COEF + MAX_JOINTS
#: the limit's columns after the joint blocks: range lo, hi, stiffness K, damping C
LIMIT = BLOCKS + MAX_JOINTS * JOINT_BLOCK
LIM_LO, LIM_HI, LIM_K, LIM_C = LIMIT, LIMIT + 1, LIMIT + 2, LIMIT + 3
#: the friction's columns: level F_f and creep velocity v_eps
FRIC, V_EPS = LIMIT + 4, LIMIT + 5
#: the upper end b of the spring's dead band [a, b] (a in REST; b = a without a band)
REST_HI = LIMIT + 6
N_PARAM = LIMIT + 7


@njit
def length(S, P, D):
    """(L, L') of the tendon with parameter row P; D a (1, 12) scratch row."""
    L, Ld = 0.0, 0.0
    for m in range(int(P[N_JOINTS])):
        q, qd, _ = joint_coordinate(S, P, BLOCKS + m * JOINT_BLOCK, 1.0, 0.0, D, 0)
        L += P[COEF + m] * q
        Ld += P[COEF + m] * qd
    return L, Ld


@njit
def tendon_force(P, L, Ld, u):
    """(actuator force f, total tendon force F) at length L, rate L', command u."""
    u = min(max(u, P[CTRL_LO]), P[CTRL_HI])
    f = P[GAIN] * u + P[B0] + P[B1] * L + P[B2] * Ld
    f = min(max(f, P[FORCE_LO]), P[FORCE_HI])
    return f, f - P[STIFF] * stretch(P, L) - P[DAMP] * Ld


@njit
def stretch(P, L):
    """The spring's stretch: L - b above the dead band's upper end b, L - a below its lower a,
    0 inside (a = b = L0 without a band)."""
    if L > P[REST_HI]:
        return L - P[REST_HI]
    if L < P[REST]:
        return L - P[REST]
    return 0.0


@njit
def friction_force(P, Ld):
    """The tendon's friction force -F_f tanh(L' / v_eps) (0 without frictionloss)."""
    if P[FRIC] == 0.0:
        return 0.0
    return -P[FRIC] * math.tanh(Ld / P[V_EPS])


@njit
def limit_force(P, L, Ld):
    """(Q signed along L, its elastic energy K delta^2 / 2, its non-conservative power) of the
    tendon's limit at length L, rate L'."""
    if L < P[LIM_LO]:
        delta, rate, sign = P[LIM_LO] - L, -Ld, 1.0
    elif L > P[LIM_HI]:
        delta, rate, sign = L - P[LIM_HI], Ld, -1.0
    else:
        return 0.0, 0.0, 0.0
    K = P[LIM_K]
    q = max(K * delta + P[LIM_C] * rate, 0.0)
    return sign * q, 0.5 * K * delta * delta, sign * (q - K * delta) * Ld


@njit
def kernel(S, G, k, g, energy, power, D):
    """param: the columns above; law[k, 0] = command u. g += c_m F D_qm^T for every joint m."""
    P = G.param[k]
    L, Ld = length(S, P, D)
    f, F = tendon_force(P, L, Ld, G.law[k, 0])
    Q, V_lim, P_lim = limit_force(P, L, Ld)
    Qf = friction_force(P, Ld)
    F += Q + Qf
    for m in range(int(P[N_JOINTS])):
        off = BLOCKS + m * JOINT_BLOCK
        for c in range(12):
            D[0, c] = 0.0
        joint_coordinate(S, P, off, 1.0, 0.0, D, 0)
        tau = P[COEF + m] * F
        bi, bj = int(P[off + 26]), int(P[off + 27])
        add_wrench(g, bi, tau * D[0, 0], tau * D[0, 1], tau * D[0, 2], tau * D[0, 3],
                   tau * D[0, 4], tau * D[0, 5])
        add_wrench(g, bj, tau * D[0, 6], tau * D[0, 7], tau * D[0, 8], tau * D[0, 9],
                   tau * D[0, 10], tau * D[0, 11])
    dL = stretch(P, L)
    energy[k] = 0.5 * P[STIFF] * dL * dL + V_lim
    power[k] = (f - P[DAMP] * Ld + Qf) * Ld + P_lim


@njit
def details(S, G, out):
    """out[k] = (L, L', actuator force f, tendon force F) of every instance."""
    D = np.zeros((1, 12))
    for k in range(out.shape[0]):
        P = G.param[k]
        L, Ld = length(S, P, D)
        f, F = tendon_force(P, L, Ld, G.law[k, 0])
        out[k, 0], out[k, 1], out[k, 2] = L, Ld, f
        out[k, 3] = F + limit_force(P, L, Ld)[0] + friction_force(P, Ld)


def _joints(spec, builder):
    """[(joint spec, coefficient, coordinate kind)] of the tendon, checked."""
    from ..constraints.couplers import COORDINATE_OF
    joints, coefs = spec.params.get("joints"), spec.params.get("coefficients")
    if isinstance(joints, str) or not isinstance(joints, (list, tuple)) \
            or not 1 <= len(joints) <= MAX_JOINTS:
        raise ModelError(f"forces[{spec.name!r}].joints: give a list of 1 to {MAX_JOINTS} "
                         f"joint names, got {joints!r}")
    try:
        coefs = [float(c) for c in coefs]
    except (TypeError, ValueError):
        coefs = None
    if coefs is None or len(coefs) != len(joints) or not all(map(math.isfinite, coefs)):
        raise ModelError(f"forces[{spec.name!r}].coefficients: give one finite number per "
                         f"joint ({len(joints)}), got {spec.params.get('coefficients')!r}")
    out = []
    for name, c in zip(joints, coefs):
        if name not in builder.joints:
            raise ModelError(f"forces[{spec.name!r}].joints: unknown joint {name!r} (joints: "
                             f"{', '.join(builder.joints) or 'none'})")
        jtype = builder.joints[name].type
        kind = COORDINATE_OF.get(jtype)
        coordinate = spec.params.get("coordinates", {}).get(name) \
            if isinstance(spec.params.get("coordinates"), dict) else None
        if jtype in ("cylindrical", "screw") and coordinate == "translation":
            kind = KIND_TRANSLATION
        if kind is None:
            raise ModelError(f"forces[{spec.name!r}].joints: joint {name!r} is a {jtype} "
                             "joint; a tendon combines the coordinates of revolute, "
                             "translational, cylindrical and screw joints")
        out.append((builder.joints[name], c, kind))
    if len({j.name for j, _, _ in out}) != len(out):
        raise ModelError(f"forces[{spec.name!r}].joints: a joint appears twice in {joints!r}; "
                         "add its coefficients")
    return out


@register
class FixedTendon(ForceType):
    """Fixed tendon: spring, damper and affine actuator on L = sum c_m q_m of 1 to 4 joint
    coordinates (MJCF fixed tendons)."""

    name = "fixed_tendon"
    kernel = staticmethod(kernel)
    n_param = N_PARAM
    required = ("joints", "coefficients")
    parameters = {"joints": "any", "coefficients": "any", "coordinates": "any",
                  "stiffness": "number", "damping": "number", "rest_length": "any",
                  "command": "law", "gain": "number", "bias": "any", "ctrlrange": "any",
                  "forcerange": "any", "range": "any", "limit_stiffness": "number",
                  "limit_damping": "number", "frictionloss": "number",
                  "creep_velocity": "number"}

    def __init__(self, names, param, laws):
        super().__init__(names)
        self.param = np.asarray(param, dtype=float).reshape(-1, N_PARAM)
        self.laws = MotionLawSet(laws)

    @classmethod
    def _bias(cls, spec):
        value = spec.params.get("bias", (0.0, 0.0, 0.0))
        try:
            bias = [float(x) for x in value]
        except (TypeError, ValueError):
            bias = []
        if len(bias) != 3 or not all(map(math.isfinite, bias)):
            raise ModelError(f"forces[{spec.name!r}].bias: give [b0, b1, b2] (N, N/m, N s/m "
                             f"in tendon units), got {value!r}")
        return bias

    @classmethod
    def _limit(cls, spec):
        """(lo, hi, K, C) of the tendon's limit; (-inf, inf, 0, 0) without ``range``."""
        has = "range" in spec.params
        for key in ("limit_stiffness", "limit_damping"):
            if key in spec.params and not has:
                raise ModelError(f"forces[{spec.name!r}].{key}: a tendon without range has no "
                                 "limit; give range: [lower, upper] (tendon units) as well")
        if not has:
            return -math.inf, math.inf, 0.0, 0.0
        lo, hi = _range(spec, "range", "tendon units")
        K = _number(spec, "limit_stiffness", None, nonnegative=True)
        if K == 0.0:
            raise ModelError(f"forces[{spec.name!r}].limit_stiffness: must be > 0 for a limit "
                             "(range given), got 0")
        C = _number(spec, "limit_damping", 0.0, nonnegative=True)
        return lo, hi, K, C

    @classmethod
    def _rest(cls, spec):
        """(a, b) of ``rest_length``: a number L0 gives (L0, L0), [a, b] a dead band."""
        value = spec.params.get("rest_length", 0.0)
        if isinstance(value, (list, tuple)):
            return _range(spec, "rest_length", "tendon units: a dead band [a, b]")
        L0 = _number(spec, "rest_length", 0.0)
        return L0, L0

    @classmethod
    def _friction(cls, spec):
        """(F_f, v_eps) of the tendon's friction."""
        level = _number(spec, "frictionloss", 0.0, nonnegative=True)
        v_eps = _number(spec, "creep_velocity", 1e-4, nonnegative=True)
        if v_eps == 0.0:
            raise ModelError(f"forces[{spec.name!r}].creep_velocity: must be > 0 (tendon "
                             "units/s: the regularization of the friction), got 0")
        return level, v_eps

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        _joints(spec, builder)
        for key in ("stiffness", "damping"):
            _number(spec, key, 0.0, nonnegative=True)
        cls._rest(spec)
        _number(spec, "gain", 1.0)
        cls._bias(spec)
        _range(spec, "ctrlrange", "command units")
        _range(spec, "forcerange", "tendon force units")
        cls._limit(spec)
        cls._friction(spec)
        try:
            make_law(spec.params.get("command", 0.0))
        except ModelError as exc:
            raise ModelError(f"forces[{spec.name!r}].command: {exc}") from None

    @classmethod
    def build(cls, specs, ctx):
        rows, laws = [], []
        for spec in specs:
            row = np.zeros(N_PARAM)
            row[STIFF] = _number(spec, "stiffness", 0.0, nonnegative=True)
            row[DAMP] = _number(spec, "damping", 0.0, nonnegative=True)
            row[REST], row[REST_HI] = cls._rest(spec)
            row[GAIN] = _number(spec, "gain", 1.0)
            row[B0:B2 + 1] = cls._bias(spec)
            row[CTRL_LO:CTRL_HI + 1] = _range(spec, "ctrlrange", "")
            row[FORCE_LO:FORCE_HI + 1] = _range(spec, "forcerange", "")
            row[LIM_LO:LIM_C + 1] = cls._limit(spec)
            row[FRIC:V_EPS + 1] = cls._friction(spec)
            joints = _joints(spec, ctx.builder)
            row[N_JOINTS] = len(joints)
            for m, (joint, c, kind) in enumerate(joints):
                row[COEF + m] = c
                row[BLOCKS + m * JOINT_BLOCK:BLOCKS + (m + 1) * JOINT_BLOCK] = _block(
                    joint, kind, ctx)
            rows.append(row)
            laws.append(make_law(spec.params.get("command", 0.0)))
        return cls([s.name for s in specs], rows, laws)

    def columns(self):
        return dict(bi=np.zeros(self.n, np.intp), param=self.param)

    def details(self, state, t) -> np.ndarray:
        """(n, 4): L, L', actuator force f, tendon force F of every instance at (state, t)."""
        from .kernels import ForceTable
        table = ForceTable([self], only_compiled=False)
        table.set_time(t)
        out = np.empty((self.n, 4))
        details(state.arrays(), table.G, out)
        return out

    def output_units(self, i) -> dict:
        return {"length": "tendon", "length_rate": "tendon/s", "actuator_force": "-",
                "force": "-"}

    def output_columns(self, results, i, states) -> dict:
        cols = np.array([self.details(s, float(t))[i] for s, t in zip(states, results.t)])
        cols = cols.reshape(-1, 4)
        return dict(length=cols[:, 0], length_rate=cols[:, 1], actuator_force=cols[:, 2],
                    force=cols[:, 3])


def _block(joint, kind, ctx) -> np.ndarray:
    """The coupler joint block (couplers.JOINT_BLOCK) of one tendon joint: its geometry, the
    sides 0 (body i) and 1 (body j) of the scratch row (-1 for the ground), its bodies, the
    coordinate kind and the assembled translation."""
    geom = ctx.joint_geometry(joint.name)
    bi, bj = ctx.index[joint.body_i], ctx.index[joint.body_j]
    out = np.zeros(JOINT_BLOCK)
    out[0:3], out[3:6] = geom.s_i[0], geom.s_j[0]
    out[6:15], out[15:24] = geom.R_i[0].ravel(), geom.R_j[0].ravel()
    out[24] = 0 if bi < ctx.nb else -1
    out[25] = 1 if bj < ctx.nb else -1
    out[26:28] = bi, bj
    out[28] = kind
    if kind == KIND_TRANSLATION:
        r_i, A_i = ctx.pose(joint.body_i)
        r_j, A_j = ctx.pose(joint.body_j)
        d = r_j + A_j @ geom.s_j[0] - r_i - A_i @ geom.s_i[0]
        out[29] = float((A_i @ geom.R_i[0][:, 0]) @ d)
    return out
