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
import json
import os
import pathlib
import tempfile
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

FORMAT_NAME = "spatialmbd-results"
FORMAT_VERSION = 1
HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")
CSV_SUFFIXES = (".csv",)

__all__ = ["to_dataframe", "save_results", "write_csv", "write_hdf5", "read_results",
           "load_results", "LoadedResults", "atomic_write", "results_kind", "FORMAT_NAME",
           "FORMAT_VERSION"]


# ----------------------------------------------------------------------------------------------
# atomic writing
# ----------------------------------------------------------------------------------------------
def _default_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def atomic_write(path):
    """Yield a temporary path next to ``path``; on normal exit fsync it and ``os.replace`` it
    onto ``path``. On any exception (KeyboardInterrupt included) the temporary file is removed
    and ``path`` is left untouched."""
    path = pathlib.Path(path)
    directory = path.parent if str(path.parent) else pathlib.Path(".")
    if not directory.is_dir():
        raise FileNotFoundError(f"cannot write {path}: directory {directory} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    os.close(fd)
    tmp = pathlib.Path(tmp)
    try:
        yield tmp
        mode = path.stat().st_mode & 0o777 if path.exists() else _default_mode()
        os.chmod(tmp, mode)
        fd = os.open(tmp, os.O_RDWR)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    with contextlib.suppress(OSError, AttributeError):        # make the rename durable
        dfd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)


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


def write_csv(results, path, *, table=None) -> pathlib.Path:
    """The results table as CSV (header row, one row per output time), written atomically."""
    path = pathlib.Path(path)
    df = to_dataframe(results) if table is None else table
    with atomic_write(path) as tmp:
        df.to_csv(tmp, index=False)
    return path


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


def write_hdf5(results, path, *, analysis=None, table=None) -> pathlib.Path:
    """The results with their model, settings and counters as HDF5 (layout in the module
    docstring), written atomically."""
    import h5py
    path = pathlib.Path(path)
    df = to_dataframe(results) if table is None else table
    meta = _metadata(results, analysis)
    kind = meta.get("kind", "dynamic")
    arrays = {"t": results.t, "q": results.q, "v": results.v, "vdot": results.vdot}
    if kind == "dynamic":
        arrays.update(lam=results.lam, work=results.work)
    else:
        arrays.update(newton_iterations=results.newton_iterations, residual=results.residual)
    with atomic_write(path) as tmp:
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = FORMAT_NAME
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["spatialmbd_version"] = str(meta.get("version", ""))
            f.attrs["kind"] = kind
            f.attrs["status"] = str(meta.get("status", ""))
            f.attrs["created"] = datetime.datetime.now(datetime.timezone.utc).isoformat()
            for name, arr in arrays.items():
                if arr is None:
                    continue
                _dataset(f, name, np.asarray(arr))
            tab = f.create_group("table")
            tab.attrs["columns"] = json.dumps([str(c) for c in df.columns])
            tab.attrs["units"] = json.dumps(column_units_of(df))
            for c in df.columns:
                _dataset(tab, str(c), df[c].to_numpy())
            grp = f.create_group("metadata")
            for key, value in meta.items():
                grp.create_dataset(key, data=_json(value), dtype=h5py.string_dtype("utf-8"))
    return path


def _dataset(group, name, arr):
    kwargs = {"compression": "gzip", "compression_opts": 4, "shuffle": True} \
        if arr.size > 4096 else {}
    group.create_dataset(name, data=arr, **kwargs)


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
        return pd.read_csv(path)
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
        return _loaded_from_table(path, read_results(path))
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
