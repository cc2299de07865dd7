"""Parameter spaces of a sweep and model values addressed by path.

A parameter is a dotted path into the model-file dictionary (docs/model-file.md) or into the
analysis settings:

    bodies.link.mass                  kg        (lists of named items are indexed by name)
    bodies.link.inertia               kg m^2    ([Ixx, Iyy, Izz] or a 3x3 list)
    bodies.link.inertia.0             kg m^2    (one component: a list index)
    bodies.link.angular_velocity.0    rad/s     (an initial velocity; missing vectors start at 0)
    joints.pivot.axis                 -         (a joint's axis, unit vector or any length)
    forces.spring_A.stiffness         N/m
    gravity.2                         m/s^2
    analysis.t_end                    s
    analysis.integrator.rtol          -

With a factory (a callable returning a Model) the parameter names are its keyword arguments,
except ``analysis.*`` which still address the analysis settings.

Spaces (each gives an (n_members, n_params) table of values, member order fixed):
    :func:`grid`: the full factorial of value lists (first parameter varies slowest);
    :func:`points`: given points (a list of dicts, or equal-length lists zipped);
    :func:`latin_hypercube`: n random samples stratified in every parameter (seeded).
A plain ``{path: values}`` dict given to :func:`..sweep` is a grid.
"""
from __future__ import annotations

import copy
import itertools
import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..errors import ModelError
from .limits import check_members

__all__ = ["ParameterSpace", "grid", "points", "latin_hypercube", "parse_range",
           "as_space", "set_path", "get_path"]


@dataclass
class ParameterSpace:
    """The members of a sweep: ``values[k, j]`` is parameter ``names[j]`` of member k.

    kind: "grid" (``axes`` holds each parameter's distinct values; members are the full
    factorial in C order, so a result reshapes to one dimension per parameter) or "points".
    """

    names: list
    values: np.ndarray
    kind: str = "points"
    axes: list = field(default_factory=list)

    @property
    def n_members(self) -> int:
        return int(self.values.shape[0])

    def member(self, k: int) -> dict:
        """{name: value} of member k (Python floats)."""
        return {n: float(self.values[k, j]) for j, n in enumerate(self.names)}


def _values(name, vals, max_members=None) -> np.ndarray:
    a = None
    if not isinstance(vals, str):
        try:
            a = np.asarray(vals, dtype=float).ravel()
        except (TypeError, ValueError):
            raise ModelError(f"parameter {name!r}: values must be numbers, a list of numbers "
                             f"or a 'start:stop:count' range, got {vals!r}"[:300]) from None
    if isinstance(vals, str):
        a = parse_range(vals, name, max_members)
    if a.size == 0:
        raise ModelError(f"parameter {name!r}: no values given")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"parameter {name!r}: values must be finite numbers, got {list(a)}")
    return a


def parse_range(text: str, name: str = "parameter",
                max_members: Optional[int] = None) -> np.ndarray:
    """Values from ``"start:stop:count"`` (count values, both ends included, like
    numpy.linspace), ``"start:stop:count:log"`` (geometric) or ``"v1,v2,v3"``. A count above
    ``max_members`` (default limits.MAX_MEMBERS) is refused before the values exist."""
    text = text.strip()
    parts = text.split(":")
    if len(parts) in (3, 4) and parts[2].strip().isdigit():
        check_members(int(parts[2]), 1, f"parameter {name!r}: {text!r}", max_members)
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
                raise ValueError
            a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
            if n < 1:
                raise ValueError
            if len(parts) == 4:
                if a <= 0 or b <= 0:
                    raise ValueError
                return np.geomspace(a, b, n)
            return np.linspace(a, b, n)
        return np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise ModelError(f"parameter {name!r}: cannot read values {text!r}; write "
                         "start:stop:count (e.g. 1:10:10), start:stop:count:log or a "
                         "comma-separated list (e.g. 1,2,5)") from None


def grid(params: dict, max_members: Optional[int] = None) -> ParameterSpace:
    """Full factorial of ``{name: values}`` (values: a list/array or a "start:stop:count"
    string). The first parameter varies slowest. More than ``max_members`` (default
    limits.MAX_MEMBERS) members are refused before the table of values is made."""
    if not params:
        raise ModelError("a sweep needs at least one parameter")
    names = list(params)
    axes = [_values(n, params[n], max_members) for n in names]
    sizes = [a.size for a in axes]
    check_members(math.prod(sizes), len(names),
                  "a grid of " + " x ".join(str(s) for s in sizes) + " values", max_members)
    values = np.array(list(itertools.product(*axes)), dtype=float).reshape(-1, len(names))
    return ParameterSpace(names, values, "grid", axes)


def points(pts) -> ParameterSpace:
    """Members at given points: a list of ``{name: value}`` dicts (same names in each) or a
    dict ``{name: [v0, v1, ...]}`` of equal-length lists (zipped, not crossed)."""
    if isinstance(pts, dict):
        names = list(pts)
        cols = [_values(n, pts[n]) for n in names]
        sizes = {n: c.size for n, c in zip(names, cols)}
        if len(set(sizes.values())) != 1:
            raise ModelError(f"points: every parameter needs the same number of values, got "
                             f"{sizes}; use grid() for all combinations")
        return ParameterSpace(names, np.column_stack(cols), "points")
    pts = list(pts)
    if not pts or not all(isinstance(p, dict) for p in pts):
        raise ModelError("points: expected a non-empty list of {parameter: value} dicts")
    names = list(pts[0])
    for k, p in enumerate(pts):
        if set(p) != set(names):
            raise ModelError(f"points: point {k} has parameters {sorted(p)}, point 0 has "
                             f"{sorted(names)}; every point must set the same parameters")
    values = np.array([[float(p[n]) for n in names] for p in pts], dtype=float)
    return ParameterSpace(names, values, "points")


def latin_hypercube(bounds: dict, n: int, seed: Optional[int] = 0,
                    max_members: Optional[int] = None) -> ParameterSpace:
    """n samples of ``{name: (low, high)}`` by Latin hypercube sampling: each parameter's range
    is cut into n equal strata and every stratum holds exactly one sample (uniform inside it);
    the strata are paired at random. ``seed`` makes the members reproducible."""
    n = int(n)
    if n < 1:
        raise ModelError(f"latin_hypercube: n must be >= 1, got {n}")
    check_members(n, len(bounds), f"a Latin hypercube of n = {n}", max_members)
    rng = np.random.default_rng(seed)
    names = list(bounds)
    cols = []
    for name in names:
        try:
            lo, hi = (float(v) for v in bounds[name])
        except (TypeError, ValueError):
            raise ModelError(f"latin_hypercube: bounds of {name!r} must be (low, high), got "
                             f"{bounds[name]!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ModelError(f"latin_hypercube: bounds of {name!r} must be finite with "
                             f"high > low, got ({lo}, {hi})")
        u = (rng.permutation(n) + rng.random(n)) / n
        cols.append(lo + (hi - lo) * u)
    return ParameterSpace(names, np.column_stack(cols), "points")


def as_space(params, max_members: Optional[int] = None) -> ParameterSpace:
    """A ParameterSpace from a space, a ``{name: values}`` dict (grid) or a list of points."""
    if isinstance(params, ParameterSpace):
        check_members(params.n_members, len(params.names), "the parameter space",
                      max_members)
        return params
    if isinstance(params, dict):
        return grid(params, max_members)
    if isinstance(params, (list, tuple)):
        return points(params)
    raise ModelError(f"params: expected a dict {{path: values}}, a list of points or a "
                     f"ParameterSpace (grid, points, latin_hypercube), got "
                     f"{type(params).__name__}")


# ---------------------------------------------------------------------------------- paths
#: vectors a body may omit in a model file (they then start at zero)
_ZERO_VECTORS = ("position", "velocity", "angular_velocity", "angular_velocity_local")


def _step(node, token, path, create):
    """The child of ``node`` named by ``token`` (a name in a list of named items, an index
    or a key)."""
    if isinstance(node, list):
        if token.lstrip("-").isdigit():
            k = int(token)
            if not -len(node) <= k < len(node):
                raise ModelError(f"parameter {path!r}: index {k} is out of range (the list "
                                 f"has {len(node)} items)")
            return node, k
        named = [i for i, item in enumerate(node) if isinstance(item, dict)
                 and item.get("name") == token]
        if not named:
            from ..suggest import closest_first, suggest
            names = [item.get("name") for item in node if isinstance(item, dict)]
            raise ModelError(f"parameter {path!r}: no item named {token!r}"
                             f"{suggest(token, names)}; names here: "
                             f"{', '.join(closest_first(token, names)) or 'none'} (the names "
                             "of a model: spatialmbd info MODEL)")
        return node, named[0]
    if isinstance(node, dict):
        if token not in node:
            if create and token in _ZERO_VECTORS:
                node[token] = [0.0, 0.0, 0.0]
            elif create:
                node[token] = None
            else:
                raise ModelError(f"parameter {path!r}: no key {token!r}; keys here: "
                                 f"{', '.join(map(str, node))}")
        return node, token
    raise ModelError(f"parameter {path!r}: {token!r} cannot be looked up in a "
                     f"{type(node).__name__} value ({node!r})")


def get_path(data: dict, path: str):
    """The value at a dotted path of a model dictionary."""
    node = data
    for token in path.split("."):
        parent, key = _step(node, token, path, create=False)
        node = parent[key]
    return node


def set_path(data: dict, path: str, value) -> None:
    """Set the value at a dotted path of a model dictionary, in place.

    A scalar given for a vector (e.g. ``joints.pivot.axis = 2``) is an error naming the path;
    missing keys of the last mapping are created (e.g. ``analysis.integrator.rtol``), missing
    body velocity vectors start at zero."""
    tokens = path.split(".")
    if not all(tokens):
        raise ModelError(f"parameter {path!r}: empty path component")
    node = data
    for token in tokens[:-1]:
        parent, key = _step(node, token, path, create=True)
        if parent[key] is None:
            parent[key] = {}
        node = parent[key]
    parent, key = _step(node, tokens[-1], path, create=True)
    old = parent[key]
    if isinstance(old, list) and not isinstance(value, (list, tuple, np.ndarray)):
        raise ModelError(f"parameter {path!r}: addresses a list ({old!r}); give one component "
                         f"with an index, e.g. {path}.0")
    parent[key] = value.tolist() if isinstance(value, np.ndarray) else value


def plain_copy(value):
    """A deep copy of plain data (dicts, lists and immutable leaves), several times faster
    than copy.deepcopy on a model dictionary."""
    if isinstance(value, dict):
        return {k: plain_copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain_copy(v) for v in value]
    if isinstance(value, (str, int, float, bool, type(None), tuple)):
        return value
    return copy.deepcopy(value)


def apply(data: dict, member: dict) -> dict:
    """A deep copy of the model dictionary with a member's values set."""
    out = plain_copy(data)
    for path, value in member.items():
        set_path(out, path, value)
    return out


def split(member: dict, factory: bool) -> tuple:
    """(model values, analysis values) of a member: paths ``analysis.*`` go to the analysis."""
    model, analysis = {}, {}
    for name, value in member.items():
        if name.startswith("analysis."):
            analysis[name[len("analysis."):]] = value
        else:
            model[name] = value
    return model, analysis


def check_names(names: Sequence[str]) -> None:
    for n in names:
        if not isinstance(n, str) or not n:
            raise ModelError(f"parameter names must be non-empty strings, got {n!r}")
