"""Issue 31, item 8: inline meshes of the wrong kind are located errors (never a TypeError), a
mesh with a non-finite vertex is refused naming the vertex and the body, and files outside the
model's folder are listed by ``info`` and refused with ``--no-external-files``."""
from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from spatialmbd.cli import main
from spatialmbd.errors import ModelError
from spatialmbd.io.external import external_files
from spatialmbd.io.modelfile import ModelFileError, load_model
from spatialmbd.io.sidecar import MeshStore
from spatialmbd.model import ModelBuilder

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "examples" / "pendulum_ch15.yaml"
V = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]]
F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
NAN_V = [[0, 0, 0], [0.1, 0, 0], [0, float("nan"), 0], [0, 0, 0.1]]

BAD_MESHES = {                      # mesh fields -> (what the message names, what it says)
    "faces as a string": (dict(vertices=V, faces="0 1 2"), ".faces", "got a string ('0 1 2')"),
    "faces as a mapping": (dict(vertices=V, faces={"a": 1}), ".faces", "got a mapping of 1 key"),
    "faces of strings": (dict(vertices=V, faces=[["0", "1", "2"]]), ".faces[0]",
                         "got a string ('0')"),
    "faces of booleans": (dict(vertices=V, faces=[[True, False, True]]), ".faces[0]",
                          "got a boolean (True)"),
    "faces of mappings": (dict(vertices=V, faces=[{"a": 1}]), ".faces[0]", "got a mapping"),
    "vertices as a mapping": (dict(vertices={"x": 1}, faces=F), ".vertices",
                              "got a mapping of 1 key"),
    "ragged vertices": (dict(vertices=[[0, 0], [1, 1, 1], [0, 0, 0]], faces=F), ".vertices",
                        "rows of different lengths"),
    "fractional faces": (dict(vertices=V, faces=[[0, 1, 2.5]]), ".faces[0]", "got [0.0, 1.0, 2.5]"),
    "non-finite vertex": (dict(vertices=NAN_V, faces=F), ".vertices[2]",
                          "non-finite coordinates [0.0, nan, 0.0]"),
    # found by the fuzz test (tests/fuzz_surfaces.py): a ValueError from NumPy before
    "scale as a string": (dict(vertices=V, faces=F, scale="x"), ".scale", "got a string ('x')"),
}


def pendulum_with(shape: dict) -> dict:
    data = yaml.safe_load(PENDULUM.read_text(encoding="utf-8"))
    data["bodies"][0]["shapes"].append(shape)
    return data


@pytest.mark.parametrize("case", list(BAD_MESHES))
def test_bad_inline_meshes_in_a_model_file_are_located(case):
    fields, where, said = BAD_MESHES[case]
    with pytest.raises(ModelFileError) as info:
        load_model(pendulum_with(dict(type="mesh", **copy.deepcopy(fields))))
    (problem,) = info.value.problems
    assert problem.startswith("bodies[0].shapes[1]") and "body 'pendulum'" in problem, problem
    assert f"{where}:" in problem and said in problem, problem


@pytest.mark.parametrize("case", list(BAD_MESHES))
def test_bad_inline_meshes_given_to_the_builder_name_the_body(case):
    fields, where, said = BAD_MESHES[case]
    b = ModelBuilder("m")
    with pytest.raises(ModelError) as info:
        b.add_body("link", mass=1.0, inertia=(0.01, 0.01, 0.01),
                   shapes=[{"type": "box", "size": [0.1, 0.1, 0.1]},
                           dict(type="mesh", **copy.deepcopy(fields))])
    text = str(info.value)
    assert text.startswith(f"bodies['link'].shapes[1] (mesh){where}:") and said in text, text
    assert "link" not in b.bodies


def test_a_good_inline_mesh_still_loads():
    model, _ = load_model(pendulum_with(dict(type="mesh", vertices=V, faces=F)))
    assert model.nb == 1


# ------------------------------------------------------------------------- external files
@pytest.fixture
def outside(tmp_path):
    """model/model.yaml naming ../shared.meshes.npz (outside its folder)."""
    store = MeshStore(tmp_path / "shared.meshes.npz")
    store.arrays = {"tet.vertices": np.array(V, float), "tet.faces": np.array(F)}
    store.write()
    (tmp_path / "model").mkdir()
    path = tmp_path / "model" / "model.yaml"
    path.write_text(yaml.safe_dump(pendulum_with(
        {"type": "mesh", "file": "../shared.meshes.npz", "mesh": "tet"})))
    return path


def test_external_files_are_allowed_listed_and_refused_when_untrusted(outside, tmp_path):
    model, _ = load_model(outside)                                   # allowed by default
    assert model.nb == 1
    real = str((tmp_path / "shared.meshes.npz").resolve())
    assert external_files(outside) == [("bodies[0].shapes[1].file", real)]
    with pytest.raises(ModelFileError) as info:
        load_model(outside, external_files=False)
    (problem,) = info.value.problems
    assert problem.startswith(f"bodies[0].shapes[1].file: {real} is outside the model's "
                              f"folder {outside.parent.resolve()}"), problem
    # a file inside the folder is not external; a link inside pointing outside is
    os.replace(tmp_path / "shared.meshes.npz", outside.parent / "shared.meshes.npz")
    text = outside.read_text().replace("../shared.meshes.npz", "shared.meshes.npz")
    outside.write_text(text)
    assert external_files(outside) == []
    assert load_model(outside, external_files=False)[0].nb == 1
    os.replace(outside.parent / "shared.meshes.npz", tmp_path / "elsewhere.npz")
    os.symlink(tmp_path / "elsewhere.npz", outside.parent / "shared.meshes.npz")
    assert [p for p, _ in external_files(outside)] == ["bodies[0].shapes[1].file"]
    with pytest.raises(ModelFileError, match="outside the model's folder"):
        load_model(outside, external_files=False)


def test_cli_info_lists_them_and_no_external_files_refuses(outside, tmp_path, capsys):
    assert main(["info", str(outside)]) == 0
    out = capsys.readouterr().out
    assert "files outside the model's folder (1; refused with --no-external-files):" in out
    assert str((tmp_path / "shared.meshes.npz").resolve()) in out
    for command in (["info", str(outside)],
                    ["run", str(outside), "--t-end", "0.01", "-o", str(tmp_path / "r.csv")],
                    ["animate", str(outside), "--t-end", "0.01", "-o",
                     str(tmp_path / "a.html")],
                    ["plot", str(outside), "--t-end", "0.01", "-y", "pendulum.z", "-o",
                     str(tmp_path / "p.png")]):
        assert main(command + ["--no-external-files"]) == 2, command
        err = capsys.readouterr().err
        assert "outside the model's folder" in err and "Traceback" not in err, err
    assert not any((tmp_path / n).exists() for n in ("r.csv", "a.html", "p.png"))
