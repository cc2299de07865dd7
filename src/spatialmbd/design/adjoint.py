"""Adjoint sensitivities: the gradient of a scalar cost of the sampled states with respect to
many parameters from one forward run (with checkpoints) and one backward run.

What is differentiated: the discrete solution, not the continuous problem. The model is
integrated by the scheme of :func:`spatialmbd.sweep.forward_sensitivities` -- classic RK4 with
a fixed step ``h`` landing on every output time, on the index-1 ODE of the standard or
Baumgarte method (Eq. 12.3, y = [q, v, w]), each step followed by the renormalisation of the
Euler parameters -- and the adjoint of that map (:mod:`.adjoint_kernels`) gives the exact
gradient of the cost of the computed samples, whatever ``h`` is. Its accuracy is that of the
vector-Jacobian products, central differences of the compiled right-hand side (about 1e-9
relative; checked against Richardson-extrapolated differences of the same run in
tests/design/test_adjoint.py). How close that gradient is to the gradient of the exact
solution depends on h as the states do (O(h^4)); no error control acts on it: refine h and
compare, as for the states.

Parameters reach the right-hand side through the packed model floats F (masses, inertias and
their inverses, weights, joint and force-element geometry, force-law parameters: every value
:meth:`spatialmbd.sweep.batch.BatchSetup.pack_F` writes) and through the initial state y0
(initial positions and velocities, corrected as simulate() does). dF/dp and dy0/dp are
central differences at x +- delta (exact for the linear entries): over model builds, or, for
the parameters that set one entry of the masses, inertias, gravity or initial state, over
the built model's patched arrays (:mod:`.adjoint_params`, no builds); the backward pass
returns ybar0 = d cost / d y0 and Fbar = d cost / d F on the floats the parameters move
("active"), and

    d cost / d p = ybar0 . dy0/dp + Fbar . dF/dp.

Cost of one gradient: the builds (the first gradient: 2 p; later ones: 2 per group of the
parameters that are not direct, those whose floats and initial-state entries are disjoint
sharing a build pair), the forward run (4 evaluations per step), the recomputation of the
segments between checkpoints (one more forward run) and, per RK4 stage, the vector-Jacobian
products: by :mod:`.adjoint_vjp` (one solve per cost and 2 (12 n_colours + n_float_colours)
evaluations of local residuals) when its check at the start state passes, else
2 (n + n_active) evaluations of the right-hand side (n = 13 nb + 1).
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..errors import ModelError
from ..integrators.controller import landing_steps, landing_time
from ..sweep.batch import BatchSetup
from ..sweep.core import _make_job
from ..sweep.outputs import parse_outputs
from ..sweep.params import points
from ..sweep.sensitivity import _reduce_derivative, _state_index
from . import adjoint_kernels as ak
from . import adjoint_params as ap

__all__ = ["Adjoint", "adjoint_gradients", "output_gradients", "FD_EPS"]

#: relative step of the central differences of the right-hand side in the backward pass
FD_EPS = 1e-6
_E = np.zeros(1, dtype=np.int64)
#: the structure argument of the dense path (unused there; the compiled signature needs one)
_EMPTY_S = (_E,) * 12 + (np.zeros((4, 0), dtype=np.int64),)


def _scale(x: float) -> float:
    return abs(x) if x != 0.0 else 1.0


_BODY_FLOATS = ("mass", "Jl", "Jl_inv", "weight")
_JOINT_FLOATS = ("s_i", "s_j", "R_i", "R_j", "param")
_FORCE_FLOATS = ("fs_i", "fs_j", "fR_i", "fR_j", "fparam")


def _packed_ints(system, name):
    """The integer field ``name`` of a packed system (its header in I)."""
    import math as _m
    from ..dynamics import system as cs
    for k, (fname, buf, ndim) in enumerate(cs.FIELDS):
        if fname == name and buf == "I":
            off = int(system.I[4 * k])
            shape = tuple(int(v) for v in system.I[4 * k + 1:4 * k + 1 + ndim])
            return np.asarray(system.I[off:off + _m.prod(shape)]).reshape(shape)
    raise KeyError(name)


def _greedy(supports):
    """Colour classes of items whose (bodies, rows) supports must not intersect: (ptr, idx)."""
    classes = []                    # [(members, bodies used, rows used)]
    for j, (bodies, rows) in enumerate(supports):
        for members, used_b, used_r in classes:
            if not (used_b & bodies) and not (used_r & rows):
                members.append(j)
                used_b |= bodies
                used_r |= rows
                break
        else:
            classes.append(([j], set(bodies), set(rows)))
    ptr = np.cumsum([0] + [len(c[0]) for c in classes]).astype(np.int64)
    idx = np.array([j for c in classes for j in c[0]], dtype=np.int64)
    return ptr, idx


def _csr(sets):
    ptr = np.cumsum([0] + [len(x) for x in sets]).astype(np.int64)
    return ptr, np.array([v for x in sets for v in sorted(x)], dtype=np.int64)


def structure(setup, active):
    """The colouring of :func:`.adjoint_vjp.vjp_structured` for the packed floats ``active``,
    or None when a float's owner is unknown (the dense path is then used)."""
    system, nb = setup.system, setup.nb
    real = lambda b: 0 <= b < nb                                       # noqa: E731
    row_bi, row_bj = _packed_ints(system, "row_bi"), _packed_ints(system, "row_bj")
    links = [(int(a), int(b)) for a, b in zip(row_bi, row_bj)]
    try:
        fbi, fbj = _packed_ints(system, "fbi"), _packed_ints(system, "fbj")
        links += [(int(a), int(b)) for a, b in zip(fbi, fbj)]
    except KeyError:
        fbi = fbj = np.zeros(0, dtype=np.int64)
    near = [{b} for b in range(nb)]
    for a, b in links:
        if real(a) and real(b):
            near[a].add(b)
            near[b].add(a)
    touch = [set() for _ in range(nb)]
    for r, (a, b) in enumerate(zip(row_bi, row_bj)):
        for c in (int(a), int(b)):
            if real(c):
                touch[c].add(r)
    # bodies: distance >= 3 in one class (their neighbourhoods disjoint)
    cls_ptr, cls_body = _greedy([(near[b], set()) for b in range(nb)])
    ji, jj = _packed_ints(system, "bi"), _packed_ints(system, "bj")
    owners, body_floats = [], []            # body floats: (j, kind, body, component)
    for j, a in enumerate(np.asarray(active).tolist()):
        owner = None
        for name, off, shape in setup._slots:
            size = int(np.prod(shape))
            if off <= a < off + size:
                per = max(1, size // shape[0])
                inst = (a - off) // per
                if name in _BODY_FLOATS:
                    owner = ({inst}, set())
                    body_floats.append((j, _BODY_FLOATS.index(name), inst, (a - off) % per))
                elif name in _JOINT_FLOATS:
                    bodies = {int(b) for b in (ji[inst], jj[inst]) if real(int(b))}
                    owner = (bodies, set().union(*[touch[b] for b in bodies]) if bodies
                             else set())
                elif name in _FORCE_FLOATS and inst < fbi.size:
                    owner = ({int(b) for b in (fbi[inst], fbj[inst]) if real(int(b))}, set())
                break
        if owner is None:
            return None
        owners.append(owner)
    analytic = {bf[0] for bf in body_floats}
    rest = [j for j in range(len(owners)) if j not in analytic]
    fcl_ptr, fcl_idx = _greedy([owners[j] for j in rest])
    fcl_idx = np.array([rest[i] for i in fcl_idx], dtype=np.int64)
    nbr = _csr(near)
    crw = _csr(touch)
    fb = _csr([o[0] for o in owners])
    fc = _csr([o[1] for o in owners])
    bfl = np.array(body_floats, dtype=np.int64).reshape(-1, 4).T.copy()
    return (cls_ptr, cls_body, nbr[0], nbr[1], crw[0], crw[1], fcl_ptr, fcl_idx,
            fb[0], fb[1], fc[0], fc[1], bfl)


class Adjoint:
    """The forward and backward passes of one model as a function of ``names``.

    model: a model file, Model, ModelBuilder, model dict or factory; names: parameter paths
    (docs/sweeps.md#parameters; ``analysis.*`` paths are refused: they change the step
    grid); analysis: dict (default the model's; a dynamic analysis with method "standard" or
    "baumgarte"); overrides: {path: value} fixed for this run (an experiment's own values);
    step: the RK4 step h (s; default the analysis' step, else 1e-3); checkpoint: steps between
    stored states (default about sqrt(n_steps)); relative_delta: the parameter step of dF/dp
    and dy0/dp.
    """

    def __init__(self, model, names, analysis=None, *, overrides=None,
                 step: Optional[float] = None, checkpoint: Optional[int] = None,
                 relative_delta: float = 1e-6):
        from ..simulate import output_times
        self.names = list(names)
        if not self.names:
            raise ModelError("adjoint gradient: name at least one parameter")
        bad = [n for n in self.names if n.startswith("analysis.")]
        if bad:
            raise ModelError(f"parameter {bad[0]!r}: the adjoint differentiates the run on a "
                             "fixed step grid; analysis values cannot be varied here (use "
                             "jacobian='fd')")
        self.overrides = dict(overrides or {})
        self.relative_delta = float(relative_delta)
        space = points({n: [0.0] for n in self.names + list(self.overrides)})
        self.job = _make_job(model, space, parse_outputs(["t"]), analysis, "batch", {})
        if self.job.data is not None:
            from .problem import start_values
            start_values(self.job, self.names)      # a path the model lacks: named here
        an = self.job.analysis
        method = (an.get("method") or {}).get("name", "auto") \
            if isinstance(an.get("method"), dict) else an.get("method")
        if an.get("type", "dynamic") != "dynamic":
            raise ModelError("adjoint gradient: the analysis must be dynamic")
        if method not in ("standard", "baumgarte"):
            raise ModelError(f"adjoint gradient: the backward pass differentiates the "
                             f"'standard' or 'baumgarte' method, not {method!r}; set the "
                             "analysis method to 'standard'")
        self.setup = None
        self._analysis_step = step
        self.checkpoint = checkpoint
        self.t_out = None
        self.output_times = output_times
        self.n_builds = 0
        self.x = None
        self.active = None
        self.structured = False
        self._groups = None
        self._support = None
        self._direct = None

    # -------------------------------------------------------------------------- forward
    def _build(self, values):
        member = dict(self.overrides)
        member.update(values)
        self.n_builds += 1
        return self.job.build(member)

    def _pack(self, values, with_model=False):
        m, an = self._build(values)
        if self.setup is None:
            self.setup = BatchSetup(m, an.method, an.method_options)
            self.model, self.analysis = m, an
        F = self.setup.pack_F(m)
        y0 = self.setup.initial_state(m, F, an)
        return (F, y0, m, an) if with_model else (F, y0)

    def _grid(self):
        an = self.analysis
        h = float(self._analysis_step if self._analysis_step is not None else (an.step or 1e-3))
        if not h > 0:
            raise ModelError(f"adjoint gradient: step must be positive, got {h}")
        t_out = self.output_times(an.t_end, an.output_step, an.t_eval, 0.0)
        ts, hs, after = [], [], []
        t, out0 = 0.0, -1
        for ko, to in enumerate(t_out.tolist()):
            if to > t:
                msteps = landing_steps(t, to, h)
                t_start = t
                for i in range(1, msteps + 1):
                    t_new = landing_time(t_start, to, h, i)
                    ts.append(t)
                    hs.append(t_new - t)
                    after.append(-1)
                    t = t_new
                after[-1] = ko
            elif ko == 0:
                out0 = 0
            else:
                raise ModelError(f"adjoint gradient: output time {to:g} s repeats an earlier "
                                 "one; make the output times strictly increasing")
        self.h, self.t_out, self.out0 = h, t_out, out0
        self.step_t, self.step_h = np.array(ts), np.array(hs)
        self.out_after = np.array(after, dtype=np.int64)
        ns = max(1, self.step_t.size)
        self.every = int(self.checkpoint or max(1, round(math.sqrt(ns))))
        if self.every < 1:
            raise ModelError(f"adjoint gradient: checkpoint must be >= 1, got {self.checkpoint}")

    def run(self, x, derivatives: bool = True) -> np.ndarray:
        """Forward pass at parameter values x (p,): the states Y (n_out, n) at the output
        times :attr:`t_out` (a ModelError when the run fails: a value the model refuses, a
        singular matrix, a non-finite state). derivatives=False skips dF/dp and dy0/dp (no
        :meth:`gradient` afterwards)."""
        x = np.asarray(x, dtype=float)
        values = dict(zip(self.names, map(float, x)))
        F, y0, m, an = self._pack(values, with_model=True)
        if self.t_out is None:
            self._grid()
        p = x.size
        dF = np.zeros((F.size, p))
        dy0 = np.zeros((y0.size, p))
        first = self._groups is None
        groups = [[j] for j in range(p)] if first else self._groups
        probes = {}
        for group in (groups if derivatives else []):
            d = {j: self.relative_delta * _scale(x[j]) for j in group}
            plus, minus = dict(values), dict(values)
            for j in group:
                plus[self.names[j]] += d[j]
                minus[self.names[j]] -= d[j]
            try:
                Fa, ya, ma, _ = self._pack(plus, with_model=True)
                Fb, yb = self._pack(minus)
            except ModelError as exc:
                if "differs in topology" not in str(exc):
                    raise
                which = self.names[group[0]] if len(group) == 1 else \
                    f"one of {[self.names[j] for j in group]}"
                raise ModelError(f"parameter {which!r} cannot be varied by the adjoint: it "
                                 "changes a force law (a magnitude, command or reference "
                                 "held in the work arrays) or the topology; use "
                                 "jacobian='fd'") from None
            with np.errstate(invalid="ignore"):            # inf limits: no derivative
                dFg = np.where(Fa == Fb, 0.0, Fa - Fb)
            dyg = ya - yb
            for j in group:                # a group's members move disjoint entries
                fs, ys = self._support[j] if self._groups is not None else (None, None)
                if fs is None:
                    dF[:, j] = dFg / (2 * d[j])
                    dy0[:, j] = dyg / (2 * d[j])
                else:
                    dF[fs, j] = dFg[fs] / (2 * d[j])
                    dy0[ys, j] = dyg[ys] / (2 * d[j])
            if first:
                probes[group[0]] = (ma, Fa, plus[self.names[group[0]]])
        if derivatives and not first and self._direct:
            self._direct_derivatives(x, m, an, F, dF, dy0)
        if derivatives and first:
            self._direct = {}
            for j, (ma, Fa, value) in probes.items():
                entry = ap.direct_entry(self.setup, m, ma, Fa, value)
                if entry is not None:
                    self._direct[j] = entry
            self._direct = ap.keep_valid(self._direct, dy0, self.model.nb)
            self._group_parameters(dF, dy0)
        if derivatives:
            active = np.flatnonzero(np.any(dF != 0.0, axis=1)).astype(np.int64)
            if self.active is None or not np.array_equal(active, self.active):
                self.active = active
                self._choose_path(F, y0, dF[active])
        self.F, self.y0, self.dF, self.dy0 = F, y0, dF, dy0
        n = y0.size
        ns = self.step_t.size
        self.Y = np.zeros((self.t_out.size, n))
        if self.out0 >= 0:
            self.Y[0] = y0
        self.checkpoints = np.zeros(((ns + self.every - 1) // self.every, n))
        self.W = self.setup.system.W.copy()
        status, where = ak.forward_pass(self.step_t, self.step_h, self.out_after, y0, self.Y,
                                        self.checkpoints, self.every, F, self.setup.system.I,
                                        self.W, self.setup.mp, self.model.nb)
        if status != 0:
            raise ModelError(f"adjoint gradient: the run failed at t = {self.step_t[where]:.6g}"
                             f" s (right-hand side status {status}: singular or not finite) "
                             f"at {values}")
        self.x = x.copy() if derivatives else None
        return self.Y

    def _group_parameters(self, dF, dy0):
        """After the first gradient (one build pair per parameter): the direct parameters
        (:mod:`.adjoint_params`) need no builds from now on; the others whose packed floats
        and initial-state entries are disjoint share a build pair (a greedy colouring of
        their supports), so later gradients cost 2 n_groups builds."""
        supports = []
        for j in range(len(self.names)):
            fs = np.flatnonzero(dF[:, j] != 0.0)
            ys = np.flatnonzero(dy0[:, j] != 0.0)
            supports.append((fs, ys))
        built = [j for j in range(len(self.names)) if j not in self._direct]
        ptr, idx = _greedy([(set(supports[j][0].tolist()), set(supports[j][1].tolist()))
                            for j in built])
        self._support = supports
        self._groups = [[built[i] for i in idx[ptr[k]:ptr[k + 1]]]
                        for k in range(ptr.size - 1)]

    def _direct_derivatives(self, x, m, an, F, dF, dy0):
        """The columns of dF/dp and dy0/dp of the direct parameters, from the model m at x
        (no builds; :mod:`.adjoint_params`)."""
        for kinds, fill in ((ap.BODY_ARRAYS, "F"), (("q0", "v0"), "y")):
            cols = [j for j, (a, _) in self._direct.items() if a in kinds]
            if not cols:
                continue
            entries = [self._direct[j] for j in cols]
            deltas = [self.relative_delta * _scale(x[j]) for j in cols]
            if fill == "F":
                dF[:, cols] = ap.body_columns(self.setup, m, F, entries, x[cols], deltas)
            else:
                dy0[:, cols] = ap.state_columns(self.setup, m, an, F, entries, x[cols],
                                                deltas)

    def _choose_path(self, F, y0, dF):
        """The structured vector-Jacobian products (:mod:`.adjoint_vjp`) when the model's
        floats have known owners and they agree with the dense products at the start state
        (f_y^T kbar and f_F^T kbar dF/dp to 1e-6 of their largest entry, for a random
        cotangent); else the dense ones. (Per float they differ: the solve reads J'^-1, the
        residual J'; along dF/dp, which moves both consistently, they agree.)"""
        S = structure(self.setup, self.active)
        self.structured = False
        self.S = S if S is not None else _EMPTY_S
        if S is None:
            return
        n = y0.size
        kbar = np.random.default_rng(1).standard_normal((n, 2))
        kbar[-1] = 0.0                                      # no cost reads the work entry
        W = self.setup.system.W.copy()
        args = (0.0, y0, kbar, F.copy(), self.setup.system.I, W, self.setup.mp, self.active,
                FD_EPS, S)
        s1, yb1, fb1 = ak.vjp_at(*args, False)
        s2, yb2, fb2 = ak.vjp_at(*args, True)
        ok = s1 == 0 and s2 == 0
        for a, b in ((yb1[:-1], yb2[:-1]), (fb1.T @ dF, fb2.T @ dF)):
            ok = ok and np.all(np.isfinite(b)) and \
                np.abs(a - b).max() <= 1e-6 * max(np.abs(a).max(), 1e-300)
        self.structured = bool(ok)

    # ------------------------------------------------------------------------- backward
    def gradient(self, Wt) -> np.ndarray:
        """d cost / d x (K, p) of K costs whose derivatives with respect to the output states
        are Wt (n_out, n, K) (or (n_out, n) for one cost), after :meth:`run`."""
        Wt = np.asarray(Wt, dtype=float)
        one = Wt.ndim == 2
        Wt = Wt[..., None] if one else Wt
        o, r, k = np.nonzero(Wt)
        g = self.gradient_sparse(Wt.shape[2], o, r, k, Wt[o, r, k])
        return g[0] if one else g

    def gradient_sparse(self, K, times, rows, cols, vals) -> np.ndarray:
        """d cost / d x (K, p) of K costs with d cost_cols[e] / d Y[times[e], rows[e]] =
        vals[e] (entries not given are 0): the form of a least-squares misfit, one cost per
        residual, without an (n_out, n, K) array."""
        if self.x is None:
            raise ModelError("adjoint gradient: call run(x) before gradient()")
        times = np.asarray(times, dtype=np.int64)
        if np.any(np.asarray(rows) >= 13 * self.model.nb):
            raise ModelError("adjoint gradient: costs read the body states (q, v) only")
        order = np.argsort(times, kind="stable")
        ptr = np.searchsorted(times[order], np.arange(self.t_out.size + 1)).astype(np.int64)
        status, ybar0, Fbar = ak.backward_pass(
            self.step_t, self.step_h, self.out_after, self.out0, self.checkpoints, self.every,
            int(K), ptr, np.asarray(rows, dtype=np.int64)[order],
            np.asarray(cols, dtype=np.int64)[order], np.asarray(vals, dtype=float)[order],
            self.F.copy(), self.setup.system.I, self.W, self.setup.mp, self.model.nb,
            self.active, FD_EPS, self.S, self.structured)
        if status != 0:
            raise ModelError("adjoint gradient: the right-hand side failed at a perturbed "
                             "state of the backward pass (a singular configuration?)")
        return ybar0.T @ self.dy0 + Fbar.T @ self.dF[self.active]

    def column(self, name) -> int:
        """The state index of a body state column (<body>.x..e3, <body>.vx..wz)."""
        return _state_index(self.model, name)


def adjoint_gradients(model, params, outputs, analysis=None, *, step: Optional[float] = None,
                      checkpoint: Optional[int] = None):
    """d(output)/d(parameter) of scalar outputs by one forward and one backward run.

    params: {path: value}; outputs: reductions of body state columns (``final(slider.x)``,
    ``rms(pendulum.wx)``, ``peak(...)``, ``mean``, ``max``, ``min``, ``period``, as
    :func:`spatialmbd.sweep.forward_sensitivities`); analysis, step, checkpoint: as
    :class:`Adjoint`. Returns a Dataset (output, parameter) with ``derivative`` and
    ``nominal`` (the outputs of the RK4 run).
    """
    import xarray as xr
    if not isinstance(params, dict) or not params:
        raise ModelError("adjoint_gradients: params must be a {path: value} dict")
    outs = parse_outputs(outputs)
    adj = Adjoint(model, list(params), analysis, step=step, checkpoint=checkpoint)
    x = np.array([float(v) for v in params.values()])
    nominal, G = output_gradients(adj, outs, x)
    return xr.Dataset(
        dict(derivative=(("output", "parameter"), G), nominal=(("output",), nominal)),
        coords=dict(output=[o.name for o in outs], parameter=adj.names,
                    value=(("parameter",), x)),
        attrs=dict(method="discrete adjoint of RK4", step=adj.h, checkpoint=adj.every,
                   n_active=int(adj.active.size)))


def output_gradients(adj: Adjoint, outs, x, gradient: bool = True):
    """(values (K,), d values / dx (K, p) or None) of parsed outputs (reductions of body state
    columns) at x, from the forward run of ``adj`` and, when ``gradient``, its backward run
    (all K outputs in one backward pass). The derivative of a reduction with respect to the
    samples is :func:`spatialmbd.sweep.sensitivity._reduce_derivative` applied to the unit
    sensitivities (it is linear in them)."""
    for o in outs:
        if o.series or o.function is not None or o.reduction is None:
            raise ModelError(f"output {o.name!r}: the adjoint takes reductions of body state "
                             "columns, e.g. final(pendulum.z)")
    Y = adj.run(x, derivatives=gradient)
    nt, n = Y.shape
    eye = np.eye(nt)
    values = np.zeros(len(outs))
    times, rows, cols, vals = [], [], [], []
    for k, o in enumerate(outs):
        c = adj.column(o.column)
        values[k], w = _reduce_derivative(o.reduction, adj.t_out, Y[:, c], eye)
        nz = np.flatnonzero(w)
        times.append(nz)
        rows.append(np.full(nz.size, c))
        cols.append(np.full(nz.size, k))
        vals.append(w[nz])
    if not gradient:
        return values, None
    return values, adj.gradient_sparse(len(outs), np.concatenate(times), np.concatenate(rows),
                                       np.concatenate(cols), np.concatenate(vals))
