"""Every example model file runs from the command line (shortened to keep CI fast)."""
from pathlib import Path

import pytest

from spatialmbd.cli import main
from spatialmbd.io import load_model

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.yaml"))


def test_the_issue_list_of_examples_is_there():
    names = {p.stem for p in EXAMPLES}
    assert {"pendulum_ch15", "double_pendulum", "four_bar", "slider_crank", "flyball_governor",
            "bricard", "heavy_top", "robot_arm"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs_from_the_cli(path, tmp_path, capsys):
    _, analysis = load_model(path)
    t_end = min(analysis.t_end, 0.05)
    out = tmp_path / f"{path.stem}.csv"
    code = main(["run", str(path), "--t-end", str(t_end), "--output-step", str(t_end / 5),
                 "-o", str(out), "--quiet"])
    assert code == 0, capsys.readouterr().err
    assert out.exists() and out.stat().st_size > 0
    assert main(["info", str(path)]) == 0
