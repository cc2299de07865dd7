"""A batch's set-up: what it returns per member (:class:`BatchMember`) and the stacked packs,
work arrays and states of its members (:class:`BatchSetup`), with the checks of its scope."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...dynamics import recursive as rc
from ...dynamics import system as cs
from ...dynamics.fused import projection_params
from ...guards import guard_length
from ...errors import ModelError


# ------------------------------------------------------------------------------ Python side
#: position of a joint-table entry in the table tuple G (body_i, body_j, s_i, s_j, R_i, R_j,
#: length or param, law, coord) when G has no field names
_JOINT_ROW_INDEX = {"s_i": 2, "s_j": 3, "R_i": 4, "R_j": 5, "length": 6, "param": 6}


@dataclass
class BatchMember:
    """What the batch returns per member: the arrays of a Results (same shapes) and status."""

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


class BatchSetup:
    """The prototype System of a topology and the checks that a model belongs to it.

    integrator: the analysis' integrator. With "rk45" or "dop853", method "auto" takes the
    recursive method for a tree of joints as simulate() does (joint coordinates,
    :mod:`..dynamics.recursive`), else the projection method; "recursive" needs one of them
    and a tree."""

    def __init__(self, model, method="standard", method_options=None, integrator=None):
        from ...dynamics import EquationsOfMotion, get_method
        from ...kinematics import mobility
        self._check_model(model)
        self.recursive = False
        self.tree = None                        # the prototype's JointTree (recursive)
        if method in ("auto", "recursive"):
            tree_error = self._tree_error(model, integrator)
            if method == "recursive" and tree_error:
                raise ModelError(f"batch integration with method 'recursive': {tree_error}")
            self.recursive = not tree_error
            # else the body-coordinate default of simulate()
            method = "recursive" if self.recursive else "projection"
        meth = get_method(method, **({} if self.recursive else (method_options or {})))
        if not self.recursive and (meth.name not in ("standard", "baumgarte", "projection")
                                   or getattr(meth, "solver", "") == "kkt"):
            raise ModelError(f"batch integration supports the 'standard', 'baumgarte', "
                             f"'projection' and 'recursive' methods, not {meth.name!r}; use "
                             "engine='simulate'")
        self.eom = EquationsOfMotion(model)
        self.system = system = self.eom.system
        if not system.fused:
            raise ModelError("batch integration needs a fully compiled right-hand side: model "
                             f"{model.name!r} has force elements or joint types without a "
                             "compiled kernel; use engine='simulate'")
        if model.n_eq:
            mob = mobility(model, np.asarray(model.q0, float), 0.0)
            if mob.redundant:
                raise ModelError(f"batch integration: model {model.name!r} has redundant "
                                 "constraints; use engine='simulate'")
        meth.setup(self.eom, None)
        self.mp = np.asarray(meth.params(), dtype=float)
        # the singular-position guard as in simulate() (standard and Baumgarte members)
        self.pp = projection_params(meth, None,
                                    guard_length(model, np.asarray(model.q0, dtype=float)))
        self.method = meth
        self.model = model
        self.nb = model.nb
        self.m = model.n_eq
        self.lam_off = system._layout["lam"][0]
        self._topology = self._signature(model)
        self._slots = self._f_slots()
        self._corrector = None                  # the System of the initial corrections

    @staticmethod
    def _tree_error(model, integrator) -> str:
        """Why the recursive method cannot run this model's batch ('' when it can)."""
        if integrator not in ("rk45", "dop853"):
            return f"it integrates with rk45 or dop853, not {integrator!r}"
        try:
            tree = rc.JointTree(model, model.q0, model.v0)
        except ModelError as exc:
            return str(exc)
        if not set(tree.kind.tolist()) - {rc.FREE}:
            return "the model has no joints (free bodies only)"
        return ""

    def joint_start(self, model, y0):
        """(x0, Tf) of a recursive member from its corrected y0 = [q, v, 0]: the joint state
        and the tree's float pack (the member's joint geometry and its own work arrays)."""
        nb = self.nb
        q, v = y0[:7 * nb].reshape(nb, 7), y0[7 * nb:13 * nb].reshape(nb, 6)
        tree = rc.JointTree(model, q, v)
        tree.check_initial(q)
        if self.tree is None:
            self.tree = tree
        elif not np.array_equal(tree.Ti, self.tree.Ti):
            raise ModelError(f"batch integration: member model {model.name!r} has another "
                             "joint tree than the first member")
        return tree.x0, tree.Tf

    @staticmethod
    def _check_model(model):
        from ...forces.contact.memory import impact_groups
        python = [g.name for g in model.force_groups if not g.compiled]
        if python:
            raise ModelError(f"batch integration: model {model.name!r} has force elements "
                             f"evaluated in Python ({', '.join(python)}); use "
                             "engine='simulate'")
        if impact_groups(model):
            raise ModelError(f"batch integration: model {model.name!r} has contact elements "
                             "(or joint limits with a hysteresis law), "
                             "whose impact memory simulate() keeps by events between steps; "
                             "use engine='simulate'")
        timed = [g.name for g in model.force_groups if g.time_dependent]
        if timed:
            raise ModelError(f"batch integration: model {model.name!r} has force elements "
                             f"with time-dependent laws ({', '.join(timed)}), set from Python "
                             "at every evaluation; use engine='simulate'")
        if any(g.rheonomic for g in model.constraint_groups):
            raise ModelError(f"batch integration: model {model.name!r} has drivers (Python "
                             "motion laws); use engine='simulate'")
        reaction = [n for g in model.force_groups if getattr(g, "reaction_dependent", False)
                    for n in g.names]
        if reaction:
            raise ModelError(f"batch integration: model {model.name!r} has joint friction "
                             f"proportional to the joint reaction ({', '.join(reaction)}), "
                             "whose loop the batch drivers do not close; use "
                             "engine='simulate'")
        stateful = [g.name for g in model.force_groups if np.any(g.state_rows())]
        if stateful:
            raise ModelError(f"batch integration: model {model.name!r} has force elements "
                             "with internal states (LuGre friction), which the batch "
                             "engine does not integrate; use engine='simulate'")
        couplers = [n for g in model.constraint_groups if g.coupler
                    for n in g.names]
        if couplers:
            raise ModelError(f"batch integration: model {model.name!r} has couplers "
                             f"({', '.join(couplers)}), whose angles are unwrapped per step by "
                             "simulate(); use engine='simulate'")

    @staticmethod
    def _tables(model):
        """(joint table, force table) of a model."""
        from ...constraints.kernels import JointTable
        from ...forces.kernels import ForceTable
        return (JointTable(model.constraint_groups, model.group_offsets),
                ForceTable(model.force_groups))

    @staticmethod
    def _signature(model, tables=None):
        """What members of one batch must share: the topology (bodies, joints and force
        elements, their kinds, bodies and coordinates) and the force elements' law values
        (in the work arrays, which the members share)."""
        table, ftable = BatchSetup._tables(model) if tables is None else tables
        G, Gf = table.G, ftable.G
        ints = lambda a: tuple(np.asarray(a).ravel().tolist())   # noqa: E731
        return (model.nb, model.n_eq, ints(table.kind), ints(table.rows), ints(G[0]),
                ints(G[1]), ints(G[8]), ints(ftable.kind), ints(Gf.bi), ints(Gf.bj),
                ints(Gf.coord), ints(ftable.law))

    def _f_slots(self) -> list:
        """(name, offset, shape) of every non-empty F field of the packed layout, read once
        from the prototype's header (a member's F is the prototype's with these refilled)."""
        sysm = self.system
        slots = []
        for k, (name, buf, ndim) in enumerate(cs.FIELDS):
            if buf != "F":
                continue
            off = int(sysm.I[4 * k])
            shape = tuple(int(x) for x in sysm.I[4 * k + 1:4 * k + 1 + ndim])
            if math.prod(shape):
                slots.append((name, off, shape))
        return slots

    def pack_F(self, model) -> np.ndarray:
        """The float pack F of a member model (its topology checked against the prototype).

        Every F field of the packed layout (:data:`..dynamics.system.FIELDS`) is filled from
        the member model: the body arrays and the joint table's geometry; a field this module
        does not know raises unless it is empty for this model (the layout changed: the batch
        engine must learn the field)."""
        self._check_model(model)
        tables = self._tables(model)
        if self._signature(model, tables) != self._topology:
            raise ModelError(f"batch integration: member model {model.name!r} differs in "
                             "topology (bodies, joints, force elements or their order) or in "
                             "force-law values from the first member; members of one batch "
                             "may differ only in geometry, inertia, parameters and initial "
                             "state")
        F = self.system.F.copy()
        G, Gf = tables[0].G, tables[1].G
        arrays = dict(mass=model.mass, Jl=model.inertia, Jl_inv=model.inertia_inverse,
                      weight=model.mass[:, None] * model.gravity[None, :],
                      fs_i=Gf.s_i, fs_j=Gf.s_j, fR_i=Gf.R_i, fR_j=Gf.R_j, fparam=Gf.param)
        for name, off, shape in self._slots:
            value = arrays.get(name)
            if value is None:
                value = getattr(G, name, None)          # the joint rows, by name or position
            if value is None and name in _JOINT_ROW_INDEX:
                value = G[_JOINT_ROW_INDEX[name]]
            if value is None:
                raise ModelError(f"batch integration does not know the packed model field "
                                 f"{name!r}; use engine='simulate'")
            size = math.prod(shape)
            F[off:off + size] = np.asarray(value, dtype=float).reshape(size)
        return F

    def pack_bodies(self, mass, inertia, gravity) -> np.ndarray:
        """Float packs (B, nF) of members that differ from the prototype only in masses (B,
        nb), inertias (B, nb, 3, 3) and gravity (B, 3): its F with the body fields rewritten
        as :meth:`pack_F` writes them (vectorised over the members)."""
        B = mass.shape[0]
        Fs = np.repeat(self.system.F[None, :], B, axis=0)
        arrays = dict(mass=mass, Jl=inertia, Jl_inv=np.linalg.inv(inertia),
                      weight=mass[:, :, None] * gravity[:, None, :])
        for name, off, shape in self._slots:
            if name in arrays:
                size = math.prod(shape)
                Fs[:, off:off + size] = arrays[name].reshape(B, size)
        return Fs

    def initial_state(self, model, F, analysis) -> np.ndarray:
        """y0 = [q, v, 0] of a member, corrected (chapter 14) as simulate() does."""
        from ...dynamics.correction import correct_initial_conditions, hold_mask
        from ...state import normalize_q
        nb = model.nb
        q = normalize_q(np.array(model.q0, dtype=float).reshape(nb, 7))
        v = np.array(model.v0, dtype=float).reshape(nb, 6)
        if analysis.correct_initial and model.n_eq:
            if self._corrector is None:
                self._corrector = self.system.clone()
            self._corrector.F = F                      # the member's values, shared layout
            q, v, _ = correct_initial_conditions(model, q, v, 0.0,
                                                 hold_mask(model, analysis.hold),
                                                 system=self._corrector)
        return np.concatenate([q.reshape(-1), v.reshape(-1), [0.0]])


def _check_analysis(analysis):
    if analysis.type != "dynamic":
        raise ModelError(f"batch integration runs dynamic analyses, not {analysis.type!r}")
    if analysis.integrator not in ("rk45", "dop853", "rk4"):
        raise ModelError(f"batch integration supports the integrators 'rk45' and 'dop853' "
                         f"(per-member step control) and 'rk4' (common fixed step), not "
                         f"{analysis.integrator!r}")
    extra = set(analysis.integrator_options or {}) - {"max_step"}
    if extra:
        raise ModelError(f"batch integration: integrator options {sorted(extra)} are not "
                         "supported (only step, rtol, atol, max_step)")
