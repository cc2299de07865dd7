"""Running the compiled force-element kernels over many instances at once.

A compiled force type has a kernel ``kernel(S, G, k, g, energy, power, D)`` for one instance k:
it adds the generalized forces of the instance, acting on the bodies, to ``g`` (flat, 6 per
body [f; n] in global axes, n about the centre of mass; the ground's entries are skipped) and
writes its potential energy ``energy[k]`` (J) and the power ``power[k]`` (W) of its
non-conservative parts -- all from one evaluation. ``S`` are the body state arrays (ground
last), ``G`` the force table (:class:`~spatialmbd.constraints.kernels.JointRows`: bodies,
points, triads, the type's parameters and its law values f, f', f'' at the current time) and
``D`` a (1, 12) scratch row.

Internal states (a LuGre bristle deflection, a contact's dissipated work): an instance whose
group marks it in ``state_rows()`` owns STATE_WIDTH entries of the integrated state
y = [q, v, z, work] (entries 0-2 a vector such as the bristle deflection, 3-4 two
accumulated works such as a contact's normal-damping and friction work, J);
``G.coord[k]`` is its offset among the z (-1 without). Before the kernels run, the
stage copies the instance's state into ``G.law[k, 3:]``; the kernel reads it there and writes
its rate in its place, which goes into ydot (:func:`spatialmbd.dynamics.system.stage_state`,
``_write_ydot``).

As for the constraints, :func:`evaluate_forces` is generated from the registry (one branch per
compiled type of the package) and cached like any source; :class:`ForceTable` concatenates the
groups of a model; the Python methods of a group (``evaluate``, ``potential_energy``,
``nonconservative_power``) run the same kernels, so every formula exists once.
"""
from __future__ import annotations

import threading
import weakref

import numpy as np

from .. import jit
from ..constraints.kernels import JointRows
from ..jit import njit
from . import base
from .base import FORCE_TYPES


#: internal states per stateful force instance (a vector in global axes and two accumulated
#: works; see ForceTable)
STATE_WIDTH = 5

#: the compiled force kinds (types of the package with a kernel), by name
KINDS = tuple(sorted(n for n, c in FORCE_TYPES.items() if getattr(c, "kernel", None) is not None))
KIND_ID = {name: k for k, name in enumerate(KINDS)}
#: parameter columns of the force table
N_PARAM = max([1] + [c.n_param for c in FORCE_TYPES.values() if hasattr(c, "n_param")])
evaluate_forces = jit.generated_module("force_dispatch", jit.dispatch_source(
    "spatialmbd.forces.kernels", "evaluate_forces", "S, G, g, energy, power, D",
    "S, G, k, g, energy, power, D", [(name, FORCE_TYPES[name].kernel) for name in KINDS],
    "Every instance k with kind[k] >= 0: generalized forces into g, its energy and power.")
).evaluate_forces


class ForceTable:
    """The force table of a list of compiled force groups (instances in group order)."""

    def __init__(self, groups, only_compiled=True):
        groups = [g for g in groups if g.compiled or not only_compiled]
        n = sum(g.n for g in groups)
        self.groups = groups
        self.kind = np.empty(n, dtype=np.int64)
        bi, bj = np.zeros(n, np.int64), np.zeros(n, np.int64)
        s_i, s_j = np.zeros((n, 3)), np.zeros((n, 3))
        R_i, R_j = np.tile(np.eye(3), (n, 1, 1)), np.tile(np.eye(3), (n, 1, 1))
        param = np.zeros((n, N_PARAM))
        # law columns: f, f', f'' of a motion law (or a contact's impact speed in column 0),
        # then STATE_WIDTH columns through which an instance with internal states (a LuGre
        # bristle) receives its state z and returns its rate z' (see the module docstring)
        self.law = np.zeros((n, 3 + STATE_WIDTH))
        coord = np.full(n, -1, dtype=np.int64)
        self._laws = []
        start = 0
        n_states = 0
        for g in groups:
            sl = slice(start, start + g.n)
            cols = g.columns()
            self.kind[sl] = KIND_ID.get(g.name, -1)
            bi[sl], bj[sl] = cols["bi"], cols.get("bj", cols["bi"])
            for key, arr in (("s_i", s_i), ("s_j", s_j), ("R_i", R_i), ("R_j", R_j)):
                if key in cols:
                    arr[sl] = cols[key]
            p = np.asarray(cols.get("param", np.zeros((g.n, 0))), dtype=float)
            param[sl, :p.shape[1]] = p
            if g.time_dependent:
                self._laws.append((sl, g))
            else:
                self.law[sl, :3] = g.law_values(0.0)
            rows = np.flatnonzero(np.asarray(g.state_rows(), dtype=bool))
            coord[start + rows] = n_states + STATE_WIDTH * np.arange(rows.size)
            n_states += STATE_WIDTH * rows.size
            start += g.n
        #: internal states of the instances (STATE_WIDTH per stateful instance; coord holds
        #: each one's offset among them, -1 for instances without)
        self.n_states = n_states
        self.G = JointRows(bi, bj, s_i, s_j, R_i, R_j, param, self.law, coord)
        self.has_laws = bool(self._laws)

    @property
    def n(self) -> int:
        return self.kind.size

    def set_time(self, t: float, law=None) -> None:
        """The law values (f, f', f'') of the time-dependent groups at t (into ``law``)."""
        law = self.law if law is None else law
        for sl, g in self._laws:
            law[sl, :3] = g.law_values(t)


_TABLES = threading.local()


def states_by_group(groups, z) -> dict:
    """{id(group): (n, STATE_WIDTH) internal states} of the groups with states, from a row z
    of the integrated states (in the order of ``ForceTable(groups)``)."""
    table = ForceTable(groups)
    out, start = {}, 0
    for g in table.groups:
        coord = table.G.coord[start:start + g.n]
        if np.any(coord >= 0):
            st = np.zeros((g.n, STATE_WIDTH))
            for k in np.flatnonzero(coord >= 0):
                st[k] = z[coord[k]:coord[k] + STATE_WIDTH]
            out[id(g)] = st
        start += g.n
    return out


def evaluate_group(group, state, t: float, states=None):
    """(g (nb+1, 6), energy (n,), power (n,)) of one compiled force group at (state, t);
    states: (n, STATE_WIDTH) internal states of its instances (default zero)."""
    registry = getattr(_TABLES, "registry", None)      # one table per group and thread
    if registry is None:
        registry = _TABLES.registry = weakref.WeakKeyDictionary()
    table = registry.get(group)
    if table is None:
        table = registry[group] = ForceTable([group], only_compiled=False)
    table.set_time(t)
    table.law[:, 3:] = 0.0 if states is None else states
    nb1 = state.r.shape[0]
    g = np.zeros(6 * nb1)
    energy, power = np.zeros(group.n), np.zeros(group.n)
    if group.name in KIND_ID:
        evaluate_forces(table.kind, state.arrays(), table.G, g, energy, power,
                        np.zeros((1, 12)))
    else:                                  # registered from user code: a loop of its own
        loop = _LATE.get(group.name)
        if loop is None:
            kernel = type(group).kernel

            def run(S, G, g, energy, power, D):
                for k in range(energy.size):
                    kernel(S, G, k, g, energy, power, D)
            loop = _LATE[group.name] = njit(run, cache=False)
        loop(state.arrays(), table.G, g, energy, power, np.zeros((1, 12)))
    return g.reshape(nb1, 6), energy, power


#: compiled loops of the force types registered from user code (name -> loop)
_LATE: dict = {}


# the types' groups (forces.base, below this module) reach the dispatch through this slot
base.DISPATCH.kind_id = KIND_ID
base.DISPATCH.evaluate_group = evaluate_group
