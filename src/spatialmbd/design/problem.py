"""A model as a function of its parameters: the simulated columns at the measured times and
their Jacobian, for :func:`.identify` and :func:`.optimize`.

Parameters are the sweep's paths (``bodies.link.mass``, ``forces.damper.damping``, ...,
:mod:`spatialmbd.sweep.params`); an experiment is the model with some values of its own (an
initial state, a load) and measured columns at its time stamps. The model runs with the
analysis' output times set to the data's time stamps (``t_eval``), so no interpolation is
needed.

The Jacobian d(column at t_i)/d(parameter) comes from

* ``"forward"``: the forward sensitivity equations (:func:`spatialmbd.sweep.
  forward_sensitivities`; method "standard" or "baumgarte", body state columns); the residual
  is then taken from the same RK4 integration, so residual and Jacobian belong together;
* ``"fd"``: central differences (x_j +- h_j, h_j = fd_step max(|x_j|, 1e-8)), all 2 p members
  of one Jacobian run together (one :func:`spatialmbd.sweep.core.run_chunk`, either engine);
* ``"adjoint"``: the adjoint of the same RK4 run (:mod:`.adjoint`; the same cases as
  "forward"): every residual is one cotangent of one backward pass, so the Jacobian costs one
  forward and one backward run whatever the number of parameters, and its dot products grow
  with the number of residuals m;
* ``"auto"``: "adjoint" where it applies and the residuals are fewer than the parameters
  (m < p: reverse mode pays when the Jacobian has fewer rows than columns), else "forward"
  where it applies, else "fd".

A member that fails (a trial mass below zero, a singular configuration, a step-size
underflow) is recorded in :attr:`Problem.failures` with its parameters and message, and its
residual is NaN: SciPy's trust-region methods then shrink the step and try again.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
import numpy as np

from ..errors import ModelError
from ..outputs.vocabulary import BODY_POSITION, BODY_VELOCITY
from ..sweep.core import SUCCESS, _make_job, run_chunk
from ..sweep.outputs import parse_outputs
from ..sweep.params import _ZERO_VECTORS, apply, get_path, points

__all__ = ["Experiment", "Problem", "read_data", "start_values"]

TIME_COLUMNS = ("t", "time")


@dataclass
class Experiment:
    """One measured run: ``overrides`` {path: value} of its own (e.g. an initial velocity),
    ``t`` (n,) s, ``values`` (n, n_columns) measured, ``sigma`` (n_columns,) noise levels
    (NaN: unknown), ``model`` its own model (None: the common one)."""

    name: str
    t: np.ndarray
    columns: list
    values: np.ndarray
    overrides: dict
    sigma: np.ndarray
    model: object = None


def read_data(data, columns=None, name: str = "data"):
    """(t, columns, values) from a pandas DataFrame, a dict of arrays or a CSV file with a
    time column ``t`` (or ``time``) in seconds. ``columns``: the columns to fit (default: all
    but time). NaN, infinite values, times not increasing or negative are errors naming the
    column and the row."""
    import pandas as pd
    if isinstance(data, (str, Path)):
        path = Path(data)
        if not path.is_file():
            raise ModelError(f"{name}: file {str(path)!r} does not exist")
        frame = pd.read_csv(path)
    elif isinstance(data, pd.DataFrame):
        frame = data
    elif isinstance(data, dict):
        try:
            frame = pd.DataFrame({k: np.asarray(v, dtype=float) for k, v in data.items()})
        except ValueError as exc:
            raise ModelError(f"{name}: the columns must be equal-length numeric arrays "
                             f"({exc})") from None
    else:
        raise ModelError(f"{name}: expected a DataFrame, a dict of arrays or a CSV file, got "
                         f"{type(data).__name__}")
    tcol = next((c for c in TIME_COLUMNS if c in frame.columns), None)
    if tcol is None:
        raise ModelError(f"{name}: no time column; name it 't' (s). Columns: "
                         f"{', '.join(map(str, frame.columns))}")
    cols = [str(c) for c in frame.columns if c != tcol] if columns is None else list(columns)
    if isinstance(columns, str):
        cols = [columns]
    if not cols:
        raise ModelError(f"{name}: no measured column besides {tcol!r}")
    missing = [c for c in cols if c not in frame.columns]
    if missing:
        raise ModelError(f"{name}: no column {missing[0]!r}; columns: "
                         f"{', '.join(map(str, frame.columns))}")
    t = frame[tcol].to_numpy(dtype=float)
    values = frame[cols].to_numpy(dtype=float).reshape(t.size, len(cols))
    for j, c in enumerate([tcol] + cols):
        v = t if j == 0 else values[:, j - 1]
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ModelError(f"{name}: column {c!r} holds {v[bad[0]]} at row {bad[0]} "
                             f"({bad.size} non-finite value(s)); drop or fill those rows")
    if t.size < 1:
        raise ModelError(f"{name}: no rows")
    if t[0] < 0.0:
        raise ModelError(f"{name}: time stamp {t[0]:g} s lies before the start of the run "
                         "(t = 0); shift the time column")
    steps = np.flatnonzero(np.diff(t) <= 0.0)
    if steps.size:
        k = int(steps[0])
        raise ModelError(f"{name}: time stamps must increase strictly; row {k + 1} has "
                         f"t = {t[k + 1]:g} s after {t[k]:g} s")
    return t, cols, values


def _model_data(model):
    """The model-file dictionary of a model source (None for a factory)."""
    job = _make_job(model, points({"analysis.t_end": [1.0]}), parse_outputs(["t"]), None,
                    "simulate", {})
    return job


def start_values(job, names, given=None) -> np.ndarray:
    """The start value of each parameter: ``given[name]`` or, when absent, the model's own.
    A path the model does not have is an error naming it (the sweep's setter would create
    it)."""
    given = dict(given or {})
    out = []
    for name in names:
        value = given.get(name)
        if job.data is not None:
            target = job.analysis if name.startswith("analysis.") else job.data
            path = name[len("analysis."):] if name.startswith("analysis.") else name
            try:
                held = get_path(target, path)
            except ModelError:
                tokens = path.split(".")
                if not any(tok in _ZERO_VECTORS for tok in tokens[-2:]):
                    raise ModelError(f"parameter {name!r} does not exist in the model: "
                                     f"check the path (docs/sweeps.md#parameters), e.g. "
                                     "bodies.<body>.mass, forces.<force>.damping") from None
                held = 0.0
            if isinstance(held, list) or isinstance(held, bool) or \
                    not isinstance(held, (int, float)):
                hint = (f"give one component with an index, e.g. {name}.0"
                        if isinstance(held, list) else "give a numeric value's path")
                raise ModelError(f"parameter {name!r}: the model holds {held!r}, not a number "
                                 f"that can be varied; {hint}")
            if value is None:
                value = held
        elif value is None:
            raise ModelError(f"parameter {name!r}: give its start value (a factory has no "
                             "model file to read it from)")
        value = float(value)
        if not math.isfinite(value):
            raise ModelError(f"parameter {name!r}: start value {value} is not finite")
        out.append(value)
    return np.array(out, dtype=float)


def _body_state_column(column) -> bool:
    parts = column.split(".")
    return len(parts) == 2 and parts[1] in BODY_POSITION + BODY_VELOCITY


class Problem:
    """Simulated columns at the experiments' time stamps and their Jacobian.

    model: a model file, Model, ModelBuilder, model dict or factory; names: parameter paths;
    experiments: list of :class:`Experiment`; analysis: dict (default the model's); scale:
    per experiment (n_columns,) factors the residuals are multiplied by.
    """

    def __init__(self, model, names, experiments, analysis=None, *, jacobian="auto",
                 engine="simulate", fd_step: float = 1e-4):
        if jacobian not in ("auto", "adjoint", "forward", "fd"):
            raise ModelError(f"jacobian must be 'auto', 'adjoint', 'forward' or 'fd', got "
                             f"{jacobian!r}")
        if not fd_step > 0:
            raise ModelError(f"fd_step must be positive, got {fd_step}")
        self.names = list(names)
        self.experiments = list(experiments)
        self.engine, self.fd_step = engine, float(fd_step)
        self.failures: list = []
        self.n_runs = 0
        self.jobs, self.kinds = [], []
        base = _model_data(model)
        self.base_job = base
        for e in self.experiments:
            src = model if e.model is None else e.model
            an = dict(analysis) if analysis is not None else dict(base.analysis)
            if an.get("type", "dynamic") != "dynamic":
                raise ModelError("identification fits a dynamic analysis; set analysis type "
                                 "'dynamic'")
            t_end = float(an.get("t_end") or max(an.get("t_eval") or [0.0]))
            if e.t[-1] > t_end + 1e-12 * max(1.0, t_end):
                raise ModelError(f"{e.name}: time stamps reach {e.t[-1]:g} s, beyond the run "
                                 f"(t_end = {t_end:g} s); set analysis.t_end >= {e.t[-1]:g} "
                                 "or drop the later rows")
            an["t_eval"] = [float(v) for v in e.t]
            an.pop("output_step", None)
            over = list(e.overrides)
            space = points({n: [0.0] for n in self.names + over})
            job = _make_job(src, space, parse_outputs(list(e.columns)), an, engine, {})
            self.jobs.append(job)
            method = (job.analysis.get("method") or {}).get("name", "auto") \
                if isinstance(job.analysis.get("method"), dict) else job.analysis.get("method")
            forward_ok = (job.data is not None and method in ("standard", "baumgarte")
                          and all(_body_state_column(c) for c in e.columns))
            if jacobian in ("forward", "adjoint") and not forward_ok:
                raise ModelError(f"{e.name}: forward sensitivities need a model file with the "
                                 "'standard' or 'baumgarte' method and body state columns "
                                 f"(<body>.x..wz), got method {method!r} and columns "
                                 f"{list(e.columns)}; use jacobian='fd'")
            adjoint_ok = forward_ok and not any(n.startswith("analysis.") for n in self.names)
            if jacobian == "adjoint" or (jacobian == "auto" and adjoint_ok and
                                         e.t.size * len(e.columns) < len(self.names)):
                self.kinds.append("adjoint")
            else:
                self.kinds.append("forward" if jacobian != "fd" and forward_ok else "fd")
        self._adjoints = {}
        self._forward_steps = {}       # experiment -> the f_p steps of its first forward run
        self._cache_x = None
        self._cache = None

    # ----------------------------------------------------------------------------- runs
    def _members(self, e, X):
        over = np.array([float(e.overrides[k]) for k in e.overrides])
        return np.column_stack([X, np.broadcast_to(over, (X.shape[0], over.size))]) \
            if over.size else X

    def _run(self, k, X):
        """Columns (n_members, nt, ncol) of experiment k at parameter rows X (NaN where a
        member failed; failures recorded)."""
        e, job = self.experiments[k], self.jobs[k]
        rows = run_chunk(job, self._members(e, np.atleast_2d(X)))
        self.n_runs += len(rows)
        out = np.full((len(rows), e.t.size, len(e.columns)), np.nan)
        for i, (status, message, vals, t) in enumerate(rows):
            if status != SUCCESS or any(np.asarray(v).size != e.t.size for v in vals):
                self.failures.append(dict(experiment=e.name, parameters=dict(
                    zip(self.names, map(float, np.atleast_2d(X)[i]))),
                    message=message or "the run ended before the last time stamp"))
                continue
            out[i] = np.column_stack(vals)
        return out

    def _forward(self, k, x):
        """(columns (nt, ncol), Jacobian (nt, ncol, p)) of experiment k by forward
        sensitivities (NaN and a recorded failure when the run fails)."""
        from ..sweep.sensitivity import _state_index, forward_sensitivities
        from ..io.modelfile import load_model
        e, job = self.experiments[k], self.jobs[k]
        data = apply(job.data, dict(e.overrides))
        data["analysis"] = dict(job.analysis)
        params = dict(zip(self.names, map(float, x)))
        self.n_runs += 1 + 2 * len(self.names)
        try:
            fw = forward_sensitivities(data, params, [f"final({c})" for c in e.columns],
                                       scheme="rk4",
                                       parameter_steps=self._forward_steps.get(k))
            self._forward_steps.setdefault(k, fw.attrs["parameter_steps"])
            model, _ = load_model(apply(data, {n: v for n, v in params.items()
                                               if not n.startswith("analysis.")}))
        except Exception as exc:                        # a trial value the model refuses
            self.failures.append(dict(experiment=e.name, parameters=params,
                                      message=f"{type(exc).__name__}: {exc}"))
            nt, nc = e.t.size, len(e.columns)
            return np.full((nt, nc), np.nan), np.full((nt, nc, len(self.names)), np.nan)
        idx = [_state_index(model, c) for c in e.columns]
        return fw["y"].values[:, idx], fw["S"].values[:, idx, :]

    def _adjoint(self, k, x):
        """(columns (nt, ncol), Jacobian (nt, ncol, p)) of experiment k by one forward and one
        backward run, every sample of every column a cotangent (NaN and a recorded failure
        when the run fails)."""
        from .adjoint import Adjoint
        e, job = self.experiments[k], self.jobs[k]
        nt, nc, p = e.t.size, len(e.columns), len(self.names)
        self.n_runs += 2
        try:
            if k not in self._adjoints:
                self._adjoints[k] = Adjoint(dict(job.data, analysis=job.analysis), self.names,
                                            overrides=e.overrides)
            adj = self._adjoints[k]
            Y = adj.run(x)
            idx = [adj.column(c) for c in e.columns]
            times = np.repeat(np.arange(nt), nc)
            rows = np.tile(np.array(idx), nt)
            J = adj.gradient_sparse(nt * nc, times, rows, np.arange(nt * nc), np.ones(nt * nc))
        except ModelError as exc:
            self.failures.append(dict(experiment=e.name, parameters=dict(
                zip(self.names, map(float, x))), message=f"{type(exc).__name__}: {exc}"))
            return np.full((nt, nc), np.nan), np.full((nt, nc, p), np.nan)
        return Y[:, idx], J.reshape(nt, nc, p)

    def steps(self, x) -> np.ndarray:
        return self.fd_step * np.maximum(np.abs(x), 1e-8)

    def evaluate(self, x, jacobian: bool = False):
        """Per experiment: simulated columns (nt, ncol) and, when asked, d/dx (nt, ncol, p)."""
        x = np.asarray(x, dtype=float)
        if self._cache_x is not None and np.array_equal(x, self._cache_x) and \
                (not jacobian or self._cache[1] is not None):
            return self._cache
        sims, jacs = [], []
        for k in range(len(self.experiments)):
            if self.kinds[k] in ("forward", "adjoint"):
                y, s = (self._forward if self.kinds[k] == "forward" else self._adjoint)(k, x)
                sims.append(y)
                jacs.append(s)
                continue
            if not jacobian:
                sims.append(self._run(k, x[None, :])[0])
                continue
            h = self.steps(x)
            p = x.size
            X = np.repeat(x[None, :], 2 * p + 1, axis=0)
            for j in range(p):
                X[1 + 2 * j, j] += h[j]
                X[2 + 2 * j, j] -= h[j]
            Y = self._run(k, X)
            sims.append(Y[0])
            J = np.empty(Y.shape[1:] + (p,))
            for j in range(p):
                plus, minus = Y[1 + 2 * j], Y[2 + 2 * j]
                if np.all(np.isfinite(plus)) and np.all(np.isfinite(minus)):
                    J[..., j] = (plus - minus) / (2 * h[j])
                elif np.all(np.isfinite(plus)):                 # one side failed: one-sided
                    J[..., j] = (plus - Y[0]) / h[j]
                else:
                    J[..., j] = (Y[0] - minus) / h[j]
            jacs.append(J)
        complete = jacobian or all(kind != "fd" for kind in self.kinds)
        result = (sims, jacs if complete else None)
        self._cache_x, self._cache = x.copy(), result
        return result
