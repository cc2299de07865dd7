"""Issue 31, item 9: the work of a long run (fixed steps, an adaptive max_step, output rows) is
estimated before it starts from one timed evaluation, announced above budget.NOTE_SECONDS and
refused above budget.MAX_ESTIMATED_TIME unless the user raises the limit or bounds the run."""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import pytest

from spatialmbd import budget, models
from spatialmbd.budget import Budget, WorkEstimate, check_work, estimate_work
from spatialmbd.cli import main
from spatialmbd.errors import ModelError
from spatialmbd.simulate import simulate

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "simple_pendulum_a01.yaml"


@pytest.fixture(scope="module")
def pendulum():
    return models.double_pendulum().compile()


def test_the_cost_model():
    e = estimate_work(1e6, 4, 11, 2e-6)
    per_step = (4 + budget.STEP_EVALUATIONS) * 2e-6 + budget.STEP_SECONDS
    assert e.seconds == pytest.approx(1e6 * per_step + 11 * budget.OUTPUT_EVALUATIONS * 2e-6)
    assert "1e+06 steps x 4 evaluations + 11 output rows at 2 us per evaluation" in e.text()
    big = estimate_work(1e7, 4, 11, 1e-4)                       # about 2.8 hours
    with pytest.raises(ModelError, match=r"about 2\.79 h of computing; the limit is 10 min"):
        check_work(big, Budget())
    with pytest.warns(WorkEstimate):
        check_work(big, Budget(max_wall_time=60.0))              # bounded: runs (and stops)
    with pytest.warns(WorkEstimate, match="estimated work"):
        check_work(big, Budget(max_estimated_time=1e5))          # raised: runs, and says so
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_work(estimate_work(1e3, 4, 11, 2e-6), Budget())   # short: nothing said
    with pytest.raises(ModelError, match="max_estimated_time"):
        Budget(max_estimated_time=-1.0)


def test_a_long_fixed_step_run_is_refused_before_it_starts(pendulum, monkeypatch):
    """rk4 at 2e-5 s over 0.5 s (25,000 steps): with the limit at 10 ms it is refused in far
    less time than it would take; raising the limit runs it and announces the estimate."""
    monkeypatch.setattr(budget, "MAX_ESTIMATED_TIME", 0.01)
    monkeypatch.setattr(budget, "NOTE_SECONDS", 0.005)
    start = time.perf_counter()
    with pytest.raises(ModelError) as info:
        simulate(pendulum, 0.5, integrator="rk4", step=2e-5, output_step=0.1)
    assert time.perf_counter() - start < 0.2
    assert "estimated work: 2.5e+04 steps x 4 evaluations" in str(info.value)
    assert "the limit is 0.01 s" in str(info.value)
    with pytest.warns(WorkEstimate, match="2.5e\\+04 steps x 4 evaluations"):
        res = simulate(pendulum, 0.5, integrator="rk4", step=2e-5, output_step=0.1,
                       budget=Budget(max_estimated_time=100.0))
    assert res.status == "success"


def test_an_adaptive_max_step_and_tiny_output_steps_count_too(pendulum, monkeypatch):
    monkeypatch.setattr(budget, "MAX_ESTIMATED_TIME", 0.01)
    with pytest.raises(ModelError, match=r"1e\+06 steps x 1 evaluation \+ 11 output rows"):
        simulate(pendulum, 1.0, integrator="rk45", output_step=0.1,
                 integrator_options={"max_step": 1e-6})
    with pytest.raises(ModelError, match=r"estimated work: 200,001 output rows"):
        simulate(pendulum, 2.0, integrator="rk45", output_step=1e-5)


def test_cli_prints_the_estimate_and_refuses_with_exit_2(monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(budget, "MAX_ESTIMATED_TIME", 0.01)
    monkeypatch.setattr(budget, "NOTE_SECONDS", 0.005)
    args = ["run", str(EXAMPLE), "--integrator", "rk4", "--step", "2e-5", "--t-end", "0.5",
            "-o", str(tmp_path / "r.csv"), "-q"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: estimated work: 2.51e+04 steps") and \
        "--max-estimated-time" in err and len(err.strip().splitlines()) == 1, err
    assert main(args + ["--max-estimated-time", "100"]) == 0
    assert "note: estimated work: 2.51e+04 steps x 4 evaluations" in capsys.readouterr().err
