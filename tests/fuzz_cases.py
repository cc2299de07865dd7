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


#: what a fuzz run may use: a short simulated time and a budget (steps, wall time, outputs)
FUZZ_T_END = 0.02
FUZZ_BUDGET = dict(max_steps=300, max_wall_time=2.0, max_outputs=20_000)


def bounded_run(model, analysis):
    """Run ``analysis`` as the file says, but shortened to FUZZ_T_END and under FUZZ_BUDGET;
    return its status."""
    from spatialmbd.budget import Budget
    from spatialmbd.kinematics import kinematic_analysis
    from spatialmbd.simulate import output_times, simulate
    t_end = min(analysis.t_end, FUZZ_T_END) if math.isfinite(analysis.t_end) else FUZZ_T_END
    t_eval = None
    if analysis.t_eval is not None:
        t_eval = [t for t in analysis.t_eval if t <= FUZZ_T_END] or [t_end]
    if analysis.type == "kinematic":
        times = output_times(t_end, analysis.output_step, t_eval, max_outputs=200)
        return kinematic_analysis(model, times).status
    res = simulate(model, t_end, method=analysis.method, integrator=analysis.integrator,
                   output_step=analysis.output_step, t_eval=t_eval, step=analysis.step,
                   rtol=analysis.rtol, atol=analysis.atol,
                   method_options=dict(analysis.method_options),
                   integrator_options=dict(analysis.integrator_options),
                   correct_initial=analysis.correct_initial, hold=analysis.hold,
                   budget=Budget(**FUZZ_BUDGET))
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


# ------------------------------------------------------------------------------ API calls
API_NAMES = st.one_of(st.sampled_from(["standard", "penalty", "augmented_lagrangian",
                                       "baumgarte", "projection", "standrd", "Penalty", "al",
                                       "rk4", "rk45", "euler", "heun", "abm4", "bdf4",
                                       "scipy-rk45", "scipy-radau", "rk5", "", "ground",
                                       "pendulum", "pendulum.tip", "tip"]),
                      st.text(max_size=8), st.sampled_from(NASTY_SCALARS),
                      st.lists(st.sampled_from(["a", 1]), max_size=2))
API_OPTIONS = st.dictionaries(
    st.sampled_from(["alpha", "beta", "alpah", "omega", "mu", "solver", "tolerance",
                     "max_iterations", "step", "rtol", "atol", "max_step", "first_step",
                     "stpe", 3]),
    st.one_of(st.sampled_from(NASTY_SCALARS), st.floats(1e-6, 1e3)), max_size=2)
API_TIMES = st.one_of(st.sampled_from([None, 0.0, -1.0, 1e-15, 1e-300, 0.01, 0.02, 1e300,
                                       float("nan"), float("inf"), 10 ** 40, "0.1", [0.01]]),
                      st.floats(-1.0, 0.05))


@st.composite
def api_call(draw):
    """Keyword arguments of simulate() on the pendulum, and names to look up afterwards."""
    kwargs = {}
    for key, strategy in (("method", API_NAMES), ("integrator", API_NAMES),
                          ("method_options", st.one_of(st.none(), API_OPTIONS,
                                                       st.sampled_from([[1], "x"]))),
                          ("integrator_options", st.one_of(st.none(), API_OPTIONS)),
                          ("output_step", API_TIMES), ("step", API_TIMES),
                          ("rtol", API_TIMES), ("t0", API_TIMES),
                          ("q0", st.sampled_from(["zero_p", "nan", "short", "list"])),
                          ("v0", st.sampled_from(["nan", "huge", "short"])),
                          ("hold", st.sampled_from([{"pendulum": ["x"]}, ["pendulum"],
                                                    {"pendulum": 5}, {"x": ["x"]},
                                                    {"pendulum": "q"}, {"pendulum": "rz"},
                                                    None])),
                          ("correct_initial", st.sampled_from([True, False])),
                          ("t_eval", st.sampled_from([[0.0, 0.01], [0.01, 0.0], [],
                                                      [[0.0]], ["a"], [float("nan")]]))):
        if draw(st.integers(0, 7)) == 0:
            kwargs[key] = draw(strategy)
    t_end = draw(st.one_of(st.floats(0.001, 0.02), API_TIMES))
    lookups = draw(st.lists(st.tuples(st.sampled_from(["point", "body", "reactions"]),
                                      API_NAMES), max_size=3))
    return t_end, kwargs, lookups


def check_api(model, t_end, kwargs, lookups) -> str:
    """The fuzz property for one API call: Results (any status) or a SpatialMBDError."""
    import warnings

    import numpy as np

    from spatialmbd.budget import Budget
    from spatialmbd.simulate import simulate
    kwargs = dict(kwargs)
    nb = model.nb
    q0 = np.array(model.q0, dtype=float)
    special = {"zero_p": np.concatenate([q0[:, :3], np.zeros((nb, 4))], axis=1),
               "nan": np.full((nb, 7), np.nan), "short": np.zeros(3),
               "list": q0.tolist()}
    if "q0" in kwargs:
        kwargs["q0"] = special[kwargs["q0"]]
    if "v0" in kwargs:
        kwargs["v0"] = {"nan": np.full((nb, 6), np.nan), "huge": np.full((nb, 6), 1e300),
                        "short": np.zeros(2)}[kwargs["v0"]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = simulate(model, t_end, budget=Budget(**FUZZ_BUDGET), **kwargs)
        except SpatialMBDError as exc:
            assert str(exc).strip()
            return "error"
        assert res.status in ("success", "failed", "budget"), res.status
        for what, name in lookups:
            try:
                if what == "reactions":
                    res.reactions()
                else:
                    getattr(res, what)(name)
            except SpatialMBDError as exc:
                assert str(exc).strip()
        return res.status
