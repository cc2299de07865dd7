"""Fuzz generators and properties of the surfaces besides model files (issue 31): MJCF/URDF
import, mesh shapes, sweep parameters and output paths (tests/test_fuzz.py runs them).

The property is the same everywhere: the input works, or it is refused with the project's
error (SpatialMBDError; a CLI run: exit 2 and one line naming the target file) -- never another
exception, a traceback, a temporary file left behind or a file written outside the output.
"""
from __future__ import annotations

import contextlib
import copy
import os
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

from hypothesis import strategies as st

from spatialmbd.errors import SpatialMBDError

ROOT = Path(__file__).resolve().parents[1]
XML_EXAMPLES = {p.name: p.read_text(encoding="utf-8")
                for p in sorted((ROOT / "examples" / "mjcf").glob("*"))
                if p.suffix in (".xml", ".urdf")}
PENDULUM = ROOT / "examples" / "pendulum_ch15.yaml"
RUN_EXAMPLE = ROOT / "examples" / "simple_pendulum_a01.yaml"

ATTRIBUTE_VALUES = ["", "nan", "inf", "-inf", "1e300", "-1e300", "0", "-1", "1e-300", "0 0",
                    "a b c", "1 2 3 4 5 6 7 8 9 10", "NaN NaN NaN", "1e300 0 0", "-0.5 0 0",
                    "x" * 200, "none", "world", "link1", "0 0 0 0", "1 0 0 0 1 0"]


@contextlib.contextmanager
def working_directory(path):
    old = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


# ------------------------------------------------------------------------------ import
@st.composite
def xml_file(draw):
    """(text, suffix): an example MJCF/URDF file with 1-3 small mutations (an attribute set to
    a nasty value or removed, an element removed or duplicated, the text truncated)."""
    name = draw(st.sampled_from(sorted(XML_EXAMPLES)))
    root = ET.fromstring(XML_EXAMPLES[name])
    for _ in range(draw(st.integers(1, 3))):
        elements = list(root.iter())
        element = draw(st.sampled_from(elements))
        action = draw(st.sampled_from(["set", "set", "set", "drop_attribute", "remove",
                                       "duplicate"]))
        if action == "set":
            key = draw(st.sampled_from(sorted(element.attrib) or ["pos"]))
            element.set(key, draw(st.sampled_from(ATTRIBUTE_VALUES)))
        elif action == "drop_attribute" and element.attrib:
            del element.attrib[draw(st.sampled_from(sorted(element.attrib)))]
        else:
            parents = [p for p in root.iter() if element in list(p)]
            if parents:
                if action == "remove":
                    parents[0].remove(element)
                else:
                    parents[0].append(copy.deepcopy(element))
    text = ET.tostring(root, encoding="unicode")
    if draw(st.integers(0, 9)) == 0:
        text = text[:draw(st.integers(0, len(text)))]
    return text, Path(name).suffix


def check_xml(path) -> str:
    """Import ``path``: a builder that compiles, or a SpatialMBDError; nothing written to the
    working directory (MuJoCo's MUJOCO_LOG.TXT included)."""
    from spatialmbd.importers import read_mjcf
    before = set(os.listdir("."))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            imported = read_mjcf(path)
            imported.builder.compile()
            outcome = "imported"
        except SpatialMBDError as exc:
            assert str(exc).strip()
            outcome = "refused"
    assert set(os.listdir(".")) == before, set(os.listdir(".")) - before
    return outcome


# ------------------------------------------------------------------------------ meshes
GOOD_V = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]
GOOD_F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
TABLES = [GOOD_V, GOOD_F, [], [[]], "0 1 2", {"a": 1}, [{"a": 1}], [["0", "1", "2"]],
          [[True, False, True]], [[0, 1]], [[0, 1, 2, 3]], [[0, 1, 2.5]], [[0, 1, 99]],
          [[0, 1, -1]], [[float("nan")] * 3] * 3, [[1e300, 0, 0]] * 3, [[0, 0], [1, 1, 1]],
          [[[0, 1, 2]]], None, 3, [None, None, None], [[10 ** 40, 0, 0]] * 3]
MESH_FILES = [None, "", "missing.stl", "missing.npz", "/etc/passwd", "/", "../x.npz", 5,
              ["a.npz"], "/proc/self/status"]


@st.composite
def mesh_shape(draw):
    """A mesh shape dict with its fields drawn from good and bad values."""
    shape = {"type": "mesh"}
    if draw(st.booleans()):
        shape["vertices"] = copy.deepcopy(draw(st.sampled_from(TABLES)))
        shape["faces"] = copy.deepcopy(draw(st.sampled_from(TABLES)))
    else:
        shape["file"] = draw(st.sampled_from(MESH_FILES))
        if draw(st.booleans()):
            shape["mesh"] = draw(st.sampled_from(["tet", "", 3, None]))
    if draw(st.integers(0, 3)) == 0:
        shape["scale"] = draw(st.sampled_from([0, -1, [1, 2], "x", float("nan"), 1e300, 2]))
    return shape


def check_mesh(shape) -> str:
    """A mesh shape in a model file and given to the builder: accepted by both, or refused
    with a located ModelFileError / a ModelError naming the body."""
    import yaml

    from spatialmbd.errors import ModelError
    from spatialmbd.io.modelfile import ModelFileError, load_model
    from spatialmbd.model import ModelBuilder
    data = yaml.safe_load(PENDULUM.read_text(encoding="utf-8"))
    data["bodies"][0]["shapes"].append(copy.deepcopy(shape))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            load_model(data)
            outcome = "loaded"
        except ModelFileError as exc:
            assert all(p.startswith("bodies[0].shapes[1]") for p in exc.problems), exc.problems
            outcome = "refused"
        if shape.get("file") is None:
            try:
                ModelBuilder("m").add_body("link", mass=1.0, inertia=(1, 1, 1),
                                           shapes=[copy.deepcopy(shape)])
            except ModelError as exc:
                assert str(exc).startswith("bodies['link'].shapes[0]"), str(exc)
    return outcome


# ------------------------------------------------------------------------------ sweeps
SWEEP_PATHS = ["bodies.pendulum.mass", "gravity.2", "analysis.t_end", "bodies.0.inertia.0",
               "bodies.99.mass", "", "bodies..mass", "joints.nothing.axis", "bodies.pendulum",
               "bodies.pendulum.mass.0", "analysis.integrator.rtol", "analysis.nothing"]
SWEEP_VALUES = ["1:2:2", "0.5:1:3", "1:2:0", "1:2:1000000000", "a:b:c", "1:2:3:lin",
                "-1:1:3:log", "1,2,,3", "", "1e300,1", "nan,1", [1.0, 2.0], [], [[1, 2]],
                ["x"], [float("inf")], [0.0], [-1.0], 7, None]


@st.composite
def sweep_case(draw):
    """(params, lhs): a grid {path: values} of one or two parameters, or Latin-hypercube
    bounds {path: (low, high)} and a sample count."""
    paths = draw(st.lists(st.sampled_from(SWEEP_PATHS), min_size=1, max_size=2, unique=True))
    if draw(st.integers(0, 3)) == 0:
        bounds = {p: draw(st.sampled_from([(1.0, 2.0), (2.0, 1.0), (0, float("nan")), "x",
                                           (1.0,), (0.5, 1.5)])) for p in paths}
        return bounds, draw(st.sampled_from([2, 0, -3, 10 ** 9, 2.5, "3"]))
    return {p: copy.deepcopy(draw(st.sampled_from(SWEEP_VALUES))) for p in paths}, None


def check_sweep(params, lhs) -> str:
    """A sweep of at most 4 members of 5 ms each: a Dataset (members may fail) or a
    ModelError before anything runs."""
    from spatialmbd.sweep import latin_hypercube, sweep
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            space = params if lhs is None else latin_hypercube(params, lhs, max_members=4)
            ds = sweep(str(PENDULUM), space, ["max(t)"], {"t_end": 0.005,
                                                          "output_step": 0.005},
                       progress=False, max_members=4)
        except SpatialMBDError as exc:
            assert str(exc).strip()
            return "refused"
    assert int(ds.attrs["n_members"]) <= 4
    return "ran"


# ------------------------------------------------------------------------------ outputs
@st.composite
def output_target(draw):
    """An output path (relative to a fresh folder holding a sub-folder ``dir.csv`` and a
    file ``file.txt``) that may or may not be writable."""
    folder = draw(st.sampled_from(["", "missing/", "file.txt/", "dir.csv/", "/proc/",
                                   "/proc/self/", "a b/", "../"]))
    stem = draw(st.sampled_from(["r", "dir", "ü é", "x" * 300, ".hidden", "r.csv", "-o",
                                 "nul"]))
    suffix = draw(st.sampled_from([".csv", ".h5", ".hdf5", ".CSV", ".txt", ""]))
    return folder + stem + suffix


def check_output(target: str, folder: Path) -> str:
    """``spatialmbd run EXAMPLE -o target`` in ``folder``: exit 0 and the file written, or
    exit 2 and one line naming the target; never a traceback or a temporary left behind."""
    import io

    from spatialmbd.cli import main
    (folder / "dir.csv").mkdir(exist_ok=True)
    (folder / "file.txt").write_text("x")
    if "a b/" in target:
        (folder / "a b").mkdir(exist_ok=True)
    err = io.StringIO()
    with working_directory(folder), contextlib.redirect_stderr(err), \
            contextlib.redirect_stdout(io.StringIO()):
        code = main(["run", str(RUN_EXAMPLE), "--t-end", "0.002", "-q", f"--output={target}"])
        written = code == 0 and Path(target).is_file()
    text = err.getvalue()
    assert "Traceback" not in text and ".tmp" not in text, text
    for place in (folder, folder / "a b", folder.parent):
        if place.is_dir():
            assert not [p for p in os.listdir(place) if p.endswith(".tmp")], place
    if code == 0:
        assert written, target
        return "written"
    assert code == 2 and len(text.strip().splitlines()) == 1, (code, text)
    assert target in text or repr(target) in text, text
    return "refused"
