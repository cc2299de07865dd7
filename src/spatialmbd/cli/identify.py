"""`spatialmbd identify`: fit parameters of a model file to measured time series
(spatialmbd.design.identify does the work).

    spatialmbd identify model.yaml --data rig.csv --param bodies.link.mass \\
        --param forces.damper.damping --noise 0.01 -o fit.yaml
"""
from __future__ import annotations

import pathlib

from . import common

MODEL_SUFFIXES = (".yaml", ".yml", ".json")


def add_parser(command) -> None:
    p = command("identify", "fit model parameters to measured time series (least squares)",
                "Fit the parameters PATH of MODEL to the measured columns of --data (a CSV "
                "with a time column t in seconds and result columns such as pendulum.wx or "
                "pivot.angle) by least squares, and write the fitted model file (-o) and a "
                "report: estimates with standard errors, correlations, identifiability "
                "warnings. A PATH is a model value (bodies.link.mass, "
                "forces.damper.damping, bodies.link.angular_velocity.0), optionally with a "
                "start value PATH=START and bounds PATH=START:LOW:HIGH.",
                """
                spatialmbd identify pendulum_damped.yaml --data rig.csv \\
                    --param bodies.pendulum.mass --param forces.pivot_damper.damping \\
                    --noise 0.01 -o fit.yaml --plot residuals.png
                """)
    p.add_argument("model", metavar="MODEL", help="model file (.yaml, .yml or .json)")
    p.add_argument("--data", required=True, action="append", metavar="CSV",
                   help="measurements (repeatable: several experiments of the same model)")
    p.add_argument("--param", "-p", action="append", required=True,
                   metavar="PATH[=START[:LOW:HIGH]]", help="a fitted parameter (repeatable)")
    p.add_argument("--output", action="append", metavar="COLUMN",
                   help="a data column to fit (repeatable; default every column but t)")
    p.add_argument("--noise", type=common.positive, metavar="SIGMA",
                   help="noise level of the measurements (their units): standard errors "
                        "from it instead of the residual variance")
    p.add_argument("--loss", default="linear",
                   choices=("linear", "soft_l1", "huber", "cauchy", "arctan"),
                   help="robust loss of SciPy's least_squares (default linear)")
    p.add_argument("--jacobian", default="auto", choices=("auto", "adjoint", "forward", "fd"),
                   help="adjoint, forward sensitivities or central differences (default "
                        "auto: docs/design.md)")
    p.add_argument("--engine", choices=("simulate", "batch"), default="simulate",
                   help="how the runs are made (batch: members of a Jacobian together)")
    common.add_analysis_options(p)
    p.add_argument("-o", "--out", metavar="FILE",
                   help="fitted model file .yaml/.json (default <model stem>_fit.yaml)")
    p.add_argument("--report", metavar="FILE",
                   help="report text file (default next to the fitted model, .txt)")
    p.add_argument("--plot", metavar="FIG", help="residual plot .png/.svg/.pdf")
    p.add_argument("-q", "--quiet", action="store_true", help="no report on the terminal")
    p.set_defaults(func=cmd_identify)


def parse_param(item: str):
    """(path, start or None, (low, high) or None) of PATH[=START[:LOW:HIGH]]."""
    if "=" not in item:
        return item.strip(), None, None
    path, text = (s.strip() for s in item.split("=", 1))
    parts = text.split(":")
    try:
        if len(parts) == 1:
            return path, float(parts[0]), None
        if len(parts) == 3:
            return path, float(parts[0]), (float(parts[1]), float(parts[2]))
    except ValueError:
        pass
    raise common.UsageError(f"--param {item!r}: write PATH, PATH=START or "
                            "PATH=START:LOW:HIGH (e.g. bodies.link.mass=2:0.5:10)")


def params_and_bounds(items):
    params, bounds = {}, {}
    for item in items:
        path, start, pair = parse_param(item)
        if path in params:
            raise common.UsageError(f"--param {path!r} given twice")
        params[path] = start
        if pair is not None:
            bounds[path] = pair
    return params, bounds


def out_path(args, suffix: str) -> pathlib.Path:
    out = pathlib.Path(args.out) if args.out else \
        pathlib.Path(pathlib.Path(args.model).stem + suffix)
    if out.suffix.lower() not in MODEL_SUFFIXES:
        raise common.UsageError(f"output file {str(out)!r}: use .yaml, .yml or .json")
    if not (out.parent if str(out.parent) else pathlib.Path(".")).is_dir():
        raise common.UsageError(f"output file {str(out)!r}: directory does not exist")
    return out


def cmd_identify(args) -> int:
    from ..design import identify
    _, analysis = common.load(args.model)
    analysis, notes = common.apply_overrides(analysis, args)
    params, bounds = params_and_bounds(args.param)
    out = out_path(args, "_fit.yaml")
    for d in args.data:
        if not pathlib.Path(d).is_file():
            raise common.UsageError(f"--data {d!r}: no such file")
    kwargs = dict(outputs=args.output, noise=args.noise, bounds=bounds, loss=args.loss,
                  analysis=analysis.to_dict(), jacobian=args.jacobian, engine=args.engine)
    if len(args.data) == 1:
        fit = identify(args.model, args.data[0], params, **kwargs)
    else:
        fit = identify(args.model, None, params, experiments=[({}, d) for d in args.data],
                       **kwargs)
    fit.write_model(out)
    report = pathlib.Path(args.report) if args.report else out.with_suffix(".txt")
    report.write_text(fit.report() + "\n", encoding="utf-8")
    if args.plot:
        fit.plot_residuals(args.plot)
    if not args.quiet:
        for note in notes:
            print(f"note: {note}")
        print(fit.report())
        print(f"fitted model written to {out}; report to {report}"
              + (f"; residual plot to {args.plot}" if args.plot else ""))
    return 0 if fit.success else 1
