"""Helpers shared by the commands: the usage error, loading a model file (or an MJCF/URDF
file, imported in memory), the analysis options and their overrides, running an analysis and
its summary, output paths."""
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

from ..atomic import check_writable


class UsageError(Exception):
    """Bad command-line input (exit status 2)."""


class Formatter(argparse.RawDescriptionHelpFormatter):
    def __init__(self, prog):
        super().__init__(prog, max_help_position=32)


def epilog(text: str) -> str:
    return "examples:\n" + textwrap.indent(textwrap.dedent(text).strip("\n"), "  ")


def model_file_error():
    try:
        from ..io.modelfile import ModelFileError
        return ModelFileError
    except ImportError:                                           # pragma: no cover
        return ()


def err(*lines: str) -> None:
    for line in lines:
        print(line, file=sys.stderr)


def load(path: str, external_files: bool = True, **import_options):
    """(Model, Analysis) of a model file, or of an MJCF/URDF file imported in memory (with the
    default analysis; ``import_options``: strict, verbose, quiet of :func:`import_file`); file
    problems raise ModelFileError / UsageError. external_files=False: a model file naming
    files outside its folder is refused (--no-external-files)."""
    p = pathlib.Path(path)
    if not p.exists():
        raise UsageError(f"no such model file: {path}")
    if p.is_dir():
        raise UsageError(f"{path} is a directory, not a model file")
    if p.suffix.lower() in MJCF_SUFFIXES:        # MJCF / URDF: imported, default analysis
        from ..io.modelfile import load_model, model_to_dict
        builder = import_file(p, **import_options)
        return load_model(model_to_dict(builder, meshes="arrays"))
    from ..io.modelfile import load_model
    return load_model(p, external_files=external_files)


MJCF_SUFFIXES = (".xml", ".mjcf", ".urdf")


def import_options(args, path) -> dict:
    """The import options of the command line (--strict, --verbose, -q) for an MJCF/URDF
    ``path``; for a model file only --no-external-files."""
    if pathlib.Path(path).suffix.lower() not in MJCF_SUFFIXES:
        return {"external_files": False} if getattr(args, "no_external_files", False) else {}
    return dict(strict=bool(getattr(args, "strict", False)),
                verbose=bool(getattr(args, "verbose", False)),
                quiet=bool(getattr(args, "quiet", False)),
                keyframe=getattr(args, "keyframe", None),
                contacts=bool(getattr(args, "contacts", False)))


def add_import_options(parser: argparse.ArgumentParser, model_files: bool = True) -> None:
    """--strict, --verbose (and the accepted no-op --lenient) of MJCF/URDF imports."""
    g = parser.add_argument_group("MJCF/URDF import" + (" (when the input is a .xml or .urdf "
                                                        "file)" if model_files else ""))
    g.add_argument("--strict", action="store_true",
                   help="refuse features with no counterpart (tendons, actuators "
                        "with dynamics, ...) instead of leaving them out, and the "
                        "approximations (MuJoCo's soft limits and friction loss as force "
                        "laws) instead of making them")
    g.add_argument("--verbose", action="store_true",
                   help="list every feature left out or approximated, not only their counts")
    g.add_argument("--keyframe", metavar="NAME",
                   help="start from the file's keyframe NAME (its qpos, qvel and ctrl) "
                        "instead of qpos0 at rest")
    g.add_argument("--contacts", action="store_true",
                   help="make the colliding geom pairs contact elements (MuJoCo's filtering, "
                        "friction and margin; its soft contact as a linear law, "
                        "docs/import.md) instead of leaving them out")
    g.add_argument("--lenient", action="store_true", help=argparse.SUPPRESS)   # the default
    if model_files:
        parser.add_argument("--no-external-files", action="store_true",
                            help="an untrusted model: refuse files it names outside its own "
                                 "folder (meshes, sidecars, time series) before reading any; "
                                 "`spatialmbd info` lists them")


def import_file(path, strict: bool = False, verbose: bool = False, quiet: bool = False,
                keyframe=None, contacts: bool = False):
    """ModelBuilder of an MJCF/URDF file (from its keyframe ``keyframe`` if given). What is
    left out is summarised on stderr in one line (counts per kind; every feature with
    ``verbose``); ``strict``: refused instead."""
    from ..importers import read_mjcf
    from ..importers.mjcf.report import details
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        imported = read_mjcf(path, strict=strict, keyframe=keyframe, contacts=contacts)
    approximated = getattr(imported, "approximated", [])
    if (imported.left_out or approximated) and not (quiet and not verbose):
        name = pathlib.Path(path).name
        parts = ([f"left out of {name}: {imported.summary}"] if imported.left_out else []) + (
            [f"approximated{'' if imported.left_out else ' in ' + name}: "
             f"{imported.approximation_summary}"] if approximated else [])
        err("note: " + "; ".join(parts)
            + ("" if verbose else " (--verbose lists them; --strict refuses the "
                                  "approximations and those with no exact counterpart)"))
    if verbose:
        for line in details(imported.left_out) + details(approximated):
            err(f"  {line}")
    for w in caught:
        text = str(w.message)
        if not text.startswith(("left out:", "approximated:")):
            err(f"warning: {text}")
    return imported.builder


def check_name(kind: str, name: str) -> str:
    if kind == "method":
        from ..dynamics.base import ALIASES, METHODS
        key = ALIASES.get(name.lower(), name.lower())
        if key not in METHODS and key != "auto":
            raise UsageError(f"unknown method {name!r}; valid names: auto, "
                             + ", ".join(sorted(METHODS)))
    else:
        from ..integrators import INTEGRATORS
        if name.lower() not in INTEGRATORS:
            raise UsageError(f"unknown integrator {name!r}; valid names: "
                             + ", ".join(sorted(INTEGRATORS)))
    return name


def name_of(value) -> Optional[str]:
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, dict):
        return value.get("name")
    return getattr(value, "name", None)


def positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value > 0 or value != value or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def add_analysis_options(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("analysis options (override the model file's analysis)")
    g.add_argument("--method", metavar="M",
                   help="formulation: auto (the default: recursive for open trees, else "
                        "projection), standard, baumgarte, penalty, augmented_lagrangian, "
                        "projection, recursive (joint coordinates of open trees)")
    g.add_argument("--integrator", metavar="I",
                   help="euler, heun, rk4, abm4, bdf4, rk45, dop853, or a SciPy solver: "
                        "scipy-rk45, scipy-dop853, scipy-radau, scipy-bdf, scipy-lsoda")
    g.add_argument("--t-end", type=positive, metavar="T", help="end time [s]")
    g.add_argument("--step", type=positive, metavar="H",
                   help="step size [s] of euler, heun and rk4 (initial step of abm4 and "
                        "bdf4)")
    g.add_argument("--rtol", type=positive, metavar="R", help="relative tolerance")
    g.add_argument("--atol", type=positive, metavar="A", help="absolute tolerance")
    g.add_argument("--output-step", type=positive, metavar="DT",
                   help="interval between output times [s]")


def integrator_parameters(name: str) -> set:
    from ..integrators import INTEGRATORS
    cls = INTEGRATORS[name.lower()]
    return set(inspect.signature(cls.__init__).parameters) - {"self"}


def apply_overrides(analysis, args):
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
        check_name("method", args.method)
        old = name_of(analysis.method)
        changes["method"] = args.method
        if (old or "").lower() != args.method.lower() and analysis.method_options:
            changes["method_options"] = {}
            notes.append(f"method options {analysis.method_options} of {old!r} not used with "
                         f"{args.method!r}")
    if args.integrator is not None:
        check_name("integrator", args.integrator)
        old = name_of(analysis.integrator)
        changes["integrator"] = args.integrator
        if (old or "").lower() != args.integrator.lower():
            # the file's settings for its own integrator: keep those the new one takes
            accepted = integrator_parameters(args.integrator)
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


def run_analysis(model, analysis, progress: bool, budget=None, stream=None):
    """Run; return (results, wall time, warning texts). The estimate of a long run's work
    (budget.WorkEstimate) is printed as a note when it comes, before the run."""
    from ..budget import WorkEstimate
    if any(c.get("type") == "fmu" for c in getattr(analysis, "controllers", None) or []):
        try:                                  # registers the fmu controller type
            from ..fmi import controller as _fmu_controllers  # noqa: F401
        except ImportError as exc:
            raise UsageError(f"the analysis names FMU controllers, which need the extra "
                             f"spatialmbd[fmi] (pip install 'spatialmbd[fmi]'): {exc}") from None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        record = warnings.showwarning

        def show(message, category, *rest, **kwargs):
            if issubclass(category, WorkEstimate):
                err(f"note: {message}")
            else:
                record(message, category, *rest, **kwargs)
        warnings.showwarning = show
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


def is_kinematic(results) -> bool:
    return hasattr(results, "newton_iterations")


def summary(results, wall: float, warning_texts: Sequence[str]) -> str:
    if is_kinematic(results):
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


def output_paths(args, stem: str, default_suffix: str, allowed: Sequence[str]) -> list:
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
        check_writable(out)        # a read-only folder, /proc: refused before any work
    return outs


def failure_line(results, t=None) -> str:
    if t is None:
        t = results.t[-1] if len(results.t) else float("nan")
    return (f"error: the analysis failed; results up to t = {t:.6g} s were written. "
            f"{results.message}").rstrip()


# ----------------------------------------------------------------------------------------------
# commands


def non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {text!r}")
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text!r}")
    return value
