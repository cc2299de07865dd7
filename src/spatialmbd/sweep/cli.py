"""The ``spatialmbd sweep`` command (registered by :func:`spatialmbd.cli.build_parser`).

    spatialmbd sweep model.yaml --param bodies.link.mass=1:10:10 \\
        --output 'max(link.z)' --output 'period(link.wx)' --scheduler tcp://host:8786 -o sweep.nc
"""
from __future__ import annotations

import json
import pathlib
import sys

import numpy as np

SWEEP_SUFFIXES = (".nc", ".csv", ".parquet")
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


def add_parser(command, add_analysis_options) -> None:
    """Add the ``sweep`` sub-command through the CLI's ``command`` helper."""
    p = command("sweep", "run a parameter sweep of a model file (serial, processes or Dask)",
                "Run MODEL once per member of a parameter sweep and write one labelled result "
                "(.nc: netCDF with one dimension per parameter; .csv/.parquet: a tidy table), "
                "with a status and message per member (failing members are recorded, never "
                "fatal) and a summary plot. A PARAM is PATH=VALUES: PATH addresses a value of "
                "the model file (bodies.link.mass, joints.pivot.axis.0, forces.spring.stiffness,"
                " bodies.link.angular_velocity.0, gravity.2) or of its analysis "
                "(analysis.t_end, analysis.integrator.rtol); VALUES is start:stop:count, "
                "start:stop:count:log or v1,v2,...; several --param make a grid (or, with "
                "--lhs N, N Latin-hypercube samples between the first and last value). An "
                "OUTPUT is reduction(column) with reduction max, min, absmax, final, initial, "
                "mean, rms (of the samples), peak, trough (between the samples, for smooth "
                "columns) or period (zero crossings), or a column for its whole time series.",
                """
                spatialmbd sweep pendulum.yaml --param bodies.pendulum.mass=1:10:10 \\
                    --output 'period(pendulum.wx)' -o sweep.nc
                spatialmbd sweep governor.yaml --param forces.spring_A.stiffness=1e4:1e6:5:log \\
                    --output 'final(slider.z)' --scheduler dask --workers 2 -o k.csv
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
    p.add_argument("--scheduler", default="auto", metavar="S",
                   help="serial, processes, dask (a local cluster), a scheduler address "
                        "tcp://host:8786, or auto (default: serial below 16 members, else "
                        "dask when installed)")
    p.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of processes/dask (default: the number of cores)")
    p.add_argument("--engine", choices=("simulate", "batch"), default="simulate",
                   help="batch: integrate the members of a chunk together in one compiled "
                        "call (methods auto, standard, baumgarte, projection, recursive; "
                        "rk45, dop853 or rk4; fully compiled models without drivers)")
    p.add_argument("--chunk-size", type=int, metavar="N", help="members per task")
    add_analysis_options(p)
    p.add_argument("-o", "--out", action="append", metavar="FILE",
                   help="result file .nc, .csv or .parquet (repeatable; default "
                        "<model stem>_sweep.nc)")
    p.add_argument("--plot", metavar="FIG",
                   help="summary plot .png/.svg/.pdf (default <first output stem>.png; "
                        "'none' for no plot)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    p.set_defaults(func=cmd_sweep)


def _params(args, usage_error):
    from .params import grid, latin_hypercube, parse_range
    values = {}
    for item in args.param:
        if "=" not in item:
            raise usage_error(f"--param {item!r}: write PATH=VALUES, e.g. "
                              "bodies.link.mass=1:10:10")
        path, text = item.split("=", 1)
        path = path.strip()
        if path in values:
            raise usage_error(f"--param {path!r} given twice")
        values[path] = parse_range(text, path)
    if args.lhs is not None:
        if args.lhs < 1:
            raise usage_error(f"--lhs must be >= 1, got {args.lhs}")
        bounds = {}
        for path, v in values.items():
            if v.size < 2 or v.min() == v.max():
                raise usage_error(f"--lhs: parameter {path!r} needs a range (low:high:n)")
            bounds[path] = (float(v.min()), float(v.max()))
        return latin_hypercube(bounds, args.lhs, args.seed)
    return grid(values)


def cmd_sweep(args) -> int:
    from .. import cli
    from .core import save_result, sweep
    model_path = pathlib.Path(args.model)
    model, analysis = cli._load(args.model)
    analysis, notes = cli._apply_overrides(analysis, args)
    space = _params(args, cli.UsageError)
    outs = [pathlib.Path(o) for o in (args.out or [])] or \
        [pathlib.Path(model_path.stem + "_sweep.nc")]
    for out in outs:
        if out.suffix.lower() not in SWEEP_SUFFIXES:
            raise cli.UsageError(f"output file {str(out)!r}: the name must end in .nc, .csv "
                                 "or .parquet")
        if not (out.parent if str(out.parent) else pathlib.Path(".")).is_dir():
            raise cli.UsageError(f"output file {str(out)!r}: directory does not exist")
    plot = None if (args.plot or "").lower() == "none" else \
        pathlib.Path(args.plot) if args.plot else outs[0].with_suffix(".png")
    if plot is not None and plot.suffix.lower() not in PLOT_SUFFIXES:
        raise cli.UsageError(f"--plot {str(plot)!r}: use .png, .svg or .pdf")
    if not args.quiet:
        for note in notes:
            print(f"note: {note}")
    ds = sweep(str(model_path), space, args.output, analysis, args.scheduler,
               engine=args.engine, chunk_size=args.chunk_size, workers=args.workers,
               progress=False if args.quiet else None)
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


def summary_plot(ds, path) -> pathlib.Path:
    """One panel per scalar output against the first parameter (one line per value of the
    other grid parameters, at most eight; points and samples as markers); failed members as
    red crosses on the axis."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from .core import to_dataframe
    names = json.loads(ds.attrs["parameters"])
    outputs = [o for o in json.loads(ds.attrs["outputs"]) if "time" not in ds[o].dims]
    series = [o for o in json.loads(ds.attrs["outputs"]) if "time" in ds[o].dims]
    panels = outputs + series[:2]
    if not panels:
        panels = ["status"]
    fig, axes = plt.subplots(len(panels), 1, figsize=(6.4, 2.6 * len(panels)), squeeze=False)
    table = to_dataframe(ds[[v for v in ds.data_vars if "time" not in ds[v].dims]])
    x = names[0]
    grid = ds.attrs.get("space") == "grid"
    for ax, name in zip(axes[:, 0], panels):
        if name in series:
            da = ds[name].stack(member=names) if grid else ds[name]
            for k in range(min(8, da.sizes["member"])):
                ax.plot(ds["time"], da.isel(member=k), lw=1)
            ax.set_xlabel("time [s]")
            ax.set_ylabel(name)
            continue
        ok = table["status"] == "success"
        if name == "status":
            ax.plot(table[x], ok.astype(int), "o")
        elif grid and len(names) > 1:
            others = names[1:]
            for key, part in list(table[ok].groupby(others))[:8]:
                label = ", ".join(f"{n}={v:g}" for n, v in
                                  zip(others, key if isinstance(key, tuple) else (key,)))
                ax.plot(part[x], part[name], "o-", ms=3, label=label)
        else:
            ax.plot(table[x][ok], table[name][ok], "o-" if grid else "o", ms=3)
        bad = table[~ok]
        if len(bad):
            ax.plot(bad[x], np.zeros(len(bad)), "x", color="red", label="failed")
        ax.set_xlabel(x)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.suptitle(f"sweep of {ds.attrs.get('model', 'model')}: {ds.attrs['n_members']} members, "
                 f"{ds.attrs['n_failed']} failed", fontsize=10)
    fig.tight_layout()
    path = pathlib.Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
