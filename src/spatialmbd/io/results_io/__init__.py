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

Modules: ``table`` (the table, its columns and chunks, :class:`LoadedResults`), ``csv_file``,
``hdf5_file`` (one per format), ``reading`` (:func:`read_results`, :func:`load_results`);
:func:`save_results` and :func:`save_all` choose the format by the file suffix.
"""
from __future__ import annotations

import contextlib
import pathlib

# atomic writing lives in the core layer (spatialmbd.atomic); re-exported here
from ...atomic import (STALE_SECONDS, _Staged, atomic_write, clean_stale_temporaries,  # noqa: F401
                       commit_all, defers_interrupts, interrupt_check, write_error)
from .csv_file import _CSVSink, write_csv
from .hdf5_file import _Encoder, _H5Sink, _json, _metadata, write_hdf5  # noqa: F401
from .reading import load_results, read_results
from .table import (CHUNK_ROWS, CSV_SUFFIXES, FORMAT_NAME, FORMAT_VERSION,  # noqa: F401
                    HDF5_SUFFIXES, LoadedResults, column_units_of, iter_table, results_kind,
                    status_line, to_dataframe)

__all__ = ["to_dataframe", "iter_table", "save_all", "clean_stale_temporaries", "save_results",
           "write_csv", "write_hdf5", "read_results",
           "load_results", "LoadedResults", "atomic_write", "results_kind", "FORMAT_NAME",
           "FORMAT_VERSION"]


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


