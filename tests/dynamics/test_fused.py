"""The compiled drivers (dynamics.fused) against the Python drivers they stand in for."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import spatialmbd.simulate as sim
import spatialmbd.simulate.compiled as compiled_runs
from spatialmbd.dynamics import fused
from spatialmbd.io import load_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _both(model, **kw):
    """(compiled-driver results, Python-driver results) of one run."""
    compiled_runs.FUSED_RUNS = True
    try:
        a = sim.simulate(model, **kw)
        compiled_runs.FUSED_RUNS = False
        b = sim.simulate(model, **kw)
    finally:
        compiled_runs.FUSED_RUNS = True
    return a, b


@pytest.mark.parametrize("method", ["projection", "standard", "baumgarte"])
@pytest.mark.parametrize("integrator, opts", [("rk45", dict(rtol=1e-8, atol=1e-10)),
                                              ("dop853", dict(rtol=1e-8, atol=1e-10)),
                                              ("rk4", dict(step=2e-3))])
def test_compiled_driver_takes_the_python_drivers_steps(method, integrator, opts):
    model, _ = load_model(EXAMPLES / "sweeps" / "slider_crank_free.yaml")
    a, b = _both(model, t_end=0.6, method=method, integrator=integrator, output_step=0.01,
                 **opts)
    assert a.status == b.status == "success"
    for key in ("nfev", "steps", "rejected"):            # the same step sequence
        assert a.counters[key] == b.counters[key], key
    assert np.array_equal(a.t, b.t)
    tol = 0.0 if integrator == "rk4" else 1e-9          # rk4: bit for bit
    assert np.abs(a.q - b.q).max() <= tol
    assert np.abs(a.v - b.v).max() <= tol * 100
    scale = 1.0 + np.abs(b.vdot).max()
    assert np.abs(a.vdot - b.vdot).max() <= max(tol, 1e-14) * 1e4 * scale
    assert np.abs(a.lam - b.lam).max() <= max(tol, 1e-14) * 1e4 * (1.0 + np.abs(b.lam).max())
    assert np.array_equal(a.work, b.work) or np.abs(a.work - b.work).max() <= 1e-9


def test_slices_continue_the_same_step_sequence(monkeypatch):
    """A run cut into compiled calls of a few steps gives the one-call result exactly."""
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")
    whole = sim.simulate(model, 2.0, rtol=1e-7, atol=1e-9, method="projection")
    monkeypatch.setattr(compiled_runs, "FUSED_FIRST_SLICE", 3)
    monkeypatch.setattr(compiled_runs, "FUSED_SLICE_SECONDS", 1e-9)  # then one step per call
    sliced = sim.simulate(model, 2.0, rtol=1e-7, atol=1e-9, method="projection")
    assert sliced.counters["steps"] == whole.counters["steps"]
    assert np.array_equal(sliced.q, whole.q) and np.array_equal(sliced.vdot, whole.vdot)


def test_ctrl_c_between_slices_keeps_the_outputs(monkeypatch):
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")
    monkeypatch.setattr(compiled_runs, "FUSED_FIRST_SLICE", 5)
    monkeypatch.setattr(compiled_runs, "FUSED_SLICE_SECONDS", 1e-9)
    real, calls = fused.dopri_steps, []

    def steps(*args):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(*args)
    monkeypatch.setattr(fused, "dopri_steps", steps)
    res = sim.simulate(model, 2.0, output_step=0.01, method="projection")
    assert res.status == "interrupted" and "Ctrl-C" in res.message
    assert 2 <= len(res.t) < 201 and np.all(np.isfinite(res.q))
    assert np.all(np.isfinite(res.vdot))


def test_failed_compiled_run_is_rerun_by_the_python_driver(monkeypatch):
    """A run the compiled driver cannot finish goes through the Python driver, which gives
    its status and message (here a forced failure of the compiled driver's first call)."""
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")
    # (status, t, h, err_prev, k_out) of a first call that failed
    monkeypatch.setattr(fused, "dopri_steps", lambda *a: (fused.RHS_FAILED, a[0], 0.0, a[4],
                                                          a[12]))
    res = sim.simulate(model, 0.5, method="projection")
    compiled_runs.FUSED_RUNS = False
    try:
        ref = sim.simulate(model, 0.5, method="projection")
    finally:
        compiled_runs.FUSED_RUNS = True
    assert res.status == "success" and np.array_equal(res.q, ref.q)


def test_runs_with_events_or_budgets_keep_the_python_driver(monkeypatch):
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")

    def refuse(*args):
        raise AssertionError("the compiled driver was used")
    monkeypatch.setattr(compiled_runs, "_fused_run", refuse)
    sim.simulate(model, 0.2, events=[lambda t, s: s.r[0, 2] + 0.5])
    sim.simulate(model, 0.2, integrator="rk45", atol=np.full(14, 1e-9))
    sim.simulate(model, 0.2, max_steps=10_000)


def test_progress_is_reported_between_calls(monkeypatch):
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")
    monkeypatch.setattr(compiled_runs, "FUSED_SLICE_SECONDS", 1e-9)
    seen = []
    res = sim.simulate(model, 1.0, progress=seen.append, method="projection")
    # the first call takes 64 steps, then (target ~0 s) one step per call
    assert res.status == "success" and len(seen) == 1 + max(0, res.counters["steps"] - 64)
    assert seen == sorted(seen) and seen[-1] == pytest.approx(1.0)


@pytest.mark.parametrize("integrator", ["rk45", "rk4"])
def test_streamed_chunks_equal_the_in_memory_run(tmp_path, integrator, monkeypatch):
    """Streaming through the compiled driver: a window of outputs slides over the run (and
    grows when one step has more outputs than it holds); the rows equal the in-memory run's
    bit for bit."""
    from spatialmbd.io.results_io import load_results
    from spatialmbd.io.stream import simulate_to_file
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")
    opts = dict(integrator=integrator, output_step=1e-3,      # rk45: ~20 outputs per step
                method="projection")
    if integrator == "rk4":
        opts["step"] = 1e-3
    ref = sim.simulate(model, 0.3, **opts)
    real, codes = fused.dopri_steps, []

    def steps(*args):
        out = real(*args)
        codes.append(out[0])
        return out
    monkeypatch.setattr(fused, "dopri_steps", steps)
    tail, written = simulate_to_file(model, 0.3, [tmp_path / "s.h5"], chunk_rows=5, **opts)
    assert written[tmp_path / "s.h5"][0] == len(ref.t) == 301
    if integrator == "rk45":             # steps with more outputs than the window: retaken
        assert fused.NEED_ROOM in codes and codes[-1] == fused.OK
    assert tail.counters["steps"] == ref.counters["steps"]
    got = load_results(tmp_path / "s.h5")
    for name in ("t", "q", "v", "vdot", "lam"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name


def test_compiled_rk4_is_fourth_order():
    """Halving the step divides the compiled rk4's error by 2^4 (against rk45 at 1e-12)."""
    model, _ = load_model(EXAMPLES / "pendulum_ch15.yaml")
    ref = sim.simulate(model, 0.5, method="standard", rtol=1e-12, atol=1e-14, output_step=0.5)
    errs = []
    for h in (0.02, 0.01, 0.005):
        res = sim.simulate(model, 0.5, method="standard", integrator="rk4", step=h,
                           output_step=0.5)
        errs.append(np.abs(res.q[-1] - ref.q[-1]).max())
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(orders - 4.0) < 0.3), orders


def test_locked_mechanism_keeps_its_outputs_and_is_diagnosed():
    """A driver that tears the mechanism (the slider of a slider-crank pushed on past its dead
    centre, where the crank would need an infinite rate) stops where the steps stall: the
    result holds the outputs reached, and the message says where and that it is a singular
    position. (It used the N-four-bar at rk45 rtol 1e-9, which still stalls at its flat
    position of t = 2.66 s -- a defect, measured by bench/singular.py, not a behaviour to
    keep.)"""
    import warnings

    from spatialmbd import models
    from spatialmbd.motion import ConstantVelocity
    b = models.slider_crank(driven=False)
    b.add_driver("translation", "push", ConstantVelocity(rate=0.5), joint="D")
    model = b.compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = sim.simulate(model, 2.0, output_step=0.01, method="projection", rtol=1e-9,
                           atol=1e-11)
    assert res.status == "failed"
    assert "rk45: step size h =" in res.message and "underflow" in res.message
    t_stall = float(res.message.split("t = ")[1].split(" s")[0])
    assert f"singular position near t = {t_stall:.6g} s" in res.message
    # every output before the stall is kept
    assert res.t[-1] <= t_stall < res.t[-1] + 0.01 and len(res.t) == int(t_stall / 0.01) + 1
    assert np.all(np.isfinite(res.q)) and np.all(np.isfinite(res.vdot))

