"""Time plots of results with matplotlib (Agg canvas, no pyplot state, no display needed).

Quantities are columns of the results table (:func:`spatialmbd.io.results_io.to_dataframe`):
``pendulum.z``, ``pivot.pendulum.fz``, ``energy.error``, ``violation.position`` ... Shell-style
patterns select several (``pendulum.*``, ``*.fz``, ``link?.z``), and a few shorthands exist:
a body name (its x, y, z), a joint name (its reaction forces on both bodies), ``energy``
(kinetic, gravitational, elastic and total energy) and ``violation`` (|Phi| and |D v - nu|).
The requested outputs (joint coordinates, spring forces, driver efforts ...; docs/outputs.md)
are columns too: ``pivot.angle``, ``spring.force``, ``motor.effort``.

The selected columns are grouped by kind (positions, velocities, forces, energy, ...; the
requested outputs by unit): one panel per kind, with the unit on its axis, all panels sharing
the horizontal axis: time, or any column given as ``x`` (phase plots, force against
deflection, a joint coordinate against the crank angle). Files are written
atomically; the format follows the extension: ``.png``, ``.svg`` or ``.pdf``.
"""
from __future__ import annotations

import fnmatch
import pathlib
from typing import Iterable, Optional, Sequence

import numpy as np

from .outputs.vocabulary import NAMED, STANDARD, column_units

__all__ = ["plot_results", "plot_violation", "select_columns", "save_figure", "FORMATS"]

FORMATS = (".png", ".svg", ".pdf")


def _pretty(unit: str) -> str:
    """A unit as an axis label shows it: m/s², - for a number."""
    return "-" if unit == "1" else unit.replace("^2", "²")


#: (kind key, axis label) by the last part of a column name, and of the columns named in full:
#: the output vocabulary's (:mod:`.outputs.vocabulary`)
_SUFFIX_KIND = {c: (what, f"{what} [{_pretty(unit)}]") for c, (what, unit) in STANDARD.items()}
_EXACT_KIND = {c: (c.replace(".", "_"), what if unit == "1" else f"{what} [{_pretty(unit)}]")
               for c, (what, unit) in NAMED.items() if c != "t" and not c.startswith("energy.")}
_EXACT_KIND["energy.error"] = ("energy_error", "energy balance error [J]")
_LOG_KINDS = {"violation_position", "violation_velocity", "violation_phi_squared"}


def _kind(column: str, units: Optional[dict] = None) -> tuple:
    """(panel key, axis label) of a column: the standard kinds by name, the requested outputs
    (docs/outputs.md) by their unit."""
    if column in _EXACT_KIND:
        return _EXACT_KIND[column]
    if column.startswith("energy."):
        return ("energy", "energy [J]")
    last = column.rsplit(".", 1)[-1]
    if column in (units or {}) and not (last in _SUFFIX_KIND and ".imu." not in column):
        unit = units[column]
        return ("unit:" + unit, f"[{_pretty(unit)}]")
    return _SUFFIX_KIND.get(last, ("other:" + column, column))


def _units(table) -> dict:
    return column_units(table.columns, getattr(table, "attrs", {}).get("units"))


def _table(results):
    """The DataFrame of Results, KinematicResults, LoadedResults or a DataFrame itself."""
    if hasattr(results, "columns") and hasattr(results, "to_numpy"):
        return results
    from .io.results_io import to_dataframe
    return to_dataframe(results)


def _shorthand(token: str, columns: Sequence[str]) -> list:
    if token == "energy":
        return [c for c in ("energy.kinetic", "energy.gravitational", "energy.elastic",
                            "energy.total") if c in columns]
    if token == "violation":
        return [c for c in ("violation.position", "violation.velocity") if c in columns]
    body = [f"{token}.{c}" for c in ("x", "y", "z")]
    if all(c in columns for c in body):
        return body
    reaction = [c for c in columns if c.startswith(token + ".") and c.count(".") == 2
                and c.rsplit(".", 1)[-1] in ("fx", "fy", "fz")]
    return reaction


def select_columns(columns: Sequence[str], quantities: Iterable[str]) -> list:
    """Columns named by ``quantities`` (exact names, glob patterns or shorthands), in order,
    without duplicates. Raises ValueError naming what matched nothing (with close matches)."""
    columns = [str(c) for c in columns]
    out: list = []
    missing = []
    for token in quantities:
        for part in (p.strip() for p in str(token).split(",")):
            if not part:
                continue
            if part in columns:
                found = [part]
            elif any(ch in part for ch in "*?["):
                found = [c for c in columns if fnmatch.fnmatchcase(c, part) and c != "t"]
            else:
                found = _shorthand(part, columns)
            if not found:
                missing.append(part)
            out.extend(c for c in found if c not in out)
    if missing:
        import difflib
        hints = []
        for m in missing:
            close = difflib.get_close_matches(m, columns, n=3, cutoff=0.5)
            hints.append(f"{m!r}" + (f" (did you mean {', '.join(close)}?)" if close else ""))
        raise ValueError("no results column matches " + "; ".join(hints)
                         + f". Columns: {_column_overview(columns)}")
    return out


def _column_overview(columns: Sequence[str]) -> str:
    heads = []
    for c in columns:
        head = c.split(".", 1)[0] + (".*" if "." in c else "")
        if head not in heads:
            heads.append(head)
    return ", ".join(heads)


def default_quantities(columns: Sequence[str]) -> list:
    """Body positions, energy balance error and position violation (what exists of them)."""
    out = [c for c in columns if c.count(".") == 1 and c.rsplit(".", 1)[-1] in "xyz"
           and not c.startswith(("energy.", "violation."))][:30]
    out += [c for c in ("energy.error", "violation.position") if c in columns]
    return out


def _new_figure(n_panels: int, width: float = 8.0, height: Optional[float] = None):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    height = height or max(3.0, min(2.4 * n_panels + 0.8, 24.0))
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def plot_results(results, quantities: Optional[Sequence[str]] = None, path=None, *,
                 labels: Optional[Sequence[str]] = None, log: Optional[bool] = None,
                 title: Optional[str] = None, x: Optional[str] = None):
    """Plot columns of one or several results against time (or against the column ``x``);
    return the Figure (and write it to ``path`` when given).

    results: Results, KinematicResults, LoadedResults or a DataFrame, or a list of them (the
        same quantities are then drawn for each, labelled by ``labels``).
    quantities: column names, patterns or shorthands (see the module docstring); default: body
        positions, energy error and position violation.
    log: logarithmic y axes for every panel (True), none (False) or only the constraint
        violation panels (None).
    x: the column on the horizontal axis (default "t"): any output against any other, e.g.
        a phase plot (``x="pivot.angle"``, quantities ``pivot.angle_rate``), force against
        deflection, a joint coordinate against the crank angle.
    """
    many = isinstance(results, (list, tuple))
    items = list(results) if many else [results]
    tables = [_table(r) for r in items]
    if labels is None:
        labels = [f"run {k + 1}" for k in range(len(items))] if many else [""]
    if len(labels) != len(tables):
        raise ValueError(f"{len(labels)} labels for {len(tables)} results")
    columns = list(tables[0].columns)
    if quantities:
        selected = select_columns(columns, quantities)
    else:
        selected = default_quantities(columns)
    if not selected:
        raise ValueError("nothing to plot: the results have no columns besides t")
    x = x or "t"
    if x != "t":
        found = select_columns(columns, [x])
        if len(found) != 1:
            raise ValueError(f"--x must name one column, {x!r} names {len(found)}: "
                             + ", ".join(found[:6]))
        x = found[0]
        selected = [c for c in selected if c != x] or selected
    for tab, lab in zip(tables[1:], labels[1:]):
        if x not in tab.columns:
            raise ValueError(f"results {lab!r} lack the x column {x!r}")
    for tab, lab in zip(tables[1:], labels[1:]):
        absent = [c for c in selected if c not in tab.columns]
        if absent:
            raise ValueError(f"results {lab!r} lack column(s) {', '.join(absent[:5])}")

    units = _units(tables[0])
    panels: dict = {}
    for c in selected:
        key, ylabel = _kind(c, units)
        panels.setdefault(key, (ylabel, []))[1].append(c)
    for key, (ylabel, cols) in list(panels.items()):
        if key.startswith("unit:"):                        # name the quantities of the panel
            names = list(dict.fromkeys(c.rsplit(".", 1)[-1] for c in cols))
            text = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")
            panels[key] = (f"{text} {ylabel}", cols)
    fig = _new_figure(len(panels))
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    styles = ["-", "--", ":", "-."]
    for ax, (key, (ylabel, cols)) in zip(axes, panels.items()):
        for k, (tab, lab) in enumerate(zip(tables, labels)):
            t = tab[x].to_numpy()
            for c in cols:
                name = f"{lab}: {c}" if lab else c
                ax.plot(t, tab[c].to_numpy(), styles[k % len(styles)], label=name, lw=1.2)
        use_log = log if log is not None else key in _LOG_KINDS
        if use_log:
            ax.set_yscale("log", nonpositive="mask")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small", loc="best", ncol=1 if len(cols) * len(tables) <= 6 else 2)
    if x == "t":
        axes[-1].set_xlabel("time t [s]")
    else:
        unit = units.get(x) or _kind(x, units)[1]
        axes[-1].set_xlabel(f"{x} [{unit}]" if x in units else f"{x} ({unit})")
    if title:
        fig.suptitle(title)
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_violation(results_list, labels: Optional[Sequence[str]] = None, path=None, *,
                   log: bool = True, quantity: str = "phi_squared",
                   title: Optional[str] = None, ax=None):
    """Constraint violation against time for several results on one axis (as Fig. 15.2).

    results_list: Results, KinematicResults, LoadedResults or DataFrames (a single one is
        accepted). quantity: "phi_squared" (Phi^T Phi, default), "position" (|Phi|) or
        "velocity" (|D v - nu|). log: logarithmic y axis (zeros are left out).
    ax: draw into this matplotlib Axes instead of a new figure.
    Returns the Figure; writes it to ``path`` when given.
    """
    if not isinstance(results_list, (list, tuple)):
        results_list = [results_list]
    if labels is None:
        labels = [str(getattr(r, "settings", {}).get("method", f"run {k + 1}"))
                  if isinstance(getattr(r, "settings", None), dict) else f"run {k + 1}"
                  for k, r in enumerate(results_list)]
    if len(labels) != len(results_list):
        raise ValueError(f"{len(labels)} labels for {len(results_list)} results")
    ylabels = {"phi_squared": "ΦᵀΦ", "position": "|Φ|", "velocity": "|D v − ν|"}
    if quantity not in ylabels:
        raise ValueError(f"quantity must be one of {', '.join(ylabels)}, got {quantity!r}")
    if ax is None:
        fig = _new_figure(1, height=4.5)
        ax = fig.subplots()
    else:
        fig = ax.figure
    for r, lab in zip(results_list, labels):
        t, y = _violation_series(r, quantity)
        ax.plot(t, y, label=str(lab), lw=1.2)
    if log:
        ax.set_yscale("log", nonpositive="mask")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(ylabels[quantity])
    ax.grid(True, which="both" if log else "major", alpha=0.3)
    ax.legend(fontsize="small")
    if title:
        ax.set_title(title)
    if path is not None:
        save_figure(fig, path)
    return fig


def _violation_series(results, quantity: str):
    """(t, violation) without building the whole table when the results can compute it."""
    if hasattr(results, "constraint_violation"):
        viol = results.constraint_violation()
        return np.asarray(results.t), viol[quantity]
    tab = _table(results)
    column = f"violation.{quantity}"
    if column not in tab.columns and quantity == "phi_squared" and \
            "violation.position" in tab.columns:
        return tab["t"].to_numpy(), tab["violation.position"].to_numpy() ** 2
    if column not in tab.columns:
        raise ValueError(f"the results have no column {column!r}")
    return tab["t"].to_numpy(), tab[column].to_numpy()


def save_figure(fig, path) -> pathlib.Path:
    """Write ``fig`` to ``path`` (PNG, SVG or PDF by the extension), atomically."""
    from .atomic import atomic_write
    path = pathlib.Path(path)
    fmt = path.suffix.lower()
    if fmt not in FORMATS:
        raise ValueError(f"cannot tell the figure format from {str(path)!r}: use a file name "
                         "ending in .png, .svg or .pdf")
    with atomic_write(path) as tmp:
        fig.savefig(tmp, format=fmt[1:], dpi=150)
    return path

