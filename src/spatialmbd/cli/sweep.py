"""`spatialmbd sweep`: a parameter sweep of a model file (spatialmbd.sweep does the work).

    spatialmbd sweep model.yaml --param bodies.link.mass=1:10:10 \\
        --output 'max(link.z)' --output 'period(link.wx)' --scheduler tcp://host:8786 -o sweep.nc
"""
from __future__ import annotations

import pathlib
import sys

from ..atomic import check_writable
from . import common

SWEEP_SUFFIXES = (".nc", ".csv", ".parquet")
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


def add_parser(command) -> None:
    p = command("sweep", "run a parameter sweep of a model file (serial, processes or Dask)",
                "Run MODEL once per member of a parameter sweep and write one labelled result "
                "(.nc: netCDF with one dimension per parameter; .csv/.parquet: a tidy table), "
                "with a status and message per member (failing members are recorded, never "
                "fatal) and a summary plot. A PARAM is PATH=VALUES: PATH addresses a value of "
                "the model file (bodies.link.mass, joints.pivot.axis.0, forces.spring.stiffness,"
                " bodies.link.angular_velocity.0, gravity.2) or of its analysis "
                "(analysis.t_end, analysis.integrator.rtol); VALUES is start:stop:count, "
                "start:stop:count:log or v1,v2,...; several --param make a grid (or, with "
                "--lhs N, N Latin-hypercube samples between the first and last value; with "
                "--zip, one member per value, all parameters together). Paths joined by "
                "commas (PATH1,PATH2=VALUES) vary together, with the same values. The paths "
                "and columns of a model: spatialmbd info MODEL; they are checked, with the "
                "extras the scheduler needs, before any member runs. An "
                "OUTPUT is reduction(column) with reduction max, min, absmax, final, initial, "
                "mean, rms (of the samples), peak, trough (between the samples, for smooth "
                "columns) or period (zero crossings), or a column for its whole time series.",
                """
                spatialmbd sweep pendulum.yaml --param bodies.pendulum.mass=1:10:10 \\
                    --output 'period(pendulum.wx)' -o sweep.nc
                spatialmbd sweep governor.yaml --param forces.spring_A.stiffness=1e4:1e6:5:log \\
                    --output 'final(slider.z)' --scheduler dask --workers 2 -o k.csv
                spatialmbd sweep flyball_governor.yaml \\
                    --param forces.spring_A.stiffness,forces.spring_B.stiffness=2e4:8e5:5:log \\
                    --output 'final(slider.z)' -o flyball.nc
                spatialmbd sweep model.yaml --param bodies.link.mass=1:2:2 \\
                    --param analysis.integrator.rtol=1e-6,1e-8 --output 'max(link.z)' \\
                    --scheduler tcp://scheduler:8786 -o sweep.parquet
                """)
    p.add_argument("model", metavar="MODEL", help="model file (.yaml, .yml or .json)")
    p.add_argument("--param", "-p", action="append", required=True, metavar="PATH=VALUES",
                   help="a swept value (repeatable)")
    p.add_argument("--output", action="append", required=True, metavar="OUTPUT",
                   help="what to keep of each member (repeatable)")
    p.add_argument("--lhs", type=int, metavar="N",
                   help="N Latin-hypercube samples within each parameter's range instead of "
                        "the grid")
    p.add_argument("--seed", type=int, default=0, help="seed of --lhs (default 0)")
    p.add_argument("--zip", action="store_true",
                   help="vary every --param together (member k takes the k-th value of each; "
                        "equal counts) instead of the grid")
    p.add_argument("--scheduler", default="auto", metavar="S",
                   help="serial, processes, dask (a local cluster), a scheduler address "
                        "tcp://host:8786, or auto (default: serial below 16 members, else "
                        "dask when installed)")
    p.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of processes/dask (default: the number of cores; "
                        "at most min(cores, members) are started)")
    p.add_argument("--max-members", type=int, metavar="N",
                   help="the most members allowed (default 1,000,000; a larger grid or --lhs "
                        "is refused before anything is allocated)")
    p.add_argument("--engine", choices=("simulate", "batch"), default="simulate",
                   help="batch: integrate the members of a chunk together in one compiled "
                        "call (methods auto, standard, baumgarte, projection, recursive; "
                        "rk45, dop853 or rk4; fully compiled models without drivers)")
    p.add_argument("--chunk-size", type=int, metavar="N", help="members per task")
    common.add_analysis_options(p)
    p.add_argument("-o", "--out", action="append", metavar="FILE",
                   help="result file .nc, .csv or .parquet (repeatable; default "
                        "<model stem>_sweep.nc)")
    p.add_argument("--plot", metavar="FIG",
                   help="summary plot .png/.svg/.pdf (default <first output stem>.png; "
                        "'none' for no plot)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=cmd_sweep)


def _params(args, usage_error):
    """The parameter space of the command line: a grid of the --param groups (a group of
    paths joined by commas varies together), their --zip (all groups together, member k
    taking the k-th values) or --lhs samples."""
    import itertools
    import math

    import numpy as np

    from ..sweep.limits import check_members
    from ..sweep.params import ParameterSpace, grid, latin_hypercube, parse_range
    groups, seen = [], set()
    for item in args.param:
        if "=" not in item:
            raise usage_error(f"--param {item!r}: write PATH=VALUES, e.g. "
                              "bodies.link.mass=1:10:10 (or PATH1,PATH2=VALUES for paths "
                              "varied together)")
        paths, text = item.split("=", 1)
        paths = [p.strip() for p in paths.split(",")]
        if not all(paths):
            raise usage_error(f"--param {item!r}: an empty path; separate linked paths by "
                              "commas, e.g. forces.a.stiffness,forces.b.stiffness=1e4:1e6:5")
        for path in paths:
            if path in seen:
                raise usage_error(f"--param {path!r} given twice")
            seen.add(path)
        groups.append((paths, parse_range(text, paths[0], args.max_members)))
    if args.lhs is not None:
        if args.lhs < 1:
            raise usage_error(f"--lhs must be >= 1, got {args.lhs}")
        if args.zip:
            raise usage_error("--lhs and --zip exclude each other")
        bounds = {}
        for paths, v in groups:
            if v.size < 2 or v.min() == v.max():
                raise usage_error(f"--lhs: parameter {paths[0]!r} needs a range (low:high:n)")
            bounds[paths[0]] = (float(v.min()), float(v.max()))
        space = latin_hypercube(bounds, args.lhs, args.seed, args.max_members)
        return _linked(space, groups)
    if args.zip:
        sizes = {paths[0]: v.size for paths, v in groups}
        if len(set(sizes.values())) != 1:
            raise usage_error(f"--zip: every --param needs the same number of values, got "
                              f"{sizes}")
        names = [p for paths, _ in groups for p in paths]
        cols = [v for paths, v in groups for _ in paths]
        return ParameterSpace(names, np.column_stack(cols), "points")
    if all(len(paths) == 1 for paths, _ in groups):
        return grid({paths[0]: v for paths, v in groups}, args.max_members)
    sizes = [v.size for _, v in groups]
    check_members(math.prod(sizes), len(seen), "a grid of " + " x ".join(map(str, sizes))
                  + " values", args.max_members)
    rows = [[x for (paths, _), x in zip(groups, combo) for _ in paths]
            for combo in itertools.product(*(v for _, v in groups))]
    return ParameterSpace([p for paths, _ in groups for p in paths],
                          np.array(rows, dtype=float), "points")


def _linked(space, groups):
    """The space of the groups' first paths with every linked path as a copy of its group's
    first column."""
    import numpy as np

    from ..sweep.params import ParameterSpace
    names, cols = [], []
    for j, (paths, _) in enumerate(groups):
        for p in paths:
            names.append(p)
            cols.append(space.values[:, j])
    return ParameterSpace(names, np.column_stack(cols), space.kind)


def cmd_sweep(args) -> int:
    from ..sweep.core import save_result, sweep
    from ..sweep.plot import summary_plot
    model_path = pathlib.Path(args.model)
    model, analysis = common.load(args.model)
    analysis, notes = common.apply_overrides(analysis, args)
    space = _params(args, common.UsageError)
    outs = [pathlib.Path(o) for o in (args.out or [])] or \
        [pathlib.Path(model_path.stem + "_sweep.nc")]
    for out in outs:
        if out.suffix.lower() not in SWEEP_SUFFIXES:
            raise common.UsageError(f"output file {str(out)!r}: the name must end in .nc, .csv "
                                    "or .parquet")
        if not (out.parent if str(out.parent) else pathlib.Path(".")).is_dir():
            raise common.UsageError(f"output file {str(out)!r}: directory does not exist")
        check_writable(out)        # a read-only folder, /proc: refused before the sweep runs
        if out.suffix.lower() == ".parquet":
            try:
                import pyarrow  # noqa: F401
            except ImportError:
                raise common.UsageError(f"output file {str(out)!r}: parquet needs pyarrow "
                                        "(pip install pyarrow); or write .nc or .csv") from None
    plot = None if (args.plot or "").lower() == "none" else \
        pathlib.Path(args.plot) if args.plot else outs[0].with_suffix(".png")
    if plot is not None and plot.suffix.lower() not in PLOT_SUFFIXES:
        raise common.UsageError(f"--plot {str(plot)!r}: use .png, .svg or .pdf")
    if plot is not None:
        check_writable(plot)
    if not args.quiet:
        for note in notes:
            print(f"note: {note}")
    import warnings

    from ..sweep.limits import SweepNote
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SweepNote)      # said here, before the sweep starts
        workers = args.workers
        if workers is not None and args.scheduler in ("processes", "dask", "auto"):
            from ..sweep.limits import cap_workers
            workers, note = cap_workers(workers, space.n_members)
            if note:
                common.err(f"note: {note}")
        ds = sweep(str(model_path), space, args.output, analysis, args.scheduler,
                   engine=args.engine, chunk_size=args.chunk_size, workers=workers,
                   progress=False if args.quiet else None, max_members=args.max_members)
    for out in outs:
        save_result(ds, out)
    if plot is not None:
        summary_plot(ds, plot)
    n, failed = int(ds.attrs["n_members"]), int(ds.attrs["n_failed"])
    if not args.quiet:
        print(f"{n} members ({n - failed} succeeded, {failed} failed) in "
              f"{ds.attrs['wall_time']:.3g} s, scheduler {ds.attrs['scheduler']}, engine "
              f"{ds.attrs['engine']}")
        for out in outs:
            print(f"sweep written to {out}")
        if plot is not None:
            print(f"summary plot written to {plot}")
    if failed:
        msgs = ds["message"].values.ravel()[ds["status"].values.ravel() != "success"]
        print(f"warning: {failed} member(s) failed; first: {msgs[0]}", file=sys.stderr)
    return 1 if failed == n else 0
