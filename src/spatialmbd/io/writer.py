"""Writing model files: builder or model -> the schema's dictionary -> YAML or JSON text,
exactly (floats with repr precision, so model -> file -> model gives bit-identical specs),
atomically. The schema is in :mod:`.schema`, the reader in :mod:`.reader`."""
from __future__ import annotations

import inspect
import json
import re
from pathlib import Path
from typing import Optional, Union

import numpy as np
import yaml

from ..atomic import atomic_write, check_writable
from ..model import Model, ModelBuilder
from .analysis import Analysis
from .schema import (GEOMETRY_KEYS, JSON_SUFFIXES, SCHEMA_VERSION, YAML_SUFFIXES, ModelFileError,
                     _plain, _Problems)
from .source import _FLOAT_RE, _FLOAT_TAG


# ============================================================================ builder -> file
def _floats(arr) -> list:
    return [float(x) for x in np.asarray(arr, dtype=float).reshape(-1)]


def _is_default(arr, default) -> bool:
    arr = np.asarray(arr, dtype=float)
    return bool(np.array_equal(arr, default) and not np.any(np.signbit(arr) & (arr == 0)))


def _state(obj) -> dict:
    if isinstance(obj, Model):
        return obj.builder_state
    if isinstance(obj, ModelBuilder):
        return dict(name=obj.name, gravity=obj.gravity, bodies=obj.bodies, joints=obj.joints,
                    drivers=obj.drivers, forces=obj.forces, ground_shapes=obj.ground_shapes,
                    couplers=obj.couplers)
    raise TypeError(f"expected a Model or a ModelBuilder, not {type(obj).__name__}")


def _shapes(shapes, P, path, meshes) -> list:
    """Shapes as plain values. Inline mesh arrays: kept as arrays (``meshes="arrays"``, for a
    model loaded in memory), moved into a sidecar (``meshes`` a MeshStore) or written as lists
    (None)."""
    out = []
    for k, shape in enumerate(shapes):
        if isinstance(shape, dict) and shape.get("type") == "mesh":
            if meshes == "arrays" and shape.get("vertices") is not None:
                rest = _plain({key: v for key, v in shape.items()
                               if key not in ("vertices", "faces")}, P, tuple(path) + (k,))
                rest.update(vertices=np.asarray(shape["vertices"]),
                            faces=np.asarray(shape.get("faces")))
                out.append(rest)
                continue
            if meshes is not None and meshes != "arrays":
                ref = meshes.reference(shape)
                if ref is not None:
                    out.append(_plain(ref, P, tuple(path) + (k,)))
                    continue
        out.append(_plain(shape, P, tuple(path) + (k,)))
    return out


def model_to_dict(model_or_builder, analysis: Union[Analysis, dict, None] = None, *,
                  meshes=None) -> dict:
    """The model file content of a Model or ModelBuilder (and an analysis) as a plain dict.

    meshes: how inline mesh arrays are written: None, as lists; a :class:`.sidecar.MeshStore`,
    the large ones as references into its sidecar; ``"arrays"``, kept as NumPy arrays (a dict
    for :func:`load_model` in memory, not for a file).
    Raises ModelFileError listing everything that cannot be written (user motion laws, user
    forces, other Python objects).
    """
    s = _state(model_or_builder)
    P = _Problems()
    out: dict = {"spatialmbd": SCHEMA_VERSION, "name": s["name"],
                 "gravity": _floats(s["gravity"])}
    bodies = []
    for spec in s["bodies"].values():
        d: dict = {"name": spec.name, "mass": float(spec.mass)}
        J = np.asarray(spec.inertia, dtype=float)
        off = J - np.diag(np.diag(J))
        d["inertia"] = _floats(np.diag(J)) if not np.any(off) else \
            [_floats(row) for row in J]
        d["position"] = _floats(spec.r)
        if not _is_default(spec.p, [1.0, 0.0, 0.0, 0.0]):
            d["orientation"] = {"euler_parameters": _floats(spec.p)}
        if not _is_default(spec.rdot, [0.0, 0.0, 0.0]):
            d["velocity"] = _floats(spec.rdot)
        if not _is_default(spec.omega, [0.0, 0.0, 0.0]):
            d["angular_velocity"] = _floats(spec.omega)
        if spec.points:
            d["points"] = {str(k): _floats(v) for k, v in spec.points.items()}
        if spec.vectors:
            d["vectors"] = {str(k): _floats(v) for k, v in spec.vectors.items()}
        if spec.shapes:
            d["shapes"] = _shapes(list(spec.shapes), P, ("bodies", len(bodies), "shapes"),
                                  meshes)
        if spec.color is not None:
            d["color"] = spec.color
        bodies.append(d)
    out["bodies"] = bodies
    joints = []
    for spec in s["joints"].values():
        d = {"name": spec.name, "type": spec.type, "body_i": spec.body_i,
             "body_j": spec.body_j}
        order = list(GEOMETRY_KEYS) + [k for k in spec.geometry if k not in GEOMETRY_KEYS]
        for key in order:
            if key in spec.geometry and spec.geometry[key] is not None:
                val = spec.geometry[key]
                d[key] = val if isinstance(val, str) else _floats(val)
        for key, value in spec.params.items():              # a number, or a list of them
            d[key] = _floats(value) if np.ndim(value) else float(value)
        joints.append(d)
    if joints:
        out["joints"] = joints
    drivers = []
    for k, spec in enumerate(s["drivers"].values()):
        d = {"name": spec.name, "kind": spec.kind}
        for key in ("joint", "body", "coordinate"):
            if getattr(spec, key) is not None:
                d[key] = getattr(spec, key)
        d["law"] = _plain(spec.law, P, ("drivers", k, "law"))
        drivers.append(d)
    if drivers:
        out["drivers"] = drivers
    couplers = [dict(name=c.name, type=c.type, joint1=c.joint1, joint2=c.joint2,
                     **{k: float(v) for k, v in c.params.items()})
                for c in (s.get("couplers") or {}).values()]
    if couplers:
        out["couplers"] = couplers
    from ..forces import FORCE_TYPES
    forces = []
    for k, spec in enumerate(s["forces"].values()):
        if not FORCE_TYPES[spec.type].in_files:
            P.add(("forces", k), f"force {spec.name!r} is a {spec.type} force (it holds Python "
                                 "objects) and cannot be written to a model file; add it in "
                                 f"Python with ModelBuilder.add_force({spec.type!r}, ...) after "
                                 "load_builder()")
            continue
        d = {"name": spec.name, "type": spec.type}
        d.update({key: _plain(val, P, ("forces", k, key))
                  for key, val in spec.params.items() if val is not None})
        forces.append(d)
    # actuators (types with outputs of their own, spatialmbd.forces.actuators) go to controls:
    controls = [d for d in forces if hasattr(FORCE_TYPES[d["type"]], "output_columns")]
    forces = [d for d in forces if not hasattr(FORCE_TYPES[d["type"]], "output_columns")]
    if forces:
        out["forces"] = forces
    if controls:
        out["controls"] = controls
    if s["ground_shapes"]:
        out["ground_shapes"] = _shapes(list(s["ground_shapes"]), P, ("ground_shapes",), meshes)
    if len(P):
        raise P.error(heading=f"model {s['name']!r} cannot be written to a model file")
    if analysis is not None:
        outputs = list(getattr(analysis, "outputs", None) or [])
        if isinstance(analysis, dict):
            analysis = Analysis.from_dict(analysis, list(s["bodies"]))
        elif not isinstance(analysis, Analysis):
            raise TypeError(f"analysis must be an Analysis, a dict or None, not "
                            f"{type(analysis).__name__}")
        else:
            analysis = Analysis.from_dict(analysis.to_dict(), list(s["bodies"]))
        out["analysis"] = analysis.to_dict()
        if outputs:
            out["outputs"] = _plain(outputs)
    return out


class _Dumper(yaml.SafeDumper):
    """Indented block sequences; strings that any YAML reader could take for a number are
    quoted (the resolvers of YAML 1.1 and of our 1.2-style loader)."""

    def increase_indent(self, flow=False, indentless=False):
        return super().increase_indent(flow, False)


_Dumper.yaml_implicit_resolvers = {
    ch: list(resolvers) for ch, resolvers in yaml.SafeDumper.yaml_implicit_resolvers.items()}
_Dumper.add_implicit_resolver(_FLOAT_TAG, _FLOAT_RE, list("-+0123456789."))


class _Block(dict):
    """A mapping always written in block style (sections and elements, for readability)."""


_Dumper.add_representer(_Block, lambda dumper, data: dumper.represent_mapping(
    "tag:yaml.org,2002:map", data.items(), flow_style=False))


def _yaml_text(data: dict, header: Optional[str] = None) -> str:
    data = dict(data)
    for key in ("bodies", "joints", "drivers", "couplers", "forces", "controls"):
        if key in data:
            data[key] = [_Block(d) for d in data[key]]
    if "analysis" in data:
        data["analysis"] = _Block(data["analysis"])
    text = yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=None,
                     allow_unicode=True, width=100)
    lines = text.splitlines()
    out = []
    if header:
        out.extend(("# " + ln).rstrip() for ln in header.strip("\n").splitlines())
    for k, ln in enumerate(lines):
        if k and re.match(r"^[A-Za-z_][\w-]*:", ln):
            out.append("")          # a blank line between top-level sections
        out.append(ln)
    return "\n".join(out) + "\n"


def _json_value(value, indent: int) -> str:
    pad = " " * indent
    if isinstance(value, dict):
        if not value:
            return "{}"
        if all(not isinstance(v, (dict, list)) for v in value.values()) and len(value) <= 6:
            return "{" + ", ".join(f"{json.dumps(k)}: {json.dumps(v, allow_nan=False)}"
                                   for k, v in value.items()) + "}"
        rows = [f"{pad}  {json.dumps(k)}: {_json_value(v, indent + 2)}"
                for k, v in value.items()]
        return "{\n" + ",\n".join(rows) + "\n" + pad + "}"
    if isinstance(value, list):
        if all(not isinstance(v, (dict, list)) for v in value):
            return "[" + ", ".join(json.dumps(v, allow_nan=False) for v in value) + "]"
        rows = [f"{pad}  {_json_value(v, indent + 2)}" for v in value]
        return "[\n" + ",\n".join(rows) + "\n" + pad + "]"
    return json.dumps(value, allow_nan=False)


def save_model(model_or_builder, path, analysis=None, *, header: Optional[str] = None,
               meshes: str = "sidecar") -> Path:
    """Write a Model or ModelBuilder (and an analysis) to ``path``: YAML (.yaml/.yml) or JSON
    (.json). header: a comment written at the top of YAML files (ignored for JSON).
    meshes: "sidecar" (default): inline meshes of SIDECAR_MIN_VERTICES vertices or more go to
    ``<stem>.meshes.npz`` next to the file, referenced by name (:mod:`.sidecar`); "inline":
    every mesh written into the model file as lists.

    The files are written atomically (a temporary file in the same directory, then os.replace;
    the sidecar first). Raises ModelFileError if the model holds Python callables (user laws,
    user forces).
    """
    from .sidecar import MeshStore, sidecar_path
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in YAML_SUFFIXES + JSON_SUFFIXES:
        raise ModelFileError([f"unsupported file extension {path.suffix!r}; use .yaml, .yml "
                              "or .json"], path)
    if meshes not in ("sidecar", "inline"):
        raise ValueError(f"meshes must be 'sidecar' or 'inline', got {meshes!r}")
    store = MeshStore(sidecar_path(path)) if meshes == "sidecar" else None
    data = model_to_dict(model_or_builder, analysis, meshes=store)
    try:
        text = _yaml_text(data, header) if suffix in YAML_SUFFIXES else \
            _json_value(data, 0) + "\n"
    except ValueError as exc:       # NaN / inf in JSON
        raise ModelFileError([str(exc)], path,
                             heading=f"cannot write {str(path)!r}") from None
    check_writable(path)                 # before the sidecar: nothing written if it cannot be
    if store is not None and store.shapes:
        store.write()
    with atomic_write(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
    return path


# ============================================================================ examples
def write_examples(directory) -> list:
    """Write examples/<name>.yaml for every entry of spatialmbd.models.EXAMPLES."""
    import textwrap

    from .. import models
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name, (function, kwargs, analysis) in models.EXAMPLES.items():
        doc = (inspect.getdoc(function) or name).split("\n\n")[0].replace("\n", " ")
        call = f"spatialmbd.models.{function.__name__}(" + ", ".join(
            f"{k}={v!r}" for k, v in kwargs.items()) + ")"
        header = "\n".join(textwrap.wrap(f"{name}: {doc}", 94)) + (
            f"\nWritten by spatialmbd.io.write_examples() from {call}\n"
            "with the analysis suggested in models.EXAMPLES. SI units; schema: "
            "docs/model-file.md.\n"
            f"Run:  model, analysis = spatialmbd.io.load_model(\"examples/{name}.yaml\")\n"
            "      results = analysis.run(model)")
        written.append(save_model(function(**kwargs), directory / f"{name}.yaml", analysis,
                                  header=header))
    return written
