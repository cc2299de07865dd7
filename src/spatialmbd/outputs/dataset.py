"""Results as an xarray Dataset (the optional extra ``spatialmbd[xarray]``)."""
from __future__ import annotations

import numpy as np

from .vocabulary import BODY_POSITION, BODY_VELOCITY, column_units


def to_xarray(results):
    """An xarray Dataset of a result: q (time, body, q_component), v and vdot (time, body,
    v_component), lam (time, equation) when present, and every table column as a variable
    over time (named as in the table). Needs the optional extra ``spatialmbd[xarray]``."""
    try:
        import xarray as xr
    except ImportError:
        raise ImportError("to_xarray needs xarray: pip install 'spatialmbd[xarray]'") from None
    table = results.to_dataframe()
    t = np.asarray(results.t, dtype=float)
    model = getattr(results, "model", None)
    names = list(model.body_names) if model is not None else list(results.body_names)
    data = {
        "q": (("time", "body", "q_component"), np.asarray(results.q)),
        "v": (("time", "body", "v_component"), np.asarray(results.v)),
        "vdot": (("time", "body", "v_component"), np.asarray(results.vdot)),
    }
    lam = getattr(results, "lam", None)
    if lam is not None:
        data["lam"] = (("time", "equation"), np.asarray(lam))
    for c in table.columns:
        if c != "t":
            data[c] = (("time",), table[c].to_numpy())
    ds = xr.Dataset(data, coords={"time": t, "body": names,
                                  "q_component": list(BODY_POSITION),
                                  "v_component": list(BODY_VELOCITY)})
    ds["time"].attrs["units"] = "s"
    for c, u in column_units(table.columns, table.attrs.get("units")).items():
        if c in ds:
            ds[c].attrs["units"] = u
    return ds
