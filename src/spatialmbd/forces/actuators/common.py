"""What every actuator kind shares: the compiled kernel, the gain/bias law, the checks.

Every actuator acts on one coordinate q of a joint -- the angle (revolute, cylindrical,
screw) theta = atan2(b_i . a_j, a_i . a_j) or the translation (translational, cylindrical,
screw) x = u_i . (P_j - P_i), as the drivers measure them (constraints/primitives.py,
``angle_row`` and ``translation_row``) -- through a gear ratio G, as MuJoCo's joint
transmission: the actuator's coordinate is L = G q (L' = G q'), its force is

    f = clamp(gain u + gain_rate u' + b0 + b1 L + b2 L', forcerange),
    u = clamp(command, ctrlrange)    (u' = 0 where the range clips it),

and the joint receives the effort tau = G f, applied as the generalized force tau D_q^T with
D_q the exact Jacobian row of q with respect to the body velocities (when the joint holds this
is the moment tau u on body j and -tau u on body i, or the force tau u_i along the axis).
The power delivered to the bodies is tau q' = f L'; all of it counts as non-conservative work
in the energy balance (the actuator stores no energy). The kinds only choose gain, gain_rate
and biases:

    motor           f = u                                   (gain 1)
    position_servo  f = kp (u - L) + kv (u' - L')           (u: the reference of L)
    velocity_servo  f = kv (u - L')                         (u: the reference of L')
    general         f = gain u + b0 + b1 L + b2 L'          (MJCF <general>)

For an angle the atan2 value lies in (-pi, pi]; where b1 != 0 the kernel takes the branch of q
nearest the equilibrium q* = -(gain u + b0) / (b1 G) (for a servo: the reference), so a servo
follows a reference through any number of turns while its error stays within half a turn.
"""
from __future__ import annotations

import math

import numpy as np

from ...constraints.drivers import wrap_angle
from ...constraints.primitives import angle_row, translation_row
from ...errors import ModelError
from ...jit import njit
from ...motion import MotionLawSet, TimeSeries, make_law
from ..base import ForceType, check_unknown
from ..kernel_tools import add_wrench

#: kernel parameter columns
COORD, GEAR, GAIN, GAIN_RATE, B0, B1, B2, CTRL_LO, CTRL_HI, FORCE_LO, FORCE_HI = range(11)
N_PARAM = 11
ANGLE, TRANSLATION = 0.0, 1.0

#: the parameters every kind takes (model-file kinds)
COMMON = {"joint": "joint", "coordinate": "string", "gear": "number", "ctrlrange": "any",
          "forcerange": "any"}


@njit
def actuator_force(P, q, qd, u, ud):
    """(command used, effort tau = G f) of an actuator with parameter row P at coordinate q,
    rate qd and command u, u' (module docstring)."""
    if u < P[CTRL_LO]:
        u, ud = P[CTRL_LO], 0.0
    elif u > P[CTRL_HI]:
        u, ud = P[CTRL_HI], 0.0
    gear, gain, b0, b1 = P[GEAR], P[GAIN], P[B0], P[B1]
    if P[COORD] == ANGLE and b1 != 0.0:
        centre = -(gain * u + b0) / (b1 * gear)           # the equilibrium angle
        q = centre + wrap_angle(q - centre)
    f = gain * u + P[GAIN_RATE] * ud + b0 + b1 * gear * q + P[B2] * gear * qd
    f = min(max(f, P[FORCE_LO]), P[FORCE_HI])
    return u, gear * f


@njit
def coordinate(S, G, k, D):
    """(q, q') of instance k; D[0] its Jacobian row over v_ij."""
    if G.param[k, COORD] == ANGLE:
        q, qd, _ = angle_row(S, G.bi[k], G.bj[k], G.R_i, G.R_j, k, D, 0)
    else:
        q, qd, _ = translation_row(S, G.bi[k], G.bj[k], G.s_i, G.s_j, G.R_i, k, D, 0)
    return q, qd


@njit
def kernel(S, G, k, g, energy, power, D):
    """param: the columns above; law[k, 0:2] = command u, u'. g_ij += tau D_q^T."""
    q, qd = coordinate(S, G, k, D)
    _, tau = actuator_force(G.param[k], q, qd, G.law[k, 0], G.law[k, 1])
    i, j = G.bi[k], G.bj[k]
    add_wrench(g, i, tau * D[0, 0], tau * D[0, 1], tau * D[0, 2], tau * D[0, 3],
               tau * D[0, 4], tau * D[0, 5])
    add_wrench(g, j, tau * D[0, 6], tau * D[0, 7], tau * D[0, 8], tau * D[0, 9],
               tau * D[0, 10], tau * D[0, 11])
    energy[k] = 0.0
    power[k] = tau * qd                                     # generalized force tau D_q: tau q'


@njit
def details(S, G, out):
    """out[k] = (q, q', command used, effort, power) of every instance."""
    D = np.zeros((1, 12))
    for k in range(out.shape[0]):
        q, qd = coordinate(S, G, k, D)
        u, tau = actuator_force(G.param[k], q, qd, G.law[k, 0], G.law[k, 1])
        out[k, 0], out[k, 1], out[k, 2], out[k, 3], out[k, 4] = q, qd, u, tau, tau * qd


# ------------------------------------------------------------------------------ checks
def _range(spec, key, unit):
    value = spec.params.get(key)
    if value is None:
        return -math.inf, math.inf
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError):
        raise ModelError(f"forces[{spec.name!r}].{key}: give [lower, upper] ({unit}), got "
                         f"{value!r}") from None
    if math.isnan(lo) or math.isnan(hi) or lo > hi:
        raise ModelError(f"forces[{spec.name!r}].{key}: lower {lo} > upper {hi}; give "
                         f"[lower, upper] with lower <= upper ({unit})")
    return lo, hi


def _number(spec, key, default, nonnegative=False, nonzero=False):
    value = spec.params.get(key, default)
    if value is None:
        raise ModelError(f"forces[{spec.name!r}]: a {spec.type} needs {key}= (a number)")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"forces[{spec.name!r}].{key}: expected a number, got "
                         f"{value!r}") from None
    if not math.isfinite(x) or (nonnegative and x < 0) or (nonzero and x == 0):
        need = ">= 0" if nonnegative else ("nonzero" if nonzero else "finite")
        raise ModelError(f"forces[{spec.name!r}].{key}: must be {need}, got {value!r}")
    return x


def joint_coordinate(spec, builder) -> float:
    """ANGLE or TRANSLATION: the coordinate of the spec's joint the actuator acts on."""
    from ...constraints import JOINT_TYPES
    joint = spec.params.get("joint")
    if joint is None:
        raise ModelError(f"forces[{spec.name!r}]: a {spec.type} acts on a joint; give joint="
                         f"(joints: {', '.join(builder.joints) or 'none'})")
    if joint not in builder.joints:
        raise ModelError(f"forces[{spec.name!r}].joint: unknown joint {joint!r} (joints: "
                         f"{', '.join(builder.joints) or 'none'})")
    jtype = builder.joints[joint].type
    kinds = JOINT_TYPES[jtype].driver_kinds
    if not kinds:
        raise ModelError(f"forces[{spec.name!r}]: joint {joint!r} is a {jtype} joint, which "
                         "has no angle or translation to actuate (revolute, translational, "
                         "cylindrical and screw joints have)")
    which = spec.params.get("coordinate")
    if which is None:
        if len(kinds) > 1:
            raise ModelError(f"forces[{spec.name!r}].coordinate: joint {joint!r} ({jtype}) has "
                             f"{' and '.join(kinds)}; say which: coordinate='angle' or "
                             "'translation'")
        which = kinds[0]
    if which not in kinds:
        raise ModelError(f"forces[{spec.name!r}].coordinate: {which!r} is not a coordinate of "
                         f"joint {joint!r} ({jtype}: {', '.join(kinds)})")
    return ANGLE if which == "angle" else TRANSLATION


def command_law(spec, key):
    """The MotionLaw of a command or reference (a number, a law, a law mapping or a time
    series mapping {type: time_series, file: ...}); 0 when absent."""
    value = spec.params.get(key, 0.0)
    try:
        return make_law(value)
    except ModelError as exc:
        raise ModelError(f"forces[{spec.name!r}].{key}: {exc}") from None


# ------------------------------------------------------------------------------ the base type
class ActuatorType(ForceType):
    """The shared part of the actuator kinds: a subclass declares ``name``, its own
    ``parameters`` (besides :data:`COMMON`), ``command_key`` (the parameter holding the
    command or reference law) and ``coefficients(spec) -> (gain, gain_rate, b0, b1, b2)``
    (validated there)."""

    kernel = staticmethod(kernel)
    n_param = N_PARAM
    required = ("joint",)
    command_key = "command"

    def __init__(self, names, bi, bj, s_i, s_j, R_i, param, laws):
        super().__init__(names)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.s_i, self.s_j = np.asarray(s_i, dtype=float), np.asarray(s_j, dtype=float)
        self.R_i = np.asarray(R_i, dtype=float)
        self.param = np.asarray(param, dtype=float).reshape(-1, N_PARAM)
        self.laws = MotionLawSet(laws)
        self.law_list = tuple(laws)

    @classmethod
    def coefficients(cls, spec):
        """The gain/bias row of one spec (each actuator kind defines it)."""
        raise TypeError(f"actuator type {cls.name!r} defines no coefficients(spec)")

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        joint_coordinate(spec, builder)
        _number(spec, "gear", 1.0, nonzero=True)
        _range(spec, "ctrlrange", "command units")
        _range(spec, "forcerange", "N or N m, actuator side")
        cls.coefficients(spec)
        command_law(spec, cls.command_key)

    @classmethod
    def build(cls, specs, ctx):
        bi, bj, s_i, s_j, R_i, params, laws = [], [], [], [], [], [], []
        for s in specs:
            joint = ctx.builder.joints[s.params["joint"]]
            geom = ctx.joint_geometry(s.params["joint"])
            bi.append(ctx.index[joint.body_i])
            bj.append(ctx.index[joint.body_j])
            s_i.append(geom.s_i[0])
            s_j.append(geom.s_j[0])
            R_i.append(geom.R_i[0])
            row = np.zeros(N_PARAM)
            row[COORD] = joint_coordinate(s, ctx.builder)
            row[GEAR] = _number(s, "gear", 1.0, nonzero=True)
            row[GAIN:B2 + 1] = cls.coefficients(s)
            row[CTRL_LO:CTRL_HI + 1] = _range(s, "ctrlrange", "")
            row[FORCE_LO:FORCE_HI + 1] = _range(s, "forcerange", "")
            params.append(row)
            laws.append(command_law(s, cls.command_key))
        group = cls([s.name for s in specs], bi, bj, s_i, s_j, R_i, params, laws)
        group.R_j = np.stack([ctx.joint_geometry(s.params["joint"]).R_j[0] for s in specs])
        return group

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, s_i=self.s_i, s_j=self.s_j, R_i=self.R_i,
                    R_j=self.R_j, param=self.param)

    def breakpoints(self) -> np.ndarray:
        """Times where a command jumps or kinks (the samples of time series)."""
        times = [law.breakpoints for law in self.law_list if isinstance(law, TimeSeries)]
        return np.unique(np.concatenate(times)) if times else np.zeros(0)

    def details(self, state, t, commands=None) -> np.ndarray:
        """(n, 5): q, q', command used, effort, power of every instance at (state, t);
        commands: (n,) held commands replacing the laws' values where finite (controllers)."""
        from ..kernels import ForceTable
        table = ForceTable([self], only_compiled=False)
        table.set_time(t)
        if commands is not None:
            held = np.isfinite(commands)
            table.law[held, 0], table.law[held, 1] = commands[held], 0.0
        out = np.empty((self.n, 5))
        details(state.arrays(), table.G, out)
        return out

    # ---------------------------------------------------------------- outputs
    def output_units(self, i) -> dict:
        """{quantity: unit} of instance i's output columns (spatialmbd.outputs)."""
        angle = self.param[i, COORD] == ANGLE
        base, effort = ("rad", "N m") if angle else ("m", "N")
        return {"coordinate": base, "coordinate_rate": base + "/s", "command": "-",
                "effort": effort, "power": "W"}

    def output_columns(self, results, i, states) -> dict:
        """coordinate, coordinate_rate, command, effort, power of instance i at the output
        times of ``results`` (the commands of sampled controllers from its control log)."""
        nt = len(results.t)
        cols = np.zeros((nt, 5))
        held = held_commands(results, self)
        for k, state in enumerate(states):
            cols[k] = self.details(state, float(results.t[k]),
                                   None if held is None else held[k])[i]
        q = cols[:, 0]
        if self.param[i, COORD] == ANGLE and nt:
            q = np.unwrap(q)
        return dict(coordinate=q, coordinate_rate=cols[:, 1], command=cols[:, 2],
                    effort=cols[:, 3], power=cols[:, 4])


def held_commands(results, group):
    """(nt, group.n) commands the sampled controllers held for the group's instances at the
    output times of ``results`` (NaN for instances without a controller), or None when no
    controller commanded the group."""
    log = getattr(results, "control_log", None) or {}
    names = [n for n in group.names if n in log]
    if not names:
        return None
    out = np.full((len(results.t), group.n), np.nan)
    for n in names:
        samples = log[n]
        idx = np.searchsorted(samples[:, 0], np.asarray(results.t, dtype=float),
                              side="right") - 1
        k = group.names.index(n)
        out[idx >= 0, k] = samples[idx[idx >= 0], 1]
    return out
