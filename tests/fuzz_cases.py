"""Generators and the property of the fuzz test (tests/test_fuzz.py).

A case is a model file (bytes + suffix) made from one of the example files in examples/ by a
few mutations: a value replaced by a wrong type, a non-finite, huge or tiny number, deep
nesting, a key removed or added, extreme physics; then written as YAML or JSON in one of several
encodings, possibly with raw text damage (junk bytes, truncation, unbalanced brackets, alias
bombs). API cases call the Python API with wrong names, options and values.

The property (:func:`check_file`, :func:`check_api`): the input either runs (bounded: a short
t_end and a step and wall-time budget) or raises the project's error (SpatialMBDError) whose
message says where the problem is. Any other exception is a failure of the project.
"""
from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path

import yaml
from hypothesis import strategies as st

from spatialmbd.errors import SpatialMBDError

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.yaml"))
#: the parsed example files (dicts), loaded once
EXAMPLE_DATA = {p.stem: yaml.safe_load(p.read_text(encoding="utf-8")) for p in EXAMPLES}

# ------------------------------------------------------------------------------ value pools
NASTY_NUMBERS = [float("nan"), float("inf"), float("-inf"), 1e300, -1e300, 5e-324, -5e-324,
                 0.0, -0.0, -1.0, 1e-300, 1e-15, 1e15, 10 ** 40, -(10 ** 40), 2 ** 63,
                 1e308, 3, 0.5, 1e-7]
NASTY_SCALARS = NASTY_NUMBERS + ["x", "", "nan", "1e400", True, False, None,
                                 "ground", "revolute", "\u00e9\u00e8\u00ea", "a" * 300]


def _deep(depth: int, leaf=1):
    out = leaf
    for _ in range(depth):
        out = [out]
    return out


def _deep_map(depth: int):
    out: object = 1
    for _ in range(depth):
        out = {"a": out}
    return out


replacement = st.one_of(
    st.sampled_from(NASTY_SCALARS),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10 ** 50), max_value=10 ** 50),
    st.text(max_size=20),
    st.lists(st.sampled_from(NASTY_NUMBERS), max_size=5),
    st.dictionaries(st.sampled_from(["name", "type", "a", "x"]),
                    st.sampled_from(NASTY_SCALARS), max_size=3),
    st.builds(_deep, st.sampled_from([5, 50, 150])),
    st.builds(_deep_map, st.sampled_from([5, 50, 150])),
    st.just([[1, 2, 3], [4, 5, 6]]), st.just([1.0, 2.0]), st.just([0, 0, 0]),
    st.just([0, 0, 0, 0]), st.just({"name": "x"}), st.just(["a", "b"]),
)


def _paths(data, prefix=()):
    """Every path (tuple of keys / indexes) in a nested dict/list (to depth 8)."""
    out = [prefix]
    if len(prefix) >= 8:
        return out
    if isinstance(data, dict):
        for k, v in data.items():
            out.extend(_paths(v, prefix + (k,)))
    elif isinstance(data, list):
        for k, v in enumerate(data):
            out.extend(_paths(v, prefix + (k,)))
    return out


def _get(data, path):
    for p in path:
        data = data[p]
    return data


def _scale_numbers(data, factor):
    if isinstance(data, dict):
        return {k: _scale_numbers(v, factor) for k, v in data.items()}
    if isinstance(data, list):
        return [_scale_numbers(v, factor) for v in data]
    if isinstance(data, float) and not isinstance(data, bool):
        return data * factor
    return data


@st.composite
def mutated_model(draw):
    """A model dict: an example with 1-4 mutations."""
    name = draw(st.sampled_from(sorted(EXAMPLE_DATA)))
    data = copy.deepcopy(EXAMPLE_DATA[name])
    n = draw(st.integers(min_value=1, max_value=4))
    for _ in range(n):
        paths = _paths(data)
        path = draw(st.sampled_from(paths))
        kind = draw(st.sampled_from(["replace", "replace", "replace", "delete", "add_key",
                                     "scale", "duplicate", "analysis"]))
        if kind == "analysis":
            analysis = data.setdefault("analysis", {}) if isinstance(data, dict) else None
            if isinstance(analysis, dict):
                key = draw(st.sampled_from(["t_end", "output_step", "t_eval", "method",
                                            "integrator", "correct_initial", "hold", "type"]))
                value = draw(st.one_of(
                    replacement,
                    st.sampled_from(["standard", "penalty", "augmented_lagrangian",
                                     "projection", "baumgarte", "standrd", "kinematic"]),
                    st.fixed_dictionaries({"name": st.sampled_from(
                        ["rk4", "euler", "rk45", "abm4", "bdf4", "scipy-rk45", "rk5"]),
                        "step": st.sampled_from([1e-3, 1e-7, 1e-300, 0.5, float("nan")])}),
                    st.fixed_dictionaries({"name": st.sampled_from(
                        ["penalty", "augmented_lagrangian", "baumgarte"]),
                        "alpha": st.sampled_from([1e300, -1.0, 5.0, float("inf")])}),
                ))
                analysis[key] = copy.deepcopy(value)
            continue
        if not path:
            continue
        parent = _get(data, path[:-1])
        key = path[-1]
        if kind == "replace":
            parent[key] = copy.deepcopy(draw(replacement))
        elif kind == "delete":
            del parent[key]
        elif kind == "add_key":
            if isinstance(parent, dict):
                parent[draw(st.sampled_from(["extra", "nam", "massa", "typ", 7]))] = \
                    copy.deepcopy(draw(replacement))
        elif kind == "scale":
            parent[key] = _scale_numbers(parent[key], draw(st.sampled_from(
                [1e-300, 1e-9, 1e9, 1e300, -1.0, 0.0])))
        elif kind == "duplicate" and isinstance(parent, list):
            parent.append(copy.deepcopy(parent[key]))
    return data


def _dump(data, fmt: str) -> str:
    try:
        if fmt == "json":
            return json.dumps(data, allow_nan=True, default=str)
        try:
            return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
        except yaml.YAMLError:                  # e.g. a key yaml cannot represent
            return json.dumps(data, allow_nan=True, default=str)
    except RecursionError:                      # deep nesting: written out by hand
        return '{"spatialmbd": 1, "bodies": ' + "[" * 1200 + "]" * 1200 + "}"


ALIAS_BOMB = """spatialmbd: 1
a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]
b: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]
c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]
d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]
e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d]
f: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e]
g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f]
h: &h [*g,*g,*g,*g,*g,*g,*g,*g,*g]
bodies: *h
"""


@st.composite
def model_file(draw):
    """(bytes, suffix) of a model file, mutated in content, format, encoding and text."""
    data = draw(mutated_model())
    fmt = draw(st.sampled_from(["yaml", "yaml", "json"]))
    text = _dump(data, fmt)
    damage = draw(st.sampled_from(["none"] * 6 + ["junk", "truncate", "brackets", "bomb",
                                                   "recursive_alias", "control", "deep"]))
    if damage == "truncate":
        text = text[:draw(st.integers(min_value=0, max_value=max(0, len(text))))]
    elif damage == "brackets":
        n = draw(st.sampled_from([10, 1000, 100_000]))
        text = text + ("\nx: " if fmt == "yaml" else "") + draw(st.sampled_from("[{")) * n
    elif damage == "deep":                      # 900-1200 levels, balanced
        n = draw(st.sampled_from([900, 1200]))
        opener = draw(st.sampled_from(["[", '{"a": ']))
        closer = "]" if opener == "[" else "}"
        text = '{"spatialmbd": 1, "bodies": ' + opener * n + "1" + closer * n + "}"
    elif damage == "bomb" and fmt == "yaml":
        text = ALIAS_BOMB
    elif damage == "recursive_alias" and fmt == "yaml":
        text = "spatialmbd: 1\nbodies: &x [*x]\n"
    elif damage == "control":
        at = draw(st.integers(min_value=0, max_value=len(text)))
        text = text[:at] + draw(st.sampled_from(["\x00", "\x07", "\ufeff", "\ud800"])) + \
            text[at:]
    encoding = draw(st.sampled_from(["utf-8", "utf-8", "utf-8", "utf-8-sig", "utf-16",
                                     "utf-16-le", "utf-32", "latin-1"]))
    raw = text.encode(encoding, errors="surrogatepass" if encoding.startswith("utf")
                      else "replace")
    if damage == "junk":
        junk = draw(st.binary(min_size=1, max_size=64))
        at = draw(st.integers(min_value=0, max_value=len(raw)))
        raw = raw[:at] + junk + raw[at:]
    return raw, ".json" if fmt == "json" else ".yaml"


# ------------------------------------------------------------------------------ the property
_LOCATED = re.compile(r"^(\(top level\)|[A-Za-z_\[].*?: |line \d+|.*: )")


def is_located(problem: str) -> bool:
    """A problem of a ModelFileError names its place ('bodies[2].mass: ...', 'line 3 ...')."""
    return bool(_LOCATED.match(problem)) and len(problem) > 10


def bounded_run(model, analysis):
    """Run ``analysis`` shortened and with a budget; return its status."""
    from spatialmbd.kinematics import kinematic_analysis
    from spatialmbd.simulate import Budget, output_times, simulate
    t_end = min(analysis.t_end, 0.02) if math.isfinite(analysis.t_end) else 0.02
    if analysis.type == "kinematic":
        times = output_times(t_end, t_end / 4, None)
        return kinematic_analysis(model, times).status
    res = simulate(model, t_end, method=analysis.method, integrator=analysis.integrator,
                   output_step=t_end / 4, step=analysis.step, rtol=analysis.rtol,
                   atol=analysis.atol, method_options=dict(analysis.method_options),
                   integrator_options=dict(analysis.integrator_options),
                   correct_initial=analysis.correct_initial, hold=analysis.hold,
                   budget=Budget(max_steps=300, max_wall_time=2.0))
    assert res.status in ("success", "failed", "budget"), res.status
    return res.status


def check_file(path) -> str:
    """The fuzz property for one model file; returns 'rejected' or the run's status."""
    import warnings

    from spatialmbd.io.modelfile import ModelFileError, load_model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            model, analysis = load_model(path)
        except ModelFileError as exc:
            assert exc.problems, "a ModelFileError without problems"
            bad = [p for p in exc.problems if not is_located(p)]
            assert not bad, f"problems without a place: {bad}"
            return "rejected"
        except SpatialMBDError as exc:
            raise AssertionError(f"load_model raised {type(exc).__name__} instead of "
                                 f"ModelFileError: {exc}") from exc
        try:
            return bounded_run(model, analysis)
        except SpatialMBDError as exc:
            assert str(exc).strip(), "an error without a message"
            return "error"
