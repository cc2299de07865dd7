"""Result arrays streamed to an HDF5 file while a run goes, with bounded memory (issue 16).

:class:`ResultsStream` appends rows (t, q, v, vdot, lam, work) to growable HDF5 datasets in
a temporary file next to the target (:mod:`spatialmbd.atomic`), flushing every
``flush_rows`` rows; :meth:`ResultsStream.finish` records the status and moves the file onto
its final path (fsync + os.replace). Used as a context manager, an exception in the middle of
a run (a failure, Ctrl-C) still finishes the file, with status "failed" / "interrupted" and
the message, so what was computed up to then is kept and readable (:func:`read_stream`).

:func:`simulate_to_file` runs :func:`spatialmbd.simulate.simulate` in segments of
``segment`` s of simulated time, each restarted from the last state of the previous one, and
streams every segment to the file: memory is bounded by one segment, whatever t_end. A
restart discards the integrator's history (adaptive step size, multistep start-up), so
adaptive runs agree with one continuous run to the integration tolerance, not to round-off;
one-step fixed-step integrators (euler, heun, rk4) whose step divides the segment give the
same steps as the continuous run.

File layout (HDF5 through h5py): datasets ``t`` (n,),
``q`` (n, nb, 7), ``v`` (n, nb, 6), ``vdot`` (n, nb, 6), ``lam`` (n, n_eq), ``work`` (n,);
attributes ``status`` ("running" until finished, then "success", "failed", "budget",
"interrupted"), ``message``, ``format`` = "spatialmbd-stream", ``version`` = 1,
``body_names`` (JSON list).
"""
from __future__ import annotations

import json
import pathlib
from typing import Optional

import numpy as np

from ..errors import ModelError

FORMAT = "spatialmbd-stream"
#: rows held in memory before they are written (each row: 13 nb + n_eq + 2 floats)
DEFAULT_FLUSH_ROWS = 4096


def _h5py():
    try:
        import h5py
    except ImportError as exc:                      # pragma: no cover - extra installed in CI
        raise ModelError("streaming results to HDF5 needs h5py (a dependency of "
                         "spatialmbd): pip install h5py") from exc
    return h5py


class ResultsStream:
    """Rows of a run appended to an HDF5 file; see the module docstring.

    path: the final file (.h5 / .hdf5); nb: bodies; n_eq: constraint equations (columns of
    lam); flush_rows: rows buffered in memory before a write (>= 1); body_names: stored as an
    attribute (optional)."""

    def __init__(self, path, nb: int, n_eq: int, *, flush_rows: int = DEFAULT_FLUSH_ROWS,
                 body_names=None):
        path = pathlib.Path(path)
        if path.suffix.lower() not in (".h5", ".hdf5"):
            raise ModelError(f"stream file {str(path)!r}: expected a .h5 or .hdf5 file name")
        if isinstance(flush_rows, bool) or not isinstance(flush_rows, int) or flush_rows < 1:
            raise ModelError(f"flush_rows: expected a positive integer, got {flush_rows!r}")
        from ..atomic import _Staged
        h5py = _h5py()
        self.path, self.nb, self.n_eq, self.flush_rows = path, int(nb), int(n_eq), flush_rows
        self._staged = _Staged(path)
        try:
            self._file = h5py.File(self._staged.tmp, "w")
            f = self._file
            shapes = dict(t=(), q=(self.nb, 7), v=(self.nb, 6), vdot=(self.nb, 6),
                          lam=(self.n_eq,), work=())
            for name, shape in shapes.items():
                chunk = (min(flush_rows, 8192),) + tuple(max(d, 1) for d in shape)
                limit = tuple(d if d else None for d in shape)    # lam of n_eq = 0
                f.create_dataset(name, shape=(0,) + shape, maxshape=(None,) + limit,
                                 chunks=chunk, dtype="f8")
            f.attrs.update(format=FORMAT, version=1, status="running", message="",
                           body_names=json.dumps(list(body_names or [])))
            f.flush()
        except BaseException:
            if hasattr(self, "_file"):
                self._close_quietly()
            self._staged.abort()
            raise
        self._buffer = []
        self.rows = 0
        self.finished = False

    def append(self, t, q, v, vdot, lam, work=None):
        """Append rows: t (n,), q (n, nb, 7), v and vdot (n, nb, 6), lam (n, n_eq), work (n,)
        (zeros when None)."""
        if self.finished:
            raise ModelError(f"stream {self.path}: append after finish")
        t = np.atleast_1d(np.asarray(t, dtype=float))
        n = t.size
        block = dict(t=t, q=np.asarray(q, float).reshape(n, self.nb, 7),
                     v=np.asarray(v, float).reshape(n, self.nb, 6),
                     vdot=np.asarray(vdot, float).reshape(n, self.nb, 6),
                     lam=np.asarray(lam, float).reshape(n, self.n_eq),
                     work=np.zeros(n) if work is None else np.asarray(work, float).reshape(n))
        self._buffer.append(block)
        if sum(b["t"].size for b in self._buffer) >= self.flush_rows:
            self.flush()

    def flush(self):
        """Write the buffered rows and flush the file (readable up to here if the process
        dies: the temporary next to the target holds them, status "running")."""
        if not self._buffer:
            return
        f = self._file
        n = sum(b["t"].size for b in self._buffer)
        for name in ("t", "q", "v", "vdot", "lam", "work"):
            data = np.concatenate([b[name] for b in self._buffer])
            ds = f[name]
            ds.resize(self.rows + n, axis=0)
            ds[self.rows:self.rows + n] = data
        self.rows += n
        self._buffer = []
        f.flush()

    def finish(self, status: str = "success", message: str = "") -> pathlib.Path:
        """Write what is buffered, record status and message, close, and move the file onto
        its final path atomically."""
        if self.finished:
            return self.path
        try:
            self.flush()
            self._file.attrs.update(status=str(status), message=str(message))
            self._file.close()
        except BaseException:
            self._close_quietly()
            self._staged.abort()
            self.finished = True
            raise
        self.finished = True
        self._staged.commit()
        return self.path

    def _close_quietly(self):
        try:
            self._file.close()
        except Exception:  # noqa: BLE001 - closing after a failed write
            pass

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if self.finished:
            return False
        if kind is None:
            self.finish("success")
        else:
            status = "interrupted" if issubclass(kind, KeyboardInterrupt) else "failed"
            self.finish(status, f"{kind.__name__}: {exc}")
        return False


def read_stream(path) -> dict:
    """The arrays and attributes of a stream file: keys t, q, v, vdot, lam, work (arrays),
    status, message, body_names."""
    path = pathlib.Path(path)
    h5py = _h5py()
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ModelError(f"cannot read stream file {path}: {exc}") from exc
    with f:
        if f.attrs.get("format") != FORMAT:
            raise ModelError(f"{path} is not a spatialmbd stream file (format attribute "
                             f"{f.attrs.get('format')!r}); read result files with "
                             "spatialmbd.io.results_io.load_results")
        out = {name: f[name][()] for name in ("t", "q", "v", "vdot", "lam", "work")}
        out.update(status=str(f.attrs["status"]), message=str(f.attrs["message"]),
                   body_names=json.loads(f.attrs["body_names"]))
    return out


def simulate_to_file(model, t_end: float, path, *, segment: float, output_step: float,
                     t0: float = 0.0, flush_rows: int = DEFAULT_FLUSH_ROWS,
                     **simulate_options) -> dict:
    """Simulate ``model`` from t0 to t_end in segments of ``segment`` s, streaming outputs
    every ``output_step`` s to the HDF5 file ``path`` (see the module docstring).

    simulate_options: any of :func:`spatialmbd.simulate.simulate`'s (method, integrator,
    step, rtol, atol, budget, ...); a budget applies to each segment. Returns dict(path,
    status, message, rows, segments). A segment that does not succeed ends the run: its
    partial outputs are written and the file keeps its status and message."""
    from ..simulate import simulate
    for name in ("t_eval", "q0", "v0"):
        if name in simulate_options:
            raise ModelError(f"simulate_to_file takes no {name}: it sets the segments' start "
                             "states and output times itself")
    correct_initial = simulate_options.pop("correct_initial", True)
    t0, t_end = float(t0), float(t_end)
    for name, value in (("segment", segment), ("output_step", output_step)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0 \
                or not np.isfinite(value):
            raise ModelError(f"simulate_to_file {name}: expected a positive number of "
                             f"seconds, got {value!r}")
    if not t_end > t0:
        raise ModelError(f"simulate_to_file: t_end {t_end!r} must be after t0 {t0!r}")
    per_segment = max(1, int(round(segment / output_step)))
    n_out = int(np.floor((t_end - t0) / output_step + 1e-9))
    times = t0 + output_step * np.arange(n_out + 1)
    if t_end - times[-1] > 1e-9 * max(1.0, abs(t_end)):
        times = np.append(times, t_end)
    stream = ResultsStream(path, model.nb, model.n_eq, flush_rows=flush_rows,
                           body_names=list(model.body_names))
    status, message, segments = "success", "", 0
    q, v, work0 = None, None, 0.0
    with stream:
        k = 0
        while k < times.size - 1:
            stop = min(k + per_segment, times.size - 1)
            t_seg = times[k:stop + 1]
            res = simulate(model, float(t_seg[-1]), t0=float(t_seg[0]), t_eval=t_seg,
                           q0=q, v0=v, correct_initial=correct_initial and k == 0,
                           **simulate_options)
            segments += 1
            first = 0 if k == 0 else 1                  # t_seg[0] was the last row before
            # the work of the non-conservative forces restarts at 0 with each segment
            work = None if res.work is None else work0 + np.asarray(res.work, float)
            stream.append(res.t[first:], res.q[first:], res.v[first:], res.vdot[first:],
                          res.lam[first:], None if work is None else work[first:])
            if work is not None and work.size:
                work0 = float(work[-1])
            if res.status != "success":
                status, message = res.status, res.message
                break
            q, v = np.array(res.q[-1]), np.array(res.v[-1])
            k = stop
        stream.finish(status, message)
    return dict(path=stream.path, status=status, message=message, rows=stream.rows,
                segments=segments)
