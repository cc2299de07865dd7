"""Results files: a CSV table and a self-describing HDF5 file, both written atomically.

Tables
------
:func:`to_dataframe` turns dynamic :class:`~spatialmbd.results.Results`, kinematic
:class:`~spatialmbd.kinematics.KinematicResults` or a :class:`LoadedResults` into a pandas
DataFrame with one row per output time and self-explaining columns (SI units):

    t                                    s
    <body>.x, .y, .z                     m, centre of mass, global axes
    <body>.e0 .. .e3                     Euler parameters (body -> global)
    <body>.vx, .vy, .vz / .wx, .wy, .wz  m/s / rad/s (omega in global axes)
    <body>.ax, .ay, .az / .alphax ..     m/s^2 / rad/s^2
    <body>.<point>.x .. .az              named points: position, velocity, acceleration
    <joint>.<body>.fx .. .mz             dynamic only: reaction of the joint (or driver) on that
                                         body, global axes, N and N m about the joint point
    violation.position, .velocity        |Phi| (2-norm) and |D v - nu|
    violation.phi_squared                Phi^T Phi (as plotted in the text's Fig. 15.2)
    energy.kinetic .. energy.error       dynamic only, J (see Results.energy)
    newton.iterations                    kinematic only: Newton iterations at each time
    <prefix>.<quantity>                  the requested outputs: joint coordinates, force
                                         elements, drivers, momentum, energy, IMU
                                         (:mod:`spatialmbd.outputs`, docs/outputs.md)

The table's ``attrs["units"]`` maps the requested outputs to their units (HDF5 keeps every
column's unit, see below). The naming scheme and this layout are documented once, for users,
in docs/outputs.md.

CSV (``.csv``)
--------------
Exactly that table: one header row of column names, then one row per output time, full float
precision, no index column. Read it back with ``pandas.read_csv(path)`` or :func:`read_results`.

HDF5 (``.h5`` / ``.hdf5``)
--------------------------
Written with h5py; every object is a plain dataset, so no PyTables is needed::

    /                        attrs: format = "spatialmbd-results", format_version = 1,
                             spatialmbd_version, kind ("dynamic" | "kinematic"), status, created
    /t (nt,)  /q (nt, nb, 7)  /v (nt, nb, 6)  /vdot (nt, nb, 6)
    /lam (nt, m)  /work (nt,)                          dynamic analyses
    /newton_iterations (nt,)  /residual (nt,)          kinematic analyses
    /table/<column>          one 1-D dataset per table column (names as above);
                             attrs["columns"]: JSON list giving the column order,
                             attrs["units"]: JSON {column: unit}
    /metadata/<key>          JSON text (scalar string datasets): model (the model-file dict of
                             spatialmbd.io.modelfile.model_to_dict, with the analysis section),
                             analysis, outputs (the requests), settings, counters, status,
                             message, messages,
                             wall_time, correction, redundant_joints, body_names,
                             equation_labels, scene (static animation geometry), version

``pandas.read_hdf`` needs PyTables and a PyTables layout, so it cannot read these files; use
:func:`read_results` (a DataFrame of the table) or :func:`load_results` (arrays + metadata, what
``spatialmbd plot`` and ``spatialmbd animate`` use). Plain h5py works too::

    with h5py.File(path) as f:
        cols = json.loads(f["table"].attrs["columns"])
        df = pandas.DataFrame({c: f["table"][c][()] for c in cols})

Atomic writing
--------------
Every file is written to a temporary file in the target's directory, flushed to disk (fsync)
and moved over the target with ``os.replace``: a crash, an exception or Ctrl-C while writing
leaves either the complete new file or the previous one, never a half-written file.
"""
from __future__ import annotations

import contextlib
import dataclasses
import datetime
import io
import json
import pathlib
import time
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

# atomic writing lives in the core layer (spatialmbd.atomic); re-exported here
from ..atomic import (STALE_SECONDS, _Staged, atomic_write, clean_stale_temporaries,  # noqa: F401
                      commit_all, defers_interrupts, interrupt_check, write_error)

FORMAT_NAME = "spatialmbd-results"
FORMAT_VERSION = 1
HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")
CSV_SUFFIXES = (".csv",)

__all__ = ["to_dataframe", "iter_table", "save_all", "clean_stale_temporaries", "save_results",
           "write_csv", "write_hdf5", "read_results",
           "load_results", "LoadedResults", "atomic_write", "results_kind", "FORMAT_NAME",
           "FORMAT_VERSION"]


# ----------------------------------------------------------------------------------------------
# tables
# ----------------------------------------------------------------------------------------------
def results_kind(results) -> str:
    """"dynamic", "kinematic" or "loaded" (a LoadedResults)."""
    if isinstance(results, LoadedResults):
        return "loaded"
    if hasattr(results, "newton_iterations"):
        return "kinematic"
    if hasattr(results, "lam") and hasattr(results, "to_dataframe"):
        return "dynamic"
    raise TypeError(f"expected Results, KinematicResults or LoadedResults, not "
                    f"{type(results).__name__}")


_Q_NAMES = ("x", "y", "z", "e0", "e1", "e2", "e3")
_V_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")
_A_NAMES = ("ax", "ay", "az", "alphax", "alphay", "alphaz")
_POINT_NAMES = ("x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az")


def _body_columns(model, q, v, vdot) -> dict:
    cols = {}
    for k, name in enumerate(model.body_names):
        for j, c in enumerate(_Q_NAMES):
            cols[f"{name}.{c}"] = q[:, k, j]
        for j, c in enumerate(_V_NAMES):
            cols[f"{name}.{c}"] = v[:, k, j]
        for j, c in enumerate(_A_NAMES):
            cols[f"{name}.{c}"] = vdot[:, k, j]
    return cols


def _point_columns(model, q, v, vdot) -> dict:
    """Position, velocity and acceleration (5.8)-(5.9) of every named point "body.point"."""
    from ..rotations import A_from_p
    cols = {}
    if not model.points or len(q) == 0:
        for name in model.points:
            for c in _POINT_NAMES:
                cols[f"{name}.{c}"] = np.zeros(len(q))
        return cols
    A = A_from_p(q[:, :, 3:])                                   # (nt, nb, 3, 3)
    for name, (body, local) in model.points.items():
        s = np.einsum("nij,j->ni", A[:, body], np.asarray(local, dtype=float))
        w, wd = v[:, body, 3:], vdot[:, body, 3:]
        r = q[:, body, :3] + s
        rd = v[:, body, :3] + np.cross(w, s)
        rdd = vdot[:, body, :3] + np.cross(wd, s) + np.cross(w, np.cross(w, s))
        for j, arr in enumerate((r, rd, rdd)):
            for i in range(3):
                cols[f"{name}.{_POINT_NAMES[3 * j + i]}"] = arr[:, i]
    return cols


def _violation(model, q, v, t) -> dict:
    asm = model.assembler
    nt = len(t)
    pos, vel = np.zeros(nt), np.zeros(nt)
    if model.n_eq:
        for k in range(nt):
            cv = asm.evaluate(q[k], v[k], t[k])
            pos[k] = float(np.linalg.norm(cv.phi))
            vel[k] = float(np.linalg.norm(cv.D @ v[k].reshape(-1) - cv.nu))
    return dict(position=pos, velocity=vel)


def to_dataframe(results):
    """One row per output time, self-explaining columns (see the module docstring).

    Accepts dynamic Results, KinematicResults or LoadedResults (returns a copy of its table).
    """
    import pandas as pd
    kind = results_kind(results)
    if kind == "loaded":
        return results.table.copy()
    model = results.model
    t = np.asarray(results.t, dtype=float)
    if kind == "dynamic":
        df = results.to_dataframe()
        extra = _point_columns(model, results.q, results.v, results.vdot)
        cols = {c: df[c].to_numpy() for c in df.columns}
        ordered = {}
        for c, arr in cols.items():                 # points right after the body columns
            if c == "violation.position" or (extra and _is_reaction(c, model)):
                ordered.update(extra)
                extra = {}
            ordered[c] = arr
        ordered.update(extra)
        ordered["violation.phi_squared"] = ordered["violation.position"] ** 2
        order = [c for c in ordered if not c.startswith("energy.")] + \
                [c for c in ordered if c.startswith("energy.")]
        out = pd.DataFrame({c: ordered[c] for c in order})
        out.attrs["units"] = dict(df.attrs.get("units", {}))
        return out
    cols = {"t": t}
    cols.update(_body_columns(model, results.q, results.v, results.vdot))
    for name, d in results.points.items():
        for j, key in enumerate(("r", "rdot", "rddot")):
            for i in range(3):
                cols[f"{name}.{_POINT_NAMES[3 * j + i]}"] = np.asarray(d[key])[:, i]
    viol = _violation(model, results.q, results.v, t)
    cols["violation.position"] = viol["position"]
    cols["violation.velocity"] = viol["velocity"]
    cols["violation.phi_squared"] = viol["position"] ** 2
    cols["newton.iterations"] = np.asarray(results.newton_iterations)
    from ..outputs import compute_outputs, output_units
    cols.update(compute_outputs(results))           # the requested outputs (docs/outputs.md)
    out = pd.DataFrame(cols)
    out.attrs["units"] = output_units(results)
    return out


def _is_reaction(column: str, model) -> bool:
    head = column.split(".", 1)[0]
    return any(head in g.names for g in model.constraint_groups)


# ----------------------------------------------------------------------------------------------
# writing
# ----------------------------------------------------------------------------------------------
@defers_interrupts(imports=("pandas", "h5py"))
def save_results(results, path, *, analysis=None, table=None) -> pathlib.Path:
    """Write ``results`` to ``path``: CSV for ``.csv``, HDF5 for ``.h5``/``.hdf5``.

    analysis: the Analysis (or analysis dict) that produced the results, stored in the HDF5
    metadata with the model. table: a precomputed :func:`to_dataframe` (saves recomputing it
    when several files are written).
    """
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if suffix in CSV_SUFFIXES:
        return write_csv(results, path, table=table)
    if suffix in HDF5_SUFFIXES:
        return write_hdf5(results, path, analysis=analysis, table=table)
    raise ValueError(f"cannot tell the results format from {str(path)!r}: use a .csv or .h5 "
                     "(.hdf5) file name")


#: rows of the results table computed and written at a time (bounded memory for long runs)
CHUNK_ROWS = 20_000
#: without an explicit chunk_rows, the table is computed in chunks of about this many seconds
#: (the first of FIRST_CHUNK_ROWS rows times it), so that Ctrl-C is honoured between them
CHUNK_SECONDS = 0.15
FIRST_CHUNK_ROWS = 2_000


def _chunk_rows(results) -> int:
    model = getattr(results, "model", None)
    if model is None:
        return CHUNK_ROWS
    width = 30 * model.nb + 12 * sum(g.n for g in model.constraint_groups) + 20
    return max(500, min(CHUNK_ROWS, 4_000_000 // width))


def _slice(results, start: int, stop: int):
    """The results at output rows start:stop (same kind)."""
    kind = results_kind(results)
    sl = slice(start, stop)
    if kind == "loaded":
        return dataclasses.replace(results, table=results.table.iloc[sl])
    if kind == "kinematic":
        return dataclasses.replace(
            results, t=results.t[sl], q=results.q[sl], v=results.v[sl], vdot=results.vdot[sl],
            points={k: {kk: np.asarray(vv)[sl] for kk, vv in d.items()}
                    for k, d in results.points.items()},
            newton_iterations=np.asarray(results.newton_iterations)[sl],
            residual=np.asarray(results.residual)[sl])
    z = getattr(results, "force_states", None)
    return dataclasses.replace(results, t=results.t[sl], q=results.q[sl], v=results.v[sl],
                               vdot=results.vdot[sl], lam=results.lam[sl],
                               work=results.work[sl], force_states=None if z is None else z[sl])


def iter_table(results, chunk_rows: Optional[int] = None):
    """The rows of :func:`to_dataframe` in DataFrames of at most chunk_rows rows, so that a
    long run is written with bounded memory (the energy error keeps its reference, the
    total energy at the first output time)."""
    kind = results_kind(results)
    n = len(results.t) if kind != "loaded" else len(results.table)
    step = chunk_rows or _chunk_rows(results)
    size = step if chunk_rows else min(step, FIRST_CHUNK_ROWS)
    if n <= size:
        yield to_dataframe(results)
        return
    total0, refs = None, getattr(results, "coupler_references", None)
    start = 0
    while start < n:
        stop = min(n, start + size)
        began = time.perf_counter()
        part = _slice(results, start, stop)
        if kind == "dynamic":        # couplers' angles unwrapped on from the previous chunk
            part.coupler_references = refs
        df = to_dataframe(part)
        refs = getattr(part, "coupler_references_end", None)
        if "energy.total" in df.columns:
            if total0 is None:
                total0 = float(df["energy.total"].iloc[0])
            df["energy.error"] = df["energy.total"] - total0 - \
                df["energy.work_nonconservative"]
        if not chunk_rows:                 # about CHUNK_SECONDS per chunk, at most step rows
            per_row = (time.perf_counter() - began) / (stop - start)
            size = int(min(step, max(500, CHUNK_SECONDS / max(per_row, 1e-9))))
        start = stop
        yield df


def status_line(results) -> Optional[str]:
    """The first line of a CSV of results that are not complete: '# status: <status>;
    <message>' (None for status success)."""
    status = str(getattr(results, "status", "success"))
    if status == "success":
        return None
    message = " ".join(str(getattr(results, "message", "") or "").split())
    return f"# status: {status}" + (f"; {message}" if message else "")


@defers_interrupts(imports=("pandas", "h5py"))
def write_csv(results, path, *, table=None) -> pathlib.Path:
    """The results table as CSV (header row, one row per output time), written atomically.
    Results that are not complete (status failed, budget, interrupted) start with a comment
    line '# status: ...' (read them with :func:`read_results` or pandas' ``comment='#'``)."""
    path = pathlib.Path(path)
    with atomic_write(path) as tmp:
        _write_csv_to(results, tmp, table)
    return path


class _CSVSink:
    """Receives the table chunk by chunk and writes it as CSV to ``tmp``."""

    def __init__(self, results, tmp):
        self.fh = open(tmp, "w", newline="")
        self.rows, self.columns = 0, 0
        line = status_line(results)
        if line:
            self.fh.write(line + "\n")

    def add(self, df):
        interrupt_check()
        df.to_csv(self.fh, index=False, header=self.rows == 0 and self.columns == 0)
        self.rows += len(df)
        self.columns = len(df.columns)

    def close(self):
        self.fh.close()
        return self.rows, self.columns

    def abort(self):
        self.fh.close()


def _write_table(results, sinks, table=None) -> None:
    """Compute the table once, in chunks, and hand every chunk to every sink."""
    for df in ([table] if table is not None else iter_table(results)):
        for sink in sinks:
            sink.add(df)


def _write_csv_to(results, tmp, table=None) -> tuple:
    sink = _CSVSink(results, tmp)
    try:
        _write_table(results, [sink], table)
    except BaseException:
        sink.abort()
        raise
    return sink.close()


@defers_interrupts(imports=("pandas", "h5py"))
def save_all(results, paths, *, analysis=None) -> dict:
    """Write ``results`` to every path (.csv / .h5) as one set: all files are written to
    temporaries first and moved onto their targets only when all of them are complete, so
    an error or Ctrl-C while writing leaves every target as it was. Each HDF5 file records
    the run (attrs run_id, outputs). Returns {path: (rows, columns)}."""
    import uuid
    run_id = uuid.uuid4().hex
    paths = [pathlib.Path(p) for p in paths]
    for path in paths:
        if path.suffix.lower() not in CSV_SUFFIXES + HDF5_SUFFIXES:
            raise ValueError(f"cannot tell the results format from {str(path)!r}: use a .csv "
                             "or .h5 (.hdf5) file name")
    staged, sinks = [], []
    current = paths[0] if paths else None
    try:
        for path in paths:
            current = path
            st = _Staged(path)
            staged.append(st)
            if path.suffix.lower() in CSV_SUFFIXES:
                sinks.append(_CSVSink(results, st.tmp))
            else:
                sinks.append(_H5Sink(results, st.tmp, analysis, run_id,
                                     [str(p) for p in paths]))
        for df in iter_table(results):
            for path, sink in zip(paths, sinks):
                current = path
                sink.add(df)
        written = {}
        for path, sink in zip(paths, sinks):
            current = path
            written[path] = sink.close()
    except BaseException as exc:
        for sink in sinks:
            with contextlib.suppress(Exception):
                sink.abort()
        for st in staged:
            st.abort()
        if isinstance(exc, OSError):
            tmp = next((st.tmp for st in staged if st.path == current), None)
            raise write_error(current, exc, tmp, "the previous files are kept") from exc
        if isinstance(exc, KeyboardInterrupt):
            raise KeyboardInterrupt(f"while writing {', '.join(map(str, paths))}: nothing "
                                    "written, the previous files are kept") from None
        raise
    commit_all(staged)
    return written


class _Encoder(json.JSONEncoder):
    def default(self, o):
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, pathlib.PurePath):
            return str(o)
        if dataclasses.is_dataclass(o) and not isinstance(o, type):
            return {f.name: getattr(o, f.name) for f in dataclasses.fields(o)}
        if isinstance(o, (set, tuple)):
            return list(o)
        return repr(o)


def _json(value) -> str:
    return json.dumps(value, cls=_Encoder)


def _analysis_dict(analysis) -> Optional[dict]:
    if analysis is None or isinstance(analysis, dict):
        return analysis
    if hasattr(analysis, "to_dict"):                    # the model file's analysis section
        return json.loads(_json(analysis.to_dict()))
    if dataclasses.is_dataclass(analysis):
        return json.loads(_json(analysis))
    return {"repr": repr(analysis)}


def _correction_dict(correction) -> Optional[dict]:
    if correction is None:
        return None
    out = json.loads(_json(correction)) if dataclasses.is_dataclass(correction) else {}
    if hasattr(correction, "summary"):
        out["summary"] = correction.summary()
    return out


def _model_metadata(model, analysis) -> tuple:
    """(model-file dict or None, note): the model as a model-file dict, when it can be one."""
    try:
        from .modelfile import model_to_dict
    except ImportError as exc:                                   # pragma: no cover
        return None, f"model not stored: {exc}"
    try:
        return json.loads(_json(model_to_dict(model, analysis))), ""
    except Exception as exc:  # noqa: BLE001 - metadata must never stop the results from being saved
        try:
            return json.loads(_json(model_to_dict(model))), ""
        except Exception:  # noqa: BLE001
            return None, f"model not stored: {exc}"


def _metadata(results, analysis) -> dict:
    kind = results_kind(results)
    if kind == "loaded":
        meta = dict(results.metadata)
        if analysis is not None:
            meta["analysis"] = _analysis_dict(analysis)
        return meta
    from ..animation import static_scene
    import spatialmbd
    model = results.model
    model_dict, note = _model_metadata(model, analysis)
    meta = dict(
        version=spatialmbd.__version__, kind=kind, status=results.status,
        message=results.message, model=model_dict, model_note=note,
        analysis=_analysis_dict(analysis), body_names=list(model.body_names),
        equation_labels=[list(x) for x in model.equation_labels],
        point_names=list(model.points), scene=static_scene(model),
        outputs=[r.to_dict() for r in getattr(results, "output_requests", None) or []
                 if hasattr(r, "to_dict")])
    if kind == "dynamic":
        meta.update(settings=results.settings, counters=results.counters,
                    wall_time=results.wall_time, messages=list(results.messages),
                    redundant_joints=list(results.redundant_joints),
                    correction=_correction_dict(results.correction))
    else:
        iters = np.asarray(results.newton_iterations)
        meta.update(settings={"type": "kinematic"},
                    counters={"outputs": int(len(results.t)),
                              "newton_iterations": int(iters.sum()) if iters.size else 0},
                    wall_time=getattr(results, "wall_time", None), messages=[],
                    redundant_joints=[], correction=None)
    return meta


@defers_interrupts(imports=("pandas", "h5py"))
def write_hdf5(results, path, *, analysis=None, table=None) -> pathlib.Path:
    """The results with their model, settings and counters as HDF5 (layout in the module
    docstring), written atomically; the table is computed and written in chunks."""
    path = pathlib.Path(path)
    with atomic_write(path) as tmp:
        _write_hdf5_to(results, tmp, analysis, table)
    return path


class _H5Sink:
    """Receives the table chunk by chunk; the HDF5 file is assembled in memory and written to
    ``tmp`` by Python in blocks on :meth:`close`: a full disk or a file-size limit then raises
    OSError (HDF5's own writes crash the process on them), and Ctrl-C is honoured between
    blocks."""

    def __init__(self, results, tmp, analysis=None, run_id=None, outputs=None):
        import h5py
        self.tmp = tmp
        self.meta = _metadata(results, analysis)
        kind = self.meta.get("kind", "dynamic")
        arrays = {"t": results.t, "q": results.q, "v": results.v, "vdot": results.vdot}
        if kind == "dynamic":
            arrays.update(lam=results.lam, work=results.work)
        else:
            arrays.update(newton_iterations=results.newton_iterations,
                          residual=results.residual)
        self.n_total = len(results.t)
        self.rows, self.columns = 0, 0
        self.image = io.BytesIO()
        self.f = f = h5py.File(self.image, "w")
        if run_id:
            f.attrs["run_id"] = run_id
            f.attrs["outputs"] = json.dumps(outputs or [])
        f.attrs["format"] = FORMAT_NAME
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["spatialmbd_version"] = str(self.meta.get("version", ""))
        f.attrs["kind"] = kind
        f.attrs["status"] = str(self.meta.get("status", ""))
        f.attrs["created"] = datetime.datetime.now(datetime.timezone.utc).isoformat()
        for name, arr in arrays.items():
            if arr is not None:
                _dataset(f, name, np.asarray(arr))
        self.tab = f.create_group("table")

    def add(self, df):
        tab, first = self.tab, self.columns == 0
        if first:
            tab.attrs["columns"] = json.dumps([str(c) for c in df.columns])
            tab.attrs["units"] = json.dumps(column_units_of(df))
            self.columns = len(df.columns)
        for c in df.columns:
            interrupt_check()
            arr = df[c].to_numpy()
            if first:
                _dataset(tab, str(c), arr, growable=len(df) < self.n_total)
            else:
                dset = tab[str(c)]
                dset.resize((self.rows + len(arr),))
                dset[self.rows:] = arr
        self.rows += len(df)

    def close(self):
        import h5py
        grp = self.f.create_group("metadata")
        for key, value in self.meta.items():
            grp.create_dataset(key, data=_json(value), dtype=h5py.string_dtype("utf-8"))
        self.f.close()
        view = self.image.getbuffer()
        try:
            with open(self.tmp, "wb") as fh:
                for start in range(0, len(view), WRITE_BLOCK):
                    interrupt_check()
                    fh.write(view[start:start + WRITE_BLOCK])
        finally:
            view.release()
            self.image = None
        return self.rows, self.columns

    def abort(self):
        import contextlib as _c
        with _c.suppress(Exception):
            self.f.close()


def _write_hdf5_to(results, tmp, analysis=None, table=None, run_id=None, outputs=None):
    sink = _H5Sink(results, tmp, analysis, run_id, outputs)
    try:
        _write_table(results, [sink], table)
    except BaseException:
        sink.abort()
        raise
    return sink.close()


#: bytes written at a time (an HDF5 file is assembled in memory, then written in blocks)
WRITE_BLOCK = 1 << 22


def _dataset(group, name, arr, growable=False):
    kwargs = {"compression": "gzip", "compression_opts": 4, "shuffle": True} \
        if arr.size > 4096 or growable else {}
    if growable:
        kwargs.update(maxshape=(None,) + arr.shape[1:], chunks=(min(max(len(arr), 1), 8192),)
                      + arr.shape[1:])
    interrupt_check()
    if arr.ndim == 0 or arr.nbytes <= WRITE_BLOCK:
        group.create_dataset(name, data=arr, **kwargs)
        return
    # large arrays in blocks of rows, so that Ctrl-C is honoured between them
    dset = group.create_dataset(name, shape=arr.shape, dtype=arr.dtype, **kwargs)
    step = max(1, WRITE_BLOCK // max(1, arr[0].nbytes))
    for start in range(0, len(arr), step):
        interrupt_check()
        dset[start:start + step] = arr[start:start + step]


# ----------------------------------------------------------------------------------------------
# reading
# ----------------------------------------------------------------------------------------------
@dataclass
class LoadedResults:
    """Results read back from a file: arrays, the table and the metadata (no model needed).

    t (nt,); q (nt, nb, 7); v, vdot (nt, nb, 6); lam (nt, m) and work (nt,) of dynamic runs;
    newton_iterations / residual of kinematic ones; table: the DataFrame of the file;
    metadata: dict (model, analysis, settings, counters, messages, scene, ...).
    """

    path: pathlib.Path
    kind: str
    t: np.ndarray
    q: Optional[np.ndarray]
    v: Optional[np.ndarray]
    vdot: Optional[np.ndarray]
    table: Any
    metadata: dict = field(default_factory=dict)
    lam: Optional[np.ndarray] = None
    work: Optional[np.ndarray] = None
    newton_iterations: Optional[np.ndarray] = None
    residual: Optional[np.ndarray] = None
    format_version: Optional[int] = None

    status = property(lambda self: self.metadata.get("status", "unknown"))
    message = property(lambda self: self.metadata.get("message", ""))
    counters = property(lambda self: self.metadata.get("counters") or {})
    settings = property(lambda self: self.metadata.get("settings") or {})
    messages = property(lambda self: self.metadata.get("messages") or [])
    wall_time = property(lambda self: self.metadata.get("wall_time"))
    version = property(lambda self: self.metadata.get("version"))
    model_dict = property(lambda self: self.metadata.get("model"))
    analysis = property(lambda self: self.metadata.get("analysis"))
    scene = property(lambda self: self.metadata.get("scene"))

    @property
    def success(self) -> bool:
        return self.status == "success"

    @property
    def body_names(self) -> list:
        names = self.metadata.get("body_names")
        if names is not None:
            return list(names)
        return [c[:-3] for c in self.table.columns if c.endswith(".e0")
                and c.count(".") == 1]

    def to_dataframe(self):
        return self.table.copy()

    def body(self, name: str) -> dict:
        k = self.body_names.index(name)
        return dict(r=self.q[:, k, :3], p=self.q[:, k, 3:], rdot=self.v[:, k, :3],
                    omega=self.v[:, k, 3:], rddot=self.vdot[:, k, :3],
                    omegadot=self.vdot[:, k, 3:])

    def load_model(self):
        """(Model, Analysis) rebuilt from the stored model-file dict."""
        if not self.model_dict:
            raise ValueError(f"{self.path}: the file holds no model description"
                             + (f" ({self.metadata.get('model_note')})"
                                if self.metadata.get("model_note") else ""))
        from .modelfile import load_model
        return load_model(self.model_dict)

    def summary(self) -> str:
        lines = [f"{self.path}: {self.kind} results, {len(self.t)} output times"
                 + (f" from {self.t[0]:.6g} to {self.t[-1]:.6g} s" if len(self.t) else ""),
                 f"status: {self.status}" + (f" ({self.message})" if self.message else "")]
        if self.version:
            lines.append(f"written by spatialmbd {self.version}")
        if self.counters:
            lines.append("counters: " + ", ".join(f"{k} {v}" for k, v in self.counters.items()))
        return "\n".join(lines)


def read_results(path):
    """The results table of a ``.h5`` or ``.csv`` results file as a pandas DataFrame."""
    import pandas as pd
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if not path.exists():
        raise FileNotFoundError(f"no such results file: {path}")
    if suffix in CSV_SUFFIXES:
        status, _ = _csv_status(path)
        df = pd.read_csv(path, skiprows=1 if status else 0)
        df.attrs["status"] = status or "success"
        return df
    if suffix in HDF5_SUFFIXES:
        with _open_h5(path) as f:
            return _read_table(f, path)
    raise ValueError(f"cannot tell the results format from {str(path)!r}: expected .csv or .h5")


@contextlib.contextmanager
def _open_h5(path):
    import h5py
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ValueError(f"{path}: not a readable HDF5 file ({exc})") from None
    with f:
        if f.attrs.get("format") != FORMAT_NAME:
            raise ValueError(f"{path}: not a spatialmbd results file (HDF5 attribute 'format' "
                             f"is {f.attrs.get('format')!r}, expected {FORMAT_NAME!r})")
        version = int(f.attrs.get("format_version", 0))
        if version > FORMAT_VERSION:
            raise ValueError(f"{path}: results format version {version} is newer than this "
                             f"spatialmbd reads ({FORMAT_VERSION}); upgrade spatialmbd")
        yield f


def _read_table(f, path):
    import pandas as pd
    if "table" not in f:
        raise ValueError(f"{path}: no /table group")
    tab = f["table"]
    cols = json.loads(tab.attrs["columns"])
    df = pd.DataFrame({c: tab[c][()] for c in cols})
    if "units" in tab.attrs:
        df.attrs["units"] = json.loads(tab.attrs["units"])
    return df


def column_units_of(df) -> dict:
    """{column: unit} of a results table: the standard columns by their names, the requested
    outputs from ``df.attrs["units"]`` (docs/outputs.md)."""
    from ..outputs import column_units
    return column_units(df.columns, df.attrs.get("units"))


def load_results(path) -> LoadedResults:
    """Arrays, table and metadata of a results file (HDF5: everything; CSV: the table, with
    t, q, v, vdot rebuilt from the body columns and no metadata)."""
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if suffix in CSV_SUFFIXES:
        loaded = _loaded_from_table(path, read_results(path))
        status, message = _csv_status(path)
        loaded.metadata.update(status=status or "success", message=message)
        return loaded
    if suffix not in HDF5_SUFFIXES:
        raise ValueError(f"cannot tell the results format from {str(path)!r}: expected .csv "
                         "or .h5")
    if not path.exists():
        raise FileNotFoundError(f"no such results file: {path}")
    with _open_h5(path) as f:
        table = _read_table(f, path)
        meta = {k: json.loads(_text(f["metadata"][k][()])) for k in f["metadata"]} \
            if "metadata" in f else {}
        arr = {k: f[k][()] for k in ("t", "q", "v", "vdot", "lam", "work",
                                     "newton_iterations", "residual") if k in f}
        kind = str(f.attrs.get("kind", meta.get("kind", "dynamic")))
        version = int(f.attrs.get("format_version", 0))
    meta.setdefault("kind", kind)
    return LoadedResults(path=path, kind=kind, t=arr["t"], q=arr.get("q"), v=arr.get("v"),
                         vdot=arr.get("vdot"), table=table, metadata=meta, lam=arr.get("lam"),
                         work=arr.get("work"), newton_iterations=arr.get("newton_iterations"),
                         residual=arr.get("residual"), format_version=version)


def _csv_status(path) -> tuple:
    """(status, message) of a CSV results file from its '# status:' line, or (None, "")."""
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    if not first.startswith("# status:"):
        return None, ""
    status, _, message = first[len("# status:"):].strip().partition(";")
    return status.strip(), message.strip()


def _text(value) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)


def _loaded_from_table(path, table) -> LoadedResults:
    names = [c[:-3] for c in table.columns if c.endswith(".e0") and c.count(".") == 1]
    nt = len(table)

    def block(keys):
        if not names or not all(f"{n}.{k}" in table for n in names for k in keys):
            return None
        return np.stack([np.column_stack([table[f"{n}.{k}"].to_numpy() for k in keys])
                         for n in names], axis=1).reshape(nt, len(names), len(keys))

    kind = "kinematic" if "newton.iterations" in table else "dynamic"
    meta = {"body_names": names, "kind": kind}
    return LoadedResults(path=path, kind=kind, t=table["t"].to_numpy(), q=block(_Q_NAMES),
                         v=block(_V_NAMES), vdot=block(_A_NAMES), table=table, metadata=meta)
