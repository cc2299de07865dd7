"""The summary plot of a sweep (written by `spatialmbd sweep`): one panel per scalar output."""
from __future__ import annotations

import json
import pathlib

import numpy as np


def log_spaced(values) -> bool:
    """True for at least three distinct positive values spaced evenly in log, not in linear
    (start:stop:count:log, numpy.geomspace): the summary plot gives them a log axis."""
    u = np.unique(np.asarray(values, dtype=float))
    u = u[np.isfinite(u)]
    if u.size < 3 or u[0] <= 0:
        return False
    step, logstep = np.diff(u), np.diff(np.log(u))
    return bool(np.allclose(logstep, logstep.mean(), rtol=1e-6)
                and not np.allclose(step, step.mean(), rtol=1e-6))


def summary_plot(ds, path) -> pathlib.Path:
    """One panel per scalar output against the first parameter (one line per value of the
    other grid parameters, at most eight; points and samples as markers), on a log axis when
    the parameter's values are log-spaced (:func:`log_spaced`); failed members as red crosses
    on the axis."""
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
    log_x = log_spaced(table[x].to_numpy())
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
        if log_x:
            ax.set_xscale("log")
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.suptitle(f"sweep of {ds.attrs.get('model', 'model')}: {ds.attrs['n_members']} members, "
                 f"{ds.attrs['n_failed']} failed", fontsize=10)
    fig.tight_layout()
    from ..atomic import atomic_write
    path = pathlib.Path(path)
    try:
        with atomic_write(path) as tmp:
            fig.savefig(tmp, format=path.suffix.lower().lstrip(".") or "png", dpi=110)
    finally:
        plt.close(fig)
    return path
