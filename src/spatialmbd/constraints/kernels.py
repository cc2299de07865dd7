"""Running the compiled constraint kernels over many instances at once.

Every compiled joint and driver type has a kernel ``kernel(S, G, k, row, out)`` for one instance
k (see :mod:`.primitives`). :func:`evaluate_instances` runs the kernel of each instance in one
compiled loop, selecting it by the instance's kind (an index into :data:`KINDS`); it serves one
group (``ConstraintType.evaluate``) as well as every compiled group of a model at once (the
assembly, where the joint table holds all instances and ``rows`` their first equation).

The joint table G = (body_i, body_j, s_i, s_j, R_i, R_j, length, law, coord):
    body_i, body_j (n,) int64, the ground being body nb; s_i, s_j (n, 3); R_i, R_j (n, 3, 3);
    length (n,); law (n, 3) = f, f', f'' of a driver's motion law (zero otherwise);
    coord (n,) int64, the coordinate of a coordinate driver (zero otherwise).
"""
from __future__ import annotations

import numpy as np

from ..jit import njit
from . import (basic, cylindrical, drivers, fixed, planar, revolute, spherical,
               spherical_revolute, spherical_spherical, translational, universal)
from .base import ConstraintEval

#: the compiled kinds, in the order of the dispatch below
KINDS = ("spherical", "revolute", "universal", "cylindrical", "translational", "planar",
         "fixed", "spherical_spherical", "spherical_revolute", "n1", "n2", "p1", "p2",
         "angle", "translation", "coordinate")
KIND_ID = {name: k for k, name in enumerate(KINDS)}


@njit
def evaluate_instances(kind, S, G, rows, out):
    """Rows of every instance k with kind[k] >= 0 into out = (phi, D, nu, gamma)."""
    for k in range(kind.size):
        c = kind[k]
        row = rows[k]
        if c == 0:
            spherical.kernel(S, G, k, row, out)
        elif c == 1:
            revolute.kernel(S, G, k, row, out)
        elif c == 2:
            universal.kernel(S, G, k, row, out)
        elif c == 3:
            cylindrical.kernel(S, G, k, row, out)
        elif c == 4:
            translational.kernel(S, G, k, row, out)
        elif c == 5:
            planar.kernel(S, G, k, row, out)
        elif c == 6:
            fixed.kernel(S, G, k, row, out)
        elif c == 7:
            spherical_spherical.kernel(S, G, k, row, out)
        elif c == 8:
            spherical_revolute.kernel(S, G, k, row, out)
        elif c == 9:
            basic.kernel_n1(S, G, k, row, out)
        elif c == 10:
            basic.kernel_n2(S, G, k, row, out)
        elif c == 11:
            basic.kernel_p1(S, G, k, row, out)
        elif c == 12:
            basic.kernel_p2(S, G, k, row, out)
        elif c == 13:
            drivers.kernel_angle(S, G, k, row, out)
        elif c == 14:
            drivers.kernel_translation(S, G, k, row, out)
        elif c == 15:
            drivers.kernel_coordinate(S, G, k, row, out)


class JointTable:
    """The joint table of a list of groups (instances concatenated in group order).

    ``kind`` is -1 for the instances of groups that are not compiled; ``rows`` the first
    equation of each instance given the groups' row offsets; ``law`` is refreshed by
    :meth:`set_time` for the drivers.
    """

    def __init__(self, groups, offsets):
        parts = []
        for g, off in zip(groups, offsets):
            geo = g.geometry
            coord = getattr(g, "coordinate", None)
            parts.append(dict(
                kind=np.full(g.n, KIND_ID[g.name] if g.compiled else -1, dtype=np.int64),
                rows=off + g.n_eq * np.arange(g.n, dtype=np.int64),
                bi=g.body_i, bj=g.body_j, s_i=geo.s_i, s_j=geo.s_j, R_i=geo.R_i, R_j=geo.R_j,
                length=np.broadcast_to(geo.length, (g.n,)),
                coord=np.zeros(g.n, np.int64) if coord is None else coord))
        def cat(key, dtype, shape):
            if not parts:
                return np.zeros((0,) + shape, dtype=dtype)
            return np.ascontiguousarray(np.concatenate([p[key] for p in parts]), dtype=dtype)
        self.kind = cat("kind", np.int64, ())
        self.rows = cat("rows", np.int64, ())
        n = self.kind.size
        self.law = np.zeros((n, 3))
        self.G = (cat("bi", np.int64, ()), cat("bj", np.int64, ()), cat("s_i", float, (3,)),
                  cat("s_j", float, (3,)), cat("R_i", float, (3, 3)), cat("R_j", float, (3, 3)),
                  cat("length", float, ()), self.law, cat("coord", np.int64, ()))
        self._drivers = []
        start = 0
        for g in groups:
            if g.rheonomic:
                self._drivers.append((slice(start, start + g.n), g))
            start += g.n
        self.has_drivers = bool(self._drivers)

    def set_time(self, t: float) -> None:
        """law = (f, f', f'') of every driver at time t."""
        for sl, g in self._drivers:
            values = g.law_values(t)
            if values is not None:
                self.law[sl] = values


def _table(group) -> JointTable:
    table = group.__dict__.get("_joint_table")
    if table is None:
        table = JointTable([group], [0])
        group.__dict__["_joint_table"] = table
    return table


def evaluate_group(group, state, t: float) -> ConstraintEval:
    """Phi, D, nu, gamma (n, m), (n, m, 12), (n, m), (n, m) of every instance of one group."""
    table = _table(group)
    table.set_time(t)
    n, m = group.n, group.n_eq
    phi, nu, gamma = np.empty(n * m), np.empty(n * m), np.empty(n * m)
    D = np.empty((n * m, 12))
    kind = np.full(n, KIND_ID[group.name], dtype=np.int64)
    evaluate_instances(kind, state.arrays(), table.G, table.rows, (phi, D, nu, gamma))
    return ConstraintEval(phi.reshape(n, m), D.reshape(n, m, 12), nu.reshape(n, m),
                          gamma.reshape(n, m))
