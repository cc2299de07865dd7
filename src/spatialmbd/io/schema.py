"""Model-file schema: the keys a model file may have, and the checks of its values.

Every check adds its problems, with their place in the file, to a :class:`_Problems` list, so a
file is checked whole and every problem reported at once (:class:`ModelFileError`). The key
tables of the element types come from their registries (``joint_keys``); numeric ranges are in
:data:`RANGES`. The reader (:mod:`.reader`) walks the file with these checks; the writer
(:mod:`.writer`) uses the same key tables.
"""
from __future__ import annotations

import contextvars
import dataclasses
import difflib
import math
import os
import re
from typing import Optional

import numpy as np

from ..checks import _RANGE_KEYS, RANGES, _range_kind, range_problems  # noqa: F401
from ..errors import ModelError
from ..model.builder import GLOBAL_KEYS, LOCAL_KEYS


SCHEMA_VERSION = 1


YAML_SUFFIXES = (".yaml", ".yml")
JSON_SUFFIXES = (".json",)

TOP_KEYS = ("spatialmbd", "name", "gravity", "bodies", "joints", "drivers", "forces",
            "ground_shapes", "analysis", "outputs", "contacts", "couplers", "controls", "fmu")
#: the ``fmu:`` section: the interface of an exported FMU (docs/fmi.md, spatialmbd.fmi)
FMU_KEYS = ("inputs", "outputs", "parameters", "start_time", "stop_time", "step", "method",
            "integrator", "rtol", "atol")
BODY_KEYS = ("name", "mass", "inertia", "position", "orientation", "velocity",
             "angular_velocity", "angular_velocity_local", "points", "vectors", "shapes", "color",
             "density")
ORIENTATION_KEYS = ("euler_parameters", "euler_zxz", "euler_zxz_deg", "bryant", "bryant_deg",
                    "matrix")
_GEOMETRY_ORDER = ("point", "axis", "reference", "point2", "axis2",
                   "point_i", "point_j", "axis_i", "axis_j", "ref_i", "ref_j")
GEOMETRY_KEYS = tuple(k for k in _GEOMETRY_ORDER if k in GLOBAL_KEYS | LOCAL_KEYS) + tuple(
    sorted((GLOBAL_KEYS | LOCAL_KEYS) - set(_GEOMETRY_ORDER)))
JOINT_KEYS = ("name", "type", "body_i", "body_j") + GEOMETRY_KEYS


def joint_keys(jtype=None) -> tuple:
    """The keys a joint entry may have: the common ones plus the parameters of its type (of
    every registered type when the type is unknown), generated from the live registry."""
    from ..constraints import JOINT_TYPES
    types = [JOINT_TYPES[jtype]] if isinstance(jtype, str) and jtype in JOINT_TYPES else \
        list(JOINT_TYPES.values())
    extra = []
    for cls in types:
        extra += [par.name for par in cls.parameters if par.name not in extra]
    return JOINT_KEYS + tuple(extra)
DRIVER_KEYS = ("name", "kind", "joint", "body", "coordinate", "law")
SHAPE_KEYS = {"box": ("type", "size", "center", "p", "color", "role"),
              "cylinder": ("type", "radius", "length", "center", "axis", "color", "role"),
              "sphere": ("type", "radius", "center", "color", "role"),
              "capsule": ("type", "radius", "length", "center", "axis", "color", "role"),
              "mesh": ("type", "file", "mesh", "vertices", "faces", "scale", "center", "p",
                       "color", "role")}
#: what a shape is for: drawn only (visual) or the body's collision geometry (collision);
#: a body with visual shapes is drawn with those only (docs/import.md)
SHAPE_ROLES = ("visual", "collision")
SHAPE_REQUIRED = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",),
                  "capsule": ("radius", "length"), "mesh": ()}
#: the directory of the model file being read: mesh files are relative to it
_BASE_DIR: contextvars.ContextVar = contextvars.ContextVar("model_file_dir", default=None)
ANALYSIS_KEYS = ("type", "t_end", "output_step", "t_eval", "method", "integrator",
                 "correct_initial", "hold", "steady", "time", "frame_rate", "controllers")
DYNAMIC_ONLY = ("method", "integrator", "correct_initial", "hold", "controllers")
#: the keys of an ``analysis.controllers`` entry of type fmu (spatialmbd.fmi.controller)
FMU_CONTROLLER_KEYS = ("type", "name", "file", "inputs_from", "outputs_to", "step",
                       "parameters")
#: engineering analyses (spatialmbd.analyses): inverse dynamics and quasi-static analysis over
#: the output times; static equilibrium and modes at one time ("time", s, default 0)
ENGINEERING_TYPES = ("inverse", "static", "quasi_static", "modal")
ANALYSIS_TYPES = ("dynamic", "kinematic") + ENGINEERING_TYPES
#: types without output times
SINGLE_TIME_TYPES = ("static", "modal")

# builder keyword -> place in the file, for relabelling the builder's messages
_BODY_FIELDS = {"r": ("position",), "rdot": ("velocity",), "omega": ("angular_velocity",),
                "omega_local": ("angular_velocity_local",),
                "p": ("orientation", "euler_parameters"), "A": ("orientation", "matrix"),
                "euler_zxz": ("orientation", "euler_zxz"), "bryant": ("orientation", "bryant")}
_COLOR = re.compile(r"^#[0-9a-fA-F]{6}$")
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_EPS = np.finfo(float).eps
#: what the builder's checks may raise on extreme values (recorded as problems at their place)
_BUILD_ERRORS = (ModelError, ValueError, TypeError, ArithmeticError, np.linalg.LinAlgError)


# ============================================================================ errors
class ModelFileError(ModelError):
    """A model file (or model dict) with problems, or a model that cannot be written.

    ``problems``: every problem found, each ``"<place in the file>: <what is wrong>"``, e.g.
    ``"bodies[2].inertia: inertia is not positive definite (...)"``. ``lines``: the YAML line
    of each problem where known (else None). ``source``: the file, if any.
    """

    def __init__(self, problems, source=None, lines=None, heading: Optional[str] = None):
        self.problems = [str(p) for p in problems]
        self.source = None if source is None else str(source)
        self.lines = list(lines) if lines is not None else [None] * len(self.problems)
        self.heading = heading
        super().__init__(self._text())

    def _text(self) -> str:
        n = len(self.problems)
        if self.heading:
            head = self.heading
        elif self.source:
            head = f"model file {self.source!r}"
        else:
            head = "model description"
        head = f"{head}: {n} problem{'s' if n != 1 else ''}"
        rows = [f"  - {p}" + (f"  (line {ln})" if ln else "")
                for p, ln in zip(self.problems, self.lines)]
        return "\n".join([head] + rows)

    def __reduce__(self):
        return (type(self), (self.problems, self.source, self.lines, self.heading))


def _render(path) -> str:
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        elif _IDENT.match(str(part)):
            out += ("." if out else "") + str(part)
        else:
            out += f"[{str(part)!r}]"
    return out or "(top level)"


class _Problems:
    """Collects (path, message) pairs; knows the YAML line of each path when available."""

    def __init__(self, lines: Optional[dict] = None):
        self.items: list = []
        self.lines = lines or {}
        self.range_paths: list = []

    def __len__(self):
        return len(self.items)

    def add(self, path, message: str, line: Optional[int] = None) -> None:
        self.items.append((tuple(path), str(message), line))

    def flagged(self, path) -> bool:
        """Whether a range error (:func:`_range_checks`) was recorded at ``path`` or inside
        it: the builder's checks of that element are then skipped."""
        n = len(path)
        return any(p[:n] == tuple(path) for p in self.range_paths)

    def line_of(self, path):
        path = tuple(str(p) if not isinstance(p, int) else p for p in path)
        while path:
            if path in self.lines:
                return self.lines[path]
            path = path[:-1]
        return None

    def error(self, source=None, heading=None) -> ModelFileError:
        return ModelFileError([f"{_render(p)}: {m}" for p, m, _ in self.items], source,
                              [line or self.line_of(p) for p, _, line in self.items], heading)


# ============================================================================ value checks
def _describe(value) -> str:
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"the boolean {value!r}".replace("True", "true").replace("False", "false")
    if isinstance(value, str):
        try:
            float(value)
            hint = " (write numbers without quotes)"
        except ValueError:
            hint = ""
        text = value if len(value) <= 40 else value[:37] + "..."
        return f"the string {text!r}{hint}"
    if isinstance(value, (int, float)):
        return f"the number {_short(value)}"
    if isinstance(value, dict):
        return f"a mapping with keys {sorted(map(str, value))}"
    if isinstance(value, list):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    return f"a {type(value).__name__}"


def _member(value, collection) -> bool:
    """``value in collection`` for names: False (not a TypeError) for lists and mappings."""
    return isinstance(value, str) and value in collection


def _finite(value) -> bool:
    """math.isfinite that is False (not an OverflowError) for integers beyond float range."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:12]}...{text[-6:]} ({len(text)} digits)"


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _number(P, path, value, positive=False, nonneg=False, integer=False) -> bool:
    if not _is_number(value):
        P.add(path, f"expected {'an integer' if integer else 'a number'}, got "
                    f"{_describe(value)}")
        return False
    if not _finite(value):
        P.add(path, f"expected a finite number, got {_short(value)}")
        return False
    if integer and value != int(value):
        P.add(path, f"expected an integer, got {value!r}")
        return False
    if positive and not value > 0:
        P.add(path, f"must be > 0, got {value!r}")
        return False
    if nonneg and not value >= 0:
        P.add(path, f"must be >= 0, got {value!r}")
        return False
    return True


def _string(P, path, value, what="a string") -> bool:
    if not isinstance(value, str) or not value:
        P.add(path, f"expected {what}, got {_describe(value)}")
        return False
    return True


def _vector(P, path, value, n=3, or_name=False) -> bool:
    if or_name and isinstance(value, str):
        return True
    if not isinstance(value, list) or len(value) != n:
        P.add(path, f"expected a list of {n} numbers{' or a point name' if or_name else ''}, "
                    f"got {_describe(value)}")
        return False
    ok = True
    for k, x in enumerate(value):
        ok = _number(P, tuple(path) + (k,), x) and ok
    return ok


def _matrix(P, path, value) -> bool:
    if not (isinstance(value, list) and len(value) == 3
            and all(isinstance(row, list) and len(row) == 3 for row in value)):
        P.add(path, f"expected a 3x3 matrix (3 lists of 3 numbers), got {_describe(value)}")
        return False
    ok = True
    for i, row in enumerate(value):
        for j, x in enumerate(row):
            ok = _number(P, tuple(path) + (i, j), x) and ok
    return ok


def _suggest(word, choices) -> str:
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _name(value) -> str:
    """A value as quoted in messages about names: 'name' for strings, else described."""
    return repr(value) if isinstance(value, str) else _describe(value)


_PLURAL = {"body": "bodies"}


def _mapping(P, path, value, allowed, required=(), what="a mapping") -> bool:
    """True if ``value`` is a dict; records unknown and missing keys."""
    if not isinstance(value, dict):
        P.add(path, f"expected {what}, got {_describe(value)}")
        return False
    for key in value:
        if key not in allowed:
            P.add(tuple(path) + (key,), f"unknown key {key!r}{_suggest(key, allowed)}; "
                                        f"valid keys: {', '.join(allowed)}")
    for key in required:
        if key not in value:
            P.add(path, f"missing required key {key!r}")
    return True


def _list(P, path, value, what) -> bool:
    if not isinstance(value, list):
        P.add(path, f"expected a list of {what}, got {_describe(value)}")
        return False
    return True


def _reference(P, path, value, declared, kind, extra=()) -> bool:
    """A name that must refer to a declared element (``extra``: e.g. 'ground')."""
    if not _string(P, path, value, f"the name of a {kind}"):
        return False
    if value in declared or value in extra:
        return True
    names = list(dict.fromkeys(list(declared) + list(extra)))
    P.add(path, f"unknown {kind} {value!r}{_suggest(value, names)}; "
                f"{_PLURAL.get(kind, kind + 's')}: {', '.join(names) or 'none'}")
    return False


def _relabel(P, path, prefix: str, message: str, fields: Optional[dict] = None) -> None:
    """Record a builder ModelError, replacing its element prefix (``bodies['x']``) by the place
    in the file and builder keywords by file keys."""
    if message.startswith(prefix):
        rest = message[len(prefix):]
        m = re.match(r"\.([A-Za-z_]\w*)(?:\[(['\"])(.*?)\2\])?: (.*)$", rest, re.S)
        if m:
            key, sub, text = m.group(1), m.group(3), m.group(4)
            where = (fields or {}).get(key, (key,))
            P.add(tuple(path) + tuple(where) + ((sub,) if sub is not None else ()), text)
            return
        if rest.startswith(": "):
            P.add(path, rest[2:])
            return
    if "name" in message.split(":")[0]:
        P.add(tuple(path) + ("name",), message)
        return
    P.add(path, message)


# ============================================================================ shapes and laws
def _shape(P, path, value, owner: Optional[str] = None) -> bool:
    """Check a shape mapping; ``owner`` (e.g. "body 'arm'") names its body in mesh errors."""
    n0 = len(P)
    if not _mapping(P, path, value, ("type",) + tuple(sorted({k for v in SHAPE_KEYS.values()
                                                             for k in v} - {"type"})),
                    ("type",), "a shape mapping {type: box|cylinder|sphere, ...}"):
        return False
    kind = value.get("type")
    if "type" not in value:
        return False
    if not _member(kind, SHAPE_KEYS):
        P.add(tuple(path) + ("type",), f"unknown shape type {_name(kind)}; valid types: "
                                        + ", ".join(SHAPE_KEYS))
        return False
    # unknown keys for this type (the generic check above allowed the union)
    for key in value:
        if key not in SHAPE_KEYS[kind] and key in {k for v in SHAPE_KEYS.values() for k in v}:
            P.add(tuple(path) + (key,), f"a {kind} takes no {key!r} (valid keys: "
                                        f"{', '.join(SHAPE_KEYS[kind])})")
    for key in SHAPE_REQUIRED[kind]:
        if key not in value:
            P.add(path, f"missing required key {key!r} for a {kind}")
    for key in ("radius", "length"):
        if key in value:
            _number(P, tuple(path) + (key,), value[key], positive=True)
    if "size" in value and _vector(P, tuple(path) + ("size",), value["size"]):
        for k, x in enumerate(value["size"]):
            if not x > 0:
                P.add(tuple(path) + ("size", k), f"must be > 0, got {x!r}")
    if "center" in value:
        _vector(P, tuple(path) + ("center",), value["center"])
    for key, n in (("axis", 3), ("p", 4)):
        if key in value and _vector(P, tuple(path) + (key,), value[key], n):
            if not any(value[key]):
                P.add(tuple(path) + (key,), "zero-length vector; give a direction")
    if "color" in value:
        _color(P, tuple(path) + ("color",), value["color"])
    if "role" in value and value["role"] not in SHAPE_ROLES:
        P.add(tuple(path) + ("role",), f"expected one of {', '.join(SHAPE_ROLES)}, got "
                                       f"{_describe(value['role'])}")
    if "mesh" in value and not (isinstance(value["mesh"], str) and value["mesh"]):
        P.add(tuple(path) + ("mesh",), f"expected a mesh name, got {_describe(value['mesh'])}")
    if kind == "mesh" and len(P) == n0:
        _mesh(P, tuple(path), value, owner)
    return len(P) == n0


def _mesh(P, path, value, owner: Optional[str] = None) -> None:
    """A mesh shape: its file (relative to the model file) found and read, or its inline
    vertices and faces checked (spatialmbd.meshes); the file becomes an absolute path. A mesh
    of a sidecar (.npz) is named in errors with its body (``owner``) and the file."""
    from ..meshes import mesh_arrays, resolve_file
    try:
        if isinstance(value.get("file"), str):
            value["file"] = resolve_file(value["file"], _BASE_DIR.get())
        elif "file" in value:
            P.add(path + ("file",), f"expected a file name, got {_describe(value['file'])}")
            return
        what = _render(path) + (f" ({value['type']} of {owner})" if owner else "")
        V, _ = mesh_arrays(value, what)
        high = RANGES["length"][1]
        if V.size and float(np.max(np.abs(V))) > high:
            k = int(np.argmax(np.max(np.abs(V), axis=1)))
            raise ModelError(f"{what}.vertices[{k}]: {V[k].tolist()} m is out of range for a "
                             f"length (|x| <= {high:g} m); check the mesh and its scale")
    except ModelError as exc:
        message = str(exc)
        prefix = _render(path)
        P.add(path, message[len(prefix):].lstrip(".: ") if message.startswith(prefix)
              else message)


def _density_body(P, path, d: dict) -> dict:
    """A body given by ``density`` (kg/m^3) and ``shapes``: the same body with the mass and
    inertia of its shapes (boxes, cylinders, spheres, capsules exactly)."""
    from ..importers.massprops import body_mass_properties
    if "mass" in d or "inertia" in d:
        P.add(path, "give density (with shapes) or mass and inertia, not both")
        return d
    scratch = _Problems()    # the shapes themselves are checked (and reported) with the body
    if not (_number(P, path + ("density",), d["density"], positive=True)
            and _list(scratch, path + ("shapes",), d.get("shapes"), "shapes") and d["shapes"]
            and all(_shape(scratch, path + ("shapes", k), s)
                    for k, s in enumerate(d["shapes"]))):
        if not scratch and not d.get("shapes"):
            P.add(path + ("shapes",), "a body given by its density needs shapes")
        return d
    try:
        mass, inertia = body_mass_properties(d["shapes"], float(d["density"]),
                                             f"bodies[{d.get('name')!r}]")
    except _BUILD_ERRORS as exc:
        P.add(path, str(exc))
        return d
    out = {k: v for k, v in d.items() if k != "density"}
    out["mass"], out["inertia"] = mass, inertia.tolist()
    return out


def _color(P, path, value) -> bool:
    if not isinstance(value, str) or not _COLOR.match(value):
        P.add(path, f"expected a colour '#rrggbb', got {_describe(value)}")
        return False
    return True


def _law(P, path, value):
    """A MotionLaw from a number or a law mapping; None (recorded) if invalid."""
    from ..motion import LAWS, make_law
    if _is_number(value):
        return make_law(float(value)) if _number(P, path, value) else None
    valid = [k for k in LAWS if k != "user"]
    if not isinstance(value, dict):
        P.add(path, f"expected a number or a motion law mapping {{type: "
                    f"{'|'.join(valid)}, ...}}, got {_describe(value)}")
        return None
    kind = value.get("type")
    if "type" not in value:
        P.add(path, f"missing required key 'type' (motion law types: {', '.join(valid)})")
        return None
    if kind == "user":
        P.add(tuple(path) + ("type",), "user-function motion laws are Python callables and "
                                        "cannot be described in a model file; use one of "
                                        + ", ".join(valid) + " or add the driver in Python")
        return None
    if kind not in valid:
        P.add(tuple(path) + ("type",), f"unknown motion law type {_name(kind)}"
                                        f"{_suggest(kind, valid)}; valid: {', '.join(valid)}")
        return None
    n0 = len(P)
    fields = {f.name: f for f in dataclasses.fields(LAWS[kind])}
    _mapping(P, path, value, ("type",) + tuple(fields))
    value = dict(value)
    for key, val in value.items():
        if key not in fields:
            continue
        if key in ("file", "interpolation"):                # a time series' text fields
            if _string(P, tuple(path) + (key,), val) and key == "file" \
                    and _BASE_DIR.get() is not None and not os.path.isabs(val):
                value[key] = os.path.join(_BASE_DIR.get(), val)   # relative to the model file
            continue
        if key in ("times", "values"):
            if _list(P, tuple(path) + (key,), val, "numbers"):
                for k, x in enumerate(val):
                    _number(P, tuple(path) + (key, k), x)
            continue
        f = fields[key]
        if f.default is dataclasses.MISSING and f.default_factory is not dataclasses.MISSING:
            if _list(P, tuple(path) + (key,), val, "numbers"):
                if not val:
                    P.add(tuple(path) + (key,), "expected at least one number")
                for k, x in enumerate(val):
                    _number(P, tuple(path) + (key, k), x)
        else:
            _number(P, tuple(path) + (key,), val)
    if len(P) != n0:
        return None
    try:
        return make_law(dict(value))
    except _BUILD_ERRORS as exc:
        P.add(path, str(exc))
        return None


# ============================================================================ ranges
def range_of(path) -> tuple:
    """(low, high) of RANGES for the value at a model-file path (a tuple of keys): a finite
    non-zero value x passes the range check when low <= |x| <= high."""
    kind = "number"
    for k, key in enumerate(path):
        kind = _range_kind(tuple(path[:k]), key, kind)
    return RANGES[kind][:2]


def _range_checks(P, data) -> None:
    """Record every finite number outside RANGES (by the nearest key naming a quantity)."""
    for path, message in range_problems(data):
        P.range_paths.append(tuple(path))
        P.add(path, message)


def _plain(value, P=None, path=()):
    """``value`` as plain Python types (dict, list, str, float, int, bool, None)."""
    from ..motion import MotionLaw
    if isinstance(value, MotionLaw):
        try:
            value = value.to_dict()
        except ModelError as exc:
            if P is None:
                raise
            P.add(path, f"{exc}; use a law of type constant, constant_velocity, harmonic, "
                        "smooth_step or polynomial, or add this element in Python after "
                        "loading")
            return None
        return _plain(value, P, path)
    if isinstance(value, dict):
        return {str(k): _plain(v, P, tuple(path) + (str(k),)) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v, P, tuple(path) + (k,)) for k, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist(), P, path)
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (str, bool, int, float)):
        return value
    what = "a Python callable" if callable(value) else f"a {type(value).__name__}"
    if P is None:
        raise ModelFileError([f"{_render(path)}: {what} cannot be written to a model file"])
    P.add(path, f"{what} cannot be written to a model file")
    return None
