"""`spatialmbd plot`: plots of results files."""
from __future__ import annotations

import argparse
import pathlib
import sys
import warnings

from . import common


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


#: inputs that are models (run first, with the analysis options), not results files
MODEL_SUFFIXES = (".yaml", ".yml", ".json") + common.MJCF_SUFFIXES


def _run(path, args):
    """The results of the analysis of a model file or an MJCF/URDF file (imported in memory)."""
    model, analysis = common.load(path, **common.import_options(args, path))
    analysis, notes = common.apply_overrides(analysis, args)
    quiet = getattr(args, "quiet", False)
    if not quiet:
        for note in notes:
            print(f"note: {note}")
    results, wall, warning_texts = common.run_analysis(model, analysis, progress=not quiet)
    if not quiet:
        print(common.summary(results, wall, warning_texts))
    return results


def cmd_plot(args) -> int:
    from ..io.results_io import load_results
    from ..plotting import plot_results
    for path in args.results:
        if not pathlib.Path(path).exists():
            raise common.UsageError(f"no such results file: {path}")
    outs = common.output_paths(args, pathlib.Path(args.results[0]).stem, ".png",
                               (".png", ".svg", ".pdf"))
    loaded = [_run(p, args) if pathlib.Path(p).suffix.lower() in MODEL_SUFFIXES
              else load_results(p) for p in args.results]
    labels = args.labels or ([pathlib.Path(p).stem for p in args.results]
                             if len(loaded) > 1 else None)
    if labels is not None and len(labels) != len(loaded):
        raise common.UsageError(f"{len(labels)} --labels for {len(loaded)} results files")
    log = True if args.log else (False if args.linear else None)
    fig = plot_results(loaded if len(loaded) > 1 else loaded[0], args.quantity or None,
                       labels=labels, log=log, title=args.title, x=args.x)
    from ..plotting import save_figure
    for out in outs:
        save_figure(fig, out)
        if not args.quiet:
            print(f"figure written to {out}")
    return 0


def add_parser(command) -> None:
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
    p.add_argument("results", nargs="+", metavar="RESULTS",
                   help="results file(s), .h5 or .csv; or a model file (.yaml, .json) or an "
                        "MJCF/URDF file (.xml, .urdf), whose analysis is run first")
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
    common.add_analysis_options(p)
    common.add_import_options(p)
    p.set_defaults(func=cmd_plot, quantity=None)
