"""The run-time memory of the contacts: the impact velocity of each contact instance (and of
each joint limit with a hysteresis law, :mod:`..joint_limit`).

The hysteresis laws need the approach speed v0 at first touch. It is per-run data: it lives
in the force table's law column 0 of the run's own compiled System (a work array, cloned for
every run -- never on the frozen Model), and is written only at located events: one restart
event per contact instance, gap falling through zero, which ends the integrator step at the
touch, records v0 = -g' there and restarts the stepper (:mod:`..integrators.driver`). The
records (t, instance, v0) are kept in the results (``results.contact_log``) so the contact
forces can be re-evaluated at any output time (:func:`contact_table`).
"""
from __future__ import annotations

import numpy as np

from ...rotations import normalize_p


def contact_groups(model) -> list:
    from .element import Contact
    return [g for g in model.force_groups if isinstance(g, Contact)]


def impact_groups(model) -> list:
    """The force groups with an impact-velocity memory: the contacts, and any group that
    declares ``records_impacts`` (a joint limit with a hysteresis law) and has an instance
    that ``needs_memory()``. Such a group provides ``table()`` (its own force table), a
    compiled ``details_kernel(S, G, out)`` whose columns 0 and 1 are the gap and its rate,
    and ``n_details``."""
    return [g for g in model.force_groups if getattr(g, "records_impacts", False)
            and np.any(g.needs_memory())]


class ContactMemory:
    """The touch events of the contacts of ``model`` for one run on ``system`` (whose force
    table's law column 0 holds the impact speeds)."""

    def __init__(self, model, system):
        self.model = model
        self.nb = model.nb
        self.log: list = []                 # (t, flat instance index, v0)
        self.flaw = system.flaw
        groups = model.force_groups
        table = system.force_table
        self.slots = []                     # (group, first row of it in the table)
        start = 0
        for g in table.groups:
            if g in impact_groups(model):
                self.slots.append((g, start))
            start += g.n
        self._key = None
        self._details = None
        self.groups = groups
        self._tables = [g.table() for g, _ in self.slots]      # built once per run

    def _state(self, t, y):
        from ...state import BodyState
        nb = self.nb
        q = y[:7 * nb].reshape(nb, 7).copy()
        q[:, 3:] = normalize_p(q[:, 3:])
        return BodyState.from_qv(q, y[7 * nb:13 * nb], t)

    def _all(self, t, y):
        if self._key is None or self._key[0] != t or not np.array_equal(self._key[1], y):
            S = self._state(t, y).arrays()
            out = []
            for (g, s), table in zip(self.slots, self._tables):
                table.law[:, 0] = self.flaw[s:s + g.n, 0]
                d = np.empty((g.n, g.n_details))
                type(g).details_kernel(S, table.G, d)
                out.append(d)
            self._details = out
            self._key = (t, np.array(y, copy=True))
        return self._details

    def start(self, t0, y0) -> None:
        """Contacts already closed at t0 record their approach speed there."""
        for (g, s), d in zip(self.slots, self._all(t0, y0)):
            for k in np.flatnonzero(d[:, 0] < 0.0):
                self._record(t0, s + k, max(-d[k, 1], 0.0))

    def restore(self, t) -> None:
        """Set the memory to what it was at time t (the last records at or before t), e.g. to
        re-evaluate the accelerations at an output time after the run."""
        for g, s in self.slots:              # its own rows only (others hold commands)
            self.flaw[s:s + g.n, 0] = 0.0
        for tr, row, v0 in self.log:
            if tr <= t:
                self.flaw[row, 0] = v0

    def _record(self, t, row, v0):
        self.flaw[row, 0] = v0
        self.log.append((float(t), int(row), float(v0)))

    def triggers(self) -> list:
        """(name, gap (t, y) -> float, touch action (t, y)) of every contact instance: the
        caller makes them restart events on the gap falling through 0."""
        out = []
        for n_slot, (g, s) in enumerate(self.slots):
            for k in np.flatnonzero(g.needs_memory()):
                def gap(t, y, n_slot=n_slot, k=k):
                    return float(self._all(t, y)[n_slot][k, 0])

                def touch(t, y, n_slot=n_slot, k=k, row=s + k):
                    self._key = None
                    d = self._all(t, np.array(y))[n_slot]
                    self._record(t, row, max(-d[k, 1], 0.0))
                    self._key = None
                out.append((f"touch:{g.names[k]}", gap, touch))
        return out


def contact_table(results) -> dict:
    """Per contact instance, at every output time of ``results``: the
    :data:`.element.DETAIL_COLUMNS` (gap m, gap rate m/s, impact velocity m/s, normal force N,
    friction force N (3), slip velocity m/s (3), contact point m (3), normal (3), active 0/1,
    the powers of the normal damping and of the friction W (<= 0), the damping in use N s/m),
    the dissipated energies J accumulated since the start (normal damping, friction; NaN for
    an instance without ``track_dissipation`` or LuGre friction, whose works are not
    integrated), and the law's stiffness K (N/m^n) and exponent n, as a dict name -> dict
    column -> (nt,) or (nt, 3) array (K and n: floats); plus "n_active" (nt,).
    Results without ``contact_log`` (not from :func:`~spatialmbd.simulate.simulate`) give NaN
    impact velocities and forces for the hysteresis laws (they depend on the records)."""
    from ...state import BodyState
    from ..kernels import STATE_WIDTH
    from .element import DETAIL_COLUMNS
    from .laws import C_K, C_N
    model = results.model
    groups = contact_groups(model)
    log = getattr(results, "contact_log", None)
    known = log is not None               # results not made by simulate() have no records
    log = sorted(log or [])
    rows = {}
    start = 0
    from ..kernels import ForceTable
    table = ForceTable(model.force_groups)
    for g in table.groups:
        if g in groups:
            rows[id(g)] = start
        start += g.n
    nt = len(results.t)
    z = getattr(results, "force_states", None)        # LuGre bristles, dissipated energies
    coord = table.G.coord
    data = {id(g): np.zeros((nt, g.n, len(DETAIL_COLUMNS))) for g in groups}
    works = {id(g): np.full((nt, g.n, 2), np.nan) for g in groups}
    memory = np.zeros(start)
    li = 0
    for it in range(nt):
        t = results.t[it]
        while li < len(log) and log[li][0] <= t:
            memory[log[li][1]] = log[li][2]
            li += 1
        state = BodyState.from_qv(results.q[it], results.v[it], t)
        for g in groups:
            s = rows[id(g)]
            states = None
            if z is not None:
                states = np.zeros((g.n, STATE_WIDTH))
                for k in np.flatnonzero(coord[s:s + g.n] >= 0):
                    o = coord[s + k]
                    states[k] = z[it, o:o + STATE_WIDTH]
                    works[id(g)][it, k] = states[k, 3:5]
            data[id(g)][it] = g.details(state, memory[s:s + g.n], states)
    out = {}
    n_active = np.zeros(nt, dtype=int)
    for g in groups:
        d = data[id(g)]
        for k, name in enumerate(g.names):
            col = d[:, k]
            out[name] = dict(gap=col[:, 0], penetration=np.maximum(-col[:, 0], 0.0),
                             gap_rate=col[:, 1], impact_velocity=col[:, 2],
                             normal_force=col[:, 3], friction=col[:, 4:7], slip=col[:, 7:10],
                             slip_speed=np.linalg.norm(col[:, 7:10], axis=1),
                             point=col[:, 10:13], normal=col[:, 13:16],
                             active=col[:, 16] > 0.5, power_normal=col[:, 17],
                             power_friction=col[:, 18], damping=col[:, 19],
                             dissipated_normal=works[id(g)][:, k, 0],
                             dissipated_friction=works[id(g)][:, k, 1],
                             stiffness=float(g.param[k, C_K]), exponent=float(g.param[k, C_N]))
            n_active += col[:, 16] > 0.5
    out["n_active"] = n_active
    if not known:       # the hysteresis laws' forces depend on impact velocities not recorded
        from .laws import C_LAW, HERTZ
        for g in groups:
            for k, name in enumerate(g.names):
                if g.param[k, C_LAW] > HERTZ:
                    for key in ("impact_velocity", "normal_force", "friction", "power_normal",
                                "power_friction", "damping"):
                        out[name][key] = np.full_like(out[name][key], np.nan)
    return out
