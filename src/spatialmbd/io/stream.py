"""Results streamed to their files while a run goes, with bounded memory (issue 16).

A long run (many output rows) or a large model need not hold its outputs in memory: every
``chunk_rows`` outputs, the integration driver hands the rows it has to a
:class:`ResultsWriter` (``simulate(..., stream=writer)``), which computes their results table
and appends rows and table to the files, then forgets them. The run is one continuous
integration -- the same steps, events and contact memory as without streaming, so the files
equal those of ``save_all(simulate(...))`` to round-off (tested).

The files have exactly the layout of :mod:`.results_io` (CSV: the table; HDF5: arrays, table
and metadata), so :func:`.results_io.load_results`, ``spatialmbd plot`` and ``animate`` read
them. Writing is atomic as everywhere: rows go to temporaries next to the targets, which are
moved onto them only when the run has finished (every target together, as ``save_all`` does).
A run that fails, reaches a budget or is interrupted still finishes its files, with its
status ("failed", "budget", "interrupted": the HDF5 attribute and metadata, the CSV's first
line ``# status: ...``) and everything computed until then. If a file cannot be written (a
full disk, a file-size limit), the run stops, the targets keep their previous contents and an
OSError names the file. HDF5 is written through a Python file object, so such errors arrive
as OSError rather than inside the HDF5 library.

:func:`simulate_to_file` is the entry point: ``simulate`` with its outputs streamed to files.
``spatialmbd run -o FILE`` uses it when a run has more than ``--stream-rows`` outputs.
"""
from __future__ import annotations

import json
import os
import pathlib
import shutil
from typing import Optional, Sequence

import numpy as np

from ..atomic import commit_all, defers_interrupts, interrupt_check, write_error
from ..errors import ModelError
from .results_io import (CSV_SUFFIXES, FORMAT_NAME, FORMAT_VERSION, HDF5_SUFFIXES, _json,
                         _metadata, _Staged, column_units_of, status_line, to_dataframe)

__all__ = ["ResultsWriter", "simulate_to_file", "DEFAULT_CHUNK_ROWS"]

#: output rows held in memory before they are written
DEFAULT_CHUNK_ROWS = 4096

_ARRAYS = ("t", "q", "v", "vdot", "lam", "work")


class _FileObject:
    """The file HDF5 writes through (h5py's file-object driver). The HDF5 library does not
    survive a failing write (a full disk or a file-size limit crash the process), so a write
    that fails is recorded in ``error`` and reported to the library as done; from then on
    writes are dropped. The caller checks ``error`` after every HDF5 operation and raises it
    (:meth:`check`); the temporary file is then discarded."""

    def __init__(self, path):
        # unbuffered: with a buffer, a failing write would surface later, in seek()
        self._fh = open(path, "wb+", buffering=0)
        self.error: Optional[OSError] = None

    def discard(self):
        if self.error is None:
            self.error = OSError("writing abandoned")

    def _guard(self, op, *args):
        if self.error is not None:
            return None
        try:
            return op(*args)
        except OSError as exc:
            self.error = exc
            return None

    def write(self, data):
        view = memoryview(data).cast("B")
        done = 0
        while done < len(view) and self.error is None:        # raw writes may be short
            done += self._guard(self._fh.write, view[done:]) or 0
        return len(view)

    def truncate(self, size=None):
        self._guard(self._fh.truncate, size)
        return size

    def flush(self):
        self._guard(self._fh.flush)

    def check(self):
        if self.error is not None:
            raise self.error

    def __getattr__(self, name):            # read, readinto, seek, tell, fileno, close
        return getattr(self._fh, name)


class _H5Stream:
    """Appends arrays and table rows to an HDF5 file of the results_io layout."""

    def __init__(self, tmp, run_id, outputs):
        import h5py
        self._h5py = h5py
        self.fh = _FileObject(tmp)
        self.f = h5py.File(self.fh, "w")
        self.f.attrs.update(format=FORMAT_NAME, format_version=FORMAT_VERSION, kind="dynamic",
                            status="running", run_id=run_id, outputs=json.dumps(outputs))
        self.rows = 0
        self.columns = None

    def _append(self, group, name, arr):
        interrupt_check()                  # Ctrl-C between datasets, never inside HDF5
        arr = np.asarray(arr, dtype=float)
        if name not in group:
            group.create_dataset(name, data=arr,
                                 maxshape=(None,) + tuple(d or None for d in arr.shape[1:]),
                                 chunks=(max(1, min(len(arr), 8192)),) + tuple(
                                     max(d, 1) for d in arr.shape[1:]),
                                 compression="gzip", compression_opts=4, shuffle=True)
            return
        ds = group[name]
        ds.resize(self.rows + len(arr), axis=0)
        ds[self.rows:] = arr

    def add(self, results, df):
        f = self.f
        if self.columns is None:
            self.columns = [str(c) for c in df.columns]
            tab = f.create_group("table")
            tab.attrs["columns"] = json.dumps(self.columns)
            tab.attrs["units"] = json.dumps(column_units_of(df))
        elif [str(c) for c in df.columns] != self.columns:
            raise ModelError("streamed results: a chunk's table columns differ from the first "
                             "chunk's")
        for name in _ARRAYS:
            self._append(f, name, getattr(results, name))
        tab = f["table"]
        for c in self.columns:
            self._append(tab, c, df[c].to_numpy())
        self.rows += len(df)
        f.flush()
        self.fh.check()

    def close(self, meta):
        f = self.f
        f.attrs.update(status=str(meta.get("status", "")),
                       spatialmbd_version=str(meta.get("version", "")))
        import datetime
        f.attrs["created"] = datetime.datetime.now(datetime.timezone.utc).isoformat()
        grp = f.create_group("metadata")
        for key, value in meta.items():
            grp.create_dataset(key, data=_json(value), dtype=self._h5py.string_dtype("utf-8"))
        f.close()
        self.fh.flush()
        self.fh.check()
        os.fsync(self.fh.fileno())
        self.fh.close()
        return self.rows, len(self.columns or ())

    def abort(self):
        self.fh.discard()
        for close in (self.f.close, self.fh.close):
            try:
                close()
            except Exception:  # noqa: BLE001 - closing after a failed write
                pass


class _CSVStream:
    """Appends table rows to a CSV file; a run that did not succeed gets its status line at
    the top when it finishes (the rows are copied behind it, in blocks)."""

    def __init__(self, tmp):
        self.tmp = pathlib.Path(tmp)
        self.fh = open(tmp, "w", newline="")
        self.rows = 0
        self.columns = None

    def add(self, results, df):
        df.to_csv(self.fh, index=False, header=self.columns is None)
        self.columns = self.columns or len(df.columns)
        self.rows += len(df)

    def close(self, meta):
        self.fh.flush()
        os.fsync(self.fh.fileno())
        self.fh.close()

        class _Status:
            status, message = meta.get("status", "success"), meta.get("message", "")
        line = status_line(_Status)
        if line:
            head = self.tmp.with_name(self.tmp.name + ".status")
            with open(head, "w", newline="") as out, open(self.tmp, "r", newline="") as body:
                out.write(line + "\n")
                shutil.copyfileobj(body, out, 1 << 22)
                out.flush()
                os.fsync(out.fileno())
            os.replace(head, self.tmp)
        return self.rows, self.columns or 0

    def abort(self):
        try:
            self.fh.close()
        except Exception:  # noqa: BLE001
            pass
        self.tmp.with_name(self.tmp.name + ".status").unlink(missing_ok=True)


class ResultsWriter:
    """Result files (.csv / .h5 / .hdf5) written chunk by chunk while a run goes.

    paths: one or more target files; analysis: stored in the HDF5 metadata with the model;
    chunk_rows: outputs held in memory between writes (>= 1). Pass it to
    ``simulate(..., stream=writer)``, then call :meth:`finish` with the returned results (or
    use :func:`simulate_to_file`, which does both). ``rows`` counts the rows written."""

    def __init__(self, paths, *, analysis=None, chunk_rows: int = DEFAULT_CHUNK_ROWS):
        import uuid
        if isinstance(paths, (str, os.PathLike)):
            paths = [paths]
        self.paths = [pathlib.Path(p) for p in paths]
        if not self.paths:
            raise ModelError("ResultsWriter: give at least one output file")
        for path in self.paths:
            if path.suffix.lower() not in CSV_SUFFIXES + HDF5_SUFFIXES:
                raise ModelError(f"output file {str(path)!r}: the name must end in .csv, .h5 "
                                 "or .hdf5")
        if isinstance(chunk_rows, bool) or not isinstance(chunk_rows, (int, np.integer)) or \
                chunk_rows < 1:
            raise ModelError(f"chunk_rows: expected a positive whole number of output rows, "
                             f"got {chunk_rows!r}")
        self.chunk_rows = int(chunk_rows)
        self.analysis = analysis
        self.rows = 0
        self.t_written = float("nan")      # time of the last row written
        self.finished = False
        self.error: Optional[BaseException] = None
        self._total0 = None              # total energy at the first output (energy.error)
        self._couplers = None            # the couplers' angle references at the next chunk
        run_id, names = uuid.uuid4().hex, [str(p) for p in self.paths]
        self._staged, self._sinks = [], []
        try:
            for path in self.paths:
                st = _Staged(path)
                self._staged.append(st)
                self._sinks.append(_CSVStream(st.tmp) if path.suffix.lower() in CSV_SUFFIXES
                                   else _H5Stream(st.tmp, run_id, names))
        except BaseException as exc:
            self.abort()
            wrapped = self._wrap_os(exc, self.paths[len(self._sinks)])
            if wrapped is not exc:
                raise wrapped from exc
            raise

    @defers_interrupts
    def add(self, results) -> None:
        """Append the output rows of ``results`` (dynamic Results of consecutive output times)
        to every file."""
        if self.finished:
            raise ModelError("ResultsWriter: add after finish")
        if not len(results.t):
            return
        results.coupler_references = self._couplers    # angles unwrapped across chunks
        df = to_dataframe(results)
        self._couplers = results.coupler_references_end
        if "energy.total" in df.columns:     # one reference for the whole run (as iter_table)
            if self._total0 is None:
                self._total0 = float(df["energy.total"].iloc[0])
            df["energy.error"] = df["energy.total"] - self._total0 - \
                df["energy.work_nonconservative"]
        path = self.paths[0]
        try:
            for path, sink in zip(self.paths, self._sinks):
                sink.add(results, df)
        except BaseException as exc:
            self.error = self._wrap_os(exc, path)
            self.abort()
            if self.error is not exc:
                raise self.error from exc
            raise
        self.rows += len(df)
        self.t_written = float(results.t[-1])

    @defers_interrupts
    def finish(self, results) -> dict:
        """Record the run (status, message, counters, model: from ``results``, the run's last
        chunk), close the files and move them onto their targets together. Returns
        {path: (rows, columns)}."""
        if self.finished:
            raise ModelError("ResultsWriter: finish called twice")
        written = {}
        path = self.paths[0]
        try:
            self.add(results)
            meta = _metadata(results, self.analysis)
            meta["counters"] = dict(meta.get("counters") or {}, outputs=self.rows)
            for path, sink in zip(self.paths, self._sinks):
                written[path] = sink.close(meta)
        except BaseException as exc:
            self.error = self._wrap_os(exc, path)
            self.abort()
            if self.error is not exc:
                raise self.error from exc
            raise
        commit_all(self._staged)
        self.finished = True
        return written

    def abort(self) -> None:
        """Close and remove the temporaries; the targets keep what they held."""
        for sink in self._sinks:
            sink.abort()
        for st in self._staged:
            st.abort()
        self.finished = True

    def _wrap_os(self, exc, path):
        """An OSError naming the target file, never its temporary (the others as they are)."""
        if isinstance(exc, OSError):
            tmp = next((st.tmp for st in self._staged if st.path == path), None)
            return write_error(path, exc, tmp, "the previous file is kept")
        return exc


def simulate_to_file(model, t_end: float, paths, *, chunk_rows: int = DEFAULT_CHUNK_ROWS,
                     analysis=None, **simulate_options):
    """Run :func:`spatialmbd.simulate.simulate` with its outputs streamed to ``paths`` (one
    file name or a list: .csv, .h5, .hdf5) every ``chunk_rows`` output rows, so memory stays
    bounded whatever the number of outputs. simulate_options: any of simulate's (output_step,
    t_eval, method, integrator, budget, outputs, ...). analysis: stored in the HDF5 metadata.

    Returns (results, written): the Results of the run's last chunk (its status, message,
    counters and messages are the whole run's; its arrays only the rows after the last full
    chunk -- read the files with :func:`.results_io.load_results` for all of them) and
    {path: (rows, columns)}. A failed, stopped or interrupted run still writes its files with
    its status; a file that cannot be written raises OSError and leaves the targets as they
    were."""
    from ..simulate import simulate
    if "stream" in simulate_options:
        raise ModelError("simulate_to_file sets stream itself; give the files as paths")
    writer = ResultsWriter(paths, analysis=analysis, chunk_rows=chunk_rows)
    try:
        results = simulate(model, t_end, stream=writer, **simulate_options)
    except BaseException:
        writer.abort()
        raise
    if writer.error is not None:             # a write failed inside the run: files unchanged
        exc = writer.error
        if not isinstance(exc, OSError):     # Ctrl-C while writing, or a bug: as it is
            raise exc
        done = f"after {writer.rows} output rows (t = {writer.t_written:g} s)" if writer.rows \
            else "before its first rows were written"
        raise OSError(exc.errno, f"{exc.strerror or exc}; the run stopped {done}")
    return results, writer.finish(results)

