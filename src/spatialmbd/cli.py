"""The ``spatialmbd`` command: a thin layer over the public API.

    spatialmbd run MODEL [options]        run the analysis of a model file, write the results
    spatialmbd info MODEL                 bodies, joints, drivers, forces, degrees of freedom
    spatialmbd plot RESULTS -y Q -o FIG   plots from a results file (--x: against any column)
    spatialmbd animate IN -o FILE.html    offline HTML animation (results file or model file)
    spatialmbd import FILE.xml -o M.yaml  MJCF / URDF -> model file (extra spatialmbd[mjcf])
    spatialmbd examples [NAME]            list the example models, or write one as a model file
    spatialmbd demo                       the chapter 15 study (figure and table)
    spatialmbd validate [--full]          the validation suite
    spatialmbd sweep MODEL --param P=V    a parameter sweep (serial, processes or Dask)

Exit status: 0 success; 1 the analysis (or a validation case) failed, partial results are
still written; 2 bad input (unreadable or invalid model file, unknown names, bad options);
130 interrupted. User errors are reported in one line each, without a Python traceback
(``--debug`` shows it).
"""
from __future__ import annotations

import argparse
import dataclasses
import inspect
import pathlib
import sys
import textwrap
import time
import warnings
from typing import Optional, Sequence

from . import __version__
from .errors import ModelError, SpatialMBDError

PROG = "spatialmbd"


class UsageError(Exception):
    """Bad command-line input (exit status 2)."""


class _Formatter(argparse.RawDescriptionHelpFormatter):
    def __init__(self, prog):
        super().__init__(prog, max_help_position=32)


def _epilog(text: str) -> str:
    return "examples:\n" + textwrap.indent(textwrap.dedent(text).strip("\n"), "  ")


def _model_file_error():
    try:
        from .io.modelfile import ModelFileError
        return ModelFileError
    except ImportError:                                           # pragma: no cover
        return ()


# ----------------------------------------------------------------------------------------------
# shared helpers
# ----------------------------------------------------------------------------------------------
def _err(*lines: str) -> None:
    for line in lines:
        print(line, file=sys.stderr)


def _load(path: str):
    """(Model, Analysis) of a model file; file problems raise ModelFileError / UsageError."""
    p = pathlib.Path(path)
    if not p.exists():
        raise UsageError(f"no such model file: {path}")
    if p.is_dir():
        raise UsageError(f"{path} is a directory, not a model file")
    if p.suffix.lower() in MJCF_SUFFIXES:        # MJCF / URDF: imported, default analysis
        from .io.modelfile import load_model, model_to_dict
        return load_model(model_to_dict(_import_mjcf(p, lenient=False)))
    from .io.modelfile import load_model
    return load_model(p)


MJCF_SUFFIXES = (".xml", ".mjcf", ".urdf")


def _import_mjcf(path, lenient: bool):
    """ModelBuilder of an MJCF/URDF file; what is left out is printed as a warning."""
    from .importers import import_mjcf
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        builder = import_mjcf(path, strict=not lenient)
    for w in caught:
        _err(f"warning: {w.message}")
    return builder


def cmd_import(args) -> int:
    src = pathlib.Path(args.input)
    if not src.is_file():
        raise UsageError(f"no such MJCF/URDF file: {args.input}")
    builder = _import_mjcf(src, lenient=args.lenient)
    from .io.modelfile import save_model
    out = pathlib.Path(args.output or (src.stem + ".yaml"))
    if out.suffix.lower() not in (".yaml", ".yml", ".json"):
        raise UsageError(f"output file {str(out)!r}: the name must end in .yaml, .yml or .json")
    save_model(builder, out, header=f"imported from {src.name} by spatialmbd import "
                                    "(MuJoCo's compiler)")
    if not args.quiet:
        print(f"{len(builder.bodies)} bodies, {len(builder.joints)} joints, "
              f"{len(builder.forces)} force elements: model written to {out}")
    return 0


def _check_name(kind: str, name: str) -> str:
    if kind == "method":
        from .dynamics.base import ALIASES, METHODS
        key = ALIASES.get(name.lower(), name.lower())
        if key not in METHODS and key != "auto":
            raise UsageError(f"unknown method {name!r}; valid names: auto, "
                             + ", ".join(sorted(METHODS)))
    else:
        from .integrators import INTEGRATORS
        if name.lower() not in INTEGRATORS:
            raise UsageError(f"unknown integrator {name!r}; valid names: "
                             + ", ".join(sorted(INTEGRATORS)))
    return name


def _name_of(value) -> Optional[str]:
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, dict):
        return value.get("name")
    return getattr(value, "name", None)


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


class _QuietOrQuantity(argparse.Action):
    """``-q`` of ``plot``: quiet, as in every other command; ``-q QUANTITY ...`` (its old
    meaning) still selects quantities, with a DeprecationWarning."""

    def __call__(self, parser, namespace, values, option_string=None):
        if not values:
            namespace.quiet = True
            return
        message = ("`spatialmbd plot -q QUANTITY` is deprecated: -q means quiet in every "
                   "command; use -y QUANTITY (or --quantity)")
        warnings.warn(message, DeprecationWarning, stacklevel=2)
        print(f"warning: {message}", file=sys.stderr)
        namespace.quantity = list(namespace.quantity or []) + list(values)


def _add_analysis_options(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("analysis options (override the model file's analysis)")
    g.add_argument("--method", metavar="M",
                   help="formulation: auto (the default: recursive for open trees, else "
                        "projection), standard, baumgarte, penalty, augmented_lagrangian, "
                        "projection, recursive (joint coordinates of open trees)")
    g.add_argument("--integrator", metavar="I",
                   help="euler, heun, rk4, abm4, bdf4, rk45, dop853, or a SciPy solver: "
                        "scipy-rk45, scipy-dop853, scipy-radau, scipy-bdf, scipy-lsoda")
    g.add_argument("--t-end", type=_positive, metavar="T", help="end time [s]")
    g.add_argument("--step", type=_positive, metavar="H",
                   help="step size [s] of euler, heun and rk4 (initial step of abm4 and "
                        "bdf4)")
    g.add_argument("--rtol", type=_positive, metavar="R", help="relative tolerance")
    g.add_argument("--atol", type=_positive, metavar="A", help="absolute tolerance")
    g.add_argument("--output-step", type=_positive, metavar="DT",
                   help="interval between output times [s]")


def _integrator_parameters(name: str) -> set:
    from .integrators import INTEGRATORS
    cls = INTEGRATORS[name.lower()]
    return set(inspect.signature(cls.__init__).parameters) - {"self"}


def _apply_overrides(analysis, args):
    """A copy of ``analysis`` with the command-line options applied; notes for the user."""
    notes = []
    changes = {}
    kind = str(getattr(analysis, "type", "dynamic")).lower()
    kinematic = kind != "dynamic"
    dynamic_only = [opt for opt, value in (("--method", args.method),
                                           ("--integrator", args.integrator),
                                           ("--step", args.step), ("--rtol", args.rtol),
                                           ("--atol", args.atol)) if value is not None]
    if kinematic and dynamic_only:
        raise UsageError(f"{', '.join(dynamic_only)}: only for dynamic analyses; this model "
                         f"file asks for a{'n' if kind[0] in 'aeiou' else ''} {kind} "
                         "analysis")
    if kind in ("static", "modal") and (args.t_end is not None or
                                        args.output_step is not None):
        raise UsageError(f"--t-end/--output-step: a {kind} analysis is at one time (set "
                         "'time' in the model file's analysis section)")
    if args.method is not None:
        _check_name("method", args.method)
        old = _name_of(analysis.method)
        changes["method"] = args.method
        if (old or "").lower() != args.method.lower() and analysis.method_options:
            changes["method_options"] = {}
            notes.append(f"method options {analysis.method_options} of {old!r} not used with "
                         f"{args.method!r}")
    if args.integrator is not None:
        _check_name("integrator", args.integrator)
        old = _name_of(analysis.integrator)
        changes["integrator"] = args.integrator
        if (old or "").lower() != args.integrator.lower():
            # the file's settings for its own integrator: keep those the new one takes
            accepted = _integrator_parameters(args.integrator)
            dropped = {}
            for key in ("step", "rtol", "atol"):
                value = getattr(analysis, key, None)
                if value is not None and getattr(args, key) is None and key not in accepted:
                    changes[key] = None
                    dropped[key] = value
            options = dict(analysis.integrator_options or {})
            kept = {k: v for k, v in options.items() if k in accepted}
            dropped.update({k: v for k, v in options.items() if k not in accepted})
            if len(kept) != len(options):
                changes["integrator_options"] = kept
            if dropped:
                notes.append("integrator settings of the model file not used by "
                             f"{args.integrator!r}: "
                             + ", ".join(f"{k}={v}" for k, v in dropped.items()))
    for key in ("step", "rtol", "atol", "t_end", "output_step"):
        value = getattr(args, key)
        if value is not None:
            changes[key] = value
    if (args.t_end is not None or args.output_step is not None) and \
            getattr(analysis, "t_eval", None) is not None:
        changes["t_eval"] = None
        notes.append("the model file's output times (t_eval) replaced by --t-end/--output-step")
    if not changes:
        return analysis, notes
    return dataclasses.replace(analysis, **changes), notes


def _run_analysis(model, analysis, progress: bool, budget=None, stream=None):
    """Run; return (results, wall time, warning texts)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        start = time.perf_counter()
        if stream is not None:
            results = analysis.run(model, progress=progress, budget=budget, stream=stream)
        elif budget is not None and getattr(analysis, "type", "dynamic") in ("dynamic",
                                                                               "kinematic"):
            results = analysis.run(model, progress=progress, budget=budget)
        else:
            results = analysis.run(model, progress=progress)
        wall = time.perf_counter() - start
    texts = []
    for w in caught:
        text = str(w.message)
        if text not in texts:
            texts.append(text)
    return results, wall, texts


def _is_kinematic(results) -> bool:
    return hasattr(results, "newton_iterations")


def _summary(results, wall: float, warning_texts: Sequence[str]) -> str:
    if _is_kinematic(results):
        it = results.newton_iterations
        lines = [f"status: {results.status}" + (f" ({results.message})"
                                                if results.message else ""),
                 f"kinematic analysis: {len(results.t)} output times, "
                 f"{int(it.sum()) if len(it) else 0} Newton iterations in all (at most "
                 f"{int(it.max()) if len(it) else 0} per time), max |Phi| "
                 f"{float(results.residual.max()) if len(it) else 0.0:.3g}, "
                 f"wall time {wall:.3g} s"]
        known = []
    else:
        known = list(results.messages)
        lines = [f"warning: {line}" if line in known else line
                 for line in results.summary().splitlines()]
    lines += [f"warning: {w}" for w in warning_texts if w not in known]
    return "\n".join(lines)


def _output_paths(args, stem: str, default_suffix: str, allowed: Sequence[str]) -> list:
    outs = [pathlib.Path(o) for o in (args.output or [])] or \
        [pathlib.Path(stem + default_suffix)]
    for out in outs:
        if out.suffix.lower() not in allowed:
            raise UsageError(f"output file {str(out)!r}: the name must end in "
                             + ", ".join(allowed[:-1]) + " or " + allowed[-1])
        parent = out.parent if str(out.parent) else pathlib.Path(".")
        if not parent.is_dir():
            raise UsageError(f"output file {str(out)!r}: directory {str(parent)!r} does not "
                             "exist")
    return outs


def _failure_line(results, t=None) -> str:
    if t is None:
        t = results.t[-1] if len(results.t) else float("nan")
    return (f"error: the analysis failed; results up to t = {t:.6g} s were written. "
            f"{results.message}").rstrip()


# ----------------------------------------------------------------------------------------------
# commands
# ----------------------------------------------------------------------------------------------
RESULT_SUFFIXES = (".csv", ".h5", ".hdf5")


def cmd_run(args) -> int:
    model, analysis = _load(args.model)
    analysis, notes = _apply_overrides(analysis, args)
    if getattr(args, "outputs", None):
        analysis = _with_outputs(model, analysis, args.outputs)
    outs = _output_paths(args, pathlib.Path(args.model).stem, ".csv", RESULT_SUFFIXES)
    if not args.quiet:
        for note in notes:
            print(f"note: {note}")
    budget = _budget_of(args)
    writer = _stream_writer(args, analysis, outs)
    try:
        results, wall, warning_texts = _run_analysis(model, analysis, progress=not args.quiet,
                                                     budget=budget, stream=writer)
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
        from .io.results_io import save_all
        written = save_all(results, outs, analysis=analysis)
    if not args.quiet:
        print(_summary(results, wall, warning_texts))
        for out, (rows, columns) in written.items():
            print(f"results written to {out} ({rows} rows, {columns} columns)")
    if results.status == "interrupted":
        _err(_failure_line(results, t_last).replace("the analysis failed", "interrupted"))
        return 130
    if results.status != "success":
        _err(_failure_line(results, t_last))
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
    from .simulate import output_times
    try:
        n = output_times(analysis.t_end, analysis.output_step, analysis.t_eval).size
    except Exception:  # noqa: BLE001 - bad output settings: simulate reports them
        return None
    if n <= limit:
        return None
    from .io.stream import DEFAULT_CHUNK_ROWS, ResultsWriter
    chunk = max(1, min(DEFAULT_CHUNK_ROWS, limit)) if limit else DEFAULT_CHUNK_ROWS
    if not args.quiet:
        print(f"note: {n:,} output rows: written to the files in chunks of {chunk:,} as the "
              "run goes (bounded memory; --stream-rows sets the threshold)")
    return ResultsWriter(outs, analysis=analysis, chunk_rows=chunk)


def _budget_of(args):
    """The Budget of --max-steps / --max-wall-time (None without them)."""
    steps, wall = getattr(args, "max_steps", None), getattr(args, "max_wall_time", None)
    if steps is None and wall is None:
        return None
    from .budget import Budget
    return Budget(max_steps=steps, max_wall_time=wall)


def _non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {text!r}")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text!r}")
    return value


def _with_outputs(model, analysis, tokens):
    """``analysis`` with the requests of ``--outputs`` added: shorthands (joints, drivers,
    forces, bodies, momentum, energy, all) or KIND:NAME (joint:pivot, imu:link.tip)."""
    from .outputs import KINDS, parse_outputs
    extra = []
    for token in tokens:
        if ":" in token:
            kind, _, of = token.partition(":")
            if kind not in KINDS:
                raise UsageError(f"--outputs {token}: {kind!r} is not one of "
                                 + ", ".join(KINDS))
            extra.append({"type": kind, "of": of} if of else {"type": kind})
        else:
            extra.append(token)
    requests = list(getattr(analysis, "outputs", None) or []) + extra
    try:
        parse_outputs(model, requests)
    except ModelError as exc:
        raise UsageError(f"--outputs: {exc}") from None
    return dataclasses.replace(analysis, outputs=requests)
ENGINEERING_TYPES = ("inverse", "static", "quasi_static", "modal")


def _write_engineering(results, analysis, outs, wall, warning_texts, quiet) -> int:
    """Files and summary of an engineering analysis (spatialmbd.analyses): its table as CSV,
    or HDF5 with the positions over time. Modal analyses: CSV, one row per mode; HDF5, the
    motion of the lowest mode that is not a rigid-body one (for ``spatialmbd animate``)."""
    from .io.results_io import save_results
    table = results.to_dataframe()
    notes = []
    for out in outs:
        if out.suffix.lower() == ".csv":
            table.to_csv(out, index=False)
        elif analysis.type == "modal":
            kinds = list(results.table["kind"])
            k = next((i for i, c in enumerate(kinds) if c != "rigid-body"), 0)
            if not kinds:
                raise UsageError(f"output file {str(out)!r}: the model has no modes to animate")
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


def cmd_info(args) -> int:
    from .kinematics import mobility
    model, analysis = _load(args.model)
    state = model.builder_state
    g = model.gravity
    lines = [f"model {model.name!r} ({args.model})",
             f"gravity: ({g[0]:.6g}, {g[1]:.6g}, {g[2]:.6g}) m/s^2",
             f"bodies ({model.nb}):"]
    for k, name in enumerate(model.body_names):
        r = model.q0[k, :3]
        lines.append(f"  {name:16s} mass {model.mass[k]:.6g} kg, centre of mass at "
                     f"({r[0]:.6g}, {r[1]:.6g}, {r[2]:.6g}) m")
    joints = state.get("joints", {})
    lines.append(f"joints ({len(model.joint_names)}):")
    types = {n: grp.name for grp in model.constraint_groups for n in grp.names}
    in_file_order = [n for n in joints if n in types] + \
        [n for n in model.joint_names if n not in joints]
    for name in in_file_order:
        spec = joints.get(name)
        between = f"{spec.body_i} - {spec.body_j}" if spec is not None else ""
        lines.append(f"  {name:16s} {types[name]:22s} {between}")
    drivers = state.get("drivers", {})
    lines.append(f"drivers ({len(model.driver_names)}):")
    for name in model.driver_names:
        spec = drivers.get(name)
        if spec is None:
            lines.append(f"  {name}")
        elif spec.kind == "coordinate":
            lines.append(f"  {name:16s} coordinate {spec.coordinate} of {spec.body}")
        else:
            lines.append(f"  {name:16s} {spec.kind} of joint {spec.joint}")
    forces = state.get("forces", {})
    lines.append(f"forces ({len(forces)}):")
    for name, spec in forces.items():
        lines.append(f"  {name:16s} {spec.type}")
    lines.append("analysis: " + _describe_analysis(analysis))
    requests = getattr(analysis, "outputs", None)
    if requests:
        from .outputs import parse_outputs
        lines.append("outputs: " + ", ".join(
            f"{r.kind} {r.of}" if r.of else r.kind for r in parse_outputs(model, requests)))
    lines.append("mobility:")
    lines.append(textwrap.indent(mobility(model).report(), "  "))
    print("\n".join(lines))
    return 0


def _describe_analysis(analysis) -> str:
    if analysis is None:
        return "none"
    parts = [str(getattr(analysis, "type", "?"))]
    if parts[0] in ("static", "modal"):                     # one time, no integration
        parts.append(f"at t = {getattr(analysis, 'time', 0.0):g} s")
        if getattr(analysis, "steady", False):
            rate = getattr(analysis, "frame_rate", None)
            parts.append("about the initial steady motion"
                         + (f", frame turning at {rate} rad/s" if rate else ""))
        return ", ".join(parts)
    for key, label in (("t_end", "t_end"), ("output_step", "output step")):
        value = getattr(analysis, key, None)
        if value is not None:
            parts.append(f"{label} {value:g} s")
    if str(parts[0]).lower() == "dynamic":
        for key in ("method", "integrator"):
            value = _name_of(getattr(analysis, key, None))
            if value:
                opts = getattr(analysis, f"{key}_options", None)
                parts.append(f"{key} {value}" + (f" {opts}" if opts else ""))
        for key in ("step", "rtol", "atol"):
            value = getattr(analysis, key, None)
            if value is not None:
                parts.append(f"{key} {value:g}")
    return ", ".join(parts)


def cmd_plot(args) -> int:
    from .io.results_io import load_results
    from .plotting import plot_results
    for path in args.results:
        if not pathlib.Path(path).exists():
            raise UsageError(f"no such results file: {path}")
    outs = _output_paths(args, pathlib.Path(args.results[0]).stem, ".png",
                         (".png", ".svg", ".pdf"))
    loaded = [load_results(p) for p in args.results]
    labels = args.labels or ([pathlib.Path(p).stem for p in args.results]
                             if len(loaded) > 1 else None)
    if labels is not None and len(labels) != len(loaded):
        raise UsageError(f"{len(labels)} --labels for {len(loaded)} results files")
    log = True if args.log else (False if args.linear else None)
    fig = plot_results(loaded if len(loaded) > 1 else loaded[0], args.quantity or None,
                       labels=labels, log=log, title=args.title, x=args.x)
    from .plotting import save_figure
    for out in outs:
        save_figure(fig, out)
        if not args.quiet:
            print(f"figure written to {out}")
    return 0


def cmd_animate(args) -> int:
    from .animation import write_animation
    src = pathlib.Path(args.input)
    outs = _output_paths(args, src.stem, ".html", (".html", ".htm"))
    status = 0
    if src.suffix.lower() in (".h5", ".hdf5", ".hdf"):
        if not src.exists():
            raise UsageError(f"no such results file: {args.input}")
        from .io.results_io import load_results
        results = load_results(src)
        model = None
        name = (results.model_dict or {}).get("name") if isinstance(results.model_dict, dict) \
            else None
        title = args.title or f"spatialmbd: {name or src.stem}"
    elif src.suffix.lower() == ".csv":
        raise UsageError(f"{args.input}: a CSV table holds no geometry; animate an HDF5 "
                         "results file (`spatialmbd run MODEL -o out.h5`) or the model file")
    else:
        model, analysis = _load(args.input)
        analysis, notes = _apply_overrides(analysis, args)
        if not args.quiet:
            for note in notes:
                print(f"note: {note}")
        results, wall, warning_texts = _run_analysis(model, analysis, progress=not args.quiet)
        if not args.quiet:
            print(_summary(results, wall, warning_texts))
        if results.status != "success":
            status = 1
        title = args.title or f"spatialmbd: {model.name}"
    for out in outs:
        write_animation(results, out, model=model, title=title, max_frames=args.max_frames,
                        reactions=getattr(args, "reactions", False),
                        renderer=getattr(args, "renderer", "auto"))
        if not args.quiet:
            print(f"animation written to {out}")
    if status:
        _err(f"error: the analysis failed; the animation shows the motion up to "
             f"t = {results.t[-1] if len(results.t) else float('nan'):.6g} s. "
             f"{results.message}")
    return status


def cmd_examples(args) -> int:
    from .models import EXAMPLES
    if args.name is None and args.write is None:
        width = max(len(n) for n in EXAMPLES)
        print("example models (write one with `spatialmbd examples NAME --write DIR`):")
        for name, (fn, _kw, analysis) in EXAMPLES.items():
            doc = (fn.__doc__ or "").strip().splitlines()[0] if fn.__doc__ else ""
            print(f"  {name:{width}s}  [{analysis.get('type', 'dynamic')}] {doc}")
        return 0
    names = [args.name] if args.name is not None else list(EXAMPLES)
    for name in names:
        if name not in EXAMPLES:
            raise UsageError(f"unknown example {name!r}; examples: " + ", ".join(EXAMPLES))
    if args.write is None:
        fn, kwargs, analysis = EXAMPLES[names[0]]
        print(f"{names[0]}: " + inspect.cleandoc(fn.__doc__ or ""))
        print(f"suggested analysis: {analysis}")
        print(f"write it as a model file with: spatialmbd examples {names[0]} --write DIR")
        return 0
    from .io.modelfile import save_model
    outdir = pathlib.Path(args.write)
    outdir.mkdir(parents=True, exist_ok=True)
    for name in names:
        fn, kwargs, analysis = EXAMPLES[name]
        path = save_model(fn(**kwargs), outdir / f"{name}.{args.format}", analysis=analysis)
        if not args.quiet:
            print(f"wrote {path}")
    return 0


def cmd_demo(args) -> int:
    try:
        from .study_ch15 import run_study
    except ImportError as exc:
        raise UsageError(f"the chapter 15 study is not available in this installation "
                         f"({exc})") from None
    outdir = pathlib.Path(args.outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    try:
        echo = None if args.quiet else (lambda line: print(line, flush=True))
        out = run_study(outdir, quick=args.quick, echo=echo)
    except RuntimeError as exc:                 # a method of the study failed to integrate
        _err(f"error: the study failed: {exc}")
        return 1
    if not args.quiet:
        print()
        if isinstance(out, dict) and isinstance(out.get("report"), str):
            print(out["report"])
        elif isinstance(out, dict) and type(out).__str__ is dict.__str__:
            _print_mapping(out)
        else:
            print(out)
    if isinstance(out, dict) and out.get("passed") is False:
        _err("error: some results of the study disagree with the exact solution beyond "
             "their tolerance (marked FAILED in the report)")
        return 1
    return 0


def _print_mapping(out) -> None:
    if not isinstance(out, dict):
        if out is not None:
            print(out)
        return
    for key, value in out.items():
        if isinstance(value, str) and "\n" in value:
            print(f"{key}:")
            print(textwrap.indent(value, "  "))
        elif isinstance(value, (str, pathlib.PurePath, int, float, bool)) or value is None:
            print(f"{key}: {value}")
        elif hasattr(value, "to_string"):
            print(f"{key}:")
            print(textwrap.indent(value.to_string(), "  "))
        elif isinstance(value, (list, tuple)) and all(
                isinstance(v, (str, pathlib.PurePath)) for v in value):
            print(f"{key}: " + ", ".join(str(v) for v in value))


def cmd_validate(args) -> int:
    try:
        from .validation import format_table, run_validation
    except ImportError as exc:
        raise UsageError(f"the validation suite is not available in this installation "
                         f"({exc})") from None

    def progress(case):
        if not args.quiet:
            print(f"{case.name}: {'pass' if case.passed else 'FAIL'} ({case.runtime:.1f} s)",
                  flush=True)

    try:
        cases = run_validation(full=args.full, out=args.out, cases=args.cases or None,
                               progress=progress, method=args.method)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    failed = [c for c in cases if not c.passed]
    if not args.quiet:
        print()
        print(format_table(cases))
    if failed:
        _err(f"error: {len(failed)} of {len(cases)} validation case(s) failed: "
             + ", ".join(c.name for c in failed))
        return 1
    if not args.quiet:
        print(f"all {len(cases)} validation cases passed")
    return 0


# ----------------------------------------------------------------------------------------------
# parser
# ----------------------------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG, formatter_class=_Formatter,
        description="Kinematics and dynamics of spatial rigid multibody systems "
                    "(body coordinates, Euler parameters).",
        epilog=_epilog("""
            spatialmbd examples                         # list the example models
            spatialmbd examples pendulum_ch15 --write . # write pendulum_ch15.yaml
            spatialmbd info pendulum_ch15.yaml          # bodies, joints, degrees of freedom
            spatialmbd run pendulum_ch15.yaml -o pendulum.h5
            spatialmbd plot pendulum.h5 -y pendulum.z energy.error -o pendulum.png
            spatialmbd animate pendulum.h5 -o pendulum.html
            spatialmbd <command> --help                 # options of a command

            exit status: 0 success, 1 analysis failed (partial results written),
            2 bad input (model file, names, options), 130 interrupted
            """))
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show Python tracebacks for errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def command(name, help_text, description, epilog):
        p = sub.add_parser(name, help=help_text, description=description,
                           epilog=_epilog(epilog), formatter_class=_Formatter)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show Python tracebacks for errors")
        return p

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
    _add_analysis_options(p)
    p.add_argument("-o", "--output", action="append", metavar="OUT",
                   help="results file, .csv or .h5 (repeat for several); default "
                        "<model stem>.csv in the current directory")
    p.add_argument("--outputs", nargs="+", metavar="REQ",
                   help="also record these outputs (added to the file's outputs section): "
                        "joints, drivers, forces, bodies, momentum, energy, all, or KIND:NAME "
                        "such as joint:pivot, force:spring, imu:link.tip (docs/outputs.md)")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress bar, no summary (errors are still reported)")
    p.add_argument("--stream-rows", type=_non_negative_int, metavar="N",
                   help=f"a dynamic run with more than N output times (default {STREAM_ROWS:,};"
                        " 0: always) writes them to its files in chunks while it runs, with "
                        "bounded memory")
    g = p.add_argument_group("budget (a run that reaches it stops with its results so far, "
                             "status 'budget', exit status 1)")
    g.add_argument("--max-steps", type=_positive_int, metavar="N",
                   help="stop after N accepted integration steps")
    g.add_argument("--max-wall-time", type=_positive, metavar="S",
                   help="stop after S seconds of wall time")
    p.set_defaults(func=cmd_run)

    p = command("info", "describe a model: bodies, joints, drivers, forces, DoF",
                "Print the bodies, joints, drivers and force elements of MODEL, its analysis, "
                "the Gruebler-Kutzbach count of degrees of freedom next to the numerical one "
                "(rank of the constraint Jacobian at the initial configuration), and the "
                "redundant constraint equations with their joints.",
                """
                spatialmbd info four_bar.yaml
                """)
    p.add_argument("model", metavar="MODEL", help="model file")
    p.set_defaults(func=cmd_info)

    p = command("plot", "plot quantities of a results file against time",
                "Plot columns of one or more results files (.h5 or .csv) against time. A "
                "QUANTITY is a column name (pendulum.z, pivot.pendulum.fz, energy.error, "
                "violation.position, and the requested outputs such as pivot.angle or "
                "spring.force: see docs/outputs.md), a pattern (pendulum.*, *.fz), a body "
                "name (its x, y, z), a joint name (its reaction forces), 'energy' or "
                "'violation'. Columns of one kind share a panel; --x puts any column on the "
                "horizontal axis instead of time. Default: body positions, energy error and "
                "constraint violation. The figure format follows the extension: .png, .svg "
                "or .pdf (default <results stem>.png in the current directory).",
                """
                spatialmbd plot pendulum.h5 -y pendulum.z energy.error -o pendulum.png
                spatialmbd plot pendulum.h5 -y 'pendulum.*' -y '*.fz' -o p.pdf
                spatialmbd plot a.h5 b.h5 --labels standard baumgarte -y violation --log -o v.svg
                spatialmbd plot pendulum.h5 --x pivot.angle -y pivot.angle_rate -o phase.png
                spatialmbd plot crank.h5 --x crank_drive.coordinate -y D.translation -o s.png
                """)
    p.add_argument("results", nargs="+", metavar="RESULTS", help="results file(s), .h5 or .csv")
    p.add_argument("-y", "--y", "--quantity", dest="quantity", action="extend", nargs="+",
                   metavar="QUANTITY",
                   help="what to plot (repeatable; patterns allowed; several series per "
                        "figure)")
    p.add_argument("--x", metavar="QUANTITY",
                   help="the column on the horizontal axis (default t): phase plots, "
                        "force against deflection, a joint coordinate against the crank angle")
    p.add_argument("-q", dest="legacy_q", action=_QuietOrQuantity, nargs="*",
                   metavar="QUANTITY",
                   help="quiet, as in every command (-q QUANTITY ... is the deprecated "
                        "spelling of -y)")
    p.add_argument("-o", "--output", action="append", metavar="FIG",
                   help="figure file .png, .svg or .pdf (repeat for several)")
    p.add_argument("--labels", nargs="+", metavar="LABEL", help="legend labels of the files")
    scale = p.add_mutually_exclusive_group()
    scale.add_argument("--log", action="store_true", help="logarithmic y axes everywhere")
    scale.add_argument("--linear", action="store_true",
                       help="linear y axes everywhere (default: log for violations only)")
    p.add_argument("--title", help="figure title")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_plot, quantity=None)

    p = command("animate", "write an offline HTML animation",
                "Write a self-contained HTML animation (no network needed) of an HDF5 results "
                "file, or of a model file, whose analysis is run first (the analysis options "
                "apply then). Default output: <input stem>.html in the current directory.",
                """
                spatialmbd animate pendulum.h5 -o pendulum.html
                spatialmbd animate four_bar.yaml --t-end 2 -o four_bar.html
                """)
    p.add_argument("input", metavar="RESULTS_OR_MODEL",
                   help="HDF5 results file (.h5) or model file")
    p.add_argument("-o", "--output", action="append", metavar="FILE.html",
                   help="HTML file to write")
    p.add_argument("--max-frames", type=int, default=1000, metavar="N",
                   help="at most N frames, evenly spread (default 1000)")
    p.add_argument("--title", help="page title")
    p.add_argument("--renderer", choices=("auto", "canvas"), default="auto",
                   help="auto: WebGL (three.js embedded) with the Canvas renderer as fallback; "
                        "canvas: Canvas only, a much smaller page")
    p.add_argument("--reactions", action="store_true",
                   help="draw the joint reaction forces as arrows (model files only)")
    _add_analysis_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=cmd_animate)

    p = command("import", "convert an MJCF or URDF file to a spatialmbd model file",
                "Read an MJCF (.xml) or URDF (.urdf) file with MuJoCo's compiler (optional "
                "extra: pip install 'spatialmbd[mjcf]') and write the equivalent model file: "
                "bodies with their mass properties, hinge/slide/ball joints as revolute/"
                "translational/spherical joints, connect/weld equalities as exact spherical/"
                "fixed joints. Features with no exact counterpart (tendons, actuators, joint "
                "couplings, contact pairs, ...) are an error naming them, or with --lenient a "
                "warning. `run`, `info` and `animate` also accept these files directly.",
                """
                spatialmbd import robot.urdf -o robot.yaml
                spatialmbd import scene.xml --lenient -o scene.yaml
                spatialmbd run four_bar.xml --t-end 2 -o four_bar.h5
                """)
    p.add_argument("input", metavar="FILE", help="MJCF (.xml) or URDF (.urdf) file")
    p.add_argument("-o", "--output", metavar="MODEL.yaml",
                   help="model file to write (.yaml, .yml or .json); default <stem>.yaml")
    p.add_argument("--lenient", action="store_true",
                   help="leave out features with no exact counterpart, with a warning")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but warnings")
    p.set_defaults(func=cmd_import)

    p = command("examples", "list the example models or write one as a model file",
                "Without NAME: list the example models. With NAME: describe it; with --write "
                "DIR: write it (with its suggested analysis) as DIR/NAME.yaml. --write without "
                "NAME writes them all.",
                """
                spatialmbd examples
                spatialmbd examples slider_crank
                spatialmbd examples pendulum_ch15 --write models/
                spatialmbd examples --write models/ --format json
                """)
    p.add_argument("name", nargs="?", metavar="NAME", help="example name")
    p.add_argument("--write", metavar="DIR", help="write the model file(s) into DIR")
    p.add_argument("--format", choices=("yaml", "json"), default="yaml",
                   help="model file format (default yaml)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_examples)

    p = command("demo", "run the chapter 15 study (figure and table)",
                "Reproduce the study of the text's chapter 15: the simple pendulum with the "
                "standard, Baumgarte, penalty, augmented Lagrangian and projection methods; "
                "writes the constraint-violation figure and the table into DIR.",
                """
                spatialmbd demo --outdir ch15
                spatialmbd demo --quick
                """)
    p.add_argument("--outdir", default="ch15_study", metavar="DIR",
                   help="output directory (default ./ch15_study)")
    p.add_argument("--quick", action="store_true", help="shorter runs (a quick check)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_demo)

    p = command("validate", "run the validation suite",
                "Run the validation cases (closed-form solutions and reference data) and "
                "print a table; the exit status is 1 if any case fails.",
                """
                spatialmbd validate
                spatialmbd validate --full --out validation/
                spatialmbd validate heavy_top slider_crank_kinematics
                spatialmbd validate --method recursive
                """)
    p.add_argument("cases", nargs="*", metavar="CASE",
                   help="run only these cases (default: all; names in the table)")
    p.add_argument("--full", action="store_true",
                   help="the complete version (longer runs, every output instant)")
    p.add_argument("--out", metavar="PATH",
                   help="also write the table to PATH (a directory, or a .md/.txt file)")
    p.add_argument("--method", metavar="M",
                   help="run every case with method M where it applies (recursive: the tree "
                        "models with rk45), else the case's own; the note names the methods")
    p.add_argument("-q", "--quiet", action="store_true", help="print only failures")
    p.set_defaults(func=cmd_validate)

    p = command("warmup", "compile the numerical kernels now (once per machine)",
                "Compile every numerical kernel (all methods, integrators, kinematics, force "
                "elements) into the on-disk cache, with progress, so that later runs start at "
                "once. Otherwise this happens on the first run, which then says so.",
                """
                spatialmbd warmup
                """)
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_warmup)

    from .sweep.cli import add_parser as add_sweep_parser      # spatialmbd sweep (issue 15)
    add_sweep_parser(command, _add_analysis_options)
    return parser


# ----------------------------------------------------------------------------------------------
# entry point
# ----------------------------------------------------------------------------------------------
def _warm_batch():
    from . import models
    from .io import Analysis
    from .sweep.batch import simulate_batch
    pendulum = models.pendulum_ch15().compile()
    for integrator in ("rk45", "rk4"):
        simulate_batch([pendulum], Analysis(t_end=1e-3, output_step=1e-3, method="standard",
                                            integrator=integrator, step=1e-3 if integrator ==
                                            "rk4" else None))
    simulate_batch([pendulum], Analysis(t_end=1e-3, output_step=1e-3, method="recursive"))
    import numpy as np
    from .sweep.outputs import period
    period(np.linspace(0.0, 1.0, 5), np.linspace(-1.0, 1.0, 5))       # compiled crossings


def cmd_warmup(args) -> int:
    """Compile every kernel now (each method, the integrators' fused stages, kinematics, the
    force elements), so that later runs start at once."""
    import time
    from .jit import cache_is_warm, compile_notice, mark_warm, warmup_lock
    from . import models
    from .kinematics import kinematic_analysis
    from .simulate import simulate
    start = time.perf_counter()
    warm = cache_is_warm()
    steps = [("kinematics", lambda: kinematic_analysis(
        models.slider_crank(crank_speed=6.0).compile(), [0.0, 0.01]))]
    fly = models.flyball_governor().compile()
    for method in ("standard", "baumgarte", "penalty", "augmented_lagrangian", "projection"):
        steps.append((f"dynamics, {method}", lambda m=method: simulate(
            fly, 1e-3, method=m, integrator="rk45", output_step=1e-3)))
    chain = models.chain(2, "revolute").compile()
    steps.append(("dynamics, recursive", lambda: simulate(chain, 1e-3, method="recursive",
                                                          output_step=1e-3)))
    steps.append(("fixed-step and implicit integrators", lambda: [
        simulate(fly, 2e-3, integrator=i, step=1e-3) for i in ("rk4", "bdf4")]))
    # dop853's own kernels (error norm, dense output) for the runs the Python driver takes
    # (events, a first_step, ...); its compiled loops are rk45's, already warm
    steps.append(("dop853 stepper", lambda: simulate(
        fly, 2e-3, integrator="dop853", integrator_options=dict(first_step=1e-4),
        output_step=1e-3)))
    steps.append(("batch engine of sweeps", _warm_batch))                  # issue 15
    with warmup_lock(), compile_notice(force=not warm and not args.quiet, every=10.0):
        for k, (what, run) in enumerate(steps):
            if not args.quiet:
                print(f"[{k + 1}/{len(steps)}] {what}", flush=True)
            run()
        mark_warm()
    if not args.quiet:
        print(f"ready in {time.perf_counter() - start:.1f} s"
              + (" (the cache was already warm)" if warm else ""))
    return 0


#: commands that may compile kernels on their first run (they get the compile notice)
_COMPUTING = (cmd_run, cmd_demo, cmd_validate)


#: environment variable set in the interpreted child of a cold start (see :func:`_race`)
INTERPRETED_ENV = "SPATIALMBD_INTERPRETED"
#: exit status of an interpreted child that met an internal error (the compiled run decides)
INTERPRETED_FAILED = 3
#: the background compile of a cold start
WARMUP_ARGV = [sys.executable, "-m", "spatialmbd", "warmup", "--quiet"]


def _cold(args) -> bool:
    """Whether this command should race (see :func:`_race`): a computing command, a cold
    compile cache, Numba enabled, not already the interpreted child, not switched off with
    SPATIALMBD_NO_RACE=1."""
    import os
    if getattr(args, "func", None) not in _COMPUTING or os.environ.get(INTERPRETED_ENV) or \
            os.environ.get("SPATIALMBD_NO_RACE"):
        return False
    from . import jit
    return jit.ENABLED and not jit.cache_is_warm()


def _race(argv, args) -> int:
    """First run on a machine (cold compile cache): compile the kernels in a background
    process (``spatialmbd warmup``) and meanwhile run this command in a child process with the
    kernels interpreted (``NUMBA_DISABLE_JIT=1``: the same functions as plain Python, one to
    two orders of magnitude slower). Whichever finishes first wins: a small model's result
    comes from the interpreted run in seconds; for a large one, once the compiled kernels are
    ready the interpreted run is stopped and the command runs compiled. The background compile
    always completes, so the next run starts at once."""
    import os
    import subprocess
    quiet = getattr(args, "quiet", False)
    start = time.perf_counter()

    def say(text):
        if not quiet:
            print(text, file=sys.stderr, flush=True)

    from . import jit
    devnull = subprocess.DEVNULL
    warm = subprocess.Popen(WARMUP_ARGV, stdin=devnull, stdout=devnull, stderr=devnull,
                            start_new_session=True)
    say("first run on this machine: compiling the numerical kernels in the background (about "
        "a minute, once); meanwhile this run uses them interpreted, and switches to the "
        "compiled ones if they are ready first")
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", **{INTERPRETED_ENV: "1"})
    child = subprocess.Popen([sys.executable, "-m", "spatialmbd", *argv], env=env)
    try:
        while True:
            code = child.poll()
            if code is not None and code != INTERPRETED_FAILED:
                if warm.poll() is None:
                    say("(the compiled kernels are still being built in the background for "
                        "the next run)")
                return code
            if code == INTERPRETED_FAILED:
                say("the interpreted run could not finish; waiting for the compiled kernels")
                warm.wait()
                break
            if warm.poll() not in (None, 0) and not jit.cache_is_warm():
                return child.wait()                    # no compiled kernels: keep interpreting
            if jit.cache_is_warm():
                child.terminate()
                child.wait()
                say(f"compiled kernels ready after {time.perf_counter() - start:.0f} s: "
                    "running compiled")
                break
            time.sleep(0.05)
    except KeyboardInterrupt:
        child.wait()                                   # it has written its partial results
        raise
    return args.func(args)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the command line ``argv`` (default sys.argv[1:]); return the exit status."""
    import os
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:                       # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    debug = getattr(args, "debug", False)
    file_error = _model_file_error()
    try:
        if _cold(args):
            return _race(argv, args)
        if getattr(args, "func", None) in _COMPUTING and not getattr(args, "quiet", False):
            from .jit import compile_notice
            with compile_notice():
                return args.func(args)
        return args.func(args)
    except KeyboardInterrupt:
        if debug:
            raise
        _err("interrupted")
        return 130
    except Exception as exc:  # noqa: BLE001 - turned into messages and exit statuses below
        if debug:
            raise
        if file_error and isinstance(exc, file_error):
            problems = list(getattr(exc, "problems", None) or [str(exc)])
            lines = list(getattr(exc, "lines", None) or [])
            lines += [None] * (len(problems) - len(lines))
            source = getattr(exc, "source", None) or getattr(exc, "heading", None)
            n = len(problems)
            _err(f"error: {source or 'model file'}: {n} problem{'s' if n != 1 else ''}:")
            for problem, line in zip(problems, lines):
                _err(f"  {problem}" + (f"  (line {line})" if line else ""))
            return 2
        if isinstance(exc, (UsageError, ModelError, FileNotFoundError, IsADirectoryError,
                            ValueError)):
            _err(f"error: {exc}")
            return 2
        if isinstance(exc, SpatialMBDError):
            _err(f"error: the analysis failed: {exc}")
            return 1
        if isinstance(exc, OSError):
            _err(f"error: {exc}")
            return 2
        if os.environ.get(INTERPRETED_ENV):         # the compiled run of the parent decides
            return INTERPRETED_FAILED
        raise


if __name__ == "__main__":                                          # pragma: no cover
    sys.exit(main())
