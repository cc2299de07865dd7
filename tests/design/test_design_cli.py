"""`spatialmbd identify` and `spatialmbd optimize` (in-process through cli.main)."""
from pathlib import Path

import numpy as np
import pytest

from spatialmbd.cli import main
from spatialmbd.sweep import points, sweep

pd = pytest.importorskip("pandas")
yaml = pytest.importorskip("yaml")

MODEL = Path(__file__).resolve().parents[2] / "examples" / "design" / "pendulum_damped.yaml"


def test_identify_writes_fitted_model_and_report(tmp_path, capsys):
    t = np.linspace(0.0, 4.0, 201)
    an = dict(type="dynamic", t_eval=list(t), integrator=dict(name="rk45", rtol=1e-9,
                                                              atol=1e-11))
    ds = sweep(MODEL, points({"bodies.pendulum.mass": [7.3],
                              "forces.pivot_damper.damping": [0.6]}), ["pivot.angle"], an)
    angle = ds["pivot.angle"].values[0] + 0.005 * np.random.default_rng(0).standard_normal(t.size)
    pd.DataFrame({"t": t, "pivot.angle": angle}).to_csv(tmp_path / "rig.csv", index=False)
    out = tmp_path / "fit.yaml"
    code = main(["identify", str(MODEL), "--data", str(tmp_path / "rig.csv"),
                 "--param", "bodies.pendulum.mass=6:1:20", "--param",
                 "forces.pivot_damper.damping", "--noise", "0.005", "--t-end", "4",
                 "--integrator", "rk45", "--rtol", "1e-9", "--atol", "1e-11",
                 "-o", str(out), "--plot", str(tmp_path / "res.png")])
    text = capsys.readouterr().out
    assert code == 0, text
    data = yaml.safe_load(out.read_text())
    mass = data["bodies"][0]["mass"]
    damping = data["forces"][0]["damping"]
    report = (tmp_path / "fit.txt").read_text()
    se = [float(line.split()[2]) for line in report.splitlines()
          if line.startswith(("bodies.pendulum.mass ", "forces.pivot_damper.damping "))]
    assert abs(mass - 7.3) < 3 * se[0] and abs(damping - 0.6) < 3 * se[1], report
    assert "correlation" in report and (tmp_path / "res.png").exists()


def test_identify_bad_input_exit_2(tmp_path, capsys):
    pd.DataFrame({"t": [0.0, 0.1, 0.2], "pivot.angle": [0.0, np.nan, 0.1]}).to_csv(
        tmp_path / "bad.csv", index=False)
    code = main(["identify", str(MODEL), "--data", str(tmp_path / "bad.csv"),
                 "--param", "bodies.pendulum.mass", "-o", str(tmp_path / "f.yaml")])
    err = capsys.readouterr().err
    assert code == 2 and "row 1" in err and "Traceback" not in err
    code = main(["identify", str(MODEL), "--data", str(tmp_path / "bad.csv"),
                 "--param", "bodies.pendulum.mass=x", "-o", str(tmp_path / "f.yaml")])
    assert code == 2 and "PATH=START" in capsys.readouterr().err


def test_optimize_writes_model(tmp_path, capsys):
    out = tmp_path / "best.yaml"
    code = main(["optimize", str(MODEL), "--objective=-rms(pendulum.wx)",
                 "--param", "forces.pivot_damper.damping=2:0.1:5", "--t-end", "1",
                 "--constraint", "rms(pendulum.wx) <= 2.45", "-o", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    data = yaml.safe_load(out.read_text())
    assert "optimized by spatialmbd optimize" in out.read_text()
    assert 0.1 <= data["forces"][0]["damping"] <= 5.0
    value = [float(line.split("=")[1]) for line in text.splitlines()
             if line.strip().startswith("rms(pendulum.wx) =")][0]
    assert value == pytest.approx(2.45, rel=1e-6)         # the active constraint
