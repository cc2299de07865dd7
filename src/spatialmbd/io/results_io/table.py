"""The results table (one row per output time, self-explaining columns), read in chunks, and
the file formats' names and suffixes."""
from __future__ import annotations

import dataclasses
import pathlib
import time
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from ...outputs.vocabulary import POINT, body_columns



FORMAT_NAME = "spatialmbd-results"
FORMAT_VERSION = 1
HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")
CSV_SUFFIXES = (".csv",)

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




def _point_columns(model, q, v, vdot) -> dict:
    """Position, velocity and acceleration (5.8)-(5.9) of every named point "body.point"."""
    from ...rotations import A_from_p
    cols = {}
    if not model.points or len(q) == 0:
        for name in model.points:
            for c in POINT:
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
                cols[f"{name}.{POINT[3 * j + i]}"] = arr[:, i]
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
    cols.update(body_columns(model.body_names, results.q, results.v, results.vdot))
    for name, d in results.points.items():
        for j, key in enumerate(("r", "rdot", "rddot")):
            for i in range(3):
                cols[f"{name}.{POINT[3 * j + i]}"] = np.asarray(d[key])[:, i]
    viol = _violation(model, results.q, results.v, t)
    cols["violation.position"] = viol["position"]
    cols["violation.velocity"] = viol["velocity"]
    cols["violation.phi_squared"] = viol["position"] ** 2
    cols["newton.iterations"] = np.asarray(results.newton_iterations)
    from ...outputs import compute_outputs, output_units
    cols.update(compute_outputs(results))           # the requested outputs (docs/outputs.md)
    out = pd.DataFrame(cols)
    out.attrs["units"] = output_units(results)
    return out


def _is_reaction(column: str, model) -> bool:
    head = column.split(".", 1)[0]
    return any(head in g.names for g in model.constraint_groups)


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


def _write_table(results, sinks, table=None) -> None:
    """Compute the table once, in chunks, and hand every chunk to every sink."""
    for df in ([table] if table is not None else iter_table(results)):
        for sink in sinks:
            sink.add(df)


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
        from ..modelfile import load_model
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


def column_units_of(df) -> dict:
    """{column: unit} of a results table: the standard columns by their names, the requested
    outputs from ``df.attrs["units"]`` (docs/outputs.md)."""
    from ...outputs import column_units
    return column_units(df.columns, df.attrs.get("units"))
