"""Running the compiled constraint kernels over many instances at once.

Every compiled joint and driver type has a kernel ``kernel(S, G, k, row, out)`` for one instance
k (see :mod:`.primitives`). :func:`evaluate_instances` runs the kernel of each instance in one
compiled loop, selecting it by the instance's kind (an index into :data:`KINDS`); it serves one
group (``ConstraintType.evaluate``) as well as every compiled group of a model at once (the
assembly and the compiled equations of motion, where the table holds all instances and ``rows``
their first equation).

The dispatch is generated, not written by hand: on import, every module of this package is
imported (each registers its types), and the source of :func:`evaluate_instances` -- one
``if kind == c`` branch per registered kernel -- is written to the compile cache and imported
from there, so Numba caches it like any other source (:func:`spatialmbd.jit.generated_module`).
Adding a type never touches this file. Types registered later (from user code) get a compiled
loop of their own (:func:`register_late`) and run per group, outside the fused dispatch.

The joint table G (:class:`JointRows`, one row per instance):
    bi, bj (n,) int64, the ground being body nb; s_i, s_j (n, 3); R_i, R_j (n, 3, 3);
    param (n, P) the types' parameters (P = the largest count of any type, at least 1);
    law (n, 3) = f, f', f'' of a driver's motion law (zero otherwise);
    coord (n,) int64, the coordinate of a coordinate driver (zero otherwise).
"""
from __future__ import annotations

import importlib
import pkgutil
import threading
import weakref
from collections import namedtuple

import numpy as np

from .. import jit
from ..jit import njit
from ..state import state_into
from . import base
from .base import CONSTRAINT_TYPES, ConstraintEval

JointRows = namedtuple("JointRows", "bi bj s_i s_j R_i R_j param law coord")


def _discover() -> None:
    """Import every module of the package: each registers its types."""
    for info in sorted(pkgutil.iter_modules(_package_path()),
                       key=lambda m: m.name):
        if info.name not in ("base", "kernels", "primitives"):
            importlib.import_module(f"{__package__}.{info.name}")


def _package_path():
    import os
    return [os.path.dirname(__file__)]


_discover()
#: the kinds of the fused dispatch: every type of this package with a compiled kernel, by name
KINDS = tuple(sorted(name for name, cls in CONSTRAINT_TYPES.items() if cls.kernel is not None))
KIND_ID = {name: k for k, name in enumerate(KINDS)}
#: parameter columns of the table (the most any type declares, at least 1)
N_PARAM = max([1] + [cls.param_columns() for cls in CONSTRAINT_TYPES.values()])
evaluate_instances = jit.generated_module("constraint_dispatch", jit.dispatch_source(
    "spatialmbd.constraints.kernels", "evaluate_instances", "S, G, rows, out",
    "S, G, k, rows[k], out", [(name, CONSTRAINT_TYPES[name].kernel) for name in KINDS],
    "Rows of every instance k with kind[k] >= 0 into out = (phi, D, nu, gamma).")
).evaluate_instances

#: loops of the types registered after the dispatch was generated (name -> compiled loop)
_LATE: dict = {}


def register_late(cls) -> None:
    """A type registered after import: compile a loop of its own over its instances."""
    if cls.kernel is None:
        return
    if cls.param_columns() > N_PARAM:
        from ..errors import ModelError
        raise ModelError(f"constraint type {cls.name!r} needs {cls.param_columns()} parameter "
                         f"columns; types registered from outside the package may have at "
                         f"most {N_PARAM}")
    kernel = cls.kernel

    def loop(S, G, rows, out):
        for k in range(rows.size):
            kernel(S, G, k, rows[k], out)
    _LATE[cls.name] = njit(loop, cache=False)
    KIND_ID.setdefault(cls.name, -1)


class JointTable:
    """The joint table of a list of groups (instances concatenated in group order).

    ``kind`` is -1 for the instances of groups that are not compiled into the dispatch; ``rows``
    the first equation of each instance given the groups' row offsets; ``law`` is refreshed by
    :meth:`set_time` for the drivers.
    """

    def __init__(self, groups, offsets):
        parts = []
        for g, off in zip(groups, offsets):
            geo = g.geometry
            coord = getattr(g, "coordinate", None)
            param = np.zeros((g.n, N_PARAM))
            param[:, :geo.param.shape[1]] = geo.param
            parts.append(dict(
                kind=np.full(g.n, KIND_ID[g.name] if g.compiled else -1, dtype=np.int64),
                rows=off + g.n_eq * np.arange(g.n, dtype=np.int64),
                bi=g.body_i, bj=g.body_j, s_i=geo.s_i, s_j=geo.s_j, R_i=geo.R_i, R_j=geo.R_j,
                param=param,
                coord=np.zeros(g.n, np.int64) if coord is None else coord))

        def cat(key, dtype, shape):
            if not parts:
                return np.zeros((0,) + shape, dtype=dtype)
            return np.ascontiguousarray(np.concatenate([p[key] for p in parts]), dtype=dtype)
        self.kind = cat("kind", np.int64, ())
        self.rows = cat("rows", np.int64, ())
        n = self.kind.size
        self.law = np.zeros((n, 3))
        self.G = JointRows(cat("bi", np.int64, ()), cat("bj", np.int64, ()),
                           cat("s_i", float, (3,)), cat("s_j", float, (3,)),
                           cat("R_i", float, (3, 3)), cat("R_j", float, (3, 3)),
                           cat("param", float, (N_PARAM,)), self.law, cat("coord", np.int64, ()))
        self._drivers = []
        start = 0
        for g in groups:
            if g.rheonomic:
                self._drivers.append((slice(start, start + g.n), g))
            start += g.n
        self.has_drivers = bool(self._drivers)

    #: further time-dependent tables to set with the drivers (the compiled force elements')
    also_set = ()

    def set_time(self, t: float) -> None:
        """law = (f, f', f'') of every driver at time t."""
        for sl, g in self._drivers:
            values = g.law_values(t)
            if values is not None:
                self.law[sl] = values
        for setter in self.also_set:
            setter(t)

    def law_history(self, times: np.ndarray) -> np.ndarray:
        """(nt, n, 3): the column ``law`` at every time of ``times`` (nt,) -- what
        :meth:`set_time` writes, for all times at once (zero rows for the other instances)."""
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.zeros((times.size,) + self.law.shape)
        for sl, g in self._drivers:
            values = g.law_history(times)
            if values is not None:
                out[:, sl] = values
        return out


@njit
def evaluate_history(kind, S, G, rows, q, v, law, out):
    """The rows of every instance with kind >= 0 at each of nt states: q (nt, nb, 7),
    v (nt, nb, 6) (p used as given, as in a run's output), law (nt, n, 3) the table's column
    ``law`` at each time (:meth:`JointTable.law_history`); out = (phi, D, nu, gamma) with
    phi, nu, gamma (nt, m) and D (nt, m, 12). S: state work arrays (nb + 1 rows)."""
    r, A, rdot, omega, p = S
    phi, D, nu, gamma = out
    for k in range(q.shape[0]):
        state_into(q[k], v[k], False, r, A, rdot, omega, p)
        Gk = JointRows(G.bi, G.bj, G.s_i, G.s_j, G.R_i, G.R_j, G.param, law[k], G.coord)
        evaluate_instances(kind, S, Gk, rows, (phi[k], D[k], nu[k], gamma[k]))


_TABLES = threading.local()


def _table(group) -> JointTable:
    """The group's own evaluation table, one per thread (its law buffer is written on every
    evaluation); nothing is stored on the group."""
    registry = getattr(_TABLES, "registry", None)
    if registry is None:
        registry = _TABLES.registry = weakref.WeakKeyDictionary()
    table = registry.get(group)
    if table is None:
        table = registry[group] = JointTable([group], [0])
    return table


def evaluate_group(group, state, t: float) -> ConstraintEval:
    """Phi, D, nu, gamma (n, m), (n, m, 12), (n, m), (n, m) of every instance of one group."""
    table = _table(group)
    table.set_time(t)
    n, m = group.n, group.n_eq
    phi, nu, gamma = np.empty(n * m), np.empty(n * m), np.empty(n * m)
    D = np.empty((n * m, 12))
    out = (phi, D, nu, gamma)
    kind_id = KIND_ID.get(group.name, -1)
    if kind_id >= 0:
        kind = np.full(n, kind_id, dtype=np.int64)
        evaluate_instances(kind, state.arrays(), table.G, table.rows, out)
    else:
        _LATE[group.name](state.arrays(), table.G, table.rows, out)
    return ConstraintEval(phi.reshape(n, m), D.reshape(n, m, 12), nu.reshape(n, m),
                          gamma.reshape(n, m))


# the types (constraints.base, below this module) reach the dispatch through this slot; from
# here on, newly registered types go through register_late
base.DISPATCH.kind_id = KIND_ID
base.DISPATCH.evaluate_group = evaluate_group
base.DISPATCH.register_late = register_late
