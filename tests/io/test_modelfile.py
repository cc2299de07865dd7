"""Model files (spatialmbd.io): exact round trips, validation messages with places, analysis."""
from __future__ import annotations

import json
import os
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from spatialmbd import models
from spatialmbd.errors import ModelError
from spatialmbd.io import (SCHEMA_VERSION, Analysis, ModelFileError, load_builder, load_model,
                           model_to_dict, save_model)
from spatialmbd.kinematics import KinematicResults
from spatialmbd.model import ModelBuilder
from spatialmbd.motion import (Constant, ConstantVelocity, Harmonic, MotionLaw, Polynomial,
                               SmoothStep, UserFunction)
from spatialmbd.results import Results

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES_DIR = ROOT / "examples"
FORMATS = ("yaml", "json")


# --------------------------------------------------------------------------- comparisons
def plain(value):
    if isinstance(value, MotionLaw):
        return {"__law__": type(value).__name__, **plain(value.to_dict())}
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def same_floats(a, b) -> bool:
    """Bitwise equality of float arrays (so 0.0 and -0.0 differ)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def same_value(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    if isinstance(a, (list, tuple)) and any(isinstance(x, (str, dict)) for x in a):
        return plain(a) == plain(b)          # body names, wall dicts
    if isinstance(a, (MotionLaw, dict)) or isinstance(b, (MotionLaw, dict)):
        return plain(a) == plain(b)
    return same_floats(a, b)


def assert_same_state(s1: dict, s2: dict) -> None:
    """Builder specs equal with exact float equality."""
    assert s1["name"] == s2["name"]
    assert same_floats(s1["gravity"], s2["gravity"])
    assert list(s1["bodies"]) == list(s2["bodies"])
    for name, a in s1["bodies"].items():
        b = s2["bodies"][name]
        assert a.mass == b.mass, name
        for key in ("inertia", "r", "p", "rdot", "omega"):
            assert same_floats(getattr(a, key), getattr(b, key)), (name, key)
        for key in ("points", "vectors"):
            ta, tb = getattr(a, key), getattr(b, key)
            assert list(ta) == list(tb), (name, key)
            assert all(same_floats(ta[k], tb[k]) for k in ta), (name, key)
        assert plain(a.shapes) == plain(b.shapes), name
        assert a.color == b.color, name
    assert list(s1["joints"]) == list(s2["joints"])
    for name, a in s1["joints"].items():
        b = s2["joints"][name]
        assert (a.type, a.body_i, a.body_j, a.length) == (b.type, b.body_i, b.body_j, b.length)
        assert set(a.geometry) == set(b.geometry), name
        assert all(same_value(a.geometry[k], b.geometry[k]) for k in a.geometry), name
    assert list(s1["drivers"]) == list(s2["drivers"])
    for name, a in s1["drivers"].items():
        b = s2["drivers"][name]
        assert (a.kind, a.joint, a.body, a.coordinate) == (b.kind, b.joint, b.body, b.coordinate)
        assert type(a.law) is type(b.law) and plain(a.law) == plain(b.law), name
    assert list(s1["forces"]) == list(s2["forces"])
    for name, a in s1["forces"].items():
        b = s2["forces"][name]
        pa = {k: v for k, v in a.params.items() if v is not None}
        assert a.type == b.type and set(pa) == set(b.params), name
        assert all(same_value(pa[k], b.params[k]) for k in pa), (name, pa, b.params)
    assert plain(s1["ground_shapes"]) == plain(s2["ground_shapes"])


def assert_same_model(m1, m2) -> None:
    assert_same_state(m1.builder_state, m2.builder_state)
    assert same_floats(m1.q0, m2.q0) and same_floats(m1.v0, m2.v0)
    assert same_floats(m1.mass, m2.mass) and same_floats(m1.inertia, m2.inertia)
    for t in (0.0, 0.37):
        c1 = m1.assembler.evaluate(m1.q0, m1.v0, t)
        c2 = m2.assembler.evaluate(m2.q0, m2.v0, t)
        for key in ("phi", "nu", "gamma"):
            assert same_floats(getattr(c1, key), getattr(c2, key)), key
        assert same_floats(np.asarray(c1.D.todense() if hasattr(c1.D, "todense") else c1.D),
                           np.asarray(c2.D.todense() if hasattr(c2.D, "todense") else c2.D))


# --------------------------------------------------------------------------- models
def rich_builder() -> ModelBuilder:
    """Every feature a file can hold: all orientation forms, inertia with products, local and
    global joint geometry, point names, composite length, every driver kind and law type,
    every writable force type, shapes, colours, ground shapes, tricky names."""
    b = ModelBuilder("rich model", gravity=(0.1, -0.2, -9.80665))
    b.add_body("a", 1.3, [[0.2, 0.01, 0.0], [0.01, 0.3, -0.02], [0.0, -0.02, 0.25]],
               r=(0.1, 0.2, 0.3), euler_zxz=(0.3, 0.7, -1.1), rdot=(0.1, 0.0, -0.3),
               omega=(0.5, -0.25, 1.0 / 3.0), points={"tip": (0.1, 0.2, 1 / 7),
                                                      "base": (0, 0, -0.1)},
               vectors={"n": (0, 1.0, 1.0)},
               shapes=[{"type": "sphere", "radius": 0.05},
                       {"type": "box", "size": (0.1, 0.2, 0.3),
                        "center": np.array([0.0, 0.1, 0.0]), "p": [1, 0, 0, 0],
                        "color": "#ff0000"}],
               color="#12ab34")
    b.add_body("yes", 2.0, (0.1, 0.1, 0.1), r=(1.0, 0.0, 0.0), bryant=(0.1, 0.2, 0.3),
               omega_local=(0.0, 0.0, 2.0))
    b.add_body("1e3", 0.5, (0.01, 0.02, 0.02), r=(2.0, 0.5, -0.5),
               A=[[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    b.add_joint("revolute", "r1", "ground", "a", point_i=(0.1, 0.2, 0.2), point_j="base",
                axis_i=(0, 0, 1), axis_j=(0, 0, 1), ref_i=(1, 0, 0))
    b.add_joint("spherical_spherical", "ss", "a", "yes", point=(0.1, 0.2, 0.3),
                point2=(1.0, 0.0, 0.0), length=0.97)
    b.add_joint("cylindrical", "cyl", "ground", "1e3", point=(2.0, 0.5, -0.5), axis=(0, 1, 0),
                reference=(1, 0, 0))
    b.add_driver("coordinate", "d1", Polynomial([0.0, 0.1, -0.02]), body="yes", coordinate="z")
    b.add_driver("translation", "d2", SmoothStep(t0=0.0, t1=1.5, f0=0.0, f1=0.2), joint="cyl")
    b.add_driver("angle", "d3", Harmonic(amplitude=0.3, frequency=2.0, phase=0.1, offset=-0.05),
                 joint="cyl")
    b.add_force("spring_damper", "sd", body_i="ground", body_j="a", point_i=(0, 0, 1),
                point_j="tip", stiffness=100.0, damping=1.5, natural_length=0.4,
                actuator=Harmonic(amplitude=1.0))
    b.add_force("spring_damper", "sd2", body_i="a", body_j="yes", stiffness=10, actuator=0.5,
                natural_length=None)
    b.add_force("point_force", "pf", body="yes", point=(0.1, 0, 0), direction=(0, 0, 1),
                magnitude=ConstantVelocity(rate=2.0), frame="body")
    b.add_force("torque", "tq", body="1e3", direction=(1, 0, 0), magnitude=3.0)
    b.add_force("rotational_spring_damper", "rsd", joint="r1", stiffness=5.0, damping=0.1,
                rest_angle=0.2, actuator=Constant(0.3))
    b.add_ground_shape({"type": "box", "size": [4, 4, 0.01], "center": [0, 0, -1]})
    return b


def base_dict() -> dict:
    """A small valid model dict with three bodies (tests mutate copies of it)."""
    return {
        "spatialmbd": 1, "name": "three",
        "gravity": [0, 0, -9.81],
        "bodies": [
            {"name": "link", "mass": 7.02, "inertia": [0.5855265, 0.001053, 0.5855265],
             "position": [0, 0.5, 0], "points": {"tip": [0, 0.5, 0]}},
            {"name": "b1", "mass": 1.0, "inertia": [0.1, 0.1, 0.1], "position": [0, 1.5, 0]},
            {"name": "b2", "mass": 1.0, "inertia": [0.1, 0.1, 0.1], "position": [0, 2.5, 0]},
        ],
        "joints": [
            {"name": "pivot", "type": "revolute", "body_i": "ground", "body_j": "link",
             "point": [0, 0, 0], "axis": [1, 0, 0]},
            {"name": "s1", "type": "spherical", "body_i": "link", "body_j": "b1",
             "point": [0, 1, 0]},
            {"name": "s2", "type": "spherical", "body_i": "b1", "body_j": "b2",
             "point": [0, 2, 0]},
        ],
        "drivers": [{"name": "drive", "kind": "angle", "joint": "pivot",
                     "law": {"type": "constant_velocity", "rate": 6.0}}],
        "forces": [{"name": "spring", "type": "spring_damper", "body_i": "ground",
                    "body_j": "b2", "point_j": [0, 0, 0], "stiffness": 10.0}],
        "analysis": {"type": "dynamic", "t_end": 1.0, "output_step": 0.01,
                     "method": {"name": "baumgarte", "alpha": 5, "beta": 5},
                     "integrator": {"name": "rk45", "rtol": 1e-6, "atol": 1e-9}},
    }


def problems_of(data) -> list:
    with pytest.raises(ModelFileError) as info:
        load_builder(data)
    return info.value.problems


# --------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("name", list(models.EXAMPLES))
def test_examples_round_trip_exactly(tmp_path, name, fmt):
    function, kwargs, analysis = models.EXAMPLES[name]
    model = function(**kwargs).compile()
    path = save_model(model, tmp_path / f"{name}.{fmt}", analysis)
    assert path == tmp_path / f"{name}.{fmt}"
    loaded, an = load_model(path)
    assert_same_model(model, loaded)
    assert an == Analysis.from_dict(analysis)
    # and once more: file -> model -> file gives the same text
    again = save_model(loaded, tmp_path / f"again.{fmt}", an)
    assert again.read_text().replace("again", name) == path.read_text().replace("again", name)


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_feature_round_trips_exactly(tmp_path, fmt):
    builder = rich_builder()
    model = builder.compile()
    analysis = {"t_end": 2, "method": "baumgarte",
                "integrator": {"name": "bdf4", "rtol": 1e-7, "max_newton": 4},
                "hold": {"a": "x", "yes": ["rx", "z"]}}
    path = save_model(builder, tmp_path / f"rich.{fmt}", analysis)
    loaded, an = load_model(path)
    assert_same_model(model, loaded)
    assert an.integrator == "bdf4" and an.rtol == 1e-7 and an.integrator_options == {
        "max_newton": 4}
    assert an.hold == {"a": ["x"], "yes": ["rx", "z"]}
    # a model dict loads as well, and JSON holds exactly the same data as YAML
    data = model_to_dict(model, analysis)
    assert_same_model(model, load_model(data)[0])
    assert json.loads(json.dumps(data)) == data


def test_model_to_dict_is_plain_and_orientation_is_euler_parameters():
    builder = ModelBuilder("m")
    builder.add_body("b", 1.0, (1, 1, 1), bryant=(0.1, 0.2, 0.3))
    builder.add_body("still", 1.0, (1, 1, 1))
    data = model_to_dict(builder)
    assert data["spatialmbd"] == SCHEMA_VERSION
    body, still = data["bodies"]
    assert list(body["orientation"]) == ["euler_parameters"]
    assert body["orientation"]["euler_parameters"] == builder.bodies["b"].p.tolist()
    assert "orientation" not in still and "velocity" not in still   # defaults left out
    assert "analysis" not in data

    def walk(v):
        assert v is None or isinstance(v, (str, bool, int, float, list, dict)), type(v)
        for w in (v.values() if isinstance(v, dict) else v if isinstance(v, list) else ()):
            walk(w)
    walk(data)


def test_example_files_match_the_registry():
    """examples/<name>.yaml exists for every EXAMPLES entry and holds exactly that model."""
    missing = [n for n in models.EXAMPLES if not (EXAMPLES_DIR / f"{n}.yaml").exists()]
    assert not missing, (f"no example file for {missing}; regenerate with python -c 'from "
                         "spatialmbd.io import write_examples; write_examples(\"examples\")'")
    for name, (function, kwargs, analysis) in models.EXAMPLES.items():
        path = EXAMPLES_DIR / f"{name}.yaml"
        assert path.read_text().startswith("# "), "keep the header comment"
        builder, an = load_builder(path)
        reference = function(**kwargs)
        assert_same_state(model_to_dict_state(reference), model_to_dict_state(builder))
        assert an == Analysis.from_dict(analysis), name


def test_documented_complete_example_loads(tmp_path):
    text = (ROOT / "docs" / "model-file.md").read_text()
    block = re.findall(r"```yaml\n(.*?)```", text, re.S)[-1]
    path = tmp_path / "doc.yaml"
    path.write_text(block)
    model, an = load_model(path)
    assert model.nb == 2 and len(model.force_groups) == 2
    assert (an.method, an.method_options, an.rtol) == ("baumgarte", {"alpha": 5, "beta": 5}, 1e-8)


def model_to_dict_state(builder):
    return builder.compile().builder_state


# --------------------------------------------------------------------------- not writable
def test_user_law_and_user_force_cannot_be_saved(tmp_path):
    b = models.pendulum_ch15()
    b.add_driver("angle", "spin", UserFunction(np.sin, np.cos, lambda t: -np.sin(t)),
                 joint="pivot")
    b.add_force("user", "push", function=lambda t, q, v: (np.zeros((1, 3)), np.zeros((1, 3))))
    target = tmp_path / "p.yaml"
    target.write_text("old content\n")
    with pytest.raises(ModelFileError) as info:
        save_model(b, target)
    problems = info.value.problems
    assert len(problems) == 2
    assert problems[0].startswith("drivers[0].law: ") and "user-function" in problems[0]
    assert problems[1].startswith("forces[0]: ") and "user force" in problems[1]
    assert isinstance(info.value, ModelError)
    assert target.read_text() == "old content\n"          # untouched
    assert os.listdir(tmp_path) == ["p.yaml"]             # no temporary file left behind


def test_user_law_in_a_force_cannot_be_saved():
    b = models.pendulum_ch15()
    b.add_force("torque", "t", body="pendulum", direction=(1, 0, 0),
                magnitude=UserFunction(np.sin, np.cos, np.sin))
    with pytest.raises(ModelFileError, match=r"forces\[0\]\.magnitude: "):
        model_to_dict(b)


def test_user_elements_in_a_file_are_rejected():
    data = base_dict()
    data["forces"].append({"name": "u", "type": "user"})
    data["drivers"][0]["law"] = {"type": "user"}
    problems = problems_of(data)
    assert any(p.startswith("forces[1].type: user forces take a Python callable")
               for p in problems)
    assert any(p.startswith("drivers[0].law.type: user-function motion laws") for p in problems)


# --------------------------------------------------------------------------- bad input
def _set(data, path, value):
    *head, last = path
    for key in head:
        data = data[key]
    if value is DELETE:
        del data[last]
    else:
        data[last] = value


DELETE = object()

BAD = [
    # (path to change, new value, expected start of the problem, expected fragment)
    (("bodies", 2, "inertia"), [1.0, -1.0, 1.0], "bodies[2].inertia: ", "not positive definite"),
    (("bodies", 2, "inertia"), [1.0, 1.0, 5.0], "bodies[2].inertia: ", "triangle inequality"),
    (("joints", 0, "body_j"), "lnk", "joints[0].body_j: ", "unknown body 'lnk'"),
    (("bodies", 0, "mass"), "7.02", "bodies[0].mass: ", "expected a number, got the string"),
    (("bodies", 0, "mass"), True, "bodies[0].mass: ", "expected a number"),
    (("bodies", 1, "mass"), -2.0, "bodies[1].mass: ", "must be positive"),
    (("bodies", 1, "inertia"), DELETE, "bodies[1]: ", "missing required key 'inertia'"),
    (("bodies", 1, "colour"), "#ff0000", "bodies[1].colour: ", "unknown key 'colour'"),
    (("bodies", 1, "color"), "red", "bodies[1].color: ", "'#rrggbb'"),
    (("drivers", 0, "name"), "pivot", "drivers[0].name: ", "duplicate name 'pivot'"),
    (("bodies", 1, "position"), [0, 1], "bodies[1].position: ", "expected a list of 3 numbers"),
    (("bodies", 1, "orientation"), {"euler_parameters": [1, 0, 0, 0.5]},
     "bodies[1].orientation.euler_parameters: ", "far from 1"),
    (("bodies", 1, "orientation"), {"bryant": [0, 0, 0], "euler_zxz": [0, 0, 0]},
     "bodies[1].orientation: ", "give exactly one of"),
    (("bodies", 1, "orientation"), {"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]},
     "bodies[1].orientation.matrix: ", "not a rotation matrix"),
    (("bodies", 1, "vectors"), {"v": [0, 0, 0]}, "bodies[1].vectors.v: ", "zero-length"),
    (("bodies", 1, "shapes"), [{"type": "cone", "radius": 1}], "bodies[1].shapes[0].type: ",
     "unknown shape type 'cone'"),
    (("bodies", 1, "shapes"), [{"type": "sphere", "radius": -1}],
     "bodies[1].shapes[0].radius: ", "must be > 0"),
    (("joints", 0, "type"), "revolut", "joints[0].type: ", "did you mean 'revolute'"),
    (("joints", 0, "axis"), DELETE, "joints[0]: ", "needs axis"),
    (("joints", 0, "axis"), [0, 0, 0], "joints[0].axis: ", "zero-length"),
    (("joints", 1, "point_i"), "nowhere", "joints[1]: ", "mixes global"),
    (("drivers", 0, "joint"), "s1", "drivers[0]: ", "cannot take an angle driver"),
    (("drivers", 0, "joint"), "pivt", "drivers[0].joint: ", "unknown joint 'pivt'"),
    (("drivers", 0, "law"), {"type": "harmonic", "amp": 1}, "drivers[0].law.amp: ",
     "unknown key 'amp'"),
    (("drivers", 0, "law"), {"type": "smooth_step", "t0": 1, "t1": 0}, "drivers[0].law: ",
     "t1 (0) must be greater than t0 (1)"),
    (("drivers", 0, "law"), {"type": "jerk"}, "drivers[0].law.type: ",
     "unknown motion law type 'jerk'"),
    (("forces", 0, "stiffness"), -1.0, "forces[0].stiffness: ", "must be >= 0"),
    (("forces", 0, "point_j"), "nope", "forces[0].point_j: ", "no point named 'nope'"),
    (("forces", 0, "spring"), 1.0, "forces[0].spring: ", "unknown key 'spring'"),
    (("forces", 0, "type"), "spring", "forces[0].type: ", "unknown force type 'spring'"),
    (("spatialmbd",), DELETE, "(top level): ", "spatialmbd: 1"),
    (("spatialmbd",), 2, "spatialmbd: ", "schema version 2"),
    (("gravty",), [0, 0, 1], "gravty: ", "did you mean 'gravity'"),
    (("gravity",), [0, 0, "g"], "gravity[2]: ", "expected a number"),
    (("analysis", "type"), "statics", "analysis.type: ", "valid: dynamic, kinematic"),
    (("analysis", "t_end"), 0, "analysis.t_end: ", "must be > 0"),
    (("analysis", "t_end"), DELETE, "analysis: ", "missing required key 't_end'"),
    (("analysis", "output_step"), -0.1, "analysis.output_step: ", "must be > 0"),
    (("analysis", "output_step"), 0, "analysis.output_step: ", "must be > 0"),
    (("analysis", "method"), {"name": "lagrangian"}, "analysis.method.name: ",
     "valid names: auto, augmented_lagrangian, baumgarte, penalty, projection, "
     "recursive, standard"),
    (("analysis", "method"), {"name": "baumgarte", "alfa": 1}, "analysis.method.alfa: ",
     "valid keys: name, alpha, beta, solver"),
    (("analysis", "method"), {"name": "penalty", "alpha": 0}, "analysis.method: ", "> 0"),
    (("analysis", "integrator"), {"name": "rk5"}, "analysis.integrator.name: ",
     "valid names: abm4, bdf4, dop853, euler, heun, rk4, rk45"),
    (("analysis", "integrator"), {"name": "rk45", "rtol": -1e-6},
     "analysis.integrator.rtol: ", "must be > 0"),
    (("analysis", "integrator"), {"name": "rk45", "atol": 0}, "analysis.integrator.atol: ",
     "must be > 0"),
    (("analysis", "integrator"), {"name": "rk4", "step": 0}, "analysis.integrator.step: ",
     "must be > 0"),
    (("analysis", "integrator"), {"name": "rk4", "rtol": 1e-6}, "analysis.integrator.rtol: ",
     "'rk4' takes no option 'rtol'"),
    (("analysis", "correct_initial"), "yes", "analysis.correct_initial: ",
     "expected true or false"),
    (("analysis", "hold"), {"lnk": ["x"]}, "analysis.hold.lnk: ", "unknown body 'lnk'"),
    (("analysis", "hold"), {"link": ["q"]}, "analysis.hold.link[0]: ", "is not one of x, y"),
    (("analysis", "tend"), 1.0, "analysis.tend: ", "unknown key 'tend'"),
]


@pytest.mark.parametrize("path, value, start, fragment", BAD,
                         ids=[".".join(map(str, b[0]))
                              + ("=<deleted>" if b[1] is DELETE else f"={b[1]!r}"[:30])
                              for b in BAD])
def test_bad_input_names_the_place(path, value, start, fragment):
    data = base_dict()
    _set(data, path, value)
    problems = problems_of(data)
    hits = [p for p in problems if p.startswith(start) and fragment in p]
    assert hits, problems
    assert len(problems) == 1, problems       # no follow-on problems


def test_bad_sections():
    data = base_dict()
    data["bodies"] = []
    data["joints"] = data["drivers"] = data["forces"] = None     # empty sections are fine
    assert problems_of(data) == ["bodies: the model has no bodies; give at least one"]
    data = base_dict()
    data["analysis"]["t_eval"] = [0.0, 0.2, 0.1]
    assert sorted(problems_of(data)) == [
        "analysis.output_step: give output_step or t_eval, not both",
        "analysis.t_eval: output times must be >= 0 and strictly increasing"]
    data = base_dict()
    data["joints"] = {"name": "pivot"}
    assert problems_of(data)[0] == ("joints: expected a list of joints, got a mapping with "
                                    "keys ['name']")


def test_kinematic_analysis_rejects_dynamic_keys():
    data = base_dict()
    data["analysis"]["type"] = "kinematic"
    problems = problems_of(data)
    assert sorted(problems) == [
        "analysis.integrator: applies to dynamic analyses only (this analysis is kinematic)",
        "analysis.method: applies to dynamic analyses only (this analysis is kinematic)"]


def test_all_problems_are_reported_at_once(tmp_path):
    text = """\
spatialmbd: 1
name: pendulum
bodies:
  - name: link
    mass: 7.02
    inertia: [1.0, -1.0, 1.0]
    position: [0, 0.5, 0]
joints:
  - {name: pivot, type: revolute, body_i: ground, body_j: lnk, point: [0, 0, 0], axis: [1, 0, 0]}
analysis:
  t_end: 10.0
  integrator: {name: rk45, rtol: -1e-6}
"""
    path = tmp_path / "three.yaml"
    path.write_text(text)
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    err = info.value
    assert len(err.problems) == 3
    assert err.problems[0].startswith("bodies[0].inertia: inertia is not positive definite "
                                      "(principal moments [")
    assert err.problems[1].startswith("joints[0].body_j: unknown body 'lnk' (did you mean "
                                      "'link'?)")
    assert err.problems[2] == "analysis.integrator.rtol: must be > 0, got -1e-06"
    assert err.lines == [6, 9, 12]
    text = str(err)
    assert text.startswith(f"model file {str(path)!r}: 3 problems")
    assert "(line 9)" in text
    clone = pickle.loads(pickle.dumps(err))
    assert clone.problems == err.problems and str(clone) == str(err)


def test_a_broken_body_does_not_cascade():
    data = base_dict()
    data["bodies"][0]["mass"] = "heavy"         # link fails; joints and forces naming it must not
    problems = problems_of(data)
    assert problems == ["bodies[0].mass: expected a number, got the string 'heavy'"]


def test_yaml_syntax_error_has_line_and_column(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("spatialmbd: 1\nbodies:\n  - name: a\n   mass: 3\n")
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert info.value.problems[0].startswith("line 4, column 4: YAML syntax error")


def test_json_syntax_error_has_line_and_column(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"spatialmbd": 1,\n "bodies": [}\n')
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert info.value.problems == ["line 2, column 13: JSON syntax error: Expecting value"]


def test_duplicate_keys_are_reported(tmp_path):
    path = tmp_path / "dup.yaml"
    path.write_text("spatialmbd: 1\nbodies:\n  - name: a\n    mass: 1\n    mass: 2\n"
                    "    inertia: [1, 1, 1]\n")
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert info.value.problems == ["bodies[0].mass: duplicate key 'mass' (each key may appear "
                                   "once per mapping)"]
    assert info.value.lines == [5]
    path = tmp_path / "dup.json"
    path.write_text('{"spatialmbd": 1, "spatialmbd": 1, "bodies": []}')
    with pytest.raises(ModelFileError, match="duplicate key 'spatialmbd'"):
        load_model(path)


def test_unsupported_extension_and_empty_file(tmp_path):
    with pytest.raises(ModelFileError, match="unsupported file extension '.txt'"):
        load_model(tmp_path / "m.txt")
    with pytest.raises(ModelFileError, match="unsupported file extension"):
        save_model(models.pendulum_ch15(), tmp_path / "m.toml")
    (tmp_path / "empty.yaml").write_text("# nothing\n")
    with pytest.raises(ModelFileError, match="the file is empty"):
        load_model(tmp_path / "empty.yaml")


# --------------------------------------------------------------------------- reading details
def test_yaml_numbers_and_degrees(tmp_path):
    path = tmp_path / "deg.yaml"
    path.write_text("""\
spatialmbd: 1
bodies:
  - name: a
    mass: 1
    inertia: [1e-3, 2E-3, 2.0e-3]
    orientation: {bryant_deg: [90, 0, 0]}
  - name: b
    mass: 1
    inertia: [1, 1, 1]
    orientation: {bryant: [1.5707963267948966, 0, 0]}
joints:
analysis:
  t_end: 1
  integrator: {name: rk45, rtol: 1e-7, atol: 1e-10}
  correct_initial: false
""")
    b, an = load_builder(path)
    assert b.name == "deg"                            # default name: the file's stem
    np.testing.assert_array_equal(np.diag(b.bodies["a"].inertia), [1e-3, 2e-3, 2e-3])
    np.testing.assert_allclose(b.bodies["a"].p, b.bodies["b"].p, rtol=0, atol=1e-15)
    assert (an.rtol, an.atol, an.correct_initial) == (1e-7, 1e-10, False)


def test_absent_analysis_gives_documented_defaults():
    data = base_dict()
    del data["analysis"]
    _, an = load_builder(data)
    assert an == Analysis()
    assert (an.type, an.t_end, an.output_step, an.method, an.integrator, an.correct_initial,
            an.hold) == ("dynamic", 1.0, None, "auto", "rk45", True, None)
    assert (an.step, an.rtol, an.atol, an.method_options, an.integrator_options) == \
        (None, None, None, {}, {})


def test_analysis_to_dict_round_trip():
    a = Analysis(type="dynamic", t_end=2.0, t_eval=[0.0, 0.5, 2.0], method="penalty",
                 method_options={"alpha": 1e6}, integrator="abm4", step=1e-3,
                 integrator_options={"fixed_step": True}, correct_initial=False,
                 hold={"link": ["x"]})
    assert Analysis.from_dict(a.to_dict()) == a
    with pytest.raises(ModelFileError, match=r"analysis\.method: unknown method 'nope'"):
        Analysis.from_dict({"t_end": 1, "method": "nope"})


# --------------------------------------------------------------------------- running and writing
def test_analysis_run_dynamic_and_kinematic(tmp_path):
    data = model_to_dict(models.pendulum_ch15(),
                         {"t_end": 0.02, "output_step": 0.01,
                          "integrator": {"name": "rk4", "step": 5e-3}})
    model, an = load_model(data)
    res = an.run(model)
    assert isinstance(res, Results) and res.status == "success"
    assert np.allclose(res.t, [0.0, 0.01, 0.02])
    builder = models.slider_crank(driven=True)
    model, an = load_model(model_to_dict(builder, {"type": "kinematic", "t_end": 0.02,
                                                   "output_step": 0.01}))
    kin = an.run(model)
    assert isinstance(kin, KinematicResults) and kin.status == "success" and kin.t.size == 3


def test_save_is_atomic_and_replaces(tmp_path):
    target = tmp_path / "m.yaml"
    target.write_text("old\n")
    save_model(models.pendulum_ch15(), target, header="my pendulum\nsecond line")
    text = target.read_text()
    assert text.startswith("# my pendulum\n# second line\nspatialmbd: 1\n")
    assert sorted(os.listdir(tmp_path)) == ["m.yaml"]
    assert load_model(target)[0].nb == 1


def test_tricky_strings_survive_yaml(tmp_path):
    b = ModelBuilder("yes")
    for name in ("1e3", "no", "null", "0x10", "true", "1_5", "~", "1:20", "0o17", "a: b", "#x"):
        b.add_body(name, 1.0, (1, 1, 1))
    path = save_model(b, tmp_path / "t.yaml")
    loaded, _ = load_builder(path)
    assert loaded.name == "yes" and list(loaded.bodies) == list(b.bodies)


def test_independent_problems_of_one_body_are_all_reported():
    from spatialmbd.io import ModelFileError, load_model
    data = {"spatialmbd": 1, "bodies": [{"name": "a", "mass": -1, "inertia": [1, 1, 5],
                                         "orientation": {"euler_parameters": [1, 0, 0, 0.5]}}]}
    with pytest.raises(ModelFileError) as info:
        load_model(data)
    text = "\n".join(info.value.problems)
    assert "bodies[0].mass" in text and "bodies[0].inertia" in text
    assert "far from 1" in text
