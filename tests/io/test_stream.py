"""Result arrays streamed to HDF5 during a run (spatialmbd.io.stream, issue 16)."""
import numpy as np
import pytest

pytest.importorskip("h5py")

from spatialmbd import models  # noqa: E402
from spatialmbd.errors import ModelError  # noqa: E402
from spatialmbd.io.stream import ResultsStream, read_stream, simulate_to_file  # noqa: E402
from spatialmbd.simulate import simulate  # noqa: E402


@pytest.fixture(scope="module")
def double_pendulum():
    return models.double_pendulum().compile()


def test_segments_of_a_one_step_fixed_step_run_equal_the_continuous_run(double_pendulum,
                                                                      tmp_path):
    # rk4 with a step dividing the segment: every segment takes the continuous run's steps
    opts = dict(integrator="rk4", step=1e-3, method="projection")
    ref = simulate(double_pendulum, 0.3, output_step=0.01, **opts)
    info = simulate_to_file(double_pendulum, 0.3, tmp_path / "run.h5", segment=0.05,
                            output_step=0.01, flush_rows=7, **opts)
    assert info["status"] == "success" and info["segments"] == 6 and info["rows"] == 31
    got = read_stream(tmp_path / "run.h5")
    assert got["status"] == "success" and got["body_names"] == list(double_pendulum.body_names)
    assert np.allclose(got["t"], ref.t, atol=1e-14, rtol=0)
    assert np.allclose(got["q"], ref.q, atol=1e-12, rtol=0)
    assert np.allclose(got["v"], ref.v, atol=1e-11, rtol=0)
    assert np.allclose(got["vdot"], ref.vdot, atol=1e-9, rtol=0)
    assert got["lam"].shape == (31, double_pendulum.n_eq)
    # no stray temporaries next to the file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5"]


def test_budget_stop_midway_keeps_rows_and_status(double_pendulum, tmp_path):
    info = simulate_to_file(double_pendulum, 1.0, tmp_path / "run.h5", segment=0.1,
                            output_step=0.01, integrator="rk4", step=1e-3, max_steps=150)
    # each segment has its own budget of 150 steps; a 0.1 s segment needs 100
    assert info["status"] == "success"
    info = simulate_to_file(double_pendulum, 1.0, tmp_path / "run.h5", segment=0.2,
                            output_step=0.01, integrator="rk4", step=1e-3, max_steps=150)
    got = read_stream(tmp_path / "run.h5")
    assert got["status"] == "budget" and "max_steps=150" in got["message"]
    assert info["segments"] == 1 and 1 < got["t"].size < 21
    assert np.all(np.diff(got["t"]) > 0) and np.all(np.isfinite(got["q"]))


def test_exception_midway_leaves_a_readable_file_with_status(tmp_path):
    path = tmp_path / "x.h5"
    with pytest.raises(ValueError, match="boom"):
        with ResultsStream(path, nb=1, n_eq=2, flush_rows=3) as s:
            for k in range(5):
                s.append([0.1 * k], np.ones((1, 1, 7)) * k, np.zeros((1, 1, 6)),
                         np.zeros((1, 1, 6)), np.full((1, 2), k))
            raise ValueError("boom")
    got = read_stream(path)
    assert got["status"] == "failed" and "boom" in got["message"]
    assert np.allclose(got["t"], 0.1 * np.arange(5)) and got["q"][:, 0, 0].tolist() == \
        [0, 1, 2, 3, 4]
    assert np.array_equal(got["lam"][:, 1], np.arange(5.0))


def test_rows_are_on_disk_before_finish(tmp_path):
    """Memory is bounded by flush_rows: rows past it are already in the (temporary) file."""
    import h5py
    s = ResultsStream(tmp_path / "y.h5", nb=1, n_eq=0, flush_rows=4)
    for k in range(10):
        s.append([k], np.zeros((1, 1, 7)), np.zeros((1, 1, 6)), np.zeros((1, 1, 6)),
                 np.zeros((1, 0)))
    assert s.rows == 8 and sum(b["t"].size for b in s._buffer) == 2
    with h5py.File(s._staged.tmp, "r") as f:       # readable while the run goes
        assert f["t"].shape == (8,) and f.attrs["status"] == "running"
    s.finish("success")
    assert read_stream(tmp_path / "y.h5")["t"].size == 10


def test_bad_arguments_are_model_errors(double_pendulum, tmp_path):
    with pytest.raises(ModelError, match="h5 or .hdf5"):
        ResultsStream(tmp_path / "a.csv", nb=1, n_eq=0)
    with pytest.raises(ModelError, match="flush_rows"):
        ResultsStream(tmp_path / "a.h5", nb=1, n_eq=0, flush_rows=0)
    with pytest.raises(ModelError, match="segment"):
        simulate_to_file(double_pendulum, 1.0, tmp_path / "a.h5", segment=-1,
                         output_step=0.1)
    with pytest.raises(ModelError, match="t_eval"):
        simulate_to_file(double_pendulum, 1.0, tmp_path / "a.h5", segment=0.5,
                         output_step=0.1, t_eval=[0, 1])
    (tmp_path / "other.h5").write_bytes(b"not hdf5")
    with pytest.raises(ModelError, match="cannot read"):
        read_stream(tmp_path / "other.h5")
