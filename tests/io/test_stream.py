"""Results streamed to their files during a run (spatialmbd.io.stream, issue 16).

The streamed files must equal those written from the in-memory results to round-off (it is
one continuous run), read back with load_results, and keep status and partial rows on
failure, budget and write errors."""
import numpy as np
import pytest

pytest.importorskip("h5py")

from spatialmbd import models  # noqa: E402
from spatialmbd.errors import ModelError  # noqa: E402
from spatialmbd.io.modelfile import load_model  # noqa: E402
from spatialmbd.io.results_io import load_results, save_all  # noqa: E402
from spatialmbd.io.stream import ResultsWriter, simulate_to_file  # noqa: E402
from spatialmbd.simulate import simulate  # noqa: E402

import pathlib  # noqa: E402

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def double_pendulum():
    return models.double_pendulum().compile()


def _same_files(a, b):
    A, B = load_results(a), load_results(b)
    assert list(A.table.columns) == list(B.table.columns) and len(A.table) == len(B.table)
    assert np.array_equal(A.table.to_numpy(), B.table.to_numpy(), equal_nan=True)
    for name in ("t", "q", "v", "vdot", "lam", "work"):
        x, y = getattr(A, name), getattr(B, name)
        if x is not None or y is not None:
            assert np.array_equal(x, y, equal_nan=True), name
    return A, B


@pytest.mark.parametrize("method", ["projection", "augmented_lagrangian"])
def test_streamed_files_equal_the_in_memory_ones(double_pendulum, tmp_path, method):
    opts = dict(method=method, integrator="rk45", output_step=0.01)
    ref = simulate(double_pendulum, 0.5, **opts)
    save_all(ref, [tmp_path / "a.h5", tmp_path / "a.csv"])
    tail, written = simulate_to_file(double_pendulum, 0.5, [tmp_path / "b.h5",
                                                            tmp_path / "b.csv"],
                                     chunk_rows=7, **opts)
    assert written[tmp_path / "b.h5"][0] == 51 and len(tail.t) == 51 % 7
    assert tail.status == "success" and tail.counters["steps"] == ref.counters["steps"]
    A, B = _same_files(tmp_path / "a.h5", tmp_path / "b.h5")
    _same_files(tmp_path / "a.csv", tmp_path / "b.csv")
    assert B.metadata["status"] == "success" and B.metadata["counters"]["outputs"] == 51
    assert B.metadata["model"] == A.metadata["model"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.h5", "b.csv", "b.h5"]


def test_contacts_and_couplers_stream_as_one_continuous_run(tmp_path):
    """The contacts' impact-velocity memory and the couplers' angle references carry across
    chunks (the outputs of a chunk are evaluated mid-run, which must not disturb them)."""
    for name, t_end in (("bouncing_ball.yaml", 0.8), ("gear_train.yaml", 0.6)):
        model, analysis = load_model(EXAMPLES / name)
        opts = dict(method=analysis.method, integrator="rk45", output_step=0.005,
                    rtol=1e-8, atol=1e-10)
        ref = simulate(model, t_end, **opts)
        save_all(ref, [tmp_path / "a.h5"])
        simulate_to_file(model, t_end, tmp_path / "b.h5", chunk_rows=13, **opts)
        _same_files(tmp_path / "a.h5", tmp_path / "b.h5")


def test_failed_and_budget_runs_keep_their_rows_and_status(double_pendulum, tmp_path):
    tail, _ = simulate_to_file(double_pendulum, 1.0, [tmp_path / "r.h5", tmp_path / "r.csv"],
                               chunk_rows=5, output_step=0.01, integrator="rk4", step=1e-3,
                               max_steps=150)
    assert tail.status == "budget"
    B = load_results(tmp_path / "r.h5")
    C = load_results(tmp_path / "r.csv")
    assert B.metadata["status"] == "budget" and "max_steps=150" in B.metadata["message"]
    assert C.metadata["status"] == "budget"
    assert 10 < len(B.t) < 20 and len(C.t) == len(B.t) and np.all(np.diff(B.t) > 0)
    assert (tmp_path / "r.csv").read_text().startswith("# status: budget")


def test_a_write_error_keeps_the_previous_file_and_names_it(double_pendulum, tmp_path,
                                                            monkeypatch):
    target = tmp_path / "keep.h5"
    target.write_bytes(b"previous")
    from spatialmbd.io import stream
    calls = {"n": 0}
    original = stream._H5Stream.add

    def failing(self, results, df):
        calls["n"] += 1
        if calls["n"] == 3:
            raise OSError(28, "No space left on device")
        return original(self, results, df)

    monkeypatch.setattr(stream._H5Stream, "add", failing)
    with pytest.raises(OSError, match="keep.h5.*previous file is kept"):
        simulate_to_file(double_pendulum, 0.5, target, chunk_rows=5, output_step=0.01)
    assert target.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.h5"]


def test_file_size_limit_is_an_os_error_not_a_crash(tmp_path):
    """HDF5 through a Python file object: RLIMIT_FSIZE gives OSError (run in a child so the
    limit does not touch the test process)."""
    import subprocess
    import sys
    import textwrap
    code = textwrap.dedent(f"""
        import resource, pathlib
        from spatialmbd import models
        from spatialmbd.io.stream import simulate_to_file
        m = models.double_pendulum().compile()
        target = pathlib.Path({str(tmp_path / 'big.h5')!r})
        target.write_bytes(b"previous")
        resource.setrlimit(resource.RLIMIT_FSIZE, (60_000, 60_000))
        try:
            simulate_to_file(m, 20.0, target, chunk_rows=500, output_step=0.002,
                             method="standard")
        except OSError as exc:
            print("OSError", exc)
        print("kept", target.read_bytes() == b"previous")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert "OSError" in out.stdout and "big.h5" in out.stdout and "kept True" in out.stdout


def test_bad_arguments_are_model_errors(double_pendulum, tmp_path):
    with pytest.raises(ModelError, match="must end in"):
        ResultsWriter(tmp_path / "a.txt")
    with pytest.raises(ModelError, match="chunk_rows"):
        ResultsWriter(tmp_path / "a.h5", chunk_rows=0)
    with pytest.raises(ModelError, match="stream"):
        simulate_to_file(double_pendulum, 1.0, tmp_path / "a.h5", stream=None)
    assert list(tmp_path.iterdir()) == []
