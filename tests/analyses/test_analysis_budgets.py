"""Budgets (spatialmbd.budget.Budget) of kinematic analyses and of SciPy's implicit solvers.

The wall-time cases use a fake clock (budget.time.perf_counter advanced by a fixed amount at
every reading), so they check *where* the deadline is looked at, not how fast the machine is.
"""
import numpy as np
import pytest

from spatialmbd import budget as budget_module
from spatialmbd import models
from spatialmbd.errors import ModelError
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.simulate import simulate


@pytest.fixture(scope="module")
def slider_crank():
    return models.slider_crank(crank_speed=6.0).compile()


class FakeClock:
    """perf_counter that advances `tick` s at every reading."""

    def __init__(self, tick):
        self.now, self.tick, self.readings = 0.0, tick, 0

    def __call__(self):
        self.readings += 1
        self.now += self.tick
        return self.now


def test_kinematic_analysis_step_budget_keeps_solved_instants(slider_crank):
    t = np.linspace(0.0, 0.5, 11)
    full = kinematic_analysis(slider_crank, t)
    assert full.status == "success" and len(full.t) == 11
    res = kinematic_analysis(slider_crank, t, max_steps=4)
    assert res.status == "budget" and "max_steps=4" in res.message
    # the instants solved before the cap are those of the uncapped run
    assert len(res.t) == 4 and np.array_equal(res.t, t[:4])
    assert np.allclose(res.q, full.q[:4], atol=1e-12, rtol=0)
    assert np.allclose(res.vdot, full.vdot[:4], atol=1e-9, rtol=0)
    same = kinematic_analysis(slider_crank, t, budget={"max_steps": 4})
    assert np.array_equal(same.q, res.q)


def test_kinematic_analysis_wall_time_budget(slider_crank, monkeypatch):
    # every clock reading is 1 s later: the guard starts at 1 s, so a 3.5 s cap ends at 4.5 s;
    # the checks after instants 0, 1, 2 read 2, 3, 4 s and pass, the one after instant 3 reads
    # 5 s and stops the run with the four instants solved
    monkeypatch.setattr(budget_module.time, "perf_counter", FakeClock(1.0))
    res = kinematic_analysis(slider_crank, np.linspace(0.0, 0.5, 11), max_wall_time=3.5)
    assert res.status == "budget" and "wall-time budget" in res.message
    assert len(res.t) == 4


def test_kinematic_analysis_bad_budget_is_a_model_error(slider_crank):
    with pytest.raises(ModelError, match="max_wall_time"):
        kinematic_analysis(slider_crank, [0.0, 0.1], max_wall_time=-1.0)
    with pytest.raises(ModelError, match="did you mean 'max_steps'"):
        kinematic_analysis(slider_crank, [0.0, 0.1], budget={"max_step": 3})


@pytest.mark.parametrize("integrator", ["scipy-bdf", "scipy-radau"])
def test_scipy_implicit_wall_time_checked_inside_the_step(integrator, monkeypatch):
    """The deadline is looked at in every right-hand-side evaluation (also those of SciPy's
    finite-difference Jacobian), so a solver stuck inside one step is stopped there: the run
    ends with status "budget" before SciPy has finished its first step."""
    model = models.double_pendulum().compile()
    simulate(model, 1e-3, integrator=integrator)              # compile outside the clock
    clock = FakeClock(1.0)
    monkeypatch.setattr(budget_module.time, "perf_counter", clock)
    # 1 s per reading (this clock is also read outside the guard), 5.5 s cap: at most five
    # evaluations fit, far fewer than SciPy's first step needs
    res = simulate(model, 1.0, integrator=integrator, method="penalty", max_wall_time=5.5)
    assert res.status == "budget" and "wall-time budget" in res.message
    assert res.counters["steps"] == 0 and res.counters["nfev"] <= 5


def test_cli_budget_caps_a_kinematic_analysis(tmp_path, capsys):
    """`spatialmbd run --max-steps` reaches kinematic analyses too (status budget, exit 1)."""
    from spatialmbd.cli import main
    from spatialmbd.io.modelfile import save_model
    path = tmp_path / "sc.json"
    save_model(models.slider_crank(crank_speed=6.0), path,
               analysis={"type": "kinematic", "t_end": 0.5, "output_step": 0.05})
    out = tmp_path / "out.csv"
    code = main(["run", str(path), "--max-steps", "3", "-o", str(out)])
    assert code == 1
    lines = out.read_text().splitlines()
    assert lines[0].startswith("# status: budget") and "max_steps=3" in lines[0]
    rows = [ln for ln in lines if not ln.startswith("#")]
    assert len(rows) == 1 + 3                                  # the header and three instants
    assert "step budget" in capsys.readouterr().out


def test_the_budget_and_streaming_examples_of_docs_reliability_run(tmp_path, monkeypatch,
                                                                   capsys):
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[2] / "docs" / "reliability.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)[1:]
    assert len(blocks) == 2
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "docs/reliability.md", "exec"), {})
    out = capsys.readouterr().out.split("\n")
    assert out[0] == "budget 4" and out[1] == "success 10001"
    assert (tmp_path / "long.h5").exists()
