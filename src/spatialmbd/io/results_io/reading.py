"""Reading results files back: :class:`LoadedResults`, :func:`read_results` (the table) and
:func:`load_results` (everything)."""
from __future__ import annotations

import json
import pathlib

import numpy as np

from ...outputs.vocabulary import BODY_ACCELERATION, BODY_POSITION, BODY_VELOCITY
from .table import CSV_SUFFIXES, HDF5_SUFFIXES, LoadedResults
from .hdf5_file import _open_h5
from .csv_file import _csv_status, _text


def read_results(path):
    """The results table of a ``.h5`` or ``.csv`` results file as a pandas DataFrame."""
    import pandas as pd
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if not path.exists():
        raise FileNotFoundError(f"no such results file: {path}")
    if suffix in CSV_SUFFIXES:
        status, _ = _csv_status(path)
        df = pd.read_csv(path, skiprows=1 if status else 0)
        df.attrs["status"] = status or "success"
        return df
    if suffix in HDF5_SUFFIXES:
        with _open_h5(path) as f:
            return _read_table(f, path)
    raise ValueError(f"cannot tell the results format from {str(path)!r}: expected .csv or .h5")


def _read_table(f, path):
    import pandas as pd
    if "table" not in f:
        raise ValueError(f"{path}: no /table group")
    tab = f["table"]
    cols = json.loads(tab.attrs["columns"])
    df = pd.DataFrame({c: tab[c][()] for c in cols})
    if "units" in tab.attrs:
        df.attrs["units"] = json.loads(tab.attrs["units"])
    return df


def load_results(path) -> LoadedResults:
    """Arrays, table and metadata of a results file (HDF5: everything; CSV: the table, with
    t, q, v, vdot rebuilt from the body columns and no metadata)."""
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if suffix in CSV_SUFFIXES:
        loaded = _loaded_from_table(path, read_results(path))
        status, message = _csv_status(path)
        loaded.metadata.update(status=status or "success", message=message)
        return loaded
    if suffix not in HDF5_SUFFIXES:
        raise ValueError(f"cannot tell the results format from {str(path)!r}: expected .csv "
                         "or .h5")
    if not path.exists():
        raise FileNotFoundError(f"no such results file: {path}")
    with _open_h5(path) as f:
        table = _read_table(f, path)
        meta = {k: json.loads(_text(f["metadata"][k][()])) for k in f["metadata"]} \
            if "metadata" in f else {}
        arr = {k: f[k][()] for k in ("t", "q", "v", "vdot", "lam", "work",
                                     "newton_iterations", "residual") if k in f}
        kind = str(f.attrs.get("kind", meta.get("kind", "dynamic")))
        version = int(f.attrs.get("format_version", 0))
    meta.setdefault("kind", kind)
    return LoadedResults(path=path, kind=kind, t=arr["t"], q=arr.get("q"), v=arr.get("v"),
                         vdot=arr.get("vdot"), table=table, metadata=meta, lam=arr.get("lam"),
                         work=arr.get("work"), newton_iterations=arr.get("newton_iterations"),
                         residual=arr.get("residual"), format_version=version)


def _loaded_from_table(path, table) -> LoadedResults:
    names = [c[:-3] for c in table.columns if c.endswith(".e0") and c.count(".") == 1]
    nt = len(table)

    def block(keys):
        if not names or not all(f"{n}.{k}" in table for n in names for k in keys):
            return None
        return np.stack([np.column_stack([table[f"{n}.{k}"].to_numpy() for k in keys])
                         for n in names], axis=1).reshape(nt, len(names), len(keys))

    kind = "kinematic" if "newton.iterations" in table else "dynamic"
    meta = {"body_names": names, "kind": kind}
    return LoadedResults(path=path, kind=kind, t=table["t"].to_numpy(), q=block(BODY_POSITION),
                         v=block(BODY_VELOCITY), vdot=block(BODY_ACCELERATION), table=table, metadata=meta)
