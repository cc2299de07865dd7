"""Parameter sweeps and sensitivities: one model, many members, any scheduler (docs/sweeps.md).

    from spatialmbd.sweep import sweep, grid, latin_hypercube
    ds = sweep("examples/pendulum_ch15.yaml", {"bodies.pendulum.mass": "1:10:10"},
               ["period(pendulum.wx)", "max(pendulum.z)"], scheduler="dask")

:func:`sweep` returns an xarray Dataset (or a tidy DataFrame) with a status and message per
member; :func:`sensitivities` differentiates outputs with respect to parameters (central
differences checked by Richardson extrapolation); :mod:`.batch` integrates many members of one
topology in one compiled call. Dask and xarray come with ``pip install 'spatialmbd[dask]'``.
"""
from .core import (QUIET_WORKERS, SweepJob, local_cluster, run_chunk, save_result, sweep,
                   to_dataframe)
from .limits import MAX_MEMBERS, SweepNote
from .outputs import REDUCTIONS, Output, parse_outputs, peak, period, trough
from .params import (ParameterSpace, as_space, get_path, grid, latin_hypercube, parse_range,
                     points, set_path)
from .sensitivity import forward_sensitivities, sensitivities

__all__ = ["sweep", "grid", "points", "latin_hypercube", "ParameterSpace", "parse_range",
           "as_space",
           "Output", "parse_outputs", "period", "peak", "trough", "REDUCTIONS", "set_path",
           "get_path",
           "save_result", "to_dataframe", "SweepJob", "run_chunk", "sensitivities",
           "forward_sensitivities", "simulate_batch", "local_cluster", "QUIET_WORKERS",
           "MAX_MEMBERS", "SweepNote"]


def __getattr__(name):
    if name == "simulate_batch":                 # compiled on first use only
        from .batch import simulate_batch
        return simulate_batch
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
