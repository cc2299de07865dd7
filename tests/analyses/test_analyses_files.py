"""Engineering analyses from model files, the command line and the example scripts."""
import runpy
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from spatialmbd.cli import main
from spatialmbd.io import load_model
from spatialmbd.io.modelfile import Analysis, ModelFileError

FOLDER = Path(__file__).resolve().parents[2] / "examples" / "analyses"
FILES = sorted(FOLDER.glob("*.yaml"))


def test_the_issue_list_of_analysis_examples_is_there():
    assert {p.stem for p in FILES} >= {"slider_crank_torque", "hanging_chain",
                                       "double_pendulum_modes", "spinning_top_modes"}


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_analysis_example_runs_from_the_cli(path, tmp_path, capsys):
    out = tmp_path / f"{path.stem}.csv"
    assert main(["run", str(path), "-o", str(out)]) == 0, capsys.readouterr().err
    table = pd.read_csv(out)
    text = capsys.readouterr().out
    _, analysis = load_model(path)
    if analysis.type == "inverse":
        assert "crank_drive" in table.columns and "effort" in text
    elif analysis.type == "static":
        assert len(table) == 1 and "STABLE" in text
    else:
        assert (table["frequency_hz"].dropna() >= 0).all() and "modes:" in text


def test_double_pendulum_modes_file_gives_the_closed_form_frequencies(tmp_path):
    out = tmp_path / "modes.csv"
    assert main(["run", str(FOLDER / "double_pendulum_modes.yaml"), "-o", str(out),
                 "--quiet"]) == 0
    lam = np.array([3 - np.sqrt(1008) / 14, 3 + np.sqrt(1008) / 14])   # see test_linearize
    assert np.allclose(pd.read_csv(out)["omega_n"], np.sqrt(lam * 9.81), rtol=1e-8)


def test_inverse_dynamics_to_hdf5(tmp_path):
    from spatialmbd.io.results_io import load_results
    out = tmp_path / "torque.h5"
    assert main(["run", str(FOLDER / "slider_crank_torque.yaml"), "-o", str(out),
                 "--t-end", "0.2", "--output-step", "0.05", "--quiet"]) == 0
    loaded = load_results(out)
    assert loaded.t.shape == (5,)


def test_modal_hdf5_holds_an_animatable_mode(tmp_path):
    from spatialmbd.io.results_io import load_results
    out = tmp_path / "mode.h5"
    assert main(["run", str(FOLDER / "double_pendulum_modes.yaml"), "-o", str(out),
                 "--quiet"]) == 0
    loaded = load_results(out)
    assert loaded.q.shape[1:] == (2, 7) and np.ptp(loaded.q[:, 0, 4]) > 0.01
    assert main(["animate", str(out), "-o", str(tmp_path / "mode.html")]) == 0


def test_analysis_sections_are_checked_and_round_trip():
    for data in ({"type": "static"}, {"type": "modal", "steady": True, "time": 0.5},
                 {"type": "modal", "steady": True, "frame_rate": [0, 0, 3.0]},
                 {"type": "inverse", "t_end": 1.0, "output_step": 0.1},
                 {"type": "quasi_static", "t_end": 2.0}):
        a = Analysis.from_dict(data)
        assert Analysis.from_dict(a.to_dict()) == a
    with pytest.raises(ModelFileError, match="one time"):
        Analysis.from_dict({"type": "static", "t_end": 1.0})
    with pytest.raises(ModelFileError, match="steady: true only"):
        Analysis.from_dict({"type": "modal", "frame_rate": [0, 0, 1]})
    with pytest.raises(ModelFileError, match="modal analyses only"):
        Analysis.from_dict({"type": "inverse", "t_end": 1.0, "steady": True})
    with pytest.raises(ModelFileError, match="dynamic analyses only"):
        Analysis.from_dict({"type": "quasi_static", "t_end": 1.0, "method": "standard"})
    with pytest.raises(ModelFileError, match="missing required key 't_end'"):
        Analysis.from_dict({"type": "inverse"})


def test_static_analysis_rejects_time_options_on_the_command_line(capsys):
    code = main(["run", str(FOLDER / "hanging_chain.yaml"), "--t-end", "1", "--quiet"])
    assert code != 0
    assert "one time" in capsys.readouterr().err


def test_example_scripts_run():
    ns = runpy.run_path(str(FOLDER / "engineering_analyses.py"), run_name="example")
    inv, chain, md, qs = ns["main"]()
    assert np.abs(inv.energy()["error"]).max() < 1e-5
    top = runpy.run_path(str(FOLDER / "spinning_top_threshold.py"), run_name="example")
    assert top["growth_rate"](28.0) > 0.1 and top["growth_rate"](31.0) < 1e-8


def test_bicycle_stability_script_finds_the_published_speeds(tmp_path):
    bike = runpy.run_path(str(FOLDER / "bicycle_stability.py"), run_name="example")
    weave, capsize, png = bike["main"](tmp_path, n_speeds=21)
    assert abs(weave - bike["WEAVE"]) < 1e-9 and abs(capsize - bike["CAPSIZE"]) < 1e-9
    assert png.stat().st_size > 10_000


def test_cli_reports_bad_engineering_inputs(tmp_path, capsys):
    """A free body under gravity has no equilibrium; an undriven pendulum cannot be inverted:
    clear messages and a failing exit code, no traceback."""
    free = {"spatialmbd": 1, "name": "free", "gravity": [0, 0, -9.81],
            "bodies": [{"name": "ball", "mass": 1.0, "inertia": [0.1, 0.1, 0.1]}],
            "analysis": {"type": "static"}}
    under = {"spatialmbd": 1, "name": "under", "gravity": [0, 0, -9.81],
             "bodies": [{"name": "rod", "mass": 1.0, "inertia": [0.1, 0.1, 0.001],
                         "position": [0, 0, -0.5]}],
             "joints": [{"name": "pivot", "type": "revolute", "body_i": "ground",
                         "body_j": "rod", "point": [0, 0, 0], "axis": [1, 0, 0]}],
             "analysis": {"type": "inverse", "t_end": 1.0}}
    import yaml
    for data, text in ((free, "no equilibrium exists"), (under, "pivot (revolute: angle)")):
        path = tmp_path / f"{data['name']}.yaml"
        path.write_text(yaml.safe_dump(data))
        code = main(["run", str(path), "-o", str(tmp_path / "out.csv"), "--quiet"])
        err = capsys.readouterr().err
        assert code != 0 and text in err and "Traceback" not in err


def test_docs_page_snippets_run(monkeypatch):
    import re
    root = FOLDER.parents[1]
    monkeypatch.chdir(root)
    monkeypatch.syspath_prepend(str(FOLDER))
    text = (root / "docs" / "analyses.md").read_text()
    ns = {}
    for code in re.findall(r"```python\n(.*?)```", text, flags=re.S):
        exec(compile(code, "docs/analyses.md", "exec"), ns)
    assert ns["res"].unique and ns["sol"].stable and len(ns["md"].table) == 2
