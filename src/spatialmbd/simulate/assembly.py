"""Assembling the results of a run: the evaluation at output times (contact memory, sampled
controllers), the counters, and the events given by the user."""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..state import normalize_q


class _AtTime:
    """The equations of motion with a run-time memory (the contacts' impact velocities, the
    controllers' held commands) set to what it was at each evaluation time (the accelerations
    at the output times, after the run)."""

    def __init__(self, eom, memory):
        self._eom, self._memory = eom, memory

    def evaluate(self, t, q, v):
        self._memory.restore(t)
        return self._eom.evaluate(t, q, v)

    def __getattr__(self, name):
        return getattr(self._eom, name)


def _stateful(model) -> str:
    """The force elements with internal states, for messages ("forces['a'], ...")."""
    names = [g.element[k] if hasattr(g, "element") else g.names[k]
             for g in model.force_groups for k in np.flatnonzero(g.state_rows())]
    return ", ".join(f"forces[{n!r}]" for n in dict.fromkeys(names))


def _contact_memory(model, eom, compiled, t0, y0):
    """The impact-velocity memory of the contact elements for this run (None without
    contacts): restart events at every first touch (:mod:`.forces.contact.memory`)."""
    from ..forces.contact.memory import ContactMemory, impact_groups
    if not impact_groups(model):
        return None
    if not compiled:
        from ..forces.contact.laws import C_LAW, HERTZ
        hyst = [g.element[k] for g in impact_groups(model) for k in range(g.n)
                if g.param[k, C_LAW] > HERTZ]
        if hyst:
            raise ModelError(f"forces[{hyst[0]!r}]: a hysteresis contact law needs the impact "
                             "velocity, which only the compiled right-hand sides record; use a "
                             "built-in method without solver='kkt'")
        return None
    memory = ContactMemory(model, eom.system)
    memory.start(t0, y0)
    return memory


def _counters(res, meth) -> dict:
    """The integrator's counters, and the inner iterations of an iterative method (the
    augmented Lagrangian): per run, in the results, not on the method."""
    counters = res.counters.as_dict()
    if getattr(meth, "iterate", False):
        counters["method_iterations"] = int(getattr(meth, "total_iterations", 0))
    return counters


def _state_events(events, nb):
    """The simulate-level events (functions of (t, BodyState)) as integrator events (functions
    of (t, y)); None when there are none."""
    if not events:
        return None
    from ..integrators import Event
    from ..state import BodyState
    n_q, n_v = 7 * nb, 6 * nb
    out = []
    for i, spec in enumerate(events):
        ev = Event.coerce(spec, i)
        user = ev.function

        def g(t, y, user=user):
            state = BodyState.from_qv(normalize_q(y[:n_q]).reshape(nb, 7),
                                      y[n_q:n_q + n_v].reshape(nb, 6), t)
            return float(user(t, state))
        out.append(Event(g, terminal=ev.terminal, direction=ev.direction, name=ev.name))
    return out
