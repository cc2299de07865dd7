"""Model files: one versioned schema, written as YAML or JSON (see docs/model-file.md).

A model file holds everything the Python API can express except Python callables (user motion
laws and user forces): the bodies, joints, drivers, force elements and display shapes of a
:class:`~spatialmbd.model.ModelBuilder`, and an optional ``analysis`` section saying what to run.

Loading checks the whole file before anything is computed and reports every problem at once,
each with its place in the file (``bodies[2].inertia: ...``); the checks on values are the
builder's own (its methods are called inside ``try``), this module adds the checks that only
make sense for files: unknown keys, wrong types, missing keys, references to undeclared names.

Writing is exact: floats are written with ``repr`` precision, so model -> file -> model gives
bit-identical specs, initial state and constraint values.
"""
from __future__ import annotations

import contextvars
import dataclasses
import difflib
import inspect
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np
import yaml

from ..errors import ModelError
from ..model import Model, ModelBuilder
from ..model.builder import (GLOBAL_KEYS, GROUND, LOCAL_KEYS, check_inertia, check_mass,
                             orientation_to_p)

SCHEMA_VERSION = 1

__all__ = ["SCHEMA_VERSION", "ModelFileError", "Analysis", "load_model", "load_builder",
           "model_to_dict", "save_model", "write_examples"]

YAML_SUFFIXES = (".yaml", ".yml")
JSON_SUFFIXES = (".json",)

TOP_KEYS = ("spatialmbd", "name", "gravity", "bodies", "joints", "drivers", "forces",
            "ground_shapes", "analysis", "outputs", "contacts")
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
SHAPE_KEYS = {"box": ("type", "size", "center", "p", "color"),
              "cylinder": ("type", "radius", "length", "center", "axis", "color"),
              "sphere": ("type", "radius", "center", "color"),
              "capsule": ("type", "radius", "length", "center", "axis", "color"),
              "mesh": ("type", "file", "vertices", "faces", "scale", "center", "p", "color")}
SHAPE_REQUIRED = {"box": ("size",), "cylinder": ("radius", "length"), "sphere": ("radius",),
                  "capsule": ("radius", "length"), "mesh": ()}
#: the directory of the model file being read: mesh files are relative to it
_BASE_DIR: contextvars.ContextVar = contextvars.ContextVar("model_file_dir", default=None)
ANALYSIS_KEYS = ("type", "t_end", "output_step", "t_eval", "method", "integrator",
                 "correct_initial", "hold", "steady", "time", "frame_rate")
DYNAMIC_ONLY = ("method", "integrator", "correct_initial", "hold")
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
def _shape(P, path, value) -> bool:
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
    if kind == "mesh" and len(P) == n0:
        _mesh(P, tuple(path), value)
    return len(P) == n0


def _mesh(P, path, value) -> None:
    """A mesh shape: its file (relative to the model file) found and read, or its inline
    vertices and faces checked (spatialmbd.meshes); the file becomes an absolute path."""
    from ..meshes import mesh_arrays, resolve_file
    try:
        if isinstance(value.get("file"), str):
            value["file"] = resolve_file(value["file"], _BASE_DIR.get())
        elif "file" in value:
            P.add(path + ("file",), f"expected a file name, got {_describe(value['file'])}")
            return
        mesh_arrays(value, _render(path))
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
    for key, val in value.items():
        if key not in fields:
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


# ============================================================================ analysis
@dataclass
class Analysis:
    """What to run on a model: a forward-dynamics simulation or a kinematic analysis.

    type: "dynamic" (:func:`spatialmbd.simulate.simulate`) or "kinematic"
    (:func:`spatialmbd.kinematics.kinematic_analysis`). t_end (s); output_step (s, None = 500
    intervals) or t_eval (explicit output times). Dynamic only: method and method_options,
    integrator with step (s), rtol, atol (None = the integrator's default) and
    integrator_options, correct_initial, hold ({"body": ["x", ...]}).
    Engineering analyses (spatialmbd.analyses): "inverse" and "quasi_static" over the output
    times, "static" and "modal" at ``time`` (s); modal: ``steady`` (about the initial state as
    a steady motion) and ``frame_rate`` (rad/s, a turning frame for relative equilibria).
    """

    type: str = "dynamic"
    t_end: float = 1.0
    output_step: Optional[float] = None
    t_eval: Optional[list] = None
    method: str = "projection"
    method_options: dict = field(default_factory=dict)
    integrator: str = "rk45"
    step: Optional[float] = None
    rtol: Optional[float] = None
    atol: Optional[float] = None
    integrator_options: dict = field(default_factory=dict)
    correct_initial: bool = True
    hold: Optional[dict] = None
    #: the model file's top-level ``outputs:`` section: what to record besides the standard
    #: columns (:mod:`spatialmbd.outputs`; list of request dicts or shorthand strings)
    outputs: list = field(default_factory=list)
    steady: bool = False
    time: float = 0.0
    frame_rate: Optional[list] = None

    def run(self, model, progress=False, budget=None):
        """Run this analysis of ``model`` (:func:`spatialmbd.analyses.run.run_analysis`: the
        IO package only describes analyses; running them belongs to the analyses layer)."""
        from ..analyses.run import run_analysis
        return run_analysis(self, model, progress=progress, budget=budget)

    def to_dict(self) -> dict:
        """The ``analysis`` section of a model file (plain Python types)."""
        out: dict = {"type": self.type}
        if self.type in SINGLE_TIME_TYPES:
            if self.time:
                out["time"] = float(self.time)
            if self.type == "modal" and self.steady:
                out["steady"] = True
                if self.frame_rate is not None:
                    out["frame_rate"] = [float(x) for x in self.frame_rate]
            return out
        if self.t_eval is not None:
            out["t_eval"] = [float(t) for t in self.t_eval]
        else:
            out["t_end"] = float(self.t_end)
            if self.output_step is not None:
                out["output_step"] = float(self.output_step)
        if self.type == "dynamic":
            out["method"] = {"name": self.method, **_plain(self.method_options)}
            integ = {"name": self.integrator}
            for key in ("step", "rtol", "atol"):
                if getattr(self, key) is not None:
                    integ[key] = _plain(getattr(self, key))
            integ.update(_plain(self.integrator_options))
            out["integrator"] = integ
            out["correct_initial"] = bool(self.correct_initial)
            if self.hold is not None:
                out["hold"] = {str(b): ([c] if isinstance(c, str) else list(c))
                               for b, c in self.hold.items()}
        return out

    @classmethod
    def from_dict(cls, data, body_names=None) -> "Analysis":
        """An Analysis from an ``analysis`` section; raises ModelFileError listing problems.
        body_names: the model's bodies, to check ``hold`` (None: not checked)."""
        P = _Problems()
        out = _parse_analysis(P, ("analysis",), _plain_input(data), body_names)
        if len(P):
            raise P.error(heading="analysis")
        return out


def _options(P, path, cls, options: dict, skip=()) -> bool:
    """Check option names and types against the signature of cls.__init__."""
    params = {k: p for k, p in inspect.signature(cls.__init__).parameters.items()
              if k != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}
    n0 = len(P)
    valid = ["name"] + list(params)
    for key, value in options.items():
        if key in skip:
            continue
        where = tuple(path) + (key,)
        if key not in params:
            P.add(where, f"{cls.name!r} takes no option {key!r}{_suggest(key, params)}; "
                         f"valid keys: {', '.join(valid)}")
            continue
        default = params[key].default
        if isinstance(default, bool):
            if not isinstance(value, bool):
                P.add(where, f"expected true or false, got {_describe(value)}")
        elif isinstance(default, str):
            _string(P, where, value)
        elif isinstance(default, int) and not isinstance(default, float):
            _number(P, where, value, integer=True)
        else:
            _number(P, where, value)
    return len(P) == n0


def _parse_analysis(P, path, d, body_names) -> Optional[Analysis]:
    from ..dynamics import METHODS
    from ..dynamics.base import ALIASES
    from ..dynamics.correction import HOLD_NAMES
    from ..integrators import INTEGRATORS

    if not _mapping(P, path, d, ANALYSIS_KEYS):
        return None
    a = Analysis()
    kind = d.get("type", "dynamic")
    if kind not in ANALYSIS_TYPES:
        P.add(tuple(path) + ("type",), f"unknown analysis type {_name(kind)}; valid: "
                                        + ", ".join(ANALYSIS_TYPES))
        kind = "dynamic"
    a.type = kind
    if "t_eval" in d:
        te = d["t_eval"]
        if _list(P, tuple(path) + ("t_eval",), te, "times (s)"):
            if not te:
                P.add(tuple(path) + ("t_eval",), "expected at least one time")
            elif all(_number(P, tuple(path) + ("t_eval", k), x) for k, x in enumerate(te)):
                if te[0] < 0 or any(b <= a_ for a_, b in zip(te, te[1:])):
                    P.add(tuple(path) + ("t_eval",), "output times must be >= 0 and strictly "
                                                     "increasing")
                else:
                    a.t_eval = [float(x) for x in te]
                    a.t_end = a.t_eval[-1]
        if "output_step" in d:
            P.add(tuple(path) + ("output_step",), "give output_step or t_eval, not both")
        if "t_end" in d and _number(P, tuple(path) + ("t_end",), d["t_end"]) \
                and a.t_eval is not None and float(d["t_end"]) != a.t_eval[-1]:
            P.add(tuple(path) + ("t_end",), f"t_end ({d['t_end']!r}) differs from the last "
                                            f"time of t_eval ({a.t_eval[-1]!r}); leave it out")
    elif "t_end" not in d and kind in SINGLE_TIME_TYPES:
        pass                                    # one time: "time" (s), default 0
    elif "t_end" not in d:
        P.add(path, "missing required key 't_end' (end time, s), or give t_eval")
    elif _number(P, tuple(path) + ("t_end",), d["t_end"], positive=True):
        a.t_end = float(d["t_end"])
    if "output_step" in d and "t_eval" not in d:
        if _number(P, tuple(path) + ("output_step",), d["output_step"], positive=True):
            a.output_step = float(d["output_step"])

    for key, types in (("steady", ("modal",)), ("time", SINGLE_TIME_TYPES)):
        if key in d and kind not in types:
            P.add(tuple(path) + (key,), f"applies to {' and '.join(types)} analyses only "
                                        f"(this analysis is {kind})")
    if kind in SINGLE_TIME_TYPES:
        for key in ("t_end", "output_step", "t_eval"):
            if key in d:
                P.add(tuple(path) + (key,), f"a {kind} analysis is at one time: give 'time' "
                                            "(s) instead")
    if "steady" in d and kind == "modal":
        if isinstance(d["steady"], bool):
            a.steady = d["steady"]
        else:
            P.add(tuple(path) + ("steady",), f"expected true or false, got "
                                             f"{_describe(d['steady'])}")
    if "frame_rate" in d:
        if kind != "modal" or not d.get("steady", False):
            P.add(tuple(path) + ("frame_rate",), "applies to modal analyses with steady: true "
                                                 "only (the rate, rad/s, of the frame turning "
                                                 "with a relative equilibrium)")
        elif _vector(P, tuple(path) + ("frame_rate",), d["frame_rate"]):
            a.frame_rate = [float(x) for x in d["frame_rate"]]
    if "time" in d and kind in SINGLE_TIME_TYPES:
        if _number(P, tuple(path) + ("time",), d["time"], nonneg=True):
            a.time = float(d["time"])

    if kind != "dynamic":
        for key in DYNAMIC_ONLY:
            if key in d:
                P.add(tuple(path) + (key,), "applies to dynamic analyses only (this analysis "
                                            f"is {kind})")
        return a

    if "method" in d:
        m = d["method"]
        mpath = tuple(path) + ("method",)
        name, opts = (m, {}) if isinstance(m, str) else (None, None)
        if isinstance(m, dict):
            if "name" not in m:
                P.add(mpath, "missing required key 'name' (methods: "
                             + ", ".join(sorted(METHODS)) + ")")
            else:
                name = m["name"]
                opts = {k: v for k, v in m.items() if k != "name"}
                mpath = mpath + ("name",)
        elif not isinstance(m, str):
            P.add(mpath, f"expected a method name or a mapping {{name: ..., options}}, got "
                         f"{_describe(m)}")
        if name is not None:
            key = ALIASES.get(name.lower(), name.lower()) if isinstance(name, str) else None
            if key not in METHODS:
                P.add(mpath, f"unknown method {_name(name)}{_suggest(name, METHODS)}; "
                             "valid names: " + ", ".join(sorted(METHODS)))
            else:
                a.method = key
                if _options(P, tuple(path) + ("method",), METHODS[key], opts):
                    try:
                        METHODS[key](**opts)
                        a.method_options = dict(opts)
                    except (ModelError, ValueError, TypeError) as exc:
                        P.add(tuple(path) + ("method",), str(exc))

    if "integrator" in d:
        m = d["integrator"]
        ipath = tuple(path) + ("integrator",)
        name, opts = (m, {}) if isinstance(m, str) else (None, None)
        if isinstance(m, dict):
            if "name" not in m:
                P.add(ipath, "missing required key 'name' (integrators: "
                             + ", ".join(sorted(INTEGRATORS)) + ")")
            else:
                name = m["name"]
                opts = {k: v for k, v in m.items() if k != "name"}
        elif not isinstance(m, str):
            P.add(ipath, f"expected an integrator name or a mapping {{name: ..., options}}, "
                         f"got {_describe(m)}")
        if name is not None:
            key = name.lower() if isinstance(name, str) else None
            if key not in INTEGRATORS:
                P.add(ipath + (("name",) if isinstance(m, dict) else ()),
                      f"unknown integrator {_name(name)}{_suggest(name, INTEGRATORS)}; "
                      "valid names: " + ", ".join(sorted(INTEGRATORS)))
            else:
                a.integrator = key
                n0 = len(P)
                for opt in ("step", "rtol", "atol"):
                    if opt in opts:
                        _number(P, ipath + (opt,), opts[opt], positive=True)
                if _options(P, ipath, INTEGRATORS[key], opts) and len(P) == n0:
                    try:
                        INTEGRATORS[key](**opts)
                    except (ModelError, ValueError, TypeError) as exc:
                        P.add(ipath, str(exc))
                    else:
                        a.step = opts.get("step")
                        a.rtol = opts.get("rtol")
                        a.atol = opts.get("atol")
                        a.integrator_options = {k: v for k, v in opts.items()
                                                if k not in ("step", "rtol", "atol")}

    if "correct_initial" in d:
        if isinstance(d["correct_initial"], bool):
            a.correct_initial = d["correct_initial"]
        else:
            P.add(tuple(path) + ("correct_initial",),
                  f"expected true or false, got {_describe(d['correct_initial'])}")
    if "hold" in d and d["hold"] is not None:
        hold = d["hold"]
        hpath = tuple(path) + ("hold",)
        if not isinstance(hold, dict):
            P.add(hpath, f"expected a mapping {{body: [x, y, z, rx, ry, rz]}}, got "
                         f"{_describe(hold)}")
        else:
            out, n0 = {}, len(P)
            for body, coords in hold.items():
                if body_names is not None:
                    _reference(P, hpath + (body,), body, body_names, "body")
                coords = [coords] if isinstance(coords, str) else coords
                if not isinstance(coords, list):
                    P.add(hpath + (body,), f"expected a list of coordinates "
                                           f"({', '.join(HOLD_NAMES)}), got {_describe(coords)}")
                    continue
                for k, c in enumerate(coords):
                    if not _member(c, HOLD_NAMES):
                        P.add(hpath + (body, k), f"{_describe(c)} is not one of "
                                                 f"{', '.join(HOLD_NAMES)} (translations x, y, "
                                                 "z; small rotations rx, ry, rz)")
                out[body] = list(coords)
            if len(P) == n0:
                a.hold = out
    return a


# ============================================================================ ranges
#: magnitude limits checked at load time (SI units), so that values that cannot be meant
#: (1e300 m, a mass of 5e-324 kg) are errors naming their place instead of failures deep in
#: a run; see docs/reliability.md. (key -> (smallest non-zero |x|, largest |x|, unit))
RANGES = {
    "length": (1e-100, 1e6, "m"),
    "velocity": (1e-100, 1e6, "m/s"),
    "angular_velocity": (1e-100, 1e6, "rad/s"),
    "gravity": (1e-100, 1e4, "m/s^2"),
    "mass": (1e-12, 1e12, "kg"),
    "inertia": (1e-100, 1e12, "kg m^2"),
    "number": (1e-100, 1e12, ""),
}
_RANGE_KEYS = {"position": "length", "points": "length", "center": "length", "size": "length",
               "radius": "length", "length": "length", "natural_length": "length",
               "velocity": "velocity", "angular_velocity": "angular_velocity",
               "angular_velocity_local": "angular_velocity", "gravity": "gravity",
               "mass": "mass", "inertia": "inertia"}
_RANGE_KEYS.update({k: "length" for k in ("point", "point2", "point_i", "point_j")})


def _range_checks(P, data) -> None:
    """Record every finite number outside RANGES (by the nearest key naming a quantity)."""
    stack = [(data, (), "number")]
    while stack:
        value, path, kind = stack.pop()
        if isinstance(value, dict):
            for k, v in value.items():
                stack.append((v, path + (k,), _RANGE_KEYS.get(k, kind)
                              if isinstance(k, str) and not (path and path[-1] == "points")
                              else kind))
        elif isinstance(value, list):
            stack.extend((v, path + (k,), kind) for k, v in enumerate(value))
        elif _is_number(value) and _finite(value) and value != 0:
            low, high, unit = RANGES[kind]
            size = abs(float(value))
            what = {"number": "a number", "inertia": "an inertia",
                    "angular_velocity": "an angular velocity"}.get(kind, f"a {kind}")
            if size > high or size < low:
                P.range_paths.append(tuple(path))
            if size > high:
                P.add(path, f"{_short(value)}{' ' + unit if unit else ''} is out of range for "
                            f"{what} (|x| <= {high:g}{' ' + unit if unit else ''}); check the "
                            "value and its units")
            elif size < low:
                P.add(path, f"{_short(value)}{' ' + unit if unit else ''} is too small for "
                            f"{what} (|x| >= {low:g}{' ' + unit if unit else ''}, or 0); check "
                            "the value and its units")


# ============================================================================ file -> builder
def _section(data: dict, key: str):
    """An optional list section; absent or empty (null, e.g. all entries commented out): []."""
    value = data.get(key)
    return [] if value is None else value


def _parse(P, data, default_name="model"):
    """(builder, analysis) from the file's data; problems go to P."""
    from ..constraints import DRIVER_TYPES, JOINT_TYPES
    from ..constraints.drivers import COORDINATES
    from ..forces import FORCE_TYPES

    if data is None:
        P.add((), f"the file is empty; a model file starts with 'spatialmbd: {SCHEMA_VERSION}'")
        return None, None
    if not isinstance(data, dict):
        P.add((), f"expected a mapping (spatialmbd, name, gravity, bodies, ...), got "
                  f"{_describe(data)}")
        return None, None
    if "spatialmbd" not in data:
        P.add((), f"missing the schema version: add 'spatialmbd: {SCHEMA_VERSION}' as the "
                  "first line")
    else:
        version = data["spatialmbd"]
        if not (_is_number(version) and _finite(version) and version == int(version)):
            P.add(("spatialmbd",), f"the schema version must be an integer, got "
                                   f"{_describe(version)}")
        elif version != SCHEMA_VERSION:
            P.add(("spatialmbd",), f"this file uses schema version {int(version)}; this "
                                   f"spatialmbd reads version {SCHEMA_VERSION}"
                                   + (" (upgrade spatialmbd)" if version > SCHEMA_VERSION
                                      else ""))
            return None, None
    _mapping(P, (), data, TOP_KEYS)
    _range_checks(P, {k: v for k, v in data.items() if k in TOP_KEYS})

    name = data.get("name", default_name)
    if not _string(P, ("name",), name, "a model name (string)"):
        name = default_name
    gravity = data.get("gravity", [0.0, 0.0, -9.81])
    if not _vector(P, ("gravity",), gravity):
        gravity = [0.0, 0.0, -9.81]
    b = ModelBuilder(name, gravity)

    # ------------------------------------------------------------------ bodies
    declared_bodies, ok_bodies = [], set()
    bodies = data.get("bodies")
    if "bodies" not in data:
        P.add((), "missing required key 'bodies' (a list of bodies)")
        bodies = []
    elif _list(P, ("bodies",), bodies, "bodies"):
        if not bodies:
            P.add(("bodies",), "the model has no bodies; give at least one")
    else:
        bodies = []
    for i, d in enumerate(bodies):
        path = ("bodies", i)
        by_density = isinstance(d, dict) and "density" in d
        if not _mapping(P, path, d, BODY_KEYS,
                        ("name", "shapes") if by_density else ("name", "mass", "inertia")):
            continue
        n0 = len(P)             # unknown keys (reported) do not stop the builder's checks
        if by_density:          # mass properties from the shapes (importers.massprops)
            d = _density_body(P, path, d)
        complete = all(k in d for k in ("name", "mass", "inertia"))
        if "name" in d and _string(P, path + ("name",), d["name"], "a body name (string)"):
            declared_bodies.append(d["name"])
        if "mass" in d:
            _number(P, path + ("mass",), d["mass"])
        if "inertia" in d:
            J = d["inertia"]
            if isinstance(J, list) and J and isinstance(J[0], list):
                _matrix(P, path + ("inertia",), J)
            elif not (isinstance(J, list) and len(J) == 3):
                P.add(path + ("inertia",), f"expected 3 principal moments [Ixx, Iyy, Izz] or a "
                                           f"3x3 tensor (kg m^2), got {_describe(J)}")
            else:
                _vector(P, path + ("inertia",), J)
        for key in ("position", "velocity", "angular_velocity", "angular_velocity_local"):
            if key in d:
                _vector(P, path + (key,), d[key])
        if "angular_velocity" in d and "angular_velocity_local" in d:
            P.add(path, "give angular_velocity (global axes) or angular_velocity_local (body "
                        "axes), not both")
        orient = {}
        if "orientation" in d:
            o = d["orientation"]
            opath = path + ("orientation",)
            if _mapping(P, opath, o, ORIENTATION_KEYS,
                        what="a mapping with one of " + ", ".join(ORIENTATION_KEYS)):
                given = [k for k in o if k in ORIENTATION_KEYS]
                if len(given) != 1:
                    P.add(opath, f"give exactly one of {', '.join(ORIENTATION_KEYS)}"
                                 + (f", not {len(given)} ({', '.join(given)})" if given else ""))
                else:
                    key = given[0]
                    val = o[key]
                    if key == "matrix":
                        if _matrix(P, opath + (key,), val):
                            orient["A"] = val
                    elif _vector(P, opath + (key,), val, 4 if key == "euler_parameters" else 3):
                        if key == "euler_parameters":
                            orient["p"] = val
                        elif key.endswith("_deg"):
                            orient[key[:-4]] = [math.radians(x) for x in val]
                        else:
                            orient[key] = val
        for key in ("points", "vectors"):
            if key in d:
                table = d[key]
                if not isinstance(table, dict):
                    P.add(path + (key,), f"expected a mapping name: [x, y, z], got "
                                         f"{_describe(table)}")
                    continue
                for pname, vec in table.items():
                    if not isinstance(pname, str):
                        P.add(path + (key, pname), f"{key[:-1]} names must be strings, got "
                                                   f"{_describe(pname)}")
                    _vector(P, path + (key, pname), vec)
        if "shapes" in d and _list(P, path + ("shapes",), d["shapes"], "shapes"):
            for k, s in enumerate(d["shapes"]):
                _shape(P, path + ("shapes", k), s)
        if "color" in d:
            _color(P, path + ("color",), d["color"])
        if len(P) != n0 or P.flagged(path) or not complete:
            continue
        kwargs = dict(r=d.get("position", (0.0, 0.0, 0.0)),
                      rdot=d.get("velocity", (0.0, 0.0, 0.0)),
                      omega=d.get("angular_velocity"),
                      omega_local=d.get("angular_velocity_local"),
                      points=d.get("points"), vectors=d.get("vectors"),
                      shapes=d.get("shapes"), color=d.get("color"), **orient)
        fields = dict(_BODY_FIELDS)
        for key in ("euler_zxz", "bryant"):
            if key + "_deg" in (d.get("orientation") or {}):
                fields[key] = ("orientation", key + "_deg")
        # the physical checks are independent: report each of them, not only the first
        label = f"bodies[{d['name']!r}]"
        checks = (lambda: check_mass(d["mass"], f"{label}.mass"),
                  lambda: check_inertia(d["inertia"], f"{label}.inertia"),
                  lambda: orientation_to_p(label, **orient))
        failed = False
        for check in checks:
            try:
                check()
            except _BUILD_ERRORS as exc:
                _relabel(P, path, label, str(exc), fields)
                failed = True
        if failed:
            continue
        try:
            b.add_body(d["name"], d["mass"], d["inertia"], **kwargs)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, label, str(exc), fields)
            continue
        if "p" in orient:
            # keep Euler parameters that are unit to rounding bit for bit (exact round trips)
            given = np.array(orient["p"], dtype=float)
            if abs(float(np.linalg.norm(given)) - 1.0) <= 4 * _EPS:
                b.bodies[d["name"]].p = given
        ok_bodies.add(d["name"])

    # ------------------------------------------------------------------ joints
    declared_joints, ok_joints = [], set()
    joints = _section(data, "joints")
    if not _list(P, ("joints",), joints, "joints"):
        joints = []
    for i, d in enumerate(joints):
        path = ("joints", i)
        if not _mapping(P, path, d, joint_keys(d.get("type") if isinstance(d, dict) else None),
                        ("name", "type", "body_i", "body_j")):
            continue
        n0 = len(P)
        complete = all(k in d for k in ("name", "type", "body_i", "body_j"))
        if "name" in d and _string(P, path + ("name",), d["name"], "a joint name (string)"):
            declared_joints.append(d["name"])
        if "type" in d and not _member(d["type"], JOINT_TYPES):
            P.add(path + ("type",), f"unknown joint type {_name(d['type'])}"
                                    f"{_suggest(d['type'], JOINT_TYPES)}; valid types: "
                                    + ", ".join(sorted(JOINT_TYPES)))
        for key in ("body_i", "body_j"):
            if key in d:
                _reference(P, path + (key,), d[key], declared_bodies, "body", (GROUND,))
        geometry = {k: d[k] for k in GEOMETRY_KEYS if k in d}
        for key, val in geometry.items():
            _vector(P, path + (key,), val, or_name=key in ("point_i", "point_j"))
        params = {}
        if isinstance(d.get("type"), str) and d["type"] in JOINT_TYPES:
            for par in JOINT_TYPES[d["type"]].parameters:
                if par.name not in d:
                    continue
                value = d[par.name]
                if par.size > 1:                 # a list of 1 to size numbers
                    if not isinstance(value, list) or not 1 <= len(value) <= par.size:
                        P.add(path + (par.name,), f"expected a list of 1 to {par.size} "
                                                  f"numbers ({par.unit}), got "
                                                  f"{_describe(value)}")
                    elif all([_number(P, path + (par.name, k), x, positive=par.positive)
                              for k, x in enumerate(value)]):
                        params[par.name] = value
                elif _number(P, path + (par.name,), value, positive=par.positive):
                    params[par.name] = value
        if len(P) != n0 or P.flagged(path) or not complete or \
                not {d["body_i"], d["body_j"]} <= ok_bodies | {GROUND}:
            continue        # problems here, or in a body it joins (reported there)
        try:
            b.add_joint(d["type"], d["name"], d["body_i"], d["body_j"], **params, **geometry)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"joints[{d['name']!r}]", str(exc))
            continue
        ok_joints.add(d["name"])

    # ------------------------------------------------------------------ drivers
    drivers = _section(data, "drivers")
    if not _list(P, ("drivers",), drivers, "drivers"):
        drivers = []
    for i, d in enumerate(drivers):
        path = ("drivers", i)
        if not _mapping(P, path, d, DRIVER_KEYS, ("name", "kind", "law")):
            continue
        n0 = len(P)
        complete = all(k in d for k in ("name", "kind", "law"))
        if "name" in d:
            _string(P, path + ("name",), d["name"], "a driver name (string)")
        kind = d.get("kind")
        if "kind" in d and not _member(kind, DRIVER_TYPES):
            P.add(path + ("kind",), f"unknown driver kind {_name(kind)}"
                                    f"{_suggest(kind, DRIVER_TYPES)}; valid: "
                                    + ", ".join(DRIVER_TYPES))
        if kind == "coordinate":
            for key in ("body", "coordinate"):
                if key not in d:
                    P.add(path, f"missing required key {key!r} (a coordinate driver acts on a "
                                "coordinate of a body)")
            if "joint" in d:
                P.add(path + ("joint",), "a coordinate driver acts on a body, not a joint")
            if "body" in d:
                _reference(P, path + ("body",), d["body"], declared_bodies, "body")
            if "coordinate" in d and not _member(d["coordinate"], COORDINATES):
                P.add(path + ("coordinate",), f"{_describe(d['coordinate'])} is not one of "
                                              + ", ".join(COORDINATES))
        elif _member(kind, DRIVER_TYPES):
            if "joint" not in d:
                P.add(path, f"missing required key 'joint' (an {kind} driver acts on a joint)")
            else:
                _reference(P, path + ("joint",), d["joint"], declared_joints, "joint")
            for key in ("body", "coordinate"):
                if key in d:
                    P.add(path + (key,), "applies to coordinate drivers only")
        law = _law(P, path + ("law",), d["law"]) if "law" in d else None
        if len(P) != n0 or P.flagged(path) or not complete:
            continue
        if (d.get("joint") is not None and d["joint"] not in ok_joints) or \
                (d.get("body") is not None and d["body"] not in ok_bodies):
            continue
        try:
            b.add_driver(kind, d["name"], law, joint=d.get("joint"), body=d.get("body"),
                         coordinate=d.get("coordinate"))
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"drivers[{d['name']!r}]", str(exc))

    # ------------------------------------------------------------------ forces
    forces = _section(data, "forces")
    if not _list(P, ("forces",), forces, "force elements"):
        forces = []
    valid_types = [t for t, cls in FORCE_TYPES.items() if cls.in_files]
    for i, d in enumerate(forces):
        path = ("forces", i)
        if not isinstance(d, dict):
            P.add(path, f"expected a mapping {{name, type, ...}}, got {_describe(d)}")
            continue
        ftype = d.get("type")
        if "type" not in d:
            P.add(path, "missing required key 'type' (force types: "
                        + ", ".join(valid_types) + ")")
            continue
        if isinstance(ftype, str) and ftype in FORCE_TYPES and not FORCE_TYPES[ftype].in_files:
            P.add(path + ("type",), f"{ftype} forces take a Python callable (or other Python "
                                    "objects) and cannot be "
                                    "described in a model file; add them in Python with "
                                    f"ModelBuilder.add_force({ftype!r}, ...) after load_builder()")
            continue
        if not _member(ftype, FORCE_TYPES):
            P.add(path + ("type",), f"unknown force type {_name(ftype)}"
                                    f"{_suggest(ftype, valid_types)}; valid types: "
                                    + ", ".join(valid_types))
            continue
        allowed = ("name", "type") + FORCE_TYPES[ftype].allowed()
        required = ("name",) + tuple(FORCE_TYPES[ftype].required)
        _mapping(P, path, d, allowed, required)
        n0 = len(P)
        complete = all(k in d for k in required)
        if "name" in d:
            _string(P, path + ("name",), d["name"], "a force name (string)")
        params, refs_ok = {}, True
        for key, val in d.items():
            if key in ("name", "type") or key not in allowed:
                continue
            kind = FORCE_TYPES[ftype].parameters.get(key, "any")
            where = path + (key,)
            if kind == "body":
                if _reference(P, where, val, declared_bodies, "body", (GROUND,)):
                    refs_ok = refs_ok and (val in ok_bodies or val == GROUND)
            elif kind == "joint":
                if _reference(P, where, val, declared_joints, "joint"):
                    refs_ok = refs_ok and val in ok_joints
            elif kind == "point":
                _vector(P, where, val, or_name=True)
            elif kind == "vector":
                _vector(P, where, val)
            elif kind == "matrix":
                _matrix(P, where, val)
            elif kind == "string":
                _string(P, where, val)
            elif kind == "number":
                _number(P, where, val)
            elif kind == "law":
                if not _is_number(val):
                    val = _law(P, where, val)
                else:
                    _number(P, where, val)
            params[key] = val
        if len(P) != n0 or P.flagged(path) or not complete or not refs_ok:
            continue
        try:
            b.add_force(ftype, d["name"], **params)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"forces[{d['name']!r}]", str(exc))

    # ------------------------------------------------------------------ contacts
    # contact elements (spatialmbd.forces.contact): {name, body_i, body_j, shape_i, shape_j,
    # law, ...}, the parameters of the "contact" force type
    contacts = _section(data, "contacts")
    if not _list(P, ("contacts",), contacts, "contact elements"):
        contacts = []
    ctype = FORCE_TYPES["contact"]
    for i, d in enumerate(contacts):
        path = ("contacts", i)
        if not isinstance(d, dict):
            P.add(path, f"expected a mapping {{name, body_i, body_j, shape_i, shape_j, ...}}, "
                        f"got {_describe(d)}")
            continue
        allowed = ("name",) + ctype.allowed()
        required = ("name",) + tuple(ctype.required)
        _mapping(P, path, d, allowed, required)
        n0 = len(P)
        if "name" in d:
            _string(P, path + ("name",), d["name"], "a contact name (string)")
        params, refs_ok = {}, True
        for key, val in d.items():
            if key == "name" or key not in allowed:
                continue
            kind = ctype.parameters.get(key, "any")
            where = path + (key,)
            if kind == "body":
                if _reference(P, where, val, declared_bodies, "body", (GROUND,)):
                    refs_ok = refs_ok and (val in ok_bodies or val == GROUND)
            elif kind == "string":
                _string(P, where, val)
            elif kind == "number":
                _number(P, where, val)
            elif not isinstance(val, dict):
                P.add(where, f"expected a shape mapping {{type, ...}}, got {_describe(val)}")
            params[key] = val
        if len(P) != n0 or P.flagged(path) or not all(k in d for k in required) or not refs_ok:
            continue
        try:
            b.add_force("contact", d["name"], **params)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"forces[{d['name']!r}]", str(exc))

    # ------------------------------------------------------------------ ground shapes
    shapes = _section(data, "ground_shapes")
    if _list(P, ("ground_shapes",), shapes, "shapes"):
        for k, s in enumerate(shapes):
            if _shape(P, ("ground_shapes", k), s):
                b.add_ground_shape(s)

    # ------------------------------------------------------------------ analysis
    if data.get("analysis") is None:
        analysis = Analysis()
    else:
        analysis = _parse_analysis(P, ("analysis",), data["analysis"], declared_bodies)
    if analysis is not None:
        analysis.outputs = _parse_outputs_section(P, data)
    return b, analysis


def _parse_outputs_section(P, data) -> list:
    """The top-level ``outputs:`` list (docs/outputs.md): shape and keys checked here, element
    names once the model is compiled (:func:`load_model`)."""
    from ..outputs import Output
    items = _section(data, "outputs")
    out = []
    if not _list(P, ("outputs",), items, "output requests"):
        return out
    for k, item in enumerate(items):
        if isinstance(item, str):
            out.append(item)
            continue
        try:
            out.append(Output.from_dict(item).to_dict())
        except _BUILD_ERRORS as exc:
            P.add(("outputs", k), str(exc))
    return out


# ============================================================================ reading files
#: limits of what the reader accepts (see docs/reliability.md): file size in bytes, nesting
#: depth of lists/mappings, YAML aliases, values after alias expansion, digits of an integer
MAX_FILE_BYTES = 64 * 1024 * 1024
MAX_DEPTH = 64
MAX_ALIASES = 1000
MAX_NODES = 1_000_000
MAX_INT_DIGITS = 300


class _LimitError(Exception):
    """A reader limit was exceeded (turned into a ModelFileError with the line)."""

    def __init__(self, message, mark=None):
        super().__init__(message)
        self.mark = mark


class _Loader(yaml.SafeLoader):
    """SafeLoader reading floats as YAML 1.2 does (``1e-6`` is a number, not a string) and
    only true/false as booleans (not yes/no/on/off); with limits on nesting depth and aliases
    (a "billion laughs" document is refused, not expanded)."""

    _depth = 0
    _aliases = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise _LimitError(f"more than {MAX_ALIASES} YAML aliases (*name); a model "
                                  "file needs few, write the values out",
                                  self.peek_event().start_mark)
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _LimitError(f"lists/mappings nested more than {MAX_DEPTH} levels deep "
                                  "(a model file needs at most 6); check the brackets and the "
                                  "indentation", self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_yaml_int(self, node):
        digits = len(str(node.value).lstrip("+-").replace("_", ""))
        if digits > MAX_INT_DIGITS:
            raise yaml.constructor.ConstructorError(
                None, None, f"an integer with {digits} digits (the limit is "
                f"{MAX_INT_DIGITS}); write a number in range", node.start_mark)
        return super().construct_yaml_int(node)


_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)


_FLOAT_TAG = "tag:yaml.org,2002:float"
_BOOL_TAG = "tag:yaml.org,2002:bool"
_FLOAT_RE = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?
                        |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                        |[-+]?\.(?:inf|Inf|INF)
                        |\.(?:nan|NaN|NAN))$""", re.X)
_Loader.yaml_implicit_resolvers = {
    ch: [(tag, rx) for tag, rx in resolvers if tag not in (_FLOAT_TAG, _BOOL_TAG)]
    for ch, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver(_FLOAT_TAG, _FLOAT_RE, list("-+0123456789."))
_Loader.add_implicit_resolver(_BOOL_TAG, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"),
                              list("tTfF"))


def _walk(node, path, lines, duplicates, active=(), count=None) -> None:
    """Line of every value (path -> 1-based line) and duplicate keys, from the YAML node tree
    (``active``: the nodes being walked, so that recursive aliases end; ``count``: values
    visited, aliases expanded, limited to MAX_NODES)."""
    if id(node) in active:
        raise _LimitError("a YAML alias refers to a list or mapping that contains it (a "
                          "recursive structure); write the values out", node.start_mark)
    count = [0] if count is None else count
    count[0] += 1
    if count[0] > MAX_NODES:
        raise _LimitError(f"the document holds more than {MAX_NODES:,} values once its "
                          "aliases are expanded", node.start_mark)
    active = active + (id(node),)
    if isinstance(node, yaml.MappingNode):
        seen = set()
        for knode, vnode in node.value:
            if not isinstance(knode, yaml.ScalarNode) or knode.value == "<<":
                continue
            key = knode.value
            where = path + (key,)
            if key in seen:
                duplicates.append((where, knode.start_mark.line + 1))
            seen.add(key)
            lines.setdefault(where, vnode.start_mark.line + 1)
            _walk(vnode, where, lines, duplicates, active, count)
    elif isinstance(node, yaml.SequenceNode):
        for k, item in enumerate(node.value):
            lines.setdefault(path + (k,), item.start_mark.line + 1)
            _walk(item, path + (k,), lines, duplicates, active, count)


def _expanded_size(node, memo: dict, active: set) -> int:
    """Number of values of the node tree with aliases expanded (memoised per node, so a
    "billion laughs" document costs its size, not its expansion); raises _LimitError above
    MAX_NODES or for a recursive alias."""
    key = id(node)
    if key in memo:
        return memo[key]
    if key in active:
        raise _LimitError("a YAML alias refers to a list or mapping that contains it (a "
                          "recursive structure); write the values out", node.start_mark)
    active.add(key)
    total = 1
    if isinstance(node, yaml.MappingNode):
        total += sum(_expanded_size(v, memo, active) for _, v in node.value)
    elif isinstance(node, yaml.SequenceNode):
        total += sum(_expanded_size(v, memo, active) for v in node.value)
    active.discard(key)
    if total > MAX_NODES:
        raise _LimitError(f"the document holds more than {MAX_NODES:,} values once its "
                          "aliases are expanded (a 'billion laughs' document?)",
                          node.start_mark)
    memo[key] = total
    return total


def _read_yaml(text: str, source):
    lines, duplicates = {}, []
    loader = None
    try:
        loader = _Loader(text)
        node = loader.get_single_node()
        if node is not None:
            _expanded_size(node, {}, set())
            _walk(node, (), lines, duplicates)
        data = loader.construct_document(node) if node is not None else None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        what = exc.problem or exc.context or "invalid YAML"
        if exc.context and exc.problem:
            what = f"{exc.problem} ({exc.context})"
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        raise ModelFileError([f"{where}YAML syntax error: {what}"], source) from None
    except _LimitError as exc:
        where = f"line {exc.mark.line + 1}, column {exc.mark.column + 1}: " if exc.mark else \
            "(top level): "
        raise ModelFileError([f"{where}{exc}"], source) from None
    except yaml.reader.ReaderError as exc:
        line, column = _line_column(text, exc.position)
        raise ModelFileError([f"line {line}, column {column}: the character "
                              f"{_char(exc.character)} is not allowed in a YAML file; remove "
                              "it (binary data or a wrong encoding?)"], source) from None
    except yaml.YAMLError as exc:
        raise ModelFileError([f"(top level): YAML error: {exc}"], source) from None
    except (RecursionError, MemoryError):
        raise ModelFileError([f"(top level): the document is nested too deeply or is too "
                              f"large to read (limits: {MAX_DEPTH} levels, "
                              f"{MAX_FILE_BYTES // 2 ** 20} MB)"], source) from None
    except (ValueError, OverflowError) as exc:          # e.g. Python's int-digit limit
        raise ModelFileError([f"(top level): a value cannot be read: {exc}"], source) \
            from None
    finally:
        if loader is not None:
            loader.dispose()
    return data, lines, duplicates


def _read_json(text: str, source):
    duplicates = []

    def pairs(items):
        out = {}
        for key, value in items:
            if key in out:
                duplicates.append(((key,), None))
            out[key] = value
        return out

    def parse_int(digits):
        if len(digits.lstrip("-")) > MAX_INT_DIGITS:
            raise _LimitError(f"an integer with {len(digits.lstrip('-'))} digits (the limit "
                              f"is {MAX_INT_DIGITS}); write a number in range")
        return int(digits)

    try:
        data = json.loads(text, object_pairs_hook=pairs, parse_int=parse_int)
    except json.JSONDecodeError as exc:
        raise ModelFileError([f"line {exc.lineno}, column {exc.colno}: JSON syntax error: "
                              f"{exc.msg}"], source) from None
    except _LimitError as exc:
        raise ModelFileError([f"(top level): {exc}"], source) from None
    except (RecursionError, MemoryError):
        raise ModelFileError([f"(top level): the document is nested too deeply or is too "
                              f"large to read (limits: {MAX_DEPTH} levels, "
                              f"{MAX_FILE_BYTES // 2 ** 20} MB)"], source) from None
    except (ValueError, OverflowError) as exc:
        raise ModelFileError([f"(top level): a value cannot be read: {exc}"], source) \
            from None
    deep = _too_deep(data)
    if deep is not None:
        raise ModelFileError([f"{_render(deep)}: lists/mappings nested more than {MAX_DEPTH} "
                              "levels deep (a model file needs at most 6); check the "
                              "brackets"], source)
    return data, {}, duplicates


def _too_deep(data):
    """The path of a value nested deeper than MAX_DEPTH, or None (iterative)."""
    stack = [(data, ())]
    while stack:
        value, path = stack.pop()
        if len(path) > MAX_DEPTH:
            return path[:MAX_DEPTH]
        if isinstance(value, dict):
            stack.extend((v, path + (str(k),)) for k, v in value.items())
        elif isinstance(value, (list, tuple)):
            stack.extend((v, path + (k,)) for k, v in enumerate(value))
    return None


def _line_column(text: str, position: int):
    before = text[:position]
    return before.count("\n") + 1, position - (before.rfind("\n") + 1) + 1


def _char(character) -> str:
    code = ord(character) if isinstance(character, str) and len(character) == 1 else \
        character if isinstance(character, int) else None
    return f"U+{code:04X}" if code is not None else repr(character)


def _decode(raw: bytes, source) -> str:
    """The text of a model file: UTF-8 (with or without a byte-order mark), or UTF-16 /
    UTF-32 with a byte-order mark; anything else is refused with what it looks like."""
    boms = ((b"\xef\xbb\xbf", "utf-8-sig", "UTF-8"), (b"\xff\xfe\x00\x00", "utf-32", "UTF-32"),
            (b"\x00\x00\xfe\xff", "utf-32", "UTF-32"), (b"\xff\xfe", "utf-16", "UTF-16"),
            (b"\xfe\xff", "utf-16", "UTF-16"))
    for bom, codec, label in boms:
        if raw.startswith(bom):
            try:
                return raw.decode(codec)
            except UnicodeDecodeError as exc:
                raise ModelFileError([f"byte {exc.start}: the file starts with a {label} "
                                      f"byte-order mark but is not valid {label} ({exc.reason})"
                                      "; save it as UTF-8"], source) from None
    head = raw[:4096]
    if head and head.count(0) > len(head) // 4:      # ASCII text in UTF-16/32 is valid UTF-8
        raise ModelFileError([f"line 1, column 1: the file has {raw.count(0):,} zero bytes; it "
                              "looks like UTF-16 or UTF-32 without a byte-order mark. Model "
                              "files must be UTF-8 (UTF-16 is read with a byte-order mark): "
                              "save the file as UTF-8"], source)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        head = raw[:4096]
        if head and head.count(0) > len(head) // 4:
            guess = "it looks like UTF-16 or UTF-32 without a byte-order mark"
        else:
            guess = "it looks like another encoding (e.g. Latin-1 or Windows-1252) or binary data"
        line = raw[:exc.start].count(b"\n") + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise ModelFileError([f"line {line}, column {column}: byte 0x{raw[exc.start]:02x} is not "
                              f"valid UTF-8; {guess}. Model files must be UTF-8 (UTF-16 is read "
                              "with a byte-order mark): save the file as UTF-8"], source) \
            from None


def _plain_input(value):
    """Python input (dicts with tuples / NumPy values) as the plain types a file gives."""
    if isinstance(value, dict):
        return {k: _plain_input(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain_input(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain_input(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def _read(path_or_dict):
    """(data, source, lines, duplicates, default name) of a path or a dict."""
    if isinstance(path_or_dict, dict):
        deep = _too_deep(path_or_dict)
        if deep is not None:
            raise ModelFileError([f"{_render(deep)}: lists/mappings nested more than "
                                  f"{MAX_DEPTH} levels deep (or a structure that contains "
                                  "itself)"])
        return _plain_input(path_or_dict), None, {}, [], "model"
    if not isinstance(path_or_dict, (str, os.PathLike)):
        raise ModelFileError([f"(top level): expected a path (.yaml, .yml, .json) or a dict, "
                              f"not {type(path_or_dict).__name__}"])
    path = Path(path_or_dict)
    suffix = path.suffix.lower()
    if suffix not in YAML_SUFFIXES + JSON_SUFFIXES:
        raise ModelFileError([f"unsupported file extension {path.suffix!r}; use .yaml, .yml "
                              "or .json"], path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ModelFileError([f"(top level): the file is {size:,} bytes; the limit is "
                                  f"{MAX_FILE_BYTES:,} (io.modelfile.MAX_FILE_BYTES)"], path)
        raw = path.read_bytes()
    except OSError as exc:
        raise ModelFileError([f"(top level): cannot read the file: {exc.strerror or exc}"],
                             path) from None
    text = _decode(raw, path)
    reader = _read_yaml if suffix in YAML_SUFFIXES else _read_json
    data, lines, duplicates = reader(text, path)
    return data, path, lines, duplicates, path.stem


def load_builder(path_or_dict) -> tuple[ModelBuilder, Analysis]:
    """A ModelBuilder and the Analysis of a model file (.yaml/.yml/.json) or a model dict.

    The whole file is checked first; every problem is reported at once in one
    :class:`ModelFileError` (``problems``: one string per problem, with its place).
    """
    data, source, lines, duplicates, default_name = _read(path_or_dict)
    P = _Problems(lines)
    for where, line in duplicates:
        P.add(where, f"duplicate key {where[-1]!r} (each key may appear once per mapping)",
              line)
    token = _BASE_DIR.set(None if source is None else str(Path(source).resolve().parent))
    try:
        builder, analysis = _parse(P, data, default_name)
    finally:
        _BASE_DIR.reset(token)
    if len(P):
        raise P.error(source)
    return builder, analysis


def load_model(path_or_dict) -> tuple[Model, Analysis]:
    """The compiled Model and the Analysis of a model file or dict (see :func:`load_builder`)."""
    builder, analysis = load_builder(path_or_dict)
    try:
        model = builder.compile()
    except ModelFileError:
        raise
    except ModelError as exc:
        source = None if isinstance(path_or_dict, dict) else path_or_dict
        raise ModelFileError([str(exc)], source) from None
    except _BUILD_ERRORS as exc:        # numerical trouble with extreme (but in-range) values
        source = None if isinstance(path_or_dict, dict) else path_or_dict
        raise ModelFileError([f"(top level): the model cannot be compiled: "
                              f"{type(exc).__name__}: {exc}; check extreme values"],
                             source) from None
    if analysis is not None and analysis.outputs:
        from ..outputs import parse_outputs
        try:
            parse_outputs(model, analysis.outputs)
        except ModelError as exc:
            source = None if isinstance(path_or_dict, dict) else path_or_dict
            raise ModelFileError([f"outputs: {exc}"], source) from None
    return model, analysis


# ============================================================================ builder -> file
# the writer lives in .writer (re-exported here: one import for readers and writers)
from .writer import _plain, model_to_dict, save_model, write_examples  # noqa: E402,F401
