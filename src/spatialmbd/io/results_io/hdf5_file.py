"""HDF5 results files: arrays, the table and the metadata of the run, assembled in memory and
written atomically in blocks."""
from __future__ import annotations

import contextlib
import dataclasses
import datetime
import io
import json
import pathlib
from typing import Optional

import numpy as np

from ...atomic import atomic_write, defers_interrupts, interrupt_check
from .table import column_units_of, FORMAT_NAME, FORMAT_VERSION, _write_table, results_kind


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
        from ..modelfile import model_to_dict
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
    from ...animation import static_scene
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
