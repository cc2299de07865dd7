"""Issue 31, items 1, 5 and 6: an output that cannot be written is one clean error naming the
target (never its hidden temporary), every failure path removes its temporaries, and Ctrl-C
during a large HDF5 write stops it within a second and leaves the previous file."""
from __future__ import annotations

import contextlib
import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from spatialmbd import atomic, models
from spatialmbd.cli import main
from spatialmbd.io import results_io
from spatialmbd.io.results_io import load_results, save_all, write_csv, write_hdf5
from spatialmbd.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "simple_pendulum_a01.yaml"
SRC = str(ROOT / "src")


@contextlib.contextmanager
def tmpfs(directory: Path, size: str = "200k", read_only: bool = False):
    """A small tmpfs mounted on ``directory`` (root only); yields False when it cannot be
    mounted (the caller falls back to a monkeypatched failure)."""
    directory.mkdir(parents=True, exist_ok=True)
    options = f"size={size}" + (",ro" if read_only else "")
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(directory)],
                              capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.SubprocessError):
        done = False
    try:
        yield done
    finally:
        if done:
            subprocess.run(["umount", str(directory)], capture_output=True, timeout=10)


def temporaries(directory: Path) -> list:
    return sorted(p.name for p in Path(directory).iterdir() if p.name.endswith(".tmp"))


@pytest.fixture(scope="module")
def results():
    """A double-pendulum run of 2001 output rows (about 1 MB of CSV)."""
    return simulate(models.double_pendulum().compile(), 0.2, output_step=1e-4,
                    integrator="rk45")


def one_clean_line(err: str, target) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err and ".tmp" not in err, err
    assert str(target) in lines[0], err
    return lines[0]


# ---------------------------------------------------------------------------- item 1: the CLI
@pytest.mark.parametrize("target", ["/proc/r.csv", "/proc/r.h5", "{tmp}/missing/r.csv",
                                    "{tmp}/file.txt/r.csv"])
def test_cli_run_to_an_unwritable_path_is_one_line_exit_2(target, tmp_path, capsys):
    (tmp_path / "file.txt").write_text("x")
    target = target.format(tmp=tmp_path)
    code = main(["run", str(EXAMPLE), "--t-end", "0.01", "-q", "-o", target])
    assert code == 2
    one_clean_line(capsys.readouterr().err, target)


def test_cli_run_to_a_read_only_folder(tmp_path, capsys, monkeypatch):
    folder = tmp_path / "ro"
    with tmpfs(folder, "64k", read_only=True) as mounted:
        if not mounted:             # not root: a folder without write permission does it
            folder.chmod(0o555)
            if os.access(folder, os.W_OK):
                pytest.skip("cannot make a read-only folder here")
        target = folder / "r.csv"
        code = main(["run", str(EXAMPLE), "--t-end", "0.01", "-q", "-o", str(target)])
        assert code == 2
        line = one_clean_line(capsys.readouterr().err, target)
        assert "Read-only" in line or "ermission" in line
        if not mounted:
            folder.chmod(0o755)


@pytest.mark.parametrize("command", [
    ["animate", str(EXAMPLE), "--t-end", "0.01", "-o", "/proc/a.html"],
    ["sweep", str(EXAMPLE), "--param", "bodies.0.mass=1,2", "--output", "max(t)",
     "-o", "/proc/s.nc", "-q"],
    ["import", "{urdf}", "-o", "/proc/m.yaml", "-q"],
])
def test_cli_other_commands_refuse_an_unwritable_path_before_any_work(command, tmp_path,
                                                                        capsys):
    urdf = tmp_path / "a.urdf"
    urdf.write_text('<robot name="r"><link name="a"/></robot>')
    command = [c.format(urdf=urdf) for c in command]
    assert main(command) == 2
    one_clean_line(capsys.readouterr().err, command[command.index("-o") + 1])


@pytest.mark.parametrize("command, target", [
    (["demo", "--quick", "-q", "--outdir", "/proc/study"], "/proc/study"),
    (["validate", "-q", "--out", "/proc/v.md"], "/proc/v.md"),
])
def test_cli_demo_and_validate_refuse_an_unwritable_output_before_running(command, target,
                                                                          capsys):
    start = time.perf_counter()
    assert main(command) == 2
    one_clean_line(capsys.readouterr().err, target)
    assert time.perf_counter() - start < 5.0             # refused before the study runs


# ------------------------------------------------------------------ item 1: every writer
def _writers(results, tmp_path):
    """(name, call(target)) for every writer of the package."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from spatialmbd.animation import animation_scene, write_animation
    from spatialmbd.io.modelfile import save_model
    from spatialmbd.io.sidecar import MeshStore
    from spatialmbd.plotting import save_figure
    from spatialmbd.sweep import save_result, sweep
    from spatialmbd.sweep.plot import summary_plot
    from spatialmbd.viewer.animation import write_animation_html

    ds = sweep(models.double_pendulum().compile(), {"bodies.0.mass": [1.0, 2.0]},
               ["max(t)"], {"t_end": 0.01, "output_step": 0.01}, progress=False)

    scene = animation_scene(results, max_frames=5)

    def mesh_store(target):
        store = MeshStore(target)
        store.arrays = {"m.vertices": np.eye(3), "m.faces": np.array([[0, 1, 2]])}
        return store.write()

    return [
        ("csv", ".csv", lambda p: write_csv(results, p)),
        ("hdf5", ".h5", lambda p: write_hdf5(results, p)),
        ("save_all", ".h5", lambda p: save_all(results, [p])),
        ("png", ".png", lambda p: save_figure(plt.figure(), p)),
        ("html", ".html", lambda p: write_animation(results, p, max_frames=5)),
        ("viewer html", ".html", lambda p: write_animation_html(p, scene)),
        ("model", ".yaml", lambda p: save_model(models.double_pendulum(), p)),
        ("sidecar", ".npz", mesh_store),
        ("sweep nc", ".nc", lambda p: save_result(ds, p)),
        ("sweep csv", ".csv", lambda p: save_result(ds, p)),
        ("sweep plot", ".png", lambda p: summary_plot(ds, p)),
    ]


def test_every_writer_names_its_target_and_leaves_no_temporary(results, tmp_path,
                                                               monkeypatch):
    for name, suffix, write in _writers(results, tmp_path):
        # a folder that cannot hold files (/proc): refused when the temporary is made
        target = Path("/proc") / f"out{suffix}"
        with pytest.raises(OSError) as info:
            write(target)
        assert str(target) in str(info.value) and ".tmp" not in str(info.value), name
        # a refused rename (the last step): the temporary is removed, the target named
        target = tmp_path / name.replace(" ", "_") / f"out{suffix}"
        target.parent.mkdir()
        with monkeypatch.context() as m:
            m.setattr(atomic.os, "replace",
                      lambda *a: (_ for _ in ()).throw(PermissionError(errno.EACCES, "refused",
                                                                       a[0])))
            with pytest.raises(OSError) as info:
                write(target)
        assert str(target) in str(info.value) and ".tmp" not in str(info.value), name
        assert temporaries(target.parent) == [] and not target.exists(), name


# --------------------------------------------------------------- item 6: full disk, rename
def test_two_outputs_on_a_full_disk_remove_both_temporaries(results, tmp_path, monkeypatch):
    folder = tmp_path / "small"
    with tmpfs(folder, "200k") as mounted:
        a, b = folder / "run.csv", folder / "run.h5"
        a.write_text("previous\n")
        if not mounted:               # no tmpfs: the second file's write fails with ENOSPC
            def full(self, df):
                raise OSError(errno.ENOSPC, "No space left on device")
            monkeypatch.setattr(results_io._H5Sink, "add", full)
        with pytest.raises(OSError) as info:
            save_all(results, [a, b])
        text = str(info.value)
        assert ".tmp" not in text and (str(a) in text or str(b) in text), text
        assert "space" in text.lower() or "too large" in text.lower(), text
        assert temporaries(folder) == []
        assert a.read_text() == "previous\n" and not b.exists()
        if mounted:                   # and the disk is free again
            assert os.statvfs(folder).f_bfree * os.statvfs(folder).f_frsize > 150_000


def test_a_refused_rename_of_the_second_output_removes_its_temporary(results, tmp_path,
                                                                    monkeypatch):
    a, b = tmp_path / "run.csv", tmp_path / "run.h5"
    real = os.replace
    calls = []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise PermissionError(errno.EPERM, "Operation not permitted", src)
        return real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace)
    with pytest.raises(OSError) as info:
        save_all(results, [a, b])
    text = str(info.value)
    assert f"cannot write {b}" in text and f"already written: {a}" in text, text
    assert ".tmp" not in text
    assert temporaries(tmp_path) == [] and a.exists() and not b.exists()


def test_stream_writer_on_a_full_disk_names_the_target(tmp_path, monkeypatch):
    from spatialmbd.io.stream import simulate_to_file
    folder = tmp_path / "small"
    with tmpfs(folder, "100k") as mounted:
        if not mounted:
            pytest.skip("no tmpfs (not root)")
        target = folder / "long.csv"
        model = models.double_pendulum().compile()
        with pytest.raises(OSError) as info:
            simulate_to_file(model, 0.5, [target, folder / "long.h5"], output_step=1e-4,
                             chunk_rows=500, integrator="rk45")
        assert ".tmp" not in str(info.value) and str(folder) in str(info.value)
        assert temporaries(folder) == [] and not target.exists()


# ---------------------------------------------------------------- item 5: Ctrl-C in a write
CHILD = r"""
import signal, sys, time
import h5py, pandas                                    # the write's imports, done before
from spatialmbd import models
from spatialmbd.simulate import simulate
from spatialmbd.io.results_io import save_all
res = simulate(models.double_pendulum().compile(), 2.0, output_step=1e-4, integrator="rk45")
signal.signal(signal.SIGINT, signal.SIG_IGN)          # Ctrl-C counts only during the writes
for line in sys.stdin:
    print("ready", flush=True)
    try:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        save_all(res, [sys.argv[1]])
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("done", flush=True)
    except KeyboardInterrupt as exc:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print(f"interrupted {exc}", flush=True)
"""


def test_ctrl_c_during_a_large_hdf5_write_stops_it_and_keeps_the_previous_file(tmp_path):
    """A 20,001-row run written to HDF5 (about 1.5 s on a shared core) gets SIGINT at several
    delays: each write stops within a second, says so, and leaves the previous file whole
    and no temporary."""
    target = tmp_path / "big.h5"
    target.write_bytes(b"previous file")
    delays = [0.0, 0.05, 0.2, 0.4]
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(target)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                             env=dict(os.environ, PYTHONPATH=SRC))
    outcomes = []
    try:
        for delay in delays:
            child.stdin.write("go\n")
            child.stdin.flush()
            assert child.stdout.readline().strip() == "ready"
            time.sleep(delay)
            sent = time.perf_counter()
            child.send_signal(signal.SIGINT)
            line = child.stdout.readline().strip()
            outcomes.append((delay, line, time.perf_counter() - sent))
            if line.startswith("interrupted") and "after the write completed" not in line:
                assert target.read_bytes() == b"previous file", line
            else:           # finished before the signal came (or it came after the commit)
                assert line.startswith(("done", "interrupted after the write completed")) \
                    and load_results(target).status == "success", line
                target.write_bytes(b"previous file")
            assert temporaries(tmp_path) == []
        child.stdin.close()
        assert child.wait(timeout=30) == 0, outcomes
    finally:
        child.kill()
    interrupted = [o for o in outcomes if o[1].startswith("interrupted")
                   and "after the write completed" not in o[1]]
    assert len(interrupted) >= len(delays) - 1, outcomes
    for delay, line, latency in interrupted:
        assert latency < 1.0, outcomes
    # (a signal in the instant before save_all enters its write is a plain interruption)
    during = [o for o in interrupted if f"while writing {target}" in o[1]
              and "previous files are kept" in o[1]]
    assert len(during) >= len(delays) - 2, outcomes


def test_cli_says_interrupted_while_writing_with_exit_130(tmp_path, capsys, monkeypatch):
    target = tmp_path / "r.h5"

    real_check = atomic.interrupt_check
    fake = lambda: (atomic._Deferred.handler(signal.SIGINT, None), real_check())  # noqa: E731
    for module in (results_io.hdf5_file, results_io.csv_file):    # where the writers check
        monkeypatch.setattr(module, "interrupt_check", fake)
    code = main(["run", str(EXAMPLE), "--t-end", "0.01", "-q", "-o", str(target)])
    assert code == 130
    err = capsys.readouterr().err
    assert f"interrupted while writing {target}" in err and "previous files are kept" in err
    assert not target.exists() and temporaries(tmp_path) == []
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_ctrl_c_while_the_cli_writes_exits_130_and_keeps_the_previous_file(tmp_path):
    """The issue's case: `spatialmbd run MODEL -o out.h5` gets SIGINT once its HDF5 write has
    begun (its temporary has appeared): exit 130 within a second (the process included: it
    skips the interpreter's teardown), a message, the previous file whole, no temporary."""
    from spatialmbd.io import Analysis
    from spatialmbd.io.modelfile import save_model
    model_file = tmp_path / "double.yaml"
    save_model(models.double_pendulum(), model_file,
               Analysis(t_end=2.0, output_step=1e-4, integrator="rk45"))
    target = tmp_path / "out.h5"
    target.write_bytes(b"previous file")
    child = subprocess.Popen([sys.executable, "-m", "spatialmbd", "run", str(model_file),
                              "-q", "-o", str(target)], stderr=subprocess.PIPE, text=True,
                             env=dict(os.environ, PYTHONPATH=SRC, SPATIALMBD_NO_RACE="1"))
    try:
        seen = 0
        deadline = time.perf_counter() + 60
        while seen < 2 and child.poll() is None and time.perf_counter() < deadline:
            seen = seen + 1 if temporaries(tmp_path) else 0   # twice: the write, not a probe
            time.sleep(0.01)
        assert seen == 2, "the write never started"
        time.sleep(0.1)
        sent = time.perf_counter()
        child.send_signal(signal.SIGINT)
        err = child.communicate(timeout=30)[1]
        took = time.perf_counter() - sent
    finally:
        child.kill()
    assert child.returncode == 130, err
    assert f"interrupted while writing {target}" in err and "previous files are kept" in err
    assert "Traceback" not in err and took < 1.0, (took, err)
    assert target.read_bytes() == b"previous file" and temporaries(tmp_path) == []
