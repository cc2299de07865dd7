"""`spatialmbd run`: run the analysis of a model file and write its results."""
from __future__ import annotations

import dataclasses
import pathlib

from ..errors import ModelError
from . import common


RESULT_SUFFIXES = (".csv", ".h5", ".hdf5")


def cmd_run(args) -> int:
    model, analysis = common.load(args.model, **common.import_options(args, args.model))
    analysis, notes = common.apply_overrides(analysis, args)
    if getattr(args, "outputs", None):
        analysis = _with_outputs(model, analysis, args.outputs)
    outs = common.output_paths(args, pathlib.Path(args.model).stem, ".csv", RESULT_SUFFIXES)
    if not args.quiet:
        for note in notes:
            print(f"note: {note}")
    budget = _budget_of(args)
    writer = _stream_writer(args, analysis, outs)
    try:
        results, wall, warning_texts = common.run_analysis(
            model, analysis, progress=not args.quiet, budget=budget, stream=writer)
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    if getattr(analysis, "type", "dynamic") in ENGINEERING_TYPES:
        return _write_engineering(results, analysis, outs, wall, warning_texts, args.quiet)
    t_last = results.t[-1] if len(results.t) else float("nan")
    if writer is not None:
        if writer.error is not None:            # a file could not be written: none changed
            raise writer.error
        t_last = writer.t_written if not len(results.t) else t_last
        written = writer.finish(results)
    else:
        from ..io.results_io import save_all
        written = save_all(results, outs, analysis=analysis)
    if not args.quiet:
        print(common.summary(results, wall, warning_texts))
        for out, (rows, columns) in written.items():
            print(f"results written to {out} ({rows} rows, {columns} columns)")
    if results.status == "interrupted":
        common.err(common.failure_line(results, t_last).replace("the analysis failed",
                                                                "interrupted"))
        return 130
    if results.status != "success":
        common.err(common.failure_line(results, t_last))
        return 1
    return 0


#: a dynamic run with more output times than this streams them to its files (--stream-rows)
STREAM_ROWS = 100_000


def _stream_writer(args, analysis, outs):
    """A ResultsWriter when the dynamic run has more output rows than --stream-rows (its
    outputs then go to the files in chunks, with bounded memory), else None."""
    if getattr(analysis, "type", "dynamic") != "dynamic":
        return None
    limit = getattr(args, "stream_rows", None)
    limit = STREAM_ROWS if limit is None else limit
    from ..simulate import output_times
    try:
        n = output_times(analysis.t_end, analysis.output_step, analysis.t_eval).size
    except Exception:  # noqa: BLE001 - bad output settings: simulate reports them
        return None
    if n <= limit:
        return None
    from ..io.stream import DEFAULT_CHUNK_ROWS, ResultsWriter
    chunk = max(1, min(DEFAULT_CHUNK_ROWS, limit)) if limit else DEFAULT_CHUNK_ROWS
    if not args.quiet:
        print(f"note: {n:,} output rows: written to the files in chunks of {chunk:,} as the "
              "run goes (bounded memory; --stream-rows sets the threshold)")
    return ResultsWriter(outs, analysis=analysis, chunk_rows=chunk)


def _budget_of(args):
    """The Budget of --max-steps / --max-wall-time / --max-estimated-time (None without
    them)."""
    steps, wall = getattr(args, "max_steps", None), getattr(args, "max_wall_time", None)
    estimated = getattr(args, "max_estimated_time", None)
    if steps is None and wall is None and estimated is None:
        return None
    from ..budget import Budget
    return Budget(max_steps=steps, max_wall_time=wall, max_estimated_time=estimated)


def _with_outputs(model, analysis, tokens):
    """``analysis`` with the requests of ``--outputs`` added: shorthands (joints, drivers,
    forces, bodies, momentum, energy, all) or KIND:NAME (joint:pivot, imu:link.tip)."""
    from ..outputs import KINDS, parse_outputs
    extra = []
    for token in tokens:
        if ":" in token:
            kind, _, of = token.partition(":")
            if kind not in KINDS:
                raise common.UsageError(f"--outputs {token}: {kind!r} is not one of "
                                        + ", ".join(KINDS))
            extra.append({"type": kind, "of": of} if of else {"type": kind})
        else:
            extra.append(token)
    requests = list(getattr(analysis, "outputs", None) or []) + extra
    try:
        parse_outputs(model, requests)
    except ModelError as exc:
        raise common.UsageError(f"--outputs: {exc}") from None
    return dataclasses.replace(analysis, outputs=requests)
ENGINEERING_TYPES = ("inverse", "static", "quasi_static", "modal")


def _write_engineering(results, analysis, outs, wall, warning_texts, quiet) -> int:
    """Files and summary of an engineering analysis (spatialmbd.analyses): its table as CSV,
    or HDF5 with the positions over time. Modal analyses: CSV, one row per mode; HDF5, the
    motion of the lowest mode that is not a rigid-body one (for ``spatialmbd animate``)."""
    from ..io.results_io import save_results
    table = results.to_dataframe()
    notes = []
    for out in outs:
        if out.suffix.lower() == ".csv":
            from ..atomic import atomic_write
            with atomic_write(out) as tmp:
                table.to_csv(tmp, index=False)
        elif analysis.type == "modal":
            kinds = list(results.table["kind"])
            k = next((i for i, c in enumerate(kinds) if c != "rigid-body"), 0)
            if not kinds:
                raise common.UsageError(f"output file {str(out)!r}: the model has no modes "
                                        "to animate")
            motion = results.motion(k, amplitude=0.1)
            save_results(motion, out, analysis=analysis)
            f_k = results.table["frequency_hz"][k]
            what = f"{f_k:.6g} Hz" if f_k == f_k else f"s = {results.table['real'][k]:.6g} 1/s"
            notes.append(f"{out} holds the motion of mode {k} ({kinds[k]}, {what}, largest "
                         "entry 0.1 m or rad); write a .csv for the table of all modes")
        else:
            save_results(results.results, out, analysis=analysis, table=table)
    if not quiet:
        print(results.summary())
        print(f"wall time {wall:.3g} s")
        for w in warning_texts:
            print(f"warning: {w}")
        for out in outs:
            print(f"results written to {out} ({len(table)} rows, {len(table.columns)} columns)")
        for note in notes:
            print(f"note: {note}")
    return 0


def add_parser(command) -> None:
    p = command("run", "run the analysis of a model file and write the results",
                "Run the analysis described in MODEL (a model file: YAML or JSON), with the "
                "options below overriding it, print a short summary and write the results. "
                "Default output: <model stem>.csv in the current directory. A .csv output is "
                "the results table (one row per output time); a .h5 output also stores the "
                "arrays, the model, the settings and the counters (for `plot` and `animate`). "
                "Results are written even when the analysis fails (up to the failure), and "
                "files are replaced atomically.",
                """
                spatialmbd run pendulum.yaml
                spatialmbd run pendulum.yaml --method baumgarte --integrator rk4 --step 1e-3
                spatialmbd run pendulum.yaml --t-end 2 --output-step 0.01 -o p.csv -o p.h5
                spatialmbd run model.yaml --quiet -o results.h5 && echo ok
                spatialmbd run slider_crank.yaml --outputs joints drivers -o crank.h5
                """)
    p.add_argument("model", metavar="MODEL", help="model file (.yaml, .yml or .json)")
    common.add_analysis_options(p)
    p.add_argument("-o", "--output", action="append", metavar="OUT",
                   help="results file, .csv or .h5 (repeat for several); default "
                        "<model stem>.csv in the current directory")
    p.add_argument("--outputs", nargs="+", metavar="REQ",
                   help="also record these outputs (added to the file's outputs section): "
                        "joints, drivers, forces, bodies, momentum, energy, all, or KIND:NAME "
                        "such as joint:pivot, force:spring, imu:link.tip (docs/outputs.md)")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress bar, no summary (errors are still reported)")
    p.add_argument("--stream-rows", type=common.non_negative_int, metavar="N",
                   help=f"a dynamic run with more than N output times (default {STREAM_ROWS:,};"
                        " 0: always) writes them to its files in chunks while it runs, with "
                        "bounded memory")
    g = p.add_argument_group("budget (a run that reaches it stops with its results so far, "
                             "status 'budget', exit status 1)")
    g.add_argument("--max-steps", type=common.positive_int, metavar="N",
                   help="stop after N accepted integration steps")
    g.add_argument("--max-wall-time", type=common.positive, metavar="S",
                   help="stop after S seconds of wall time")
    g.add_argument("--max-estimated-time", type=common.positive, metavar="S",
                   help="run even if its work is estimated above S seconds (default 600: a "
                        "longer run is refused before it starts unless --max-wall-time or "
                        "--max-steps bounds it)")
    common.add_import_options(p)
    p.set_defaults(func=cmd_run)
