"""Results of a dynamic analysis, and what is computed from them outside the time loop:
joint reactions, energies, constraint violation and tables.

Arrays (nt output times, nb bodies, m constraint equations):
    t (nt,), q (nt, nb, 7), v (nt, nb, 6), vdot (nt, nb, 6), lam (nt, m), work (nt,)
lam follows the convention of dynamics/eom.py: D^T lam are the reaction forces on the bodies.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .state import BodyState


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
        model = self.model
        names = list(model.body_names) + ["ground"]
        nt, nb = len(self.t), model.nb
        groups = list(zip(model.constraint_groups, model.group_offsets))
        gens = [np.zeros((nt, g.n, 12)) for g, _ in groups]
        for a, b, D, _, _ in self._constraint_rows():
            lam = self.lam[a:b]
            for (g, off), gen in zip(groups, gens):        # D^T lam per instance (n, 12)
                Dg = D[:, off:off + g.size].reshape(b - a, g.n, g.n_eq, 12)
                gen[a:b] = np.einsum("tnmc,tnm->tnc", Dg,
                                     lam[:, off:off + g.size].reshape(b - a, g.n, g.n_eq))
        # body rotations at every output, the ground (index nb) the identity
        A = np.empty((nt, nb + 1, 3, 3))
        A[:, :nb] = _rotations(self.q[:, :, 3:])
        A[:, nb] = np.eye(3)
        out = {}
        for (g, off), gen in zip(groups, gens):
            Pi = np.einsum("tnij,nj->tni", A[:, g.body_i], g.geometry.s_i)
            Pj = np.einsum("tnij,nj->tni", A[:, g.body_j], g.geometry.s_j)
            Ti = np.einsum("tnij,njk->tnik", A[:, g.body_i], g.geometry.R_i)
            for n, name in enumerate(g.names):
                fi, fj = gen[:, n, :3], gen[:, n, 6:9]
                mi = gen[:, n, 3:6] - np.cross(Pi[:, n], fi)    # moment about the joint point
                mj = gen[:, n, 9:12] - np.cross(Pj[:, n], fj)
                T = Ti[:, n]
                to_joint = lambda x: np.einsum("nji,nj->ni", T, x)  # noqa: E731
                out[name] = JointReaction(
                    name=name, type=g.name, body_i=names[g.body_i[n]], body_j=names[g.body_j[n]],
                    force_i=fi, moment_i=mi, force_j=fj, moment_j=mj,
                    force_i_joint=to_joint(fi), moment_i_joint=to_joint(mi),
                    force_j_joint=to_joint(fj), moment_j_joint=to_joint(mj),
                    unique=name not in self.redundant_joints)
        return out

    #: output rows per block of :meth:`_constraint_rows` (its D block is rows x m x 12 floats)
    _ROWS_PER_BLOCK = 2048

    def _constraint_rows(self):
        """(a, b, D, phi, nu) blocks of the outputs a:b: the constraint Jacobian rows
        (rows, m, 12), Phi and nu (rows, m), evaluated by the compiled System, one call per
        output (the Python constraint groups and the drivers' laws included, as in the run)."""
        from .dynamics.system import System
        model = self.model
        nt, nb, m = len(self.t), model.nb, model.n_eq
        if m == 0 or nt == 0:
            return
        system = System.for_model(model)
        D, phi, nu = system.D, system.phi, system.nu
        y = np.empty(13 * nb)
        rows = max(1, min(nt, self._ROWS_PER_BLOCK))
        for a in range(0, nt, rows):
            b = min(nt, a + rows)
            block, phis, nus = np.empty((b - a, m, 12)), np.empty((b - a, m)), np.empty((b - a, m))
            for k in range(a, b):
                y[:7 * nb] = self.q[k].ravel()
                y[7 * nb:] = self.v[k].ravel()
                system.evaluate(float(self.t[k]), y, False)
                block[k - a], phis[k - a], nus[k - a] = D, phi, nu
            yield a, b, block, phis, nus

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
            model = self.model
            bi = np.concatenate([np.repeat(g.body_i, g.n_eq) for g in model.constraint_groups]
                                ) if model.n_eq else np.zeros(0, np.int64)
            bj = np.concatenate([np.repeat(g.body_j, g.n_eq) for g in model.constraint_groups]
                                ) if model.n_eq else np.zeros(0, np.int64)
            for a, b, D, phi, nu in self._constraint_rows():
                # D v - nu, row by row from the two 6-blocks (the ground, index nb, is fixed)
                v = np.concatenate([self.v[a:b], np.zeros((b - a, 1, 6))], axis=1)
                Dv = (np.einsum("tmc,tmc->tm", D[:, :, :6], v[:, bi])
                      + np.einsum("tmc,tmc->tm", D[:, :, 6:], v[:, bj]))
                sq[a:b] = np.einsum("tm,tm->t", phi, phi)
                vel[a:b] = np.linalg.norm(Dv - nu, axis=1)
            pos[:] = np.sqrt(sq)
            return dict(position=pos, phi_squared=sq, velocity=vel)
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
        cols = {"t": self.t}
        for k, name in enumerate(self.model.body_names):
            for j, c in enumerate(("x", "y", "z", "e0", "e1", "e2", "e3")):
                cols[f"{name}.{c}"] = self.q[:, k, j]
            for j, c in enumerate(("vx", "vy", "vz", "wx", "wy", "wz")):
                cols[f"{name}.{c}"] = self.v[:, k, j]
            for j, c in enumerate(("ax", "ay", "az", "alphax", "alphay", "alphaz")):
                cols[f"{name}.{c}"] = self.vdot[:, k, j]
        for name, r in self.reactions().items():
            for body, f, mom in ((r.body_i, r.force_i, r.moment_i),
                                 (r.body_j, r.force_j, r.moment_j)):
                for j, c in enumerate("xyz"):
                    cols[f"{name}.{body}.f{c}"] = f[:, j]
                for j, c in enumerate("xyz"):
                    cols[f"{name}.{body}.m{c}"] = mom[:, j]
        viol = self.constraint_violation()
        cols["violation.position"] = viol["position"]
        cols["violation.velocity"] = viol["velocity"]
        en = self.energy()
        for key in ("kinetic", "gravitational", "elastic", "work_nonconservative", "total",
                    "error"):
            cols[f"energy.{key}"] = en[key]
        from .outputs import compute_outputs, output_units
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


def _rotations(p: np.ndarray) -> np.ndarray:
    from .rotations import A_from_p
    return A_from_p(p)
