"""Issue 31, item 4: sweeps are bounded -- member counts by a documented limit (refused before
anything is allocated, with a memory estimate), memory by an estimate, worker processes by the
cores and the members."""
from __future__ import annotations

import concurrent.futures
import time
import tracemalloc
from pathlib import Path

import pytest

from spatialmbd.cli import main
from spatialmbd.errors import ModelError
from spatialmbd.sweep import grid, latin_hypercube, parse_range, sweep
from spatialmbd.sweep import limits
from spatialmbd.sweep.limits import MAX_MEMBERS, SweepNote, cap_workers, check_memory

pytest.importorskip("xarray")
PENDULUM = Path(__file__).resolve().parents[2] / "examples" / "pendulum_ch15.yaml"
BILLION = {"bodies.0.mass": "1:2:1000", "bodies.0.inertia.0": "1:2:1000",
           "gravity.2": "-10:-9:1000"}


def refused_quickly(call, *words):
    """``call`` raises ModelError naming ``words`` within 1 s and allocating under 10 MB."""
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(ModelError) as info:
            call()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert time.perf_counter() - start < 1.0 and peak < 10e6, (time.perf_counter(), peak)
    for word in words:
        assert word in str(info.value), str(info.value)
    return str(info.value)


def test_a_grid_of_a_billion_members_is_refused_before_allocating():
    text = refused_quickly(lambda: grid(BILLION), "1000 x 1000 x 1000", "1e+09 members",
                           f"{MAX_MEMBERS:,}", "max_members")
    assert "about 432 GB" in text, text          # 1e9 x (8 bytes x (3 values + 1) + 400)
    refused_quickly(lambda: parse_range("0:1:1000000000", "k"), "'k'", "1e+09 members")
    refused_quickly(lambda: latin_hypercube({"a": (0, 1)}, 10**9), "n = 1000000000")
    refused_quickly(lambda: sweep(str(PENDULUM), BILLION, ["max(t)"]), "limit")


def test_the_member_limit_can_be_raised_and_lowered():
    assert grid({"a": [1, 2, 3]}, max_members=3).n_members == 3
    with pytest.raises(ModelError, match="limit of 2 members"):
        grid({"a": [1, 2, 3]}, max_members=2)
    with pytest.raises(ModelError, match="limit of 2 members"):
        sweep(str(PENDULUM), {"bodies.0.mass": [1, 2, 3]}, ["max(t)"], max_members=2)
    assert grid({"a": "0:1:1001", "b": "0:1:1000"}, max_members=2_000_000).n_members == \
        1_001_000                                       # above the default limit when raised
    with pytest.raises(ModelError, match="limit"):
        grid({"a": "0:1:1001", "b": "0:1:1000"})


def test_values_that_are_not_numbers_are_a_model_error():
    """Found by the fuzz test (tests/fuzz_surfaces.py): a ValueError from NumPy before."""
    with pytest.raises(ModelError, match=r"parameter 'k': values must be numbers.*\['x'\]"):
        grid({"k": ["x"]})


def test_memory_is_estimated_before_a_sweep_with_long_series_starts():
    with pytest.raises(ModelError, match="more than half of this machine's memory"):
        check_memory(1000, 2, 1e6, memory=1e9)
    assert check_memory(10, 2, 1.0, memory=1e9) == limits.estimate_bytes(10, 2, 1.0)
    # 100 members of one time series with 1e10 output times each: refused before any run
    message = refused_quickly(
        lambda: sweep(str(PENDULUM), {"bodies.0.mass": "1:2:100"}, ["pendulum.z"],
                      {"t_end": 10.0, "output_step": 1e-9}), "memory", "output_step")
    assert "100 members" in message


def test_workers_are_capped_by_cores_and_members(monkeypatch):
    assert cap_workers(10**6, 2, cores=24)[0] == 2
    assert cap_workers(10**6, 500, cores=24)[0] == 24
    assert cap_workers(3, 500, cores=24) == (3, "")
    with pytest.raises(ModelError, match="at least 1"):
        cap_workers(0, 5)
    started = []

    class Recording(concurrent.futures.ProcessPoolExecutor):
        def __init__(self, max_workers=None, **kwargs):
            started.append(max_workers)
            super().__init__(max_workers=max_workers, **kwargs)

    monkeypatch.setattr(concurrent.futures, "ProcessPoolExecutor", Recording)
    with pytest.warns(SweepNote, match="1000000 workers asked; starting 2"):
        ds = sweep(str(PENDULUM), {"bodies.0.mass": [1.0, 2.0]}, ["max(t)"],
                   {"t_end": 0.01, "output_step": 0.01}, "processes", workers=10**6)
    assert started == [2] and int(ds.attrs["n_failed"]) == 0


def test_cli_refuses_a_billion_member_lhs_and_notes_capped_workers(tmp_path, capsys):
    out = tmp_path / "s.csv"
    code = main(["sweep", str(PENDULUM), "--param", "bodies.0.mass=1:2:2", "--lhs",
                 "1000000000", "--output", "max(t)", "-o", str(out), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "1e+09 members" in err and len(err.strip().splitlines()) == 1, err
    code = main(["sweep", str(PENDULUM), "--param", "bodies.0.mass=1,2", "--output",
                 "max(t)", "--t-end", "0.01", "--scheduler", "processes", "--workers",
                 "1000000", "-o", str(out), "--plot", "none", "-q"])
    err = capsys.readouterr().err
    assert code == 0 and "1000000 workers asked; starting 2" in err, err
    assert out.exists()
