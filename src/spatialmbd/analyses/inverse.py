"""Inverse dynamics of a kinematically driven mechanism.

At each output time the kinematic analysis (text ch. 7: Phi = 0, D v = nu, D vdot = gamma)
gives q, v, vdot; the equations of motion (10.9)-(10.11) with the sign convention of
dynamics/eom.py,

    M vdot = g + D^T lam,

are then solved for the multipliers: D^T lam = M vdot - g. With drivers taking up every degree
of freedom D (m x 6 nb) has full column rank, so lam is unique when m = 6 nb. The effort of
driver k is lam_k (N m for an angle driver: the torque on body j about the joint axis u, with
-lam_k u on body i; N for a translation driver: the force on body j along u). The power of the
driver row on the mechanism is v^T D_k^T lam_k = lam_k d(coordinate)/dt, so a positive effort
does positive work when the driven coordinate increases.

Redundant drivers (or redundant joints) make D^T lam = b underdetermined: lam = lam_p + W c with
W spanning the left null space of D. The efforts are then the minimum-norm ones (c minimises
|lam_drivers|; what freedom remains minimises |lam| of the joints) and ``unique`` is False.

Prescribed motion data: :func:`prescribed_motion_model` turns a table of joint coordinates or
driver values over time into drivers with cubic-spline laws (f, f', f'' of the spline).
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..errors import ConvergenceError, ModelError, SingularMatrixError
from ..kinematics import JacobianFactor, apply_correction, mobility, solve_positions
from ..state import BodyState
from ..rank import nonunique_rows
from .common import (dense, driver_rows, driver_units, kinetic_energy, left_null_space,
                     nonunique_joints, potential_energy, reactions_frame, results_object)


class NonUniqueEffortsWarning(UserWarning):
    """Redundant drivers or joints: the efforts or reactions reported are minimum-norm ones."""


@dataclass
class InverseDynamicsResults:
    """Driver efforts, their power and the joint reactions over time.

    efforts: DataFrame (t and one column per driver, N or N m; sign: see the module doc);
    power: DataFrame (t and one column per driver, W = effort * d(coordinate)/dt);
    reactions: name -> JointReaction (spatialmbd.results) of every joint and driver;
    unique: False if the efforts are minimum-norm choices (redundant drivers); redundant
        joints alone leave the efforts unique but not the reactions of their loop (then
        JointReaction.unique is False for the joints named);
    results: a Results object (q, v, vdot, lam) for tables, files and the animation;
    units: driver name -> unit of its effort.
    """

    model: object
    t: np.ndarray
    efforts: object
    power: object
    reactions: dict
    unique: bool
    results: object
    units: dict
    messages: list = field(default_factory=list)
    status: str = "success"
    message: str = ""

    @property
    def q(self):
        return self.results.q

    @property
    def v(self):
        return self.results.v

    @property
    def vdot(self):
        return self.results.vdot

    @property
    def lam(self):
        return self.results.lam

    def as_user_force(self, drivers: Optional[Sequence[str]] = None):
        """A callable f(t, q, v) -> (forces (nb, 3), torques (nb, 3)) applying the efforts of
        ``drivers`` (default all) as the generalized forces D_k^T lam_k(t) of their rows, with
        lam_k interpolated by a cubic spline over the output times: add it as a "user" force
        to the model without those drivers to reproduce the motion by forward dynamics."""
        from scipy.interpolate import CubicSpline
        model = self.model
        names = list(self.efforts.columns[1:]) if drivers is None else list(drivers)
        splines = {n: CubicSpline(self.t, self.efforts[n].to_numpy()) for n in names}
        members = []
        for g in model.constraint_groups:
            if g.rheonomic:
                for k, n in enumerate(g.names):
                    if n in splines:
                        members.append((g, k, n))
        nb = model.nb

        def force(t, q, v):
            state = BodyState.from_qv(q, v, t)
            gen = np.zeros((nb + 1, 6))
            for g, k, n in members:
                Dk = g.evaluate(state, t).D[k, 0]                   # (12,) over v_i, v_j
                lam = float(splines[n](t))
                gen[g.body_i[k]] += lam * Dk[:6]
                gen[g.body_j[k]] += lam * Dk[6:]
            return gen[:nb, :3], gen[:nb, 3:]
        return force

    def reactions_table(self):
        """Reactions of every joint as a DataFrame (see common.reactions_frame)."""
        return reactions_frame(self.reactions, self.t)

    def energy(self):
        """Energy balance as a DataFrame: kinetic, potential (gravity + springs), work of the
        driver efforts and of the non-conservative force elements (integral of the cubic
        spline through the powers at the output times), and
        error = Delta(T + V) - W_efforts - W_nonconservative (J)."""
        import pandas as pd
        from scipy.interpolate import CubicSpline
        model, res = self.model, self.results
        nt = len(self.t)
        T = np.array([kinetic_energy(model, res.q[k], res.v[k]) for k in range(nt)])
        V = np.array([potential_energy(model, res.q[k], self.t[k]) for k in range(nt)])
        P_eff = self.power.drop(columns="t").to_numpy().sum(axis=1) if nt else np.zeros(0)
        P_nc = np.zeros(nt)
        for k, state in enumerate(res.states()):
            P_nc[k] = sum(g.nonconservative_power(state, self.t[k]) for g in model.force_groups)
        def work(P):                        # integral of the cubic spline through the powers
            if nt < 4:
                return np.zeros(nt)
            return CubicSpline(self.t, P).antiderivative()(self.t)
        W_eff, W_nc = work(P_eff), work(P_nc)
        error = (T + V) - (T[0] + V[0] if nt else 0.0) - W_eff - W_nc
        return pd.DataFrame(dict(t=self.t, kinetic=T, potential=V, work_efforts=W_eff,
                                 work_nonconservative=W_nc, power_efforts=P_eff, error=error))

    def to_dataframe(self):
        """One table: efforts, powers (column "<driver>.power"), reactions and the energy
        balance (columns "energy.<kinetic|potential|work_efforts|...|error>")."""
        import pandas as pd
        power = self.power.drop(columns="t").add_suffix(".power")
        reac = self.reactions_table().drop(columns="t")
        energy = self.energy().drop(columns="t").add_prefix("energy.")
        return pd.concat([self.efforts, power, reac, energy], axis=1)

    def summary(self) -> str:
        lines = [f"status: {self.status}" + (f" ({self.message})" if self.message else ""),
                 f"inverse dynamics: {len(self.t)} output times, "
                 + ("unique efforts" if self.unique else "minimum-norm efforts (NOT unique)")]
        for name in self.efforts.columns[1:]:
            e = self.efforts[name].to_numpy()
            p = self.power[name].to_numpy()
            if e.size:
                lines.append(f"  {name}: effort {e.min():.6g} .. {e.max():.6g} {self.units[name]}"
                             f", peak |power| {np.abs(p).max():.6g} W")
        if len(self.t) >= 4:
            en = self.energy()
            lines.append(f"energy balance: work of the efforts {en['work_efforts'].iloc[-1]:.6g}"
                         f" J at the end, largest error {np.abs(en['error']).max():.3g} J")
        lines.extend(self.messages)
        return "\n".join(lines)


# ------------------------------------------------------------------------------- checks
def _free_joint_coordinates(model, q, N):
    """Names of undriven revolute/translational/cylindrical joints whose coordinate moves in
    the free motions N (6 nb, k)."""
    driven = set()
    for spec in model.builder_state["drivers"].values():
        if spec.joint is not None:
            driven.add((spec.joint, spec.kind))
    state = BodyState.from_qv(q, None, 0.0)
    out = []
    nb = model.nb
    Nb = np.zeros((nb + 1, 6, N.shape[1]))
    Nb[:nb] = N.reshape(nb, 6, -1)
    for g in model.constraint_groups:
        if g.rheonomic or g.name not in ("revolute", "translational", "cylindrical"):
            continue
        for k, name in enumerate(g.names):
            bi, bj = g.body_i[k], g.body_j[k]
            u = state.A[bi] @ g.geometry.R_i[k][:, 0]
            kinds = {"revolute": ("angle",), "translational": ("translation",),
                     "cylindrical": ("angle", "translation")}[g.name]
            for kind in kinds:
                if (name, kind) in driven:
                    continue
                if kind == "angle":
                    rate = u @ (Nb[bj, 3:] - Nb[bi, 3:])
                else:
                    sj = state.A[bj] @ g.geometry.s_j[k]
                    si = state.A[bi] @ g.geometry.s_i[k]
                    vj = Nb[bj, :3] - np.cross(sj, Nb[bj, 3:], axisa=0, axisb=0, axisc=0)
                    vi = Nb[bi, :3] - np.cross(si, Nb[bi, 3:], axisa=0, axisb=0, axisc=0)
                    rate = u @ (vj - vi)
                if np.abs(rate).max() > 1e-8:
                    out.append(f"{name} ({g.name}: {kind})")
    return out


def check_fully_driven(model, q, t: float) -> None:
    """ModelError stating the mobility and what is missing when the drivers leave some
    degree of freedom free."""
    mob = mobility(model, q, t)
    if mob.dof == 0:
        return
    from .common import null_space
    D = dense(model.assembler.evaluate(q, None, t).D)
    rows = driver_rows(model)
    keep = np.ones(D.shape[0], dtype=bool)
    keep[list(rows.values())] = False
    mech_dof = 6 * model.nb - (null_space(D[keep])[1] if keep.any() else 0)
    N, _ = null_space(D)
    candidates = _free_joint_coordinates(model, q, N)
    from .common import describe_direction
    free = describe_direction(model, N[:, 0])
    hint = ("undriven joint coordinates that move freely: " + ", ".join(candidates)
            if candidates else f"a free motion: {free}")
    raise ModelError(
        f"inverse dynamics needs the drivers to take up every degree of freedom: the mechanism "
        f"has mobility {mech_dof} (DoF without drivers) and {len(rows)} driver(s) "
        f"({', '.join(rows) or 'none'}), so {mob.dof} DoF remain free; add {mob.dof} "
        f"driver(s) (angle, translation or coordinate). {hint}")


# ------------------------------------------------------------------------------- kinematics
def _kinematics(model, t, q_guess, tol, max_iter):
    """q, v, vdot at the times t (redundant but consistent drivers allowed)."""
    nb = model.nb
    asm = model.assembler
    nt = t.size
    Q = np.empty((nt, nb, 7))
    V = np.empty((nt, nb, 6))
    VD = np.empty((nt, nb, 6))
    q = np.array(q_guess, dtype=float).reshape(nb, 7)
    for k, tk in enumerate(t):
        if k > 0:
            dt = tk - t[k - 1]
            q = apply_correction(Q[k - 1], V[k - 1] * dt + 0.5 * VD[k - 1] * dt * dt)
        q, _ = solve_positions(model, q, tk, tol, max_iter)
        cv = asm.evaluate(q, None, tk)
        factor = JacobianFactor(cv.D, model, tk)
        v = factor.solve(cv.nu)                                                  # Eq. (7.4)
        resid = float(np.abs(cv.D @ v - cv.nu).max()) if cv.nu.size else 0.0
        if resid > 1e-8 * max(1.0, float(np.abs(cv.nu).max())):
            raise ModelError(f"t = {tk:.6g} s: the drivers prescribe inconsistent velocities "
                             f"(|D v - nu| = {resid:.3g}); redundant drivers must describe the "
                             "same motion")
        cv = asm.evaluate(q, v, tk)
        vdot = factor.solve(cv.gamma)                                            # Eq. (7.6)
        Q[k], V[k], VD[k] = q, v.reshape(nb, 6), vdot.reshape(nb, 6)
    return Q, V, VD


# ------------------------------------------------------------------------------- multipliers
def solve_multipliers(D: np.ndarray, b: np.ndarray, driver_mask: np.ndarray, W=None):
    """lam with D^T lam = b; minimum-norm driver part, then minimum-norm joint part, when the
    left null space W of D is not empty. Returns (lam, residual |D^T lam - b|)."""
    lam = np.linalg.lstsq(D.T, b, rcond=None)[0]
    if W is None:
        W = left_null_space(D)
    if W.shape[1]:
        # W has orthonormal columns: driver parts below 1e-9 are round-off (redundancy among
        # the joints only), not a freedom of the efforts
        Sd = W[driver_mask]                              # driver rows of the free directions
        if Sd.size:
            U, s, Vt = np.linalg.svd(Sd)
            r = int(np.sum(s > 1e-9))
        else:
            r, Vt = 0, np.eye(W.shape[1])
        if r:
            # minimum |lam_drivers| over lam + W c: c in the span of the first r directions
            c = -Vt[:r].T @ ((U[:, :r].T @ lam[driver_mask]) / s[:r])
            lam = lam + W @ c
        # remaining freedom (directions that leave the driver efforts unchanged): joints
        Z = W @ Vt[r:].T
        if Z.shape[1]:
            lam = lam - Z @ (Z.T @ lam)                  # Z orthonormal: minimum |lam|
    resid = float(np.abs(D.T @ lam - b).max()) if b.size else 0.0
    return lam, resid


def inverse_dynamics(model, t: Optional[Sequence[float]] = None, *, motion=None,
                     t_end: Optional[float] = None, output_step: Optional[float] = None,
                     q_guess=None, tol: float = 1e-10, max_iter: int = 30,
                     warn: bool = True) -> InverseDynamicsResults:
    """Driver efforts and joint reactions of a fully driven mechanism over time.

    model: a compiled Model whose drivers take up every degree of freedom (else ModelError
        stating the mobility and naming the undriven joint coordinates).
    t: output times (s), or t_end / output_step (500 intervals by default).
    motion: optional table of prescribed motion (DataFrame or dict with a "t" column, s, and
        columns named after drivers, joints or body coordinates; see
        :func:`prescribed_motion_model`); the output times default to its times.
    q_guess: (nb, 7) initial guess of the positions (default the model's q0).

    Returns :class:`InverseDynamicsResults`; efforts in N m (angle drivers) or N (translation
    and x/y/z drivers), positive when they do positive work as the coordinate increases.
    """
    from ..forces.armature import refuse_armature
    from ..simulate import output_times
    refuse_armature(model, "inverse_dynamics")
    if motion is not None:
        model, times = prescribed_motion_model(model, motion)
        if t is None and t_end is None:
            t = times
    if t is None:
        t = output_times(1.0 if t_end is None else t_end, output_step, None)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    from ..dynamics.reaction_friction import refuse
    refuse(model, "inverse dynamics")
    nb = model.nb
    q = np.array(model.q0 if q_guess is None else q_guess, dtype=float).reshape(nb, 7)
    q, _ = solve_positions(model, q, t[0], tol, max_iter)
    check_fully_driven(model, q, t[0])
    mob = mobility(model, q, t[0])
    rows = driver_rows(model)
    mask = np.zeros(model.n_eq, dtype=bool)
    mask[list(rows.values())] = True
    messages = []
    unique = True
    redundant = []
    if mob.redundant:
        # the one rank decision (spatialmbd.rank): the reactions that a self-stress reaches --
        # every joint of a redundant loop, not only the one whose equation was left out
        D0 = dense(model.assembler.evaluate(q, None, t[0]).D)
        loose = nonunique_rows(D0)
        redundant = nonunique_joints(model, q, t[0], exclude_rows=np.flatnonzero(mask),
                                     rows=loose)
        unique = not mask[loose].any()
        if unique:
            text = (f"{mob.n_redundant} redundant constraint equation(s) among the joints: the "
                    "driver efforts are unique, the reactions of the joints of the redundant "
                    f"loop ({', '.join(redundant)}) are minimum-norm ones, not unique")
        else:
            text = (f"{mob.n_redundant} redundant constraint equation(s) (in "
                    f"{', '.join(redundant)}): the drivers over-determine the motion; the "
                    "efforts are the minimum-norm ones and NOT unique")
        messages.append(text)
        if warn:
            warnings.warn(text, NonUniqueEffortsWarning, stacklevel=2)

    status, message = "success", ""
    try:
        Q, V, VD = _kinematics(model, t, q, tol, max_iter)
    except (ConvergenceError, SingularMatrixError) as exc:
        raise ConvergenceError(f"inverse dynamics: the kinematic analysis failed: {exc}") \
            from None
    from ..dynamics.eom import EquationsOfMotion
    eom = EquationsOfMotion(model)
    nt = t.size
    lam = np.zeros((nt, model.n_eq))
    rate = np.zeros((nt, len(rows)))
    for k, tk in enumerate(t):
        ev = eom.evaluate(tk, Q[k], V[k].reshape(-1))
        D = dense(ev.cv.D)
        b = ev.M.dot(VD[k].reshape(-1)) - ev.g                        # Eq. (10.9): D^T lam
        lam[k], resid = solve_multipliers(D, b, mask)
        scale = max(1.0, float(np.abs(b).max()))
        if resid > 1e-7 * scale:
            raise SingularMatrixError(
                f"t = {tk:.6g} s: the constraint forces cannot balance the equations of motion "
                f"(|D^T lam - (M vdot - g)| = {resid:.3g}); the mechanism is at a singular "
                "configuration where the drivers lose control of a motion")
        vflat = V[k].reshape(-1)
        rate[k] = [D[r] @ vflat for r in rows.values()]
    import pandas as pd
    names = list(rows)
    efforts = pd.DataFrame({"t": t, **{n: lam[:, rows[n]] for n in names}})
    power = pd.DataFrame({"t": t, **{n: lam[:, rows[n]] * rate[:, i]
                                     for i, n in enumerate(names)}})
    res = results_object(model, t, Q, V, VD, lam, redundant_joints=redundant, messages=messages,
                         settings={"analysis": "inverse"})
    return InverseDynamicsResults(model=model, t=t, efforts=efforts, power=power,
                                  reactions=res.reactions(), unique=unique, results=res,
                                  units=driver_units(model), messages=messages, status=status,
                                  message=message)


# ------------------------------------------------------------------------------- motion data
def _spline_law(times, values, name):
    from scipy.interpolate import CubicSpline
    from ..motion import UserFunction
    values = np.asarray(values, dtype=float)
    if values.shape != times.shape or not np.all(np.isfinite(values)):
        raise ModelError(f"motion column {name!r}: expected {times.size} finite values")
    spline = CubicSpline(times, values)
    d1, d2 = spline.derivative(1), spline.derivative(2)
    return UserFunction(f=lambda t: float(spline(t)), fdot=lambda t: float(d1(t)),
                        fddot=lambda t: float(d2(t)))


def prescribed_motion_model(model, motion):
    """(model, times): a copy of ``model`` whose drivers follow a table of motion data.

    motion: DataFrame or dict with "t" (s, strictly increasing, >= 4 values) and columns named
        * after a driver of the model: its law is replaced by the data;
        * after a revolute or translational joint (or "<joint>.angle" / "<joint>.translation"
          for a cylindrical one): a driver named "<joint>_drive" is added (angle in rad or
          translation in m, zero in the assembled configuration, as for angle drivers);
        * "<body>.<x|y|z|e0..e3>": a coordinate driver of that body coordinate.
    Each column is interpolated by a cubic spline (not-a-knot), whose analytic first and
    second derivatives give nu and gamma: the motion is smooth (C2) between the samples.
    """
    from ..constraints.drivers import COORDINATES
    cols = dict(motion.items()) if not hasattr(motion, "to_dict") else \
        {c: motion[c].to_numpy() for c in motion.columns}
    if "t" not in cols:
        raise ModelError("motion data: a column 't' (time, s) is required")
    times = np.asarray(cols.pop("t"), dtype=float)
    if times.ndim != 1 or times.size < 4 or np.any(np.diff(times) <= 0):
        raise ModelError("motion data: 't' must hold at least 4 strictly increasing times")
    b = model.to_builder()
    for name, values in cols.items():
        law = _spline_law(times, values, name)
        if name in b.drivers:
            b.drivers[name] = dataclasses.replace(b.drivers[name], law=law)
            continue
        joint, _, part = name.partition(".")
        if joint in b.joints:
            jtype = b.joints[joint].type
            kind = part or {"revolute": "angle", "translational": "translation"}.get(jtype)
            if kind is None:
                raise ModelError(f"motion column {name!r}: joint {joint!r} is a {jtype}; name "
                                 f"the coordinate, e.g. '{joint}.angle' or "
                                 f"'{joint}.translation'")
            b.add_driver(kind, f"{joint}_drive" if not part else f"{joint}_{part}_drive", law,
                         joint=joint)
            continue
        if joint in b.bodies and part in COORDINATES:
            b.add_driver("coordinate", f"{joint}_{part}_drive", law, body=joint, coordinate=part)
            continue
        raise ModelError(f"motion column {name!r} names no driver, joint or body coordinate "
                         f"of the model (drivers: {', '.join(b.drivers) or 'none'}; joints: "
                         f"{', '.join(b.joints)}; body coordinates like 'body.x')")
    return b.compile(), times
