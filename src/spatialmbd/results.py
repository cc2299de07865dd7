"""Results of a dynamic analysis, and what is computed from them outside the time loop:
joint reactions, energies, constraint violation and tables.

Arrays (nt output times, nb bodies, m constraint equations):
    t (nt,), q (nt, nb, 7), v (nt, nb, 6), vdot (nt, nb, 6), lam (nt, m), work (nt,)
lam follows the convention of dynamics/eom.py: D^T lam are the reaction forces on the bodies.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import math

import numpy as np

from .constraints.kernels import JointRows, evaluate_instances
from .jit import njit
from .state import BodyState, state_into


@dataclass
class JointReaction:
    """Reaction of one joint over time, on each of its two bodies, at the joint point.

    force_i, moment_i: (nt, 3) on body i, global axes, moment about the joint point P_i;
    force_j, moment_j: the same on body j (about P_j). *_joint: the same in the joint frame
    [u, a, b] of body i (u = joint axis). body_i / body_j: body names ("ground" allowed).
    unique: False if the joint has redundant equations (the split is then not unique).
    """

    name: str
    type: str
    body_i: str
    body_j: str
    force_i: np.ndarray
    moment_i: np.ndarray
    force_j: np.ndarray
    moment_j: np.ndarray
    force_i_joint: np.ndarray
    moment_i_joint: np.ndarray
    force_j_joint: np.ndarray
    moment_j_joint: np.ndarray
    unique: bool = True


@dataclass
class Results:
    model: object
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    vdot: np.ndarray
    lam: np.ndarray
    work: np.ndarray
    status: str
    message: str
    counters: dict
    wall_time: float
    correction: object = None
    redundant_joints: list = field(default_factory=list)
    messages: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    #: what :meth:`outputs` and the tables record besides the standard columns
    #: (:class:`spatialmbd.outputs.Output` requests; see docs/outputs.md)
    output_requests: list = field(default_factory=list)
    #: located events of simulate(..., events=...): dicts with t (s), name, index, terminal
    events: list = field(default_factory=list)
    #: the state at each located event: (q (nb, 7), v (nb, 6)), in the order of ``events``
    event_states: list = field(default_factory=list)
    #: the contacts' impact-velocity records (t, instance, v0) of the run
    #: (:mod:`spatialmbd.forces.contact.memory`); None: not recorded
    contact_log: Optional[list] = None
    #: the couplers' angle references at the first output (None: the assembled zero, as at
    #: the start of a run); see :meth:`constraint_violation`
    coupler_references: Optional[list] = None
    coupler_references_end: Optional[list] = None
    #: the force elements' internal states at the outputs (nt, n) -- LuGre bristle
    #: deflections, 3 per contact, m -- or None without such elements
    force_states: Optional[np.ndarray] = None

    # ----------------------------------------------------------------------------------------
    @classmethod
    def from_integration(cls, model, eom, method, integrator, t, y, status, message, counters,
                         wall_time, correction, redundant_joints, messages, settings,
                         accelerations=None):
        """Split the integrator's states and recompute vdot, lam at the output times (these
        evaluations are not counted as function evaluations); accelerations: (vdot (nt, nb,
        6), lam (nt, m)) already evaluated (by the compiled drivers)."""
        nb = model.nb
        nt = len(t)
        n_q, n_v = 7 * nb, 6 * nb
        q = y[:, :n_q].reshape(nt, nb, 7).copy() if nt else np.zeros((0, nb, 7))
        q[:, :, 3:] /= np.linalg.norm(q[:, :, 3:], axis=2, keepdims=True)
        v = y[:, n_q:n_q + n_v].reshape(nt, nb, 6) if nt else np.zeros((0, nb, 6))
        work = y[:, -1].copy() if nt else np.zeros(0)
        z = y[:, n_q + n_v:-1] if nt else np.zeros((0, 0))     # force elements' states
        vdot = np.zeros((nt, nb, 6))
        lam = np.zeros((nt, model.n_eq))
        from .errors import SpatialMBDError
        if accelerations is not None:
            vdot, lam = accelerations
        for k in range(nt if accelerations is None else 0):
            try:
                if z.shape[1]:
                    eom.system.set_force_states(z[k])
                ev = eom.evaluate(t[k], q[k], v[k].reshape(-1))
                out = method.accelerations(ev, t[k])
            except (SpatialMBDError, np.linalg.LinAlgError, ValueError, FloatingPointError):
                # a state where the run failed: kept, with NaN accelerations and multipliers
                vdot[k] = np.nan
                lam[k] = np.nan
                continue
            vdot[k] = out.vdot.reshape(nb, 6)
            lam[k] = out.lam
        return cls(model=model, t=np.asarray(t), q=q, v=v, vdot=vdot, lam=lam, work=work,
                   status=status, message=message, counters=counters, wall_time=wall_time,
                   correction=correction, redundant_joints=list(redundant_joints),
                   messages=list(messages), settings=settings,
                   force_states=np.array(z) if z.shape[1] else None)

    @property
    def success(self) -> bool:
        """True when the run reached t_end or a terminal event stopped it (status "event")."""
        return self.status in ("success", "event")

    def body(self, name: str) -> dict:
        """Time series of one body: r, p, rdot, omega, rddot, omegadot (each (nt, 3|4))."""
        if not isinstance(name, str) or name not in self.model.body_names:
            from .errors import ModelError
            from .suggest import unknown
            raise ModelError(unknown("body", name, list(self.model.body_names))
                             + (" (ground does not move)" if name == "ground" else ""))
        k = self.model.body_index(name)
        return dict(r=self.q[:, k, :3], p=self.q[:, k, 3:], rdot=self.v[:, k, :3],
                    omega=self.v[:, k, 3:], rddot=self.vdot[:, k, :3],
                    omegadot=self.vdot[:, k, 3:])

    def states(self):
        for k in range(len(self.t)):
            yield BodyState.from_qv(self.q[k], self.v[k], self.t[k])

    def point(self, name: str) -> dict:
        """Position and velocity (nt, 3) of a named point "body.point"."""
        if not isinstance(name, str) or name not in self.model.points:
            from .errors import ModelError
            from .suggest import unknown
            raise ModelError(unknown("point", name, list(self.model.points))
                             + " (points are named 'body.point')")
        body, local = self.model.points[name]
        A = _rotations(self.q[:, body, 3:])
        s = np.einsum("nij,j->ni", A, local)
        return dict(r=self.q[:, body, :3] + s,
                    rdot=self.v[:, body, :3] + np.cross(self.v[:, body, 3:], s))

    # ---------------------------------------------------------------------------- reactions
    def reactions(self) -> dict:
        """JointReaction of every joint and driver, by name (from D^T lam, Eq. 10.10)."""
        return self._reactions_from(self._row_pass(reactions=True, violation=False)[0])

    def _row_pass(self, reactions: bool, violation: bool, compiled: bool = True):
        """One pass over the constraint rows of every output: (gens, (phi_squared, velocity))
        -- D^T lam per instance of each group (nt, n, 12) when ``reactions``, Phi^T Phi and
        |D v - nu| (nt,) when ``violation`` (else None). Every group compiled: one compiled
        loop over the outputs that reduces each output's rows as it evaluates them
        (:func:`_reduce_rows`); else the rows in blocks (:meth:`_constraint_rows`)."""
        model = self.model
        nt = len(self.t)
        groups = list(zip(model.constraint_groups, model.group_offsets))
        if compiled and model.n_eq and nt and all(g.compiled for g, _ in groups):
            return self._row_pass_compiled(groups, reactions, violation)
        gens = [np.zeros((nt, g.n, 12)) for g, _ in groups] if reactions else None
        sq, vel = np.zeros(nt), np.zeros(nt)
        if violation and model.n_eq:
            bi = np.concatenate([np.repeat(g.body_i, g.n_eq) for g in model.constraint_groups])
            bj = np.concatenate([np.repeat(g.body_j, g.n_eq) for g in model.constraint_groups])
        for a, b, D, phi, nu in self._constraint_rows():
            if reactions:
                lam = self.lam[a:b]
                for (g, off), gen in zip(groups, gens):        # D^T lam per instance (n, 12)
                    Dg = D[:, off:off + g.size].reshape(b - a, g.n, g.n_eq, 12)
                    gen[a:b] = np.einsum("tnmc,tnm->tnc", Dg,
                                         lam[:, off:off + g.size].reshape(b - a, g.n, g.n_eq))
            if violation:
                # D v - nu, row by row from the two 6-blocks (the ground, index nb, is fixed)
                v = np.concatenate([self.v[a:b], np.zeros((b - a, 1, 6))], axis=1)
                Dv = (np.einsum("tmc,tmc->tm", D[:, :, :6], v[:, bi])
                      + np.einsum("tmc,tmc->tm", D[:, :, 6:], v[:, bj]))
                sq[a:b] = np.einsum("tm,tm->t", phi, phi)
                vel[a:b] = np.linalg.norm(Dv - nu, axis=1)
        return gens, ((sq, vel) if violation else None)

    def _row_pass_compiled(self, groups, reactions: bool, violation: bool):
        from .constraints.kernels import JointTable
        model = self.model
        nt, m = len(self.t), model.n_eq
        table = JointTable(model.constraint_groups, model.group_offsets)
        inst_offsets = np.cumsum([0] + [g.n for g, _ in groups])
        row_inst = np.concatenate([start + np.repeat(np.arange(g.n), g.n_eq)
                                   for (g, _), start in zip(groups, inst_offsets)])
        row_bi = np.concatenate([np.repeat(g.body_i, g.n_eq) for g, _ in groups])
        row_bj = np.concatenate([np.repeat(g.body_j, g.n_eq) for g, _ in groups])
        gens = np.zeros((nt, int(inst_offsets[-1]) if reactions else 0, 12))
        sq, vel = np.zeros(nt), np.zeros(nt)
        state = BodyState.empty(model.nb)
        scratch = (np.zeros(m), np.zeros((m, 12)), np.zeros(m), np.zeros(m))
        rows = max(1, min(nt, self._ROWS_PER_BLOCK))
        for a in range(0, nt, rows):            # the laws of a block of outputs at once
            b = min(nt, a + rows)
            _reduce_rows(table.kind, state.arrays(), table.G, table.rows,
                         np.ascontiguousarray(self.q[a:b], dtype=float),
                         np.ascontiguousarray(self.v[a:b], dtype=float),
                         table.law_history(self.t[a:b]),
                         np.ascontiguousarray(self.lam[a:b], dtype=float), row_inst.astype(
                             np.int64), row_bi.astype(np.int64), row_bj.astype(np.int64),
                         reactions, gens[a:b], sq[a:b], vel[a:b], scratch)
        split = [gens[:, a:b] for a, b in zip(inst_offsets[:-1], inst_offsets[1:])]
        return (split if reactions else None), ((sq, vel) if violation else None)

    def _reactions_from(self, gens) -> dict:
        model = self.model
        names = list(model.body_names) + ["ground"]
        nt, nb = len(self.t), model.nb
        groups = list(zip(model.constraint_groups, model.group_offsets))
        # body rotations at every output, the ground (index nb) the identity
        A = np.empty((nt, nb + 1, 3, 3))
        A[:, :nb] = _rotations(self.q[:, :, 3:])
        A[:, nb] = np.eye(3)
        out = {}
        for (g, off), gen in zip(groups, gens):
            # (nt, n, 8, 3): f_i, m_i, f_j, m_j in global axes, then in the joint frame
            parts = np.empty((nt, g.n, 8, 3))
            _joint_reactions(np.ascontiguousarray(gen), A, g.body_i.astype(np.int64),
                             g.body_j.astype(np.int64), np.ascontiguousarray(g.geometry.s_i,
                                                                              dtype=float),
                             np.ascontiguousarray(g.geometry.s_j, dtype=float),
                             np.ascontiguousarray(g.geometry.R_i, dtype=float), parts)
            for n, name in enumerate(g.names):
                x = [parts[:, n, c] for c in range(8)]
                out[name] = JointReaction(
                    name=name, type=g.name, body_i=names[g.body_i[n]], body_j=names[g.body_j[n]],
                    force_i=x[0], moment_i=x[1], force_j=x[2], moment_j=x[3],
                    force_i_joint=x[4], moment_i_joint=x[5], force_j_joint=x[6],
                    moment_j_joint=x[7], unique=name not in self.redundant_joints)
        return out

    #: output rows per block of :meth:`_constraint_rows` (its D block is rows x m x 12 floats)
    _ROWS_PER_BLOCK = 2048

    def _constraint_rows(self):
        """(a, b, D, phi, nu) blocks of the outputs a:b: the constraint Jacobian rows
        (rows, m, 12), Phi and nu (rows, m), as the run evaluates them: the drivers' laws at
        all times of a block at once (:meth:`JointTable.law_history`), then one compiled loop
        over the block's outputs (:func:`evaluate_history`); the groups without a compiled
        kernel (user types overriding evaluate) in Python, output by output."""
        from .constraints.kernels import JointTable, evaluate_history
        from .state import BodyState, state_into
        model = self.model
        nt, nb, m = len(self.t), model.nb, model.n_eq
        if m == 0 or nt == 0:
            return
        groups, offsets = model.constraint_groups, model.group_offsets
        table = JointTable(groups, offsets)
        python = [(g, off) for g, off in zip(groups, offsets) if not g.compiled]
        state = BodyState.empty(nb)
        rows = max(1, min(nt, self._ROWS_PER_BLOCK))
        for a in range(0, nt, rows):
            b = min(nt, a + rows)
            q = np.ascontiguousarray(self.q[a:b], dtype=float)
            v = np.ascontiguousarray(self.v[a:b], dtype=float)
            out = (np.zeros((b - a, m)), np.zeros((b - a, m, 12)), np.zeros((b - a, m)),
                   np.zeros((b - a, m)))
            evaluate_history(table.kind, state.arrays(), table.G, table.rows, q, v,
                             table.law_history(self.t[a:b]), out)
            phi, D, nu, gamma = out
            for k in range(b - a if python else 0):
                state_into(q[k], v[k], False, *state.arrays())
                state.t = t = float(self.t[a + k])
                for g, off in python:
                    e = g.evaluate(state, t)
                    sl = slice(off, off + g.size)
                    phi[k, sl], nu[k, sl] = e.phi.ravel(), e.nu.ravel()
                    D[k, sl] = e.D.reshape(-1, 12)
            yield a, b, D, phi, nu

    # ---------------------------------------------------------------------------- violation
    def constraint_violation(self) -> dict:
        """|Phi| (2-norm), Phi^T Phi (as in Fig. 15.2) and |D v - nu| at every output (nt,).

        Couplers' angles are unwrapped along the outputs, from ``coupler_references`` (the
        references at the first output: None, the assembled zero, for a whole run; a later
        chunk of a run starts from its predecessor's ``coupler_references_end``, which this
        sets)."""
        asm = self.model.assembler
        nt = len(self.t)
        pos, sq, vel = np.zeros(nt), np.zeros(nt), np.zeros(nt)
        if not asm.couplers:                  # no angle to unwrap: the compiled rows
            return self._violation_from(*self._row_pass(reactions=False, violation=True)[1])
        asm.set_coupler_references(self.coupler_references)
        try:
            for k in range(nt):
                if k:
                    asm.advance_couplers(self.q[k - 1])
                cv = asm.evaluate(self.q[k], self.v[k], self.t[k])
                sq[k] = float(cv.phi @ cv.phi)
                pos[k] = np.sqrt(sq[k])
                vel[k] = float(np.linalg.norm(cv.D @ self.v[k].reshape(-1) - cv.nu))
            if nt and asm.couplers:
                asm.advance_couplers(self.q[nt - 1])
                self.coupler_references_end = asm.coupler_references()
        finally:
            asm.reset_couplers()              # the shared assembler left as it was found
        return dict(position=pos, phi_squared=sq, velocity=vel)

    @staticmethod
    def _violation_from(sq, vel) -> dict:
        return dict(position=np.sqrt(sq), phi_squared=sq, velocity=vel)

    def _reactions_and_violation(self):
        """(reactions(), constraint_violation()) from one pass over the rows when there are no
        couplers (whose angles the violation unwraps output by output)."""
        if self.model.assembler.couplers:
            return self.reactions(), self.constraint_violation()
        gens, (sq, vel) = self._row_pass(reactions=True, violation=True)
        return self._reactions_from(gens), self._violation_from(sq, vel)

    # ---------------------------------------------------------------------------- contacts
    def contacts(self) -> dict:
        """Per contact instance (spatialmbd.forces.contact), at every output time: gap,
        penetration (m), gap_rate (m/s), impact_velocity (m/s), normal_force (N), friction
        (nt, 3) N, slip (nt, 3) and slip_speed m/s, point (nt, 3) m, normal (nt, 3), active;
        and "n_active" (nt,), the number of closed contacts."""
        from .forces.contact.memory import contact_table
        return contact_table(self)

    # ---------------------------------------------------------------------------- energy
    def energy(self) -> dict:
        """Kinetic (bodies and rotors: armature), gravitational and elastic energy, work of
        non-conservative forces and drivers, total mechanical energy and the energy-balance
        error, each (nt,), in J.

        error = (T + V_g + V_e)(t) - (T + V_g + V_e)(0) - W_nc(t): zero up to integration
        error for any model; for a conservative one simply the change of the total energy.
        """
        model = self.model
        m = model.mass
        A = _rotations(self.q[:, :, 3:])
        J = A @ model.inertia[None] @ np.swapaxes(A, 2, 3)
        w = self.v[:, :, 3:]
        kinetic = 0.5 * np.sum(m * np.sum(self.v[:, :, :3] ** 2, axis=2), axis=1) \
            + 0.5 * np.einsum("tni,tnij,tnj->t", w, J, w)
        gravity = -np.einsum("n,tni,i->t", m, self.q[:, :, :3], model.gravity)
        elastic = np.zeros(len(self.t))
        if model.force_groups:
            z = self.force_states
            if z is not None:
                from .forces.kernels import states_by_group
            for k, state in enumerate(self.states()):
                st = {} if z is None else states_by_group(model.force_groups, z[k])
                elastic[k] = sum(g.potential_energy(state, self.t[k], st.get(id(g)))
                                 for g in model.force_groups)
                kinetic[k] += sum(g.kinetic_energy(state, self.t[k])   # rotors (armature)
                                  for g in model.force_groups)
        total = kinetic + gravity + elastic
        error = total - (total[0] if total.size else 0.0) - self.work
        return dict(kinetic=kinetic, gravitational=gravity, elastic=elastic,
                    work_nonconservative=self.work, total=total, error=error)

    # ---------------------------------------------------------------------------- tables
    def to_dataframe(self):
        """A pandas DataFrame with one row per output time and self-explaining columns."""
        import pandas as pd
        from .outputs import compute_outputs, output_units
        from .outputs.vocabulary import ENERGY, REACTION, VIOLATION, body_columns
        cols = {"t": self.t, **body_columns(self.model.body_names, self.q, self.v, self.vdot)}
        reactions, viol = self._reactions_and_violation()
        for name, r in reactions.items():
            for body, f, mom in ((r.body_i, r.force_i, r.moment_i),
                                 (r.body_j, r.force_j, r.moment_j)):
                for j, c in enumerate(REACTION):
                    cols[f"{name}.{body}.{c}"] = (f if j < 3 else mom)[:, j % 3]
        for key in VIOLATION:
            cols[f"violation.{key}"] = viol[key]
        en = self.energy()
        for key in ENERGY:
            cols[f"energy.{key}"] = en[key]
        cols.update(compute_outputs(self))
        df = pd.DataFrame(cols)
        df.attrs["units"] = output_units(self)
        return df

    # ---------------------------------------------------------------------------- outputs
    def outputs(self, requests=None):
        """A DataFrame (column t, then ``<prefix>.<quantity>``) of the requested engineering
        outputs: joint coordinates, force elements, drivers, momentum, energy per body, IMU
        (:mod:`spatialmbd.outputs`; default: this result's ``output_requests``)."""
        import pandas as pd
        from .outputs import compute_outputs, output_units
        df = pd.DataFrame({"t": self.t, **compute_outputs(self, requests)})
        df.attrs["units"] = output_units(self, requests)
        return df

    def to_xarray(self):
        """An xarray Dataset of this result (:func:`spatialmbd.outputs.to_xarray`)."""
        from .outputs import to_xarray
        return to_xarray(self)

    def summary(self) -> str:
        c = self.counters
        lines = [f"status: {self.status}" + (f" ({self.message})" if self.message else ""),
                 f"method {self.settings.get('method')}, integrator "
                 f"{self.settings.get('integrator')}: {c.get('steps')} steps, "
                 f"{c.get('rejected')} rejected, {c.get('nfev')} function evaluations, "
                 f"wall time {self.wall_time:.3g} s"]
        if self.correction is not None:
            lines.append(self.correction.summary())
        lines.extend(m for m in self.messages if m != self.message)
        return "\n".join(lines)


@njit
def _reduce_rows(kind, S, G, rows, q, v, law, lam, row_inst, row_bi, row_bj, reactions, gens,
                 sq, vel, scratch):
    """For each output k: the constraint rows at (q[k], v[k], law[k]) (the compiled dispatch,
    into ``scratch`` = (phi, D, nu, gamma)), reduced at once: gens[k, i] = sum of D_r^T lam_r
    over the rows r of instance i (Eq. 10.10; when ``reactions``), sq[k] = Phi^T Phi,
    vel[k] = |D v - nu| (the ground, body nb, does not move)."""
    phi, D, nu, _ = scratch
    nb = q.shape[1]
    for k in range(q.shape[0]):
        state_into(q[k], v[k], False, S[0], S[1], S[2], S[3], S[4])
        Gk = JointRows(G.bi, G.bj, G.s_i, G.s_j, G.R_i, G.R_j, G.param, law[k], G.coord)
        evaluate_instances(kind, S, Gk, rows, scratch)
        total, speed = 0.0, 0.0
        for r in range(phi.size):
            total += phi[r] * phi[r]
            dv = -nu[r]
            if row_bi[r] < nb:
                for c in range(6):
                    dv += D[r, c] * v[k, row_bi[r], c]
            if row_bj[r] < nb:
                for c in range(6):
                    dv += D[r, 6 + c] * v[k, row_bj[r], c]
            speed += dv * dv
            if reactions:
                for c in range(12):
                    gens[k, row_inst[r], c] += D[r, c] * lam[k, r]
        sq[k] = total
        vel[k] = math.sqrt(speed)


@njit
def _joint_reactions(gen, A, bi, bj, s_i, s_j, R_i, out):
    """Per output t and instance n, from its D^T lam = gen[t, n] (12: force and moment about
    the centre of mass on body i, then on body j, global): out[t, n] = f_i, m_i, f_j, m_j
    (moments about the joint points P = A s), then the four in the joint frame T = A_i R_i
    (T^T x). A: (nt, nb + 1, 3, 3) rotations, the ground last."""
    for t in range(gen.shape[0]):
        for n in range(gen.shape[1]):
            Ai, Aj = A[t, bi[n]], A[t, bj[n]]
            for side in range(2):
                Ab = Ai if side == 0 else Aj
                s = s_i[n] if side == 0 else s_j[n]
                p0 = Ab[0, 0] * s[0] + Ab[0, 1] * s[1] + Ab[0, 2] * s[2]
                p1 = Ab[1, 0] * s[0] + Ab[1, 1] * s[1] + Ab[1, 2] * s[2]
                p2 = Ab[2, 0] * s[0] + Ab[2, 1] * s[1] + Ab[2, 2] * s[2]
                f = gen[t, n, 6 * side:6 * side + 3]
                m = gen[t, n, 6 * side + 3:6 * side + 6]
                o = 2 * side
                for a in range(3):
                    out[t, n, o, a] = f[a]
                # moment about the joint point: m - P x f
                out[t, n, o + 1, 0] = m[0] - (p1 * f[2] - p2 * f[1])
                out[t, n, o + 1, 1] = m[1] - (p2 * f[0] - p0 * f[2])
                out[t, n, o + 1, 2] = m[2] - (p0 * f[1] - p1 * f[0])
            for c in range(4):                          # T^T x, T = A_i R_i
                for a in range(3):
                    value = 0.0
                    for b in range(3):
                        Tba = Ai[b, 0] * R_i[n, 0, a] + Ai[b, 1] * R_i[n, 1, a] \
                            + Ai[b, 2] * R_i[n, 2, a]
                        value += Tba * out[t, n, c, b]
                    out[t, n, 4 + c, a] = value


def _rotations(p: np.ndarray) -> np.ndarray:
    from .rotations import A_from_p
    return A_from_p(p)
