"""Sweeps: one model, many members (parameter values), run by a scheduler, one labelled result.

The members are cut into chunks; a chunk is one task (one pickled job, one call on a worker),
so every worker compiles the kernels once (on its first chunk) and the per-member overhead is
that of a Python call. A member that fails (a bad parameter value, a singular configuration,
a step-size underflow, any exception) is recorded with status "failed" and its message; its
outputs are NaN and the other members complete.

Results are collected by member index, so every scheduler gives the same values in the same
order (the members are deterministic functions of their parameters).
"""
from __future__ import annotations

import copy
import json
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ..errors import ModelError
from .checks import (check_columns, check_factory_names, check_packages, check_paths,
                     column_names)
from .limits import SweepNote, cap_workers, check_memory
from .outputs import Columns, parse_outputs
from .params import ParameterSpace, as_space, plain_copy, set_path, split
from .status import FAILED, SUCCESS, _describe

__all__ = ["sweep", "SweepJob", "run_chunk", "to_dataframe", "save_result", "local_cluster",
           "QUIET_WORKERS"]

# --------------------------------------------------------------------------------- the job
@dataclass
class SweepJob:
    """Everything a worker needs to run members (pickled once per chunk).

    data: the model-file dictionary (None with a factory); factory: callable(**values) ->
    Model or (Model, Analysis); analysis: the analysis section (dict); outputs: list of
    Output; names: the parameter names; engine: "simulate" (one run per member) or "batch"
    (members integrated together, :mod:`.batch`).
    """

    data: Optional[dict]
    factory: Optional[Callable]
    analysis: dict
    outputs: list
    names: list
    engine: str = "simulate"
    batch_options: dict = field(default_factory=dict)

    # ---------------------------------------------------------------- one member
    def build(self, member: dict):
        """(Model, Analysis) of one member."""
        from ..io.modelfile import Analysis, load_model
        model_values, analysis_values = split(member, self.factory is not None)
        if self.factory is None:
            data = plain_copy(self.data)
            for path, value in model_values.items():
                set_path(data, path, value)
            data["analysis"] = self._analysis(analysis_values, self.analysis)
            return load_model(data)
        built = self.factory(**model_values)
        model, own = (built[0], built[1] if len(built) > 1 else None) \
            if isinstance(built, tuple) else (built, None)
        base = self.analysis or (own.to_dict() if own is not None else {})
        return model, Analysis.from_dict(self._analysis(analysis_values, base),
                                         list(model.body_names))

    @staticmethod
    def _analysis(values: dict, base: dict) -> dict:
        adict = plain_copy(base)
        for path, value in values.items():
            set_path(adict, path, value)
        return adict

    def empty(self):
        return [np.nan if not o.series else np.zeros(0) for o in self.outputs]

    def reduce(self, results):
        """(status, message, outputs) of one member's results."""
        if getattr(results, "status", SUCCESS) != SUCCESS:
            return FAILED, str(results.message), self.empty(), None
        cols = Columns(results)
        vals = [o.evaluate(cols) for o in self.outputs]
        t = np.asarray(results.t) if any(o.series for o in self.outputs) else None
        return SUCCESS, "", vals, t

    def run_member(self, member: dict):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                model, analysis = self.build(member)
                status, message, vals, t = self.reduce(analysis.run(model))
            except Exception as exc:                 # a failing member never stops a sweep
                return FAILED, _describe(exc), self.empty(), None
        notes = "; ".join(str(w.message) for w in caught)
        if notes and status == SUCCESS:
            message = notes
        return status, message, vals, t


def run_chunk(job: SweepJob, values: np.ndarray) -> list:
    """Run the members with parameter values ``values`` (n, n_params); one
    (status, message, outputs, t) per member, in order. The unit of work of every scheduler."""
    members = [{n: float(values[k, j]) for j, n in enumerate(job.names)}
               for k in range(values.shape[0])]
    if job.engine == "batch":
        from .batch import run_members_batched
        return run_members_batched(job, members)
    return [job.run_member(m) for m in members]


# --------------------------------------------------------------------------------- schedulers
def _chunks(n: int, size: int) -> list:
    return [(a, min(n, a + size)) for a in range(0, n, size)]


def _progress_bar(total: int, enabled):
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    from tqdm import tqdm
    return tqdm(total=total, unit="member", desc="sweep", leave=False)


def _run_serial(job, space, bounds, bar):
    out = []
    for a, b in bounds:
        out.extend(run_chunk(job, space.values[a:b]))
        if bar is not None:
            bar.update(b - a)
    return out


def _run_processes(job, space, bounds, bar, workers):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    # fork: the workers inherit the imported package and its compiled kernels, and scripts
    # need no `if __name__ == "__main__"` guard; spawn where fork does not exist
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    parts = {}
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = {pool.submit(run_chunk, job, space.values[a:b]): (a, b) for a, b in bounds}
        for fut in as_completed(futures):
            a, b = futures[fut]
            parts[a] = fut.result()
            if bar is not None:
                bar.update(b - a)
    return [r for a, _ in bounds for r in parts[a]]


#: Dask settings of the workers :func:`local_cluster` starts. Sweep tasks are compiled code that
#: keeps one worker's CPU busy for the whole task; Dask's defaults are tuned for many small
#: tasks and interactive diagnostics, and on a machine with as many workers as cores their
#: background threads take the GIL and CPU from the task: the statistical profiler walks the
#: executing thread's stack every 10 ms, the GIL monitor samples every 1 ms, the memory monitor
#: every 100 ms, the event loop ticks every 20 ms. Measured (200 pendulum members, 2 workers on
#: 2 cores): the tasks ran 10-40 % slower than the same members in one process with the
#: defaults, 0-10 % with these settings.
QUIET_WORKERS = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.gil.enabled": False,
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.tick.interval": "200ms",
}


def local_cluster(workers: Optional[int] = None):
    """A Dask ``Client`` on a new ``LocalCluster`` of ``workers`` processes (default: one per
    core), one thread each, no dashboard, configured for compute-bound tasks
    (:data:`QUIET_WORKERS`). Use it to keep warm workers across several sweeps::

        with local_cluster(2) as client:
            a = sweep(model, params_a, outputs, scheduler=client)
            b = sweep(model, params_b, outputs, scheduler=client)

    Closing the client closes the cluster. ``scheduler="dask"`` starts one of these per sweep.
    """
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError:
        raise ModelError("the Dask scheduler needs the dask extra: pip install "
                         "'spatialmbd[dask]' (or use scheduler='processes' or 'serial')") from None
    workers = int(workers or os.cpu_count() or 1)
    # the nannies hand the configuration in effect to the worker processes they start
    with dask.config.set(QUIET_WORKERS):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    return _ClosingClient(client, cluster)


class _ClosingClient:
    """A Client whose close() (and ``with`` exit) also closes its LocalCluster."""

    def __init__(self, client, cluster):
        self._client, self._cluster = client, cluster

    def __getattr__(self, name):
        return getattr(self._client, name)

    def close(self):
        try:
            self._client.close()
        finally:
            self._cluster.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _dask_client(scheduler, workers):
    """(client, owned) for "dask", an address or a Client; owned: "client" (close the
    client), "cluster" (close client and cluster) or None (the caller's)."""
    try:
        from distributed import Client
    except ImportError:
        raise ModelError("the Dask scheduler needs the dask extra: pip install "
                         "'spatialmbd[dask]' (or use scheduler='processes' or 'serial')") from None
    if isinstance(scheduler, _ClosingClient):
        return scheduler._client, None
    if isinstance(scheduler, Client):
        return scheduler, None
    if isinstance(scheduler, str) and scheduler != "dask":
        return Client(scheduler), "client"
    return local_cluster(workers), "cluster"


#: a pickled job larger than this is scattered to the workers once instead of sent per task
INLINE_JOB_BYTES = 1 << 20


def _run_dask(job, space, bounds, bar, scheduler, workers):
    from distributed import as_completed
    client, owned = _dask_client(scheduler, workers)
    try:
        # a job is a model dictionary and a few options (about 1 kB for the pendulum): sent
        # with each task it costs less than a scatter's round trips to every worker (10-30 ms
        # measured on a LocalCluster); a large one (a factory with big data) is scattered once
        import pickle
        try:
            big = len(pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL)) > INLINE_JOB_BYTES
        except Exception:                          # not picklable here: cloudpickle will try
            big = True
        if big:
            job = client.scatter(job, broadcast=True, hash=False)   # a key of its own
        futures = [client.submit(run_chunk, job, space.values[a:b], pure=False)
                   for a, b in bounds]
        where = {f.key: (a, b) for f, (a, b) in zip(futures, bounds)}
        parts = {}
        for fut in as_completed(futures):
            a, b = where[fut.key]
            parts[a] = fut.result()
            if bar is not None:
                bar.update(b - a)
        return [r for a, _ in bounds for r in parts[a]]
    finally:
        if owned is not None:
            client.close()


def _scheduler_kind(scheduler, n_members):
    if scheduler is None or scheduler == "auto":
        if n_members < 16:
            return "serial"
        try:
            import distributed  # noqa: F401
            return "dask"
        except ImportError:
            return "processes"
    if isinstance(scheduler, str):
        s = scheduler.lower()
        if s in ("serial", "processes", "dask"):
            return s
        if "://" in scheduler or ":" in scheduler:
            return "dask"
        raise ModelError(f"unknown scheduler {scheduler!r}; use 'serial', 'processes', "
                         "'dask', a scheduler address (tcp://host:8786) or a dask Client")
    return "dask"                                  # a Client (or local_cluster())


# --------------------------------------------------------------------------------- sweep
def sweep(model, params, outputs, analysis=None, scheduler="serial", *, format="xarray",
          engine="simulate", chunk_size: Optional[int] = None, workers: Optional[int] = None,
          progress=None, batch_options: Optional[dict] = None,
          max_members: Optional[int] = None):
    """Run ``model`` once per member of ``params`` and collect ``outputs``.

    model: a Model or ModelBuilder, a model file path (.yaml/.json), a model dict, or a factory
        callable(**values) -> Model (or (Model, Analysis)) whose keyword names are the
        parameter names.
    params: ``{path: values}`` (a grid; values a list or "start:stop:count"), a list of
        points, or a :class:`ParameterSpace` (:func:`grid`, :func:`points`,
        :func:`latin_hypercube`). Paths: see :mod:`.params` (e.g. "bodies.link.mass" in kg).
    outputs: "max(pendulum.z)", "period(pendulum.wx)", "pendulum.z" (time series), callables,
        or {name: spec} (see :mod:`.outputs`).
    analysis: an Analysis or an analysis dict (default: the file's, else a 1 s dynamic run).
    scheduler: "serial", "processes", "dask" (a LocalCluster of ``workers`` processes), a
        scheduler address ("tcp://host:8786"), a distributed.Client, or "auto" (serial for
        fewer than 16 members, else Dask when installed, else processes).
    format: "xarray" (a Dataset: one dimension per parameter for a grid, else "member") or
        "dataframe" (tidy: one row per member, or per member and time with series outputs).
    engine: "simulate" (one :func:`simulate` per member) or "batch" (the members of a chunk
        integrated together in one compiled call, :mod:`.batch`; rk45, dop853 or rk4).
    chunk_size: members per task (default: about two tasks per worker, at most 64 members
        with the simulate engine, 1024 with the batch engine).
    batch_options: options of the batch engine: ``threads`` (True: a chunk's members spread
        over one thread per core; default True with the serial scheduler on a machine of several
        cores, False under Dask or processes, whose workers are one process per core),
        ``max_steps`` (per member, default 10 000 000).
    progress: a progress bar (default: when stderr is a terminal).
    max_members: the most members allowed (default :data:`.limits.MAX_MEMBERS`); larger
        spaces, and sweeps whose results are estimated above half of the memory, are refused
        before anything is allocated. Local worker processes are at most min(cores, members).

    Members that fail are recorded (status "failed", message); they never raise.
    """
    space = as_space(params, max_members)
    outs = parse_outputs(outputs)
    if engine not in ("simulate", "batch"):
        raise ModelError(f"engine {engine!r}: use 'simulate' or 'batch'")
    n = space.n_members
    kind = _scheduler_kind(scheduler, n)
    batch_options = dict(batch_options or {})
    if engine == "batch" and "threads" not in batch_options:
        # serial: a chunk's members spread over the cores (threads); under Dask or
        # processes every worker is already one process per core
        batch_options["threads"] = kind == "serial" and (os.cpu_count() or 1) > 1
    check_packages(kind)                 # the result is assembled in xarray, whatever format
    job = _make_job(model, space, outs, analysis, engine, batch_options)
    _check_job(job, space)
    check_memory(n, len(space.names), _values_per_member(outs, job.analysis))
    if workers is None:
        workers = (os.cpu_count() or 1) if kind != "serial" else 1
    if kind == "processes" or (kind == "dask" and scheduler in ("dask", "auto", None)):
        workers, note = cap_workers(workers, n)          # local processes: cores, members
        if note:
            warnings.warn(note, SweepNote, stacklevel=2)
    if chunk_size is None:
        # two tasks per worker: each task costs the scheduler some ms, members of one model
        # cost about the same (measured: 200 pendulum members on 2 workers, 1.70x serial with
        # 4 tasks against 1.52x with 8)
        chunk_size = max(1, min(64 if engine == "simulate" else 1024,
                                math.ceil(n / (2 * max(1, workers)))))
    bounds = _chunks(n, int(chunk_size))
    bar = _progress_bar(n, progress)
    start = time.perf_counter()
    try:
        if kind == "serial":
            rows = _run_serial(job, space, bounds, bar)
        elif kind == "processes":
            rows = _run_processes(job, space, bounds, bar, workers)
        else:
            rows = _run_dask(job, space, bounds, bar, scheduler if scheduler not in
                             (None, "auto") else "dask", workers)
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - start
    ds = _assemble(space, outs, rows, job, dict(scheduler=str(kind), engine=engine,
                                                 wall_time=wall, chunk_size=int(chunk_size)))
    if format == "xarray":
        return ds
    if format == "dataframe":
        return to_dataframe(ds)
    raise ModelError(f"format {format!r}: use 'xarray' or 'dataframe'")


def _values_per_member(outs, analysis: dict) -> float:
    """Output numbers per member: 1 per scalar output, the number of output times per
    time-series output (from the analysis' t_end and output_step)."""
    series = sum(1 for o in outs if o.series)
    if not series:
        return float(len(outs))
    t_end = float(analysis.get("t_end") or 1.0)
    step = analysis.get("output_step")
    times = t_end / float(step) + 1.0 if step else 1001.0
    return float(len(outs) - series) + series * times


def _make_job(model, space: ParameterSpace, outs, analysis, engine, batch_options) -> SweepJob:
    from ..io.modelfile import Analysis, load_model, model_to_dict
    from ..model import Model, ModelBuilder
    if isinstance(analysis, Analysis):
        adict = analysis.to_dict()
    elif isinstance(analysis, dict):
        adict = Analysis.from_dict(analysis).to_dict()
    elif analysis is None:
        adict = None
    else:
        raise ModelError(f"analysis: expected an Analysis or a dict, got "
                         f"{type(analysis).__name__}")
    if isinstance(model, ModelBuilder):
        model.compile()                          # every problem of the builder reported now
        data = model_to_dict(model)
        factory = None
    elif isinstance(model, Model):
        data = model_to_dict(model)
        factory = None
    elif isinstance(model, (str, os.PathLike)):
        load_model(model)                        # every problem of the file reported now
        data = _read_plain(model)
        factory = None
    elif isinstance(model, dict):
        load_model(model)
        data = copy.deepcopy(model)
        factory = None
    elif callable(model):
        data, factory = None, model
    else:
        raise ModelError(f"model: expected a Model, a ModelBuilder, a model file, a model dict "
                         f"or a factory callable, got {type(model).__name__}")
    if data is not None:
        if adict is None:
            adict = data.get("analysis") or Analysis().to_dict()
        data.pop("analysis", None)
    job = SweepJob(data=data, factory=factory, analysis=adict or {}, outputs=outs,
                   names=list(space.names), engine=engine, batch_options=batch_options)
    return job


def _check_job(job: SweepJob, space: ParameterSpace) -> None:
    """Paths and output columns checked once, before any member runs (:mod:`.checks`)."""
    if job.data is not None:
        check_paths(job.data, job.analysis, space.names, space.values)
    else:
        check_factory_names(job.factory, space.names)
    if all(o.function is not None for o in job.outputs):
        return
    if job.data is not None:
        from ..io.modelfile import load_model
        model, own = load_model(dict(plain_copy(job.data), analysis=plain_copy(job.analysis)))
        adict = job.analysis
    else:
        try:                              # a member's own value may be wrong: its business
            built = job.factory(**split(space.member(0), True)[0])
        except Exception:
            return
        model, own = (built[0], built[1] if len(built) > 1 else None) \
            if isinstance(built, tuple) else (built, None)
        adict = job.analysis or (own.to_dict() if own is not None else {})
    if str(adict.get("type", "dynamic")) != "dynamic":
        return                            # other analyses' tables: checked at each member
    if job.data is None:
        from ..io.analysis import Analysis
        own = Analysis.from_dict(plain_copy(adict), list(model.body_names))
    requests = list(getattr(own, "outputs", None) or [])
    check_columns(job.outputs, column_names(model, requests))


def _read_plain(path) -> dict:
    import yaml
    p = Path(path)
    text = p.read_text(encoding="utf-8")
    if p.suffix.lower() == ".json":
        return json.loads(text)
    return yaml.safe_load(text)


# --------------------------------------------------------------------------------- result
def _assemble(space, outs, rows, job, meta):
    try:
        import xarray as xr
    except ImportError:
        raise ModelError("sweep results are xarray Datasets: pip install 'spatialmbd[dask]' "
                         "(or pip install xarray)") from None
    n = space.n_members
    status = np.array([r[0] for r in rows], dtype=object)
    message = np.array([r[1] for r in rows], dtype=object)
    grid = space.kind == "grid"
    if grid:
        dims = list(space.names)
        shape = tuple(a.size for a in space.axes)
        coords = {name: axis for name, axis in zip(space.names, space.axes)}
    else:
        dims = ["member"]
        shape = (n,)
        coords = {"member": np.arange(n)}
        for j, name in enumerate(space.names):
            coords[name] = ("member", space.values[:, j])
    data = {}
    times = [r[3] for r in rows if r[3] is not None and r[0] == SUCCESS]
    t_common = max(times, key=len) if times else np.zeros(0)
    for k, o in enumerate(outs):
        if o.series:
            arr = np.full((n, t_common.size), np.nan)
            for i, r in enumerate(rows):
                x = np.asarray(r[2][k], dtype=float)
                arr[i, :min(x.size, t_common.size)] = x[:t_common.size]
            data[o.name] = (dims + ["time"], arr.reshape(shape + (t_common.size,)))
        else:
            arr = np.array([float(r[2][k]) for r in rows], dtype=float)
            data[o.name] = (dims, arr.reshape(shape))
    data["status"] = (dims, status.astype(str).reshape(shape))
    data["message"] = (dims, message.astype(str).reshape(shape))
    if any(o.series for o in outs):
        coords["time"] = t_common
    attrs = dict(meta)
    attrs["n_members"] = n
    attrs["n_failed"] = int(np.sum(status != SUCCESS))
    attrs["parameters"] = json.dumps(list(space.names))
    attrs["outputs"] = json.dumps([o.name for o in outs])
    attrs["space"] = space.kind
    attrs["analysis"] = json.dumps(job.analysis)
    if job.data is not None:
        attrs["model"] = str(job.data.get("name", "model"))
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    if "time" in ds.coords:
        ds["time"].attrs["units"] = "s"
    return ds


def to_dataframe(ds):
    """A tidy pandas DataFrame of a sweep Dataset: one row per member (scalar outputs), or one
    row per member and output time when there are time-series outputs."""
    names = json.loads(ds.attrs["parameters"])
    scalar = [v for v in ds.data_vars if "time" not in ds[v].dims]
    series = [v for v in ds.data_vars if "time" in ds[v].dims]
    flat = ds[scalar].to_dataframe().reset_index()
    cols = [c for c in names] + [c for c in flat.columns if c not in names and c != "member"]
    if "member" in flat.columns:
        cols = ["member"] + cols
    flat = flat[cols]
    if not series:
        return flat
    long = ds[series].to_dataframe().reset_index()
    keys = [c for c in long.columns if c in names or c == "member"]
    return flat.merge(long, on=keys, how="left")


def save_result(ds, path) -> Path:
    """Write a sweep result: .nc (netCDF via xarray), .csv or .parquet (tidy table)."""
    path = Path(path)
    suffix = path.suffix.lower()
    from ..atomic import atomic_write
    if suffix not in (".nc", ".csv", ".parquet"):
        raise ModelError(f"sweep output {path.name!r}: use .nc, .csv or .parquet")
    with atomic_write(path) as tmp:          # a failed write names the target, keeps the old
        if suffix == ".nc":
            ds.to_netcdf(tmp, engine=_netcdf_engine())
        elif suffix == ".csv":
            to_dataframe(ds).to_csv(tmp, index=False)
        else:
            try:
                to_dataframe(ds).to_parquet(tmp, index=False)
            except ImportError as exc:
                raise ModelError(f"writing {path.name}: parquet needs pyarrow (pip install "
                                 f"pyarrow), or write .nc or .csv ({exc})") from None
    return path


def _netcdf_engine():
    try:
        import h5netcdf  # noqa: F401
        return "h5netcdf"
    except ImportError:
        return "scipy"
