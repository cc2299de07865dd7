"""Batches of one topology: many members integrated together in one compiled call.

Members that differ only in parameter values (masses, inertias, joint geometry, gravity) and
initial states share the model's structure: the integer pack ``I`` of
:class:`..dynamics.system.System` (topology, sparsity patterns, symbolic factorisation) is the
same, only the float pack ``F`` and the initial state differ. :func:`simulate_batch` stacks
them -- F (B, nF), work arrays W (B, nW), states (B, n) -- and runs one compiled loop over the
members that integrates each with the compiled drivers of :mod:`..dynamics.fused` (those
:func:`simulate` uses for a fully compiled model):

* ``rk45``: Dormand-Prince 5(4) with per-member step control -- the same arithmetic as
  :class:`..integrators.runge_kutta_adaptive.DormandPrince45` (Hairer's starting step, the PI
  controller with beta = 0.04, FSAL, Shampine's dense output, p renormalised -- and with the
  projection method q and v projected, the FSAL derivative re-evaluated -- after every accepted
  step and at every output), so a member's result equals its separate run to round-off;
* ``dop853``: Dormand-Prince 8(5,3) with per-member step control, the arithmetic of
  :class:`..integrators.dop853.DormandPrince853` (for tight tolerances: about a third of
  rk45's evaluations at rtol 1e-8);
* ``rk4``: classic RK4 with a common fixed step, landing on every output time as
  :class:`..integrators.fixed_step.RungeKutta4` does.

With the recursive method (what "auto" gives a tree of joints with rk45 or dop853, as in
simulate())
each member's joint coordinates and joint tree (:class:`..dynamics.recursive.JointTree`)
come from its corrected initial state and the members are integrated by
:func:`..dynamics.recursive.dopri_joint` in one compiled call
(:func:`integrate_batch_joint`), the bodies' coordinates evaluated at the outputs.

vdot and lambda at the output times are evaluated in the same call. A member whose right-hand
side fails (singular S, non-finite values) or whose step size underflows stops with a status
code and is reported as failed; the others continue.

In a sweep (:func:`run_members_batched`), members whose parameters each set one entry of the
model's masses, inertias, gravity or initial state (probed, :func:`_direct_entries`) are not
built: their values are written into copies of one built model's arrays and packs.

Scope (checked, with a ModelError naming what is not supported): dynamic analyses with the
"standard", "baumgarte", "projection" or "recursive" method (where simulate() would fall back to
least squares for a singular D D^T, a batch member fails instead); models whose right-hand side is
fully compiled (every joint type and force element compiled), without drivers or
time-dependent force laws (set from Python at every evaluation), contact elements (their
impact memory is kept by events) or force-element states; no redundant constraints. Models
outside it run through :func:`simulate` one by one
(``engine="simulate"``).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ..dynamics import recursive as rc
from ..dynamics import system as cs
from ..dynamics.fused import (OK, STATUS_TEXT, TOO_MANY_STEPS, dopri_run, projection_params,
                              rk4_outputs)
from ..errors import ModelError
from ..dynamics.layout import bare
from ..integrators.pairs import PAIR_DP5, pair_by_name
from ..jit import array_view, njit

__all__ = ["simulate_batch", "BatchSetup", "run_members_batched", "STATUS_TEXT"]


# ------------------------------------------------------------------------------ compiled part
@njit(inline="always")
def _rows(A):
    """A (B, k) C-contiguous as one flat uncounted view (rows at b k)."""
    return bare(A.reshape(-1))


@njit(nogil=True)
def integrate_batch(b0, b1, Y0, F, I, W, mp, pp, t_out, adaptive, pair, rtol, atol, max_step,
                    step, max_steps, nb, lam_off, Y, Yd, Lam, status, t_fail, counters):
    """Members b0 <= b < b1: integrate Y0[b] with F[b], W[b] (the shared I) into Y[b] (nt, n)
    and, when Yd and Lam have rows (nt each, else none), vdot into Yd[b] (nt, 6 nb) and
    lambda into Lam[b] (nt, m). status[b]: 0 or a failure code (t_fail[b] the time);
    counters[b] = (nfev, steps, rejected). adaptive: the Dormand-Prince pair ``pair``
    (:mod:`..integrators.pairs`), else RK4 with ``step``. Without the GIL: ranges of members
    run in threads at once (each member has its own F, W, state and outputs; I is read
    only). The arrays are read as uncounted views, as in :func:`integrate_batch_joint`."""
    I, mp, pp, t_out = bare(I), bare(mp), bare(pp), bare(t_out)
    nF, nW, nt, n = F.shape[1], W.shape[1], Y.shape[1], Y.shape[2]
    F, W = _rows(F), _rows(W)
    rows, nd, nl = Yd.shape[1], Yd.shape[2], Lam.shape[2]
    Yf, Ydf, Lamf, cf = _rows(Y), _rows(Yd), _rows(Lam), _rows(counters)
    for b in range(b0, b1):
        Fb, Wb = array_view(F, b * nF, (nF,)), array_view(W, b * nW, (nW,))
        Yb = array_view(Yf, b * nt * n, (nt, n))
        Ydb = array_view(Ydf, b * rows * nd, (rows, nd))
        Lamb = array_view(Lamf, b * rows * nl, (rows, nl))
        cb = array_view(cf, 3 * b, (3,))
        if adaptive:
            code, tf = dopri_run(Y0[b], Fb, I, Wb, mp, pp, pair, 0.0, t_out, rtol, atol,
                                 max_step, max_steps, nb, Yb, Ydb, Lamb, lam_off, cb)
        else:
            code, tf = rk4_outputs(0.0, Y0[b].copy(), Fb, I, Wb, mp, pp, t_out, 0, t_out.size,
                                   0, step, nb, Yb, Ydb, Lamb, lam_off, cb)
        status[b] = code
        t_fail[b] = tf


@njit(nogil=True)
def integrate_batch_joint(b0, b1, X0, Ti, Tf, F, I, W, t_out, pair, rtol, atol, max_step,
                          max_steps, nb, nq, mp, lam_off, X, Y, Yd, Lam, status, t_fail,
                          counters):
    """The recursive method's members b0 <= b < b1: the joint state X0[b] (tree packs Ti,
    shared, and Tf[b], the member's geometry and work) integrated by
    :func:`..dynamics.recursive.dopri_joint` (the pair ``pair``) into X[b] (nt, nx); the
    bodies' [q, v, work] at the outputs into Y[b] and, when Yd and Lam have rows, vdot and
    lambda (standard method, params mp) into Yd[b], Lam[b]. status, t_fail, counters as
    :func:`integrate_batch`."""
    n = X0.shape[1]
    nt = t_out.size
    # shared arrays and rows as uncounted views: every call of the driver and of the
    # right-hand side would otherwise update the reference counts of the arrays all threads
    # share (one cache line ping-ponged between the cores: 1.2x instead of 2x on two threads)
    Ti, I, t_out, mp = bare(Ti), bare(I), bare(t_out), bare(mp)
    nT, nF, nW = Tf.shape[1], F.shape[1], W.shape[1]
    Tf, F, W = _rows(Tf), _rows(F), _rows(W)
    nx, ny, nd, nl = X.shape[2], Y.shape[2], Yd.shape[2], Lam.shape[2]
    Xf, Yf = bare(X.reshape(-1)), bare(Y.reshape(-1))
    Ydf, Lamf, cf = bare(Yd.reshape(-1)), bare(Lam.reshape(-1)), bare(counters.reshape(-1))
    rows = Yd.shape[1]
    for b in range(b0, b1):
        x = X0[b].copy()
        K0 = np.empty(n)
        T = (Ti, array_view(Tf, b * nT, (nT,)))
        Fb, Wb = array_view(F, b * nF, (nF,)), array_view(W, b * nW, (nW,))
        Xb = array_view(Xf, b * nt * nx, (nt, nx))
        code, t, h, err, done = rc.dopri_joint(0.0, x, K0, 0.0, 1e-4, T, Fb, I, Wb, pair,
                                               0.0, t_out, 0, rtol, atol, max_step,
                                               max_steps, Xb, array_view(cf, 3 * b, (3,)))
        if code == OK and done < nt:
            code = TOO_MANY_STEPS
        status[b] = code
        t_fail[b] = t
        Yb = array_view(Yf, b * nt * ny, (done, ny))
        rc.body_rows(array_view(Xf, b * nt * nx, (done, nx)), T, nb, nq, Yb)
        if rows:
            rc.output_accelerations(t_out[:done], Yb, Fb, I, Wb, mp, lam_off,
                                    array_view(Ydf, b * rows * nd, (done, nd)),
                                    array_view(Lamf, b * rows * nl, (done, nl)))
        for k in range(b * nt * ny + done * ny, (b + 1) * nt * ny):   # past a failure: NaN
            Yf[k] = np.nan
        for k in range(b * rows * nd + done * nd, (b + 1) * rows * nd):
            Ydf[k] = np.nan
        for k in range(b * rows * nl + done * nl, (b + 1) * rows * nl):
            Lamf[k] = np.nan


def _run_members(args, B: int, threads: bool, kernel=None) -> None:
    """kernel (default integrate_batch) over all B members: in one call, or (threads) in
    ranges of members handed to one thread per core as each finishes its previous range."""
    import os
    kernel = integrate_batch if kernel is None else kernel
    cores = os.cpu_count() or 1
    if not threads or cores < 2 or B < 2:
        kernel(0, B, *args)
        return
    from concurrent.futures import ThreadPoolExecutor
    size = max(1, B // (8 * cores))                  # small ranges: members differ in cost
    with ThreadPoolExecutor(max_workers=min(cores, B)) as pool:
        futures = [pool.submit(kernel, b0, min(B, b0 + size), *args)
                   for b0 in range(0, B, size)]
        for f in futures:
            f.result()


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
        from ..dynamics import EquationsOfMotion, get_method
        from ..kinematics import mobility
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
        self.pp = projection_params(meth)
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
        from ..forces.contact.memory import impact_groups
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
        from ..constraints.kernels import JointTable
        from ..forces.kernels import ForceTable
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
        from ..dynamics.correction import correct_initial_conditions, hold_mask
        from ..state import normalize_q
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


def simulate_batch(models: Sequence, analysis, setup: Optional[BatchSetup] = None,
                   max_steps: int = 10_000_000, accelerations: bool = True,
                   threads: bool = False) -> list:
    """Integrate the members ``models`` (one topology) with ``analysis`` in one compiled call.

    models: Models that differ only in values (masses, inertias, geometry, gravity, initial
    state). analysis: an Analysis (dynamic; method auto/standard/baumgarte/projection/recursive
    -- "auto" as simulate() chooses it; rk45 or dop853 with rtol/atol/max_step, or rk4 with
    step). Returns one :class:`BatchMember` per model (arrays shaped as in
    :class:`..results.Results`, so the sweep outputs read them alike).
    accelerations: also evaluate vdot and lambda at the output times (one more right-hand
    side per output; False leaves them NaN). threads: spread the members over one thread per
    core (the compiled loop releases the GIL).
    """
    from ..simulate import output_times
    from ..io.modelfile import Analysis
    if isinstance(analysis, dict):
        analysis = Analysis.from_dict(analysis)
    _check_analysis(analysis)
    models = list(models)
    if not models:
        return []
    if setup is None:
        setup = BatchSetup(models[0], analysis.method, analysis.method_options,
                           analysis.integrator)
    t_out = output_times(analysis.t_end, analysis.output_step, analysis.t_eval, 0.0)
    Fs = np.stack([setup.pack_F(m) for m in models])
    Y0 = np.stack([setup.initial_state(m, Fs[k], analysis) for k, m in enumerate(models)])
    return _integrate(setup, models, analysis, t_out, Fs, Y0, max_steps, accelerations,
                      threads)


def _integrate(setup, models, analysis, t_out, Fs, Y0, max_steps, with_outputs=True,
               threads=False, starts=None):
    """Integrate the members (F rows Fs, corrected initial states Y0; for the recursive
    method, optionally their (x0, Tf) joint starts) in one compiled call."""
    if setup.recursive:
        return _integrate_joint(setup, models, analysis, t_out, Fs, Y0, max_steps,
                                with_outputs, threads, starts)
    B, n = Y0.shape
    nb, m = setup.nb, setup.m
    W = np.repeat(setup.system.W[None, :], B, axis=0)
    nt = t_out.size
    Y = np.zeros((B, nt, n))
    rows = nt if with_outputs else 0                # no rows: the drivers skip them
    Yd = np.zeros((B, rows, 6 * nb))
    Lam = np.zeros((B, rows, m))
    status = np.zeros(B, dtype=np.int64)
    t_fail = np.zeros(B)
    counters = np.zeros((B, 3), dtype=np.int64)
    pair = pair_by_name(analysis.integrator)
    adaptive = pair is not None
    rtol = 1e-6 if analysis.rtol is None else float(analysis.rtol)
    atol = 1e-9 if analysis.atol is None else float(analysis.atol)
    max_step = float((analysis.integrator_options or {}).get("max_step") or math.inf)
    step = 1e-3 if analysis.step is None else float(analysis.step)
    start = time.perf_counter()
    _run_members((Y0, Fs, setup.system.I, W, setup.mp, setup.pp, t_out, adaptive,
                  pair or PAIR_DP5, rtol, atol, max_step, step, max_steps, nb,
                  setup.lam_off, Y, Yd, Lam, status, t_fail, counters), B, threads)
    wall = time.perf_counter() - start
    return _members(setup, models, t_out, Y, Yd, Lam, status, t_fail, counters, wall,
                    with_outputs)


def _integrate_joint(setup, models, analysis, t_out, Fs, Y0, max_steps, with_outputs,
                     threads, starts=None):
    """_integrate for the recursive method: each member's joint state and tree (from its
    corrected y0 unless given in starts), all members in one compiled call
    (:func:`integrate_batch_joint`)."""
    B = Y0.shape[0]
    nb, m, nt = setup.nb, setup.m, t_out.size
    if starts is None:
        starts = [setup.joint_start(model, Y0[b]) for b, model in enumerate(models)]
    X0 = np.stack([x0 for x0, _ in starts])
    Tf = np.stack([tf for _, tf in starts])
    nq = setup.tree.nq
    W = np.repeat(setup.system.W[None, :], B, axis=0)
    X = np.empty((B, nt, X0.shape[1]))              # (every row is written, NaN past a
    Y = np.empty((B, nt, 13 * nb + 1))             # failure)
    rows = nt if with_outputs else 0
    Yd = np.empty((B, rows, 6 * nb))
    Lam = np.empty((B, rows, m))
    status = np.zeros(B, dtype=np.int64)
    t_fail = np.zeros(B)
    counters = np.zeros((B, 3), dtype=np.int64)
    rtol = 1e-6 if analysis.rtol is None else float(analysis.rtol)
    atol = 1e-9 if analysis.atol is None else float(analysis.atol)
    max_step = float((analysis.integrator_options or {}).get("max_step") or math.inf)
    start = time.perf_counter()
    _run_members((X0, setup.tree.Ti, Tf, Fs, setup.system.I, W, t_out,
                  pair_by_name(analysis.integrator), rtol, atol, max_step,
                  max_steps, nb, nq, setup.mp, setup.lam_off, X, Y, Yd, Lam, status, t_fail,
                  counters), B, threads, integrate_batch_joint)
    wall = time.perf_counter() - start
    return _members(setup, models, t_out, Y, Yd, Lam, status, t_fail, counters, wall,
                    with_outputs)


def _members(setup, models, t_out, Y, Yd, Lam, status, t_fail, counters, wall,
             with_outputs):
    """One BatchMember per model from the stacked outputs."""
    nb, m, nt, B = setup.nb, setup.m, t_out.size, len(models)
    if not with_outputs:                       # one read-only NaN array for all members
        vdot_none, lam_none = np.full((nt, nb, 6), np.nan), np.full((nt, m), np.nan)
        vdot_none.setflags(write=False)
        lam_none.setflags(write=False)
    out = []
    for b, model in enumerate(models):
        ok = status[b] == OK
        msg = "" if ok else f"t = {t_fail[b]:.6g} s: {STATUS_TEXT[int(status[b])]}"
        out.append(BatchMember(
            model=model, t=t_out, q=Y[b, :, :7 * nb].reshape(nt, nb, 7),
            v=Y[b, :, 7 * nb:13 * nb].reshape(nt, nb, 6),
            vdot=Yd[b].reshape(nt, nb, 6) if with_outputs else vdot_none,
            lam=Lam[b] if with_outputs else lam_none, work=Y[b, :, -1],
            status="success" if ok else "failed", message=msg,
            counters=dict(nfev=int(counters[b, 0]), steps=int(counters[b, 1]),
                          rejected=int(counters[b, 2]), wall_time=wall / B)))
    return out


def as_results(member: BatchMember):
    """A :class:`..results.Results` of a batch member (for energies, reactions, tables)."""
    from ..results import Results
    return Results(model=member.model, t=member.t, q=member.q, v=member.v, vdot=member.vdot,
                   lam=member.lam, work=member.work, status=member.status,
                   message=member.message, counters=member.counters,
                   wall_time=member.counters.get("wall_time", 0.0))


def run_members_batched(job, members: list) -> list:
    """The batch engine of a sweep chunk: build every member, integrate those that build in
    one compiled call, reduce the outputs. Same (status, message, outputs, t) rows as
    :meth:`.core.SweepJob.run_member`."""
    from .core import FAILED, _describe
    rows = [None] * len(members)
    left = _run_direct(job, members, rows)
    built = []
    for k in left:
        member = members[k]
        try:
            model, analysis = job.build(member)
            built.append((k, model, analysis))
        except Exception as exc:
            rows[k] = (FAILED, _describe(exc), job.empty(), None)
    # members are grouped by analysis (a swept analysis setting gives several groups)
    groups: dict = {}
    for k, model, analysis in built:
        key = repr(analysis.to_dict())
        groups.setdefault(key, []).append((k, model, analysis))
    for items in groups.values():
        analysis = items[0][2]
        try:
            _check_analysis(analysis)
            setup = BatchSetup(items[0][1], analysis.method, analysis.method_options,
                               analysis.integrator)
        except Exception as exc:
            for k, _, _ in items:
                rows[k] = (FAILED, _describe(exc), job.empty(), None)
            continue
        from ..simulate import output_times
        t_out = output_times(analysis.t_end, analysis.output_step, analysis.t_eval, 0.0)
        good, Fs, Y0, starts = [], [], [], []
        for k, model, _ in items:
            try:
                F = setup.pack_F(model)
                y0 = setup.initial_state(model, F, analysis)
                if setup.recursive:
                    starts.append(setup.joint_start(model, y0))
                Y0.append(y0)
                Fs.append(F)
                good.append((k, model))
            except Exception as exc:
                rows[k] = (FAILED, _describe(exc), job.empty(), None)
        if good:
            _integrate_reduce(job, setup, analysis, t_out, good, np.stack(Fs), np.stack(Y0),
                              starts or None, rows)
    return rows


def _integrate_reduce(job, setup, analysis, t_out, good, Fs, Y0, starts, rows):
    """Integrate the members good = [(row, model)] and reduce each to its sweep row."""
    from .core import FAILED, _describe
    opts = job.batch_options
    res = _integrate(setup, [m for _, m in good], analysis, t_out, Fs, Y0,
                     int(opts.get("max_steps", 10_000_000)),
                     with_outputs=_needs_accelerations(job.outputs),
                     threads=bool(opts.get("threads", False)), starts=starts)
    plan = _state_plan(job.outputs, setup.model)
    requests = None
    if plan is None and analysis.outputs:        # joint, force, ... columns, as simulate has
        from ..outputs import parse_outputs as parse_requests
        requests = parse_requests(setup.model, analysis.outputs)
    for (k, _), member in zip(good, res):
        try:
            if plan is not None:
                rows[k] = _reduce_states(job, member, plan)
            else:
                results = as_results(member)
                results.output_requests = requests or []
                rows[k] = job.reduce(results)
        except Exception as exc:
            rows[k] = (FAILED, _describe(exc), job.empty(), None)


def _state_plan(outputs, model):
    """[(reduction, "q" or "v", body, column)] when every output is a reduction of a body's
    position, Euler parameter or velocity column (what the member's arrays hold as they
    are); None otherwise (the outputs are then evaluated on a Results, as in a separate run)."""
    from .outputs import _BODY_Q, _BODY_V
    plan = []
    for o in outputs:
        if o.function is not None or o.reduction is None:
            return None
        parts = o.column.split(".")
        if len(parts) != 2 or parts[0] not in model.body_names:
            return None
        k = model.body_names.index(parts[0])
        if parts[1] in _BODY_Q:
            plan.append((o.reduction, "q", k, _BODY_Q.index(parts[1])))
        elif parts[1] in _BODY_V:
            plan.append((o.reduction, "v", k, _BODY_V.index(parts[1])))
        else:
            return None
    return plan


def _reduce_states(job, member, plan):
    """The sweep row of a member whose outputs are all in ``plan``: the values
    :meth:`.core.SweepJob.reduce` gives, read from the member's arrays without a Results."""
    from .core import FAILED, SUCCESS
    from .outputs import REDUCTIONS
    if member.status != SUCCESS:
        return FAILED, str(member.message), job.empty(), None
    vals = []
    for red, arr, k, i in plan:
        x = (member.q if arr == "q" else member.v)[:, k, i]
        vals.append(math.nan if x.size == 0 else REDUCTIONS[red](member.t, x))
    return SUCCESS, "", vals, None


# ------------------------------------------------------------------ members set without builds
#: the Model arrays a sweep parameter may set directly, without building the member's model
DIRECT_ARRAYS = ("mass", "inertia", "gravity", "q0", "v0")
#: fewest members of a group for which the direct path is tried (it builds one probe model
#: per parameter)
DIRECT_MIN_MEMBERS = 3


def _direct_entries(job, member0, model0, others, setup):
    """For every model parameter of the sweep, the Model entry (array, flat index) it sets, or
    None if no member changes it -- when building a member with that parameter changed is
    exactly writing its value into that one entry of :data:`DIRECT_ARRAYS`. Probed: the
    model is built with only that parameter set to another member's value and compared with
    model0 entry by entry, point by point and pack by pack. None (the whole dict) when some
    parameter is not of that kind (a joint's axis, a force element's stiffness, a velocity
    given in body axes, ...): those members are built one by one."""
    from .params import split
    names = list(split(member0, False)[0])
    F0 = setup.pack_F(model0)
    entries = {}
    for name in names:
        other = next((m[name] for m in others if m[name] != member0[name]), None)
        if other is None:
            entries[name] = None
            continue
        probe = dict(member0)
        probe[name] = other
        try:
            model_p, _ = job.build(probe)
        except Exception:
            return None
        changed = []
        for a in DIRECT_ARRAYS:
            x0 = np.asarray(getattr(model0, a), dtype=float).ravel()
            x1 = np.asarray(getattr(model_p, a), dtype=float).ravel()
            if x0.shape != x1.shape:
                return None
            changed += [(a, int(i), float(x1[i])) for i in np.flatnonzero(x0 != x1)]
        if len(changed) != 1 or changed[0][2] != float(other):
            return None
        a, i, _ = changed[0]
        if model_p.points.keys() != model0.points.keys() or any(   # (body, local point)
                model_p.points[p][0] != model0.points[p][0]
                or not np.array_equal(model_p.points[p][1], model0.points[p][1])
                for p in model0.points):
            return None
        patched = _patched(model0, {a: _with(getattr(model0, a), i, other)})
        if not np.array_equal(setup.pack_F(model_p), setup.pack_F(patched)) or \
                np.array_equal(F0, setup.pack_F(patched)) != (a in ("q0", "v0")):
            return None
        entries[name] = (a, i)
    return entries


def _with(x, i, value):
    y = np.array(x, dtype=float)
    y.reshape(-1)[i] = value
    return y


def _patched(model, arrays: dict):
    """model with some of DIRECT_ARRAYS replaced (its builder snapshot, used for model files
    and warnings, stays the prototype's: these members live only inside the sweep)."""
    import dataclasses
    return dataclasses.replace(model, **arrays)


def _run_direct(job, members: list, rows: list) -> list:
    """Members whose parameters are all direct (:func:`_direct_entries`), grouped by their
    analysis values: one model built per group (and one probe per parameter); every other
    member's masses, inertias, gravity and initial state are written into copies of its
    arrays and packs, its initial state corrected only when a parameter sets it (the
    correction is kinematic). Fills their rows; returns the indices of the members left to
    the building path."""
    from ..simulate import output_times
    from .params import split
    if job.factory is not None and not job.analysis:
        return list(range(len(members)))        # the factory's own analysis may vary
    groups: dict = {}
    for k, member in enumerate(members):
        key = tuple(sorted(split(member, False)[1].items()))
        groups.setdefault(key, []).append(k)
    left = []
    for ks in groups.values():
        if len(ks) < DIRECT_MIN_MEMBERS:
            left += ks
            continue
        try:
            model0, analysis = job.build(members[ks[0]])
            _check_analysis(analysis)
            setup = BatchSetup(model0, analysis.method, analysis.method_options,
                               analysis.integrator)
            entries = _direct_entries(job, members[ks[0]], model0,
                                      [members[k] for k in ks[1:]], setup)
        except Exception:
            entries = None
        if entries is None:
            left += ks
            continue
        left += _direct_group(job, setup, model0, analysis, output_times(
            analysis.t_end, analysis.output_step, analysis.t_eval, 0.0),
            [(k, members[k]) for k in ks], entries, rows)
    return sorted(left)


def _direct_valid(arrays, items, entries) -> np.ndarray:
    """Which direct members' values pass the checks a build applies to them (a boolean per
    member): the model file's range checks on each value (by the quantity its path names,
    :func:`..io.schema.range_of`), positive masses, the builder's inertia check and finite
    arrays. (A member that fails is built, so that its error is the build's.)"""
    from ..io.schema import range_of
    from ..model.builder import check_inertia
    B = len(items)
    ok = np.ones(B, dtype=bool)
    for a, x in arrays.items():
        ok &= np.all(np.isfinite(x.reshape(B, -1)), axis=1)
    inertias = set()
    for name, entry in entries.items():
        if entry is None:
            continue
        vals = np.array([member[name] for _, member in items], dtype=float)
        low, high = range_of(tuple(name.split(".")))
        size = np.abs(vals)
        ok &= (size == 0.0) | ((size >= low) & (size <= high))
        a, i = entry
        if a == "mass":
            ok &= vals > 0.0
        elif a == "inertia":
            inertias.add(i // 9)
    for b in np.flatnonzero(ok) if inertias else ():
        try:
            for body in inertias:
                check_inertia(arrays["inertia"][b, body], "inertia")
        except ModelError:
            ok[b] = False
    return ok


def _direct_group(job, setup, model0, analysis, t_out, items, entries, rows) -> list:
    """Run the members items = [(row, member)] of one direct group (see :func:`_run_direct`);
    the rows of members whose values fail a check (:func:`_direct_valid`) are returned, for
    the building path."""
    from .core import FAILED, _describe
    B = len(items)
    arrays = {a: np.repeat(np.asarray(getattr(model0, a), dtype=float)[None], B, axis=0)
              for a in DIRECT_ARRAYS}
    for name, entry in entries.items():
        if entry is not None:
            a, i = entry
            arrays[a].reshape(B, -1)[:, i] = [member[name] for _, member in items]
    valid = _direct_valid(arrays, items, entries)
    declined = [k for (k, _), ok in zip(items, valid) if not ok]
    items = [it for it, ok in zip(items, valid) if ok]
    arrays = {a: x[valid] for a, x in arrays.items()}
    if not items:
        return declined
    models = [_patched(model0, {a: arrays[a][b] for a in DIRECT_ARRAYS})
              for b in range(len(items))]
    Fs = setup.pack_bodies(arrays["mass"], arrays["inertia"], arrays["gravity"])
    state_set = any(e is not None and e[0] in ("q0", "v0") for e in entries.values())
    good, keep, Y0, starts = [], [], [], []
    y_shared = start_shared = None
    for b, ((k, _), model) in enumerate(zip(items, models)):
        try:
            if state_set or y_shared is None:
                y0 = setup.initial_state(model, Fs[b], analysis)
                start = setup.joint_start(model, y0) if setup.recursive else None
                if not state_set:
                    y_shared, start_shared = y0, start
            else:
                y0, start = y_shared, start_shared
            Y0.append(y0)
            starts.append(start)
            good.append((k, model))
            keep.append(b)
        except Exception as exc:
            rows[k] = (FAILED, _describe(exc), job.empty(), None)
    if good:
        _integrate_reduce(job, setup, analysis, t_out, good, Fs[keep], np.stack(Y0),
                          starts if setup.recursive else None, rows)
    return declined


_STATE_COLUMNS = ("x", "y", "z", "e0", "e1", "e2", "e3", "vx", "vy", "vz", "wx", "wy", "wz")


def _needs_accelerations(outputs) -> bool:
    """Whether any output may read vdot or lambda (accelerations, reactions, callables)."""
    for o in outputs:
        if o.function is not None:
            return True
        parts = o.column.split(".")
        if o.column == "t" or parts[0] in ("energy", "violation"):
            continue
        if parts[-1] in _STATE_COLUMNS and not parts[-1].startswith("f"):
            if len(parts) == 2 or parts[-1] in ("x", "y", "z", "vx", "vy", "vz"):
                continue
        return True
    return False
