"""Triangle meshes of display and mass shapes: ``{"type": "mesh", ...}``.

A mesh shape gives its triangles inline (``vertices`` (n, 3) in m, ``faces`` (m, 3) vertex
indices, counter-clockwise seen from outside) or a ``file`` (STL, OBJ, PLY, OFF, GLB: any format
`trimesh <https://trimesh.org>`_ reads; the optional extra ``pip install 'spatialmbd[mesh]'``),
with an optional ``scale`` (one number or three, applied to the vertices first), and like every
shape a ``center`` (m) and an orientation ``p`` (Euler parameters) in the axes of its body.

A mesh sidecar (``file: robot.meshes.npz`` with ``mesh: NAME``) is a NumPy ``.npz`` archive
written next to a model file by ``save_model`` and ``spatialmbd import`` (docs/import.md): for
each mesh NAME the arrays ``NAME.vertices`` (n, 3) floats and ``NAME.faces`` (m, 3) integers,
each mesh stored once however many shapes use it, its vertices without repeats.

:func:`mesh_arrays` returns the scaled vertices and the faces, checked (finite, indices in
range); files are read once per (path, modification time), a sidecar mesh on first use.
"""
from __future__ import annotations

import os
from typing import Optional

import numpy as np

from .errors import ModelError

_CACHE: dict = {}
#: the suffix of mesh sidecars (NumPy archives of named meshes)
SIDECAR_SUFFIX = ".npz"


def _trimesh():
    try:
        import trimesh
    except ImportError:
        raise ModelError("reading a mesh file needs trimesh: pip install 'spatialmbd[mesh]' "
                         "(or give the mesh's vertices and faces inline)") from None
    return trimesh


def resolve_file(file, base_dir: Optional[str] = None) -> str:
    """The absolute path of a mesh file given relative to ``base_dir`` (the model file's
    directory) or the working directory; ModelError when it does not exist."""
    path = os.path.expanduser(str(file))
    if not os.path.isabs(path) and base_dir is not None:
        path = os.path.join(str(base_dir), path)
    path = os.path.abspath(path)
    if not os.path.isfile(path):
        raise ModelError(f"mesh file {file!r} not found (looked for {path}); give a path "
                         "relative to the model file or an absolute one")
    return path


def read_file(path) -> tuple:
    """(vertices (n, 3), faces (m, 3)) of a mesh file, through trimesh."""
    path = resolve_file(path)
    key = (path, os.path.getmtime(path))
    if key not in _CACHE:
        trimesh = _trimesh()
        try:
            tm = trimesh.load(path, force="mesh")
        except Exception as exc:        # trimesh raises many types for unreadable files
            raise ModelError(f"mesh file {path}: cannot be read ({exc}); give an STL, OBJ, PLY "
                             "or OFF file") from None
        V = np.asarray(getattr(tm, "vertices", ()), dtype=float).reshape(-1, 3)
        F = np.asarray(getattr(tm, "faces", ()), dtype=np.int64).reshape(-1, 3)
        if F.shape[0] == 0:
            raise ModelError(f"mesh file {path}: no triangles found")
        _CACHE[key] = (V, F)
    V, F = _CACHE[key]
    return V.copy(), F.copy()


def compact(vertices, faces) -> tuple:
    """(vertices without repeated rows, faces renumbered onto them): the same triangles."""
    V = np.asarray(vertices)
    F = np.asarray(faces, dtype=np.int64)
    unique, inverse = np.unique(V, axis=0, return_inverse=True)
    return unique, inverse.reshape(-1)[F].astype(F.dtype)


def _sidecar(path: str):
    """The open archive of a sidecar (cached per path and modification time)."""
    key = ("npz", path, os.path.getmtime(path))
    if key not in _CACHE:
        import zipfile
        try:
            _CACHE[key] = np.load(path, allow_pickle=False)
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise ModelError(f"mesh sidecar {path}: cannot be read ({exc}); write it again "
                             "with spatialmbd import or save_model") from None
    return _CACHE[key]


def read_sidecar(path, name, what: str = "mesh") -> tuple:
    """(vertices (n, 3), faces (m, 3)) of mesh ``name`` in the sidecar ``path``, checked:
    ModelError naming ``what`` (the shape and its body), the mesh and the file otherwise."""
    path = resolve_file(path)
    if not isinstance(name, str) or not name:
        raise ModelError(f"{what}: a mesh from the sidecar {path} needs its name (mesh: NAME)")
    key = ("npz-mesh", path, os.path.getmtime(path), name)
    if key not in _CACHE:
        archive = _sidecar(path)
        names = sorted({k.rsplit(".", 1)[0] for k in archive.files})
        if f"{name}.vertices" not in archive.files or f"{name}.faces" not in archive.files:
            near = ", ".join(names[:8]) + (", ..." if len(names) > 8 else "")
            raise ModelError(f"{what}: the mesh sidecar {path} has no mesh {name!r} (it holds "
                             f"{len(names)}: {near})")
        try:
            V = np.asarray(archive[f"{name}.vertices"])
            F = np.asarray(archive[f"{name}.faces"])
        except (OSError, ValueError) as exc:
            raise ModelError(f"{what}: mesh {name!r} of the sidecar {path} cannot be read "
                             f"({exc})") from None
        where = f"{what} (mesh {name!r} of {path})"
        if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 3 or V.dtype.kind != "f":
            raise ModelError(f"{where}: vertices must be (n, 3) floats with n >= 3, got "
                             f"{V.dtype} of shape {V.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] < 1 or F.dtype.kind not in "iu":
            raise ModelError(f"{where}: faces must be (m, 3) integers, got {F.dtype} of shape "
                             f"{F.shape}")
        _check(V.astype(float), F.astype(np.int64), where)
        _CACHE[key] = (V.astype(float), F.astype(np.int64))
    V, F = _CACHE[key]
    return V.copy(), F.copy()


def _check(V, F, what: str) -> None:
    bad = ~np.isfinite(V)
    if np.any(bad):
        k = int(np.argwhere(bad)[0][0])
        raise ModelError(f"{what}.vertices[{k}]: non-finite coordinates {V[k].tolist()}")
    bad = (F < 0) | (F >= V.shape[0])
    if np.any(bad):
        k = int(np.argwhere(bad)[0][0])
        raise ModelError(f"{what}.faces[{k}]: vertex index {F[k].tolist()} out of range "
                         f"0..{V.shape[0] - 1}")


def _describe(value) -> str:
    if isinstance(value, str):
        text = value if len(value) <= 20 else value[:17] + "..."
        return f"a string ({text!r})"
    if isinstance(value, dict):
        return f"a mapping of {len(value)} key{'s' if len(value) != 1 else ''}"
    if isinstance(value, (bool, np.bool_)):
        return f"a boolean ({value})"
    return f"{type(value).__name__} {value!r}"[:60]


def _table(value, what: str, expected: str, kind) -> np.ndarray:
    """``value`` as an array of numbers (``kind`` float or int: whole numbers), or ModelError
    naming ``what``, the shape expected and what was given (a string, a mapping, a boolean, a
    ragged list) -- never a TypeError from NumPy."""
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, (list, tuple,
                                                                       np.ndarray)):
        raise ModelError(f"{what}: expected {expected}, got {_describe(value)}")
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = None
    if array is None or array.dtype.kind not in "iuf":
        for k, row in enumerate(value):                  # the first entry that is no number
            items = row if isinstance(row, (list, tuple, np.ndarray)) else [row]
            for x in items:
                if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float,
                                                                         np.number)):
                    inside = f" in {_describe(row)}" if x is not row else ""
                    raise ModelError(f"{what}[{k}]: expected {expected}, got "
                                     f"{_describe(x)}{inside}")
        raise ModelError(f"{what}: expected {expected}, got rows of different lengths")
    if kind is int and array.dtype.kind == "f":
        bad = ~np.isfinite(array) | (array != np.round(array))
        if np.any(bad):
            k = int(np.argwhere(bad)[0][0])
            raise ModelError(f"{what}[{k}]: expected {expected}, got {array[k].tolist()}")
    return array.astype(float) if kind is float else array


def _scale(shape: dict, what: str) -> np.ndarray:
    value = shape.get("scale", 1.0)
    try:
        if isinstance(value, (str, bytes, dict, bool)):
            raise TypeError
        s = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{what}.scale: expected one or three positive numbers, got "
                         f"{_describe(value)}") from None
    if s.size == 1:
        s = np.repeat(s, 3)
    if s.size != 3 or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise ModelError(f"{what}.scale: expected one or three positive numbers, got "
                         f"{shape.get('scale')!r}")
    return s


def mesh_arrays(shape: dict, what: str = "mesh") -> tuple:
    """(vertices (n, 3) scaled, in the shape's axes; faces (m, 3) int) of a mesh shape."""
    has_inline = shape.get("vertices") is not None or shape.get("faces") is not None
    if shape.get("file") is not None and has_inline:
        raise ModelError(f"{what}: give either a file or vertices and faces, not both")
    if shape.get("file") is not None and str(shape["file"]).lower().endswith(SIDECAR_SUFFIX):
        V, F = read_sidecar(shape["file"], shape.get("mesh"), what)
    elif shape.get("file") is not None:
        V, F = read_file(shape["file"])
    elif shape.get("vertices") is not None and shape.get("faces") is not None:
        V = _table(shape["vertices"], f"{what}.vertices", "(n, 3) coordinates in m", float)
        F = _table(shape["faces"], f"{what}.faces", "(m, 3) vertex indices (integers)", int)
        if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 3:
            raise ModelError(f"{what}.vertices: expected (n, 3) numbers with n >= 3, got shape "
                             f"{V.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] < 1:
            raise ModelError(f"{what}.faces: expected (m, 3) vertex indices (integers), got "
                             f"shape {F.shape}")
        F = F.astype(np.int64)
    else:
        raise ModelError(f"{what}: a mesh needs a file or vertices and faces")
    _check(V, F, what)
    return V * _scale(shape, what), F
