"""What a sweep checks before it runs any member: the optional packages its scheduler and result
need, every parameter path and every output column. A wrong key would otherwise fail each
member separately (a model-file error per member), and a missing package would be found only
after every member had run.

Each check raises one :class:`~spatialmbd.errors.ModelError` naming the bad path or column and
the closest valid names (all of them: ``spatialmbd info MODEL``, docs/sweeps.md).
"""
from __future__ import annotations

import inspect

import numpy as np

from ..errors import ModelError
from ..suggest import closest_first, suggest

#: the columns of a named point (:class:`.outputs.Columns`)
POINT_COLUMNS = ("x", "y", "z", "vx", "vy", "vz")
#: how many close names a message lists
SHOWN = 8


def check_packages(kind: str, needs_xarray: bool = True) -> None:
    """The packages of the scheduler ``kind`` ("dask": dask and distributed) and of the result
    (xarray), imported now; ModelError naming the extra to install."""
    if kind == "dask":
        try:
            import dask  # noqa: F401
            import distributed  # noqa: F401
        except ImportError as exc:
            raise ModelError(f"the Dask scheduler needs the dask extra ({exc.name} is not "
                             "installed): pip install 'spatialmbd[dask]' -- or use "
                             "scheduler 'processes' or 'serial'") from None
    if needs_xarray:
        try:
            import xarray  # noqa: F401
        except ImportError:
            raise ModelError("sweep results are xarray Datasets and xarray is not installed: "
                             "pip install 'spatialmbd[dask]' (or pip install xarray)") from None


def _close(word, names) -> str:
    order = closest_first(word, names)
    more = len(order) - SHOWN
    return ", ".join(order[:SHOWN]) + (f", ... ({more} more)" if more > 0 else "")


# ---------------------------------------------------------------------------- parameters
def check_factory_names(factory, names) -> None:
    """Parameter names of a factory (not analysis.*) are its keyword arguments."""
    try:
        sig = inspect.signature(factory)
    except (TypeError, ValueError):
        return
    params = sig.parameters
    if any(p.kind == p.VAR_KEYWORD for p in params.values()):
        return
    valid = [n for n, p in params.items() if p.kind in (p.POSITIONAL_OR_KEYWORD,
                                                        p.KEYWORD_ONLY)]
    for name in names:
        if not name.startswith("analysis.") and name not in valid:
            raise ModelError(f"parameter {name!r} is not a keyword argument of the factory "
                             f"{getattr(factory, '__name__', 'factory')}{suggest(name, valid)};"
                             f" its arguments: {_close(name, valid) or 'none'}")


def check_paths(data: dict, analysis: dict, names, values: np.ndarray) -> None:
    """Every path of a model-file sweep addresses a value of the file or of its analysis: an
    existing value, or a key the file accepts at that place (checked by reading the file with
    the first member's value there; the value itself is the member's business)."""
    from ..io.analysis import Analysis
    from ..io.modelfile import load_model
    from .params import get_path, plain_copy, set_path
    for j, name in enumerate(names):
        is_analysis = name.startswith("analysis.")
        target = analysis if is_analysis else data
        path = name[len("analysis."):] if is_analysis else name
        trial = plain_copy(target)
        set_path(trial, path, float(values[0, j]))    # unknown item names, bad indices: here
        try:
            get_path(target, path)
            continue                                   # an existing value
        except ModelError:
            pass
        try:
            if is_analysis:
                Analysis.from_dict(trial)
            else:
                load_model(trial)
        except ModelError as exc:
            last = path.split(".")[-1]
            text = str(exc)
            lines = [ln.strip() for ln in text.splitlines()
                     if f"{last!r}" in ln and ("unknown key" in ln or "takes no" in ln)]
            if lines:
                parent = path.rsplit(".", 1)[0] if "." in path else ""
                try:
                    node = get_path(target, parent) if parent else target
                    keys = list(node) if isinstance(node, dict) else []
                except ModelError:
                    keys = []
                raise ModelError(f"parameter {name!r}: no such value in the "
                                 f"{'analysis' if is_analysis else 'model file'} "
                                 f"({lines[0]})" + (f"; keys there now: {_close(last, keys)}"
                                                    if keys else "")
                                 + "; see spatialmbd info MODEL and docs/sweeps.md") from None


# ---------------------------------------------------------------------------- columns
def column_names(model, requests=()) -> list:
    """The output columns of a dynamic run of ``model`` (:class:`.outputs.Columns`): those of
    ``Results.to_dataframe`` -- computed on one output at the initial state, nothing run --,
    "t" and the named points' columns."""
    from ..results import Results
    from ..outputs import parse_outputs
    nb = model.nb
    res = Results(model=model, t=np.zeros(1), q=np.asarray(model.q0, float)[None].copy(),
                  v=np.asarray(model.v0, float).reshape(1, nb, 6).copy(),
                  vdot=np.zeros((1, nb, 6)), lam=np.zeros((1, model.n_eq)), work=np.zeros(1),
                  status="success", message="", counters={}, wall_time=0.0,
                  output_requests=parse_outputs(model, list(requests)) if requests else [])
    names = ["t"] + [c for c in res.to_dataframe().columns if c != "t"]
    names += [f"{p}.{c}" for p in model.points for c in POINT_COLUMNS]
    return names


def check_columns(outputs, names) -> None:
    """Every column an output reads is one of ``names``."""
    valid = set(names)
    for o in outputs:
        if o.function is not None or o.column in valid:
            continue
        raise ModelError(f"output {o.name!r}: unknown column {o.column!r}"
                         f"{suggest(o.column, names)}; closest columns: "
                         f"{_close(o.column, names)} (all of them: spatialmbd info MODEL, "
                         "docs/sweeps.md)")
