"""Mesh sidecars: the triangle meshes of a model file in one NumPy archive next to it.

``save_model(builder, "robot.yaml")`` writes a mesh shape whose vertices are given inline (as
arrays or lists) into ``robot.meshes.npz`` when it is named (``mesh: NAME``, as imported meshes
are) or has at least :data:`SIDECAR_MIN_VERTICES` vertices, and the shape in the model file
as a reference ``{type: mesh, file: robot.meshes.npz, mesh: NAME, center, p, ...}``. The archive holds ``NAME.vertices`` (n, 3) and ``NAME.faces`` (m, 3)
for each mesh, in the dtype given (an imported MuJoCo mesh: float32 and int32, exactly MuJoCo's
numbers), each distinct mesh once however many shapes use it. Reading is in
:func:`spatialmbd.meshes.read_sidecar`.
"""
from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np

from ..atomic import atomic_write

__all__ = ["MeshStore", "SIDECAR_MIN_VERTICES", "sidecar_path"]

#: inline meshes with at least this many vertices go to the sidecar (smaller ones stay inline,
#: readable in the model file)
SIDECAR_MIN_VERTICES = 64


def sidecar_path(model_path) -> Path:
    """``robot.yaml`` -> ``robot.meshes.npz`` (next to it)."""
    model_path = Path(model_path)
    return model_path.with_name(model_path.stem + ".meshes.npz")


def _arrays(shape: dict):
    """(V, F) of an inline mesh shape as arrays, or None when it has no inline data."""
    if shape.get("type") != "mesh" or shape.get("vertices") is None or \
            shape.get("faces") is None:
        return None
    V, F = np.asarray(shape["vertices"]), np.asarray(shape["faces"])
    if V.ndim != 2 or V.shape[1:] != (3,) or F.ndim != 2 or F.shape[1:] != (3,) or \
            V.dtype.kind != "f" and V.dtype.kind not in "iu" or F.dtype.kind not in "iu":
        return None                       # not plain numbers: written inline, checked on read
    return V, F


class MeshStore:
    """Collects the meshes of a model being written: :meth:`reference` replaces an inline mesh
    shape by its reference into the sidecar; :meth:`write` writes the archive (atomically)."""

    def __init__(self, path, min_vertices: int = SIDECAR_MIN_VERTICES):
        self.path = Path(path)
        self.min_vertices = min_vertices
        self.arrays: dict = {}            # NAME.vertices / NAME.faces -> array
        self._by_content: dict = {}       # digest -> NAME
        self.shapes = 0                   # shapes referring to the sidecar

    def _name(self, wanted) -> str:
        base = re.sub(r"[^A-Za-z0-9_\-]", "_", str(wanted or "mesh")) or "mesh"
        name, k = base, 1
        while f"{name}.vertices" in self.arrays:
            k += 1
            name = f"{base}_{k}"
        return name

    def reference(self, shape: dict):
        """The shape with its inline mesh moved into the store, or None (kept inline)."""
        arrays = _arrays(shape)
        if arrays is None or (shape.get("mesh") is None and
                              arrays[0].shape[0] < self.min_vertices):
            return None
        V, F = arrays
        V = V if V.dtype.kind == "f" else V.astype(float)
        digest = hashlib.sha1(str(V.dtype).encode() + np.ascontiguousarray(V).tobytes()
                              + str(F.dtype).encode() + np.ascontiguousarray(F).tobytes()
                              ).hexdigest()
        name = self._by_content.get(digest)
        if name is None:
            name = self._name(shape.get("mesh"))
            self.arrays[f"{name}.vertices"] = V
            self.arrays[f"{name}.faces"] = F
            self._by_content[digest] = name
        self.shapes += 1
        out = {k: v for k, v in shape.items() if k not in ("vertices", "faces", "mesh")}
        out["file"] = self.path.name
        out["mesh"] = name
        return out

    @property
    def n_meshes(self) -> int:
        return len(self._by_content)

    def write(self) -> Path:
        """Write the archive next to the model file (temporary file, fsync, rename)."""
        with atomic_write(self.path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, **self.arrays)
        return self.path
