"""The spatialmbd command line (spatialmbd.cli), run in-process through main([...])."""
from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from importlib import metadata

import numpy as np
import pandas as pd
import pytest

import spatialmbd
from spatialmbd import cli, models
from spatialmbd.cli import main
from spatialmbd.io.modelfile import load_model, model_to_dict, save_model
from spatialmbd.io.results_io import load_results, read_results

COMMANDS = ["run", "info", "plot", "animate", "examples", "demo", "validate", "fmu"]
SHORT = {"type": "dynamic", "t_end": 0.3, "output_step": 0.02,
         "method": {"name": "standard"}, "integrator": {"name": "rk45", "rtol": 1e-8,
                                                         "atol": 1e-10}}


@pytest.fixture
def pendulum_file(tmp_path):
    return save_model(models.pendulum_ch15(), tmp_path / "pendulum.yaml", analysis=SHORT)


@pytest.fixture(scope="module")
def pendulum_h5(tmp_path_factory):
    """Results of the pendulum file, written once by `spatialmbd run` (read-only in tests)."""
    tmp = tmp_path_factory.mktemp("h5")
    path = save_model(models.pendulum_ch15(), tmp / "pendulum.yaml", analysis=SHORT)
    out = tmp / "pendulum.h5"
    assert main(["run", str(path), "-q", "-o", str(out)]) == 0
    return out


# ---------------------------------------------------------------------------------- help
def test_help_and_version(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "examples:" in out and all(c in out for c in COMMANDS)
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"spatialmbd {spatialmbd.__version__}"
    assert main([]) == 2


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help_with_examples(capsys, command):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: spatialmbd {command}")
    assert f"examples:\n  spatialmbd {command}" in out


def test_entry_point_and_python_m():
    scripts = {e.name: e.value for e in metadata.entry_points(group="console_scripts")}
    assert scripts.get("spatialmbd") == "spatialmbd.cli:main"
    proc = subprocess.run([sys.executable, "-m", "spatialmbd", "--help"], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("usage: spatialmbd")
    assert proc.stderr == ""


# ---------------------------------------------------------------------------------- run
def test_run_writes_csv_and_hdf5(tmp_path, pendulum_file, capsys):
    csv, h5 = tmp_path / "out.csv", tmp_path / "out.h5"
    assert main(["run", str(pendulum_file), "-o", str(csv), "-o", str(h5)]) == 0
    out = capsys.readouterr().out
    assert "status: success" in out and "function evaluations" in out
    assert "initial conditions corrected" in out and "wall time" in out
    assert f"results written to {csv}" in out and f"results written to {h5}" in out

    df = pd.read_csv(csv)
    assert len(df) == 16 and df["t"].iloc[-1] == pytest.approx(0.3)
    for c in ("t", "pendulum.x", "pendulum.z", "pendulum.e0", "pendulum.wx",
              "pendulum.tip.z", "pivot.pendulum.fz", "violation.position",
              "violation.velocity", "energy.total", "energy.error"):
        assert c in df.columns, c
    assert abs(df["energy.error"]).max() < 1e-5

    loaded = load_results(h5)
    assert loaded.version == spatialmbd.__version__
    assert loaded.status == "success"
    assert loaded.counters["nfev"] > 0 and loaded.counters["steps"] > 0
    assert loaded.settings["method"] == "standard" and loaded.settings["integrator"] == "rk45"
    model, analysis = load_model(pendulum_file)
    expected = json.loads(json.dumps(model_to_dict(model, analysis)))
    assert loaded.model_dict == expected
    again, again_analysis = loaded.load_model()                 # the file alone suffices
    assert again.body_names == ("pendulum",) and again_analysis.t_end == pytest.approx(0.3)
    pd.testing.assert_frame_equal(loaded.table, df, check_exact=False, rtol=1e-14)


def test_run_streams_long_runs_to_the_same_files(tmp_path, pendulum_file, capsys):
    """Above --stream-rows the outputs go to the files in chunks during the run; the files
    equal those written from memory (one continuous run)."""
    a, b = [tmp_path / "a.csv", tmp_path / "a.h5"], [tmp_path / "b.csv", tmp_path / "b.h5"]
    assert main(["run", str(pendulum_file), "-q", "-o", str(a[0]), "-o", str(a[1])]) == 0
    assert main(["run", str(pendulum_file), "--stream-rows", "5", "-o", str(b[0]), "-o",
                 str(b[1])]) == 0
    out = capsys.readouterr().out
    assert "16 output rows: written to the files in chunks of 5" in out
    assert f"results written to {b[1]} (16 rows" in out
    for x, y in zip(a, b):
        X, Y = load_results(x), load_results(y)
        pd.testing.assert_frame_equal(X.table, Y.table, check_exact=True)
    assert load_results(b[1]).metadata["counters"]["outputs"] == 16
    # a budget stop: status, partial rows and exit status 1, streamed as well
    assert main(["run", str(pendulum_file), "--stream-rows", "0", "--max-steps", "3", "-o",
                 str(b[1])]) == 1
    err = capsys.readouterr().err
    assert "results up to t =" in err and "nan" not in err
    assert load_results(b[1]).metadata["status"] == "budget"


def test_run_options_override_the_file(tmp_path, pendulum_file, capsys):
    h5 = tmp_path / "o.h5"
    code = main(["run", str(pendulum_file), "--method", "baumgarte", "--integrator", "rk4",
                 "--step", "0.005", "--t-end", "0.2", "--output-step", "0.05", "-o", str(h5)])
    assert code == 0, capsys.readouterr().err
    loaded = load_results(h5)
    assert loaded.settings["method"] == "baumgarte"
    assert loaded.settings["integrator"] == "rk4"
    assert loaded.settings["integrator_options"]["step"] == pytest.approx(0.005)
    np.testing.assert_allclose(loaded.t, [0, 0.05, 0.1, 0.15, 0.2])
    assert loaded.analysis["integrator"]["name"] == "rk4"
    assert loaded.analysis["t_end"] == pytest.approx(0.2)
    out = capsys.readouterr().out
    assert "not used by 'rk4': rtol=1e-08, atol=1e-10" in out   # rk45 settings dropped
    # rtol/atol alone keep the file's integrator
    assert main(["run", str(pendulum_file), "-q", "--rtol", "1e-5", "--atol", "1e-7",
                 "-o", str(h5)]) == 0
    opts = load_results(h5).settings["integrator_options"]
    assert opts["rtol"] == pytest.approx(1e-5) and opts["atol"] == pytest.approx(1e-7)


def test_run_default_output_and_quiet(tmp_path, pendulum_file, monkeypatch, capsys):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["run", str(pendulum_file), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    assert [p.name for p in work.iterdir()] == ["pendulum.csv"]     # <model stem>.csv here


def test_run_kinematic_analysis(tmp_path, capsys):
    path = save_model(models.slider_crank(), tmp_path / "crank.yaml",
                      analysis={"type": "kinematic", "t_end": 0.5, "output_step": 0.05})
    out = tmp_path / "crank.csv"
    assert main(["run", str(path), "-o", str(out)]) == 0
    assert "kinematic analysis: 11 output times" in capsys.readouterr().out
    df = pd.read_csv(out)
    x, _, _ = models.slider_crank_exact(6.0 * df["t"].to_numpy())
    np.testing.assert_allclose(df["slider.x"], x, atol=1e-8)
    assert main(["run", str(path), "--method", "penalty"]) == 2
    assert "only for dynamic analyses" in capsys.readouterr().err


def _nan_force_loader(path):
    """(model, analysis) of the pendulum file plus a user force that turns NaN at t = 0.1 s."""
    from spatialmbd.io.modelfile import load_builder
    builder, analysis = load_builder(path)

    def force(t, q, v):
        f = np.zeros((1, 3))
        if t > 0.1:
            f[:] = np.nan
        return f, np.zeros((1, 3))

    builder.add_force("user", "broken", function=force)
    return builder.compile(), analysis


def test_failed_simulation_exit_1_with_partial_results(tmp_path, pendulum_file, monkeypatch,
                                                        capsys):
    monkeypatch.setattr(cli.common, "load", _nan_force_loader)
    csv, h5 = tmp_path / "fail.csv", tmp_path / "fail.h5"
    assert main(["run", str(pendulum_file), "-o", str(csv), "-o", str(h5)]) == 1
    captured = capsys.readouterr()
    assert "status: failed" in captured.out
    m = re.search(r"error: the analysis failed; results up to t = (\S+) s were written\. "
                  r"t = (\S+) s: non-finite", captured.err)
    assert m and 0.04 < float(m.group(1)) <= 0.12 and 0.1 < float(m.group(2)) < 0.12
    assert "Traceback" not in captured.err
    assert csv.read_text().startswith("# status: failed; t = ")    # a partial CSV says so
    df = pd.read_csv(csv, comment="#")
    assert read_results(csv).attrs["status"] == "failed"
    assert 3 <= len(df) <= 7 and df["t"].iloc[-1] <= 0.12 and np.all(np.isfinite(df["pendulum.z"]))
    loaded = load_results(h5)
    assert loaded.status == "failed" and len(loaded.t) == len(df)
    assert "model not stored" in loaded.metadata["model_note"]     # user forces are code
    # --quiet still explains the failure
    assert main(["run", str(pendulum_file), "-q", "-o", str(csv)]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and "failed" in captured.err


@pytest.mark.parametrize("args, message", [
    (["run", "{tmp}/missing.yaml"], "no such model file"),
    (["run", "{model}", "--method", "runge"], "unknown method 'runge'; valid names"),
    (["run", "{model}", "--integrator", "rk5"], "unknown integrator 'rk5'; valid names"),
    (["run", "{model}", "-o", "{tmp}/out.txt"], "must end in .csv, .h5 or .hdf5"),
    (["run", "{model}", "-o", "{tmp}/nodir/out.csv"], "does not exist"),
    (["run", "{model}", "--t-end", "-1"], "must be a positive number"),
    (["run", "{model}", "--t-end", "abc"], "expected a number"),
    (["run", "{model}", "--step", "0.01", "--integrator", "euler", "--method", "penalty",
      "--unknown"], "unrecognized arguments"),
    (["plot", "{tmp}/missing.h5", "-o", "{tmp}/x.png"], "no such results file"),
    (["examples", "pendulum"], "unknown example 'pendulum'"),
])
def test_bad_input_exit_2(tmp_path, pendulum_file, capsys, args, message):
    args = [a.format(tmp=tmp_path, model=pendulum_file) for a in args]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err
    assert "Traceback" not in err
    assert not (tmp_path / "pendulum.csv").exists()


def test_invalid_model_file_lists_every_problem(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("spatialmbd: 1\nname: bad\nbodies:\n  - name: a\n    mass: -1\n"
                   "    inertia: [1, 1, 1]\n    colour: red\njoints:\n  - name: j\n"
                   "    type: revolute\n    body_i: ground\n    body_j: b\n"
                   "    point: [0, 0, 0]\n    axis: [1, 0, 0]\n")
    assert main(["run", str(bad)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"error: {bad}: 3 problems:"
    assert any(line.strip().startswith("bodies[0].colour") for line in err[1:])
    assert any(line.strip().startswith("bodies[0].mass") for line in err[1:])
    assert any(line.strip().startswith("joints[0].body_j") for line in err[1:])
    assert len(err) == 4
    assert main(["info", str(bad)]) == 2


# ---------------------------------------------------------------------------------- info
def test_info_reports_dof_and_redundant_joints(tmp_path, capsys):
    path = save_model(models.bricard(), tmp_path / "bricard.yaml")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "bodies (5):" in out and "joints (6):" in out
    assert "  P3               revolute" in out
    assert "Gruebler-Kutzbach DoF (6 nb - m, Eq. 2.1): 0" in out
    assert "actual DoF (6 nb - rank D): 1" in out
    assert "redundant equations: 1" in out
    # a run reports the redundant equations as a warning (once)
    assert main(["run", str(path), "--t-end", "0.02", "--output-step", "0.01",
                 "-o", str(tmp_path / "b.csv")]) == 0
    out = capsys.readouterr().out
    assert out.count("warning: 1 redundant constraint equation(s) in joint(s) P5") == 1
    path = save_model(models.slider_crank(), tmp_path / "crank.yaml")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "crank_drive      angle of joint A" in out
    assert "actual DoF (6 nb - rank D): 0" in out


# ---------------------------------------------------------------------------------- examples
def test_examples_list_and_write(tmp_path, capsys):
    assert main(["examples"]) == 0
    out = capsys.readouterr().out
    for name in models.EXAMPLES:
        assert name in out
    assert main(["examples", "four_bar"]) == 0
    assert "Spatial four-bar" in capsys.readouterr().out
    assert main(["examples", "slider_crank", "--write", str(tmp_path / "m")]) == 0
    written = tmp_path / "m" / "slider_crank.yaml"
    model, analysis = load_model(written)
    assert analysis.type == "kinematic" and "crank_drive" in model.driver_names
    assert main(["examples", "--write", str(tmp_path / "all"), "--format", "json",
                 "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "all").iterdir()) == \
        sorted(f"{n}.json" for n in models.EXAMPLES)


# ---------------------------------------------------------------------------------- plot
def test_plot(tmp_path, pendulum_h5, capsys):
    # every format is checked in test_plotting.py; here the command line
    outs = [tmp_path / "fig.svg", tmp_path / "fig.png"]
    assert main(["plot", str(pendulum_h5), "-y", "pendulum.z", "-y", "energy.error",
                 "-o", str(outs[0]), "-o", str(outs[1]), "--title", "pendulum"]) == 0
    assert capsys.readouterr().out.splitlines() == [f"figure written to {o}" for o in outs]
    svg = outs[0].read_text()
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg and "pendulum" in svg
    assert outs[1].read_bytes()[:4] == b"\x89PNG" and outs[1].stat().st_size > 1000
    capsys.readouterr()
    assert main(["plot", str(pendulum_h5), "-y", "pendulum.w", "-o",
                 str(tmp_path / "w.png")]) == 2
    assert "did you mean" in capsys.readouterr().err
    assert main(["plot", str(pendulum_h5), "-o", str(tmp_path / "fig.gif")]) == 2


# ---------------------------------------------------------------------------------- animate
def _scene(html_path):
    text = html_path.read_text()
    m = re.search(r'<script type="application/json" id="spatialmbd-scene">(.*?)</script>',
                  text, re.S)
    return json.loads(m.group(1))


def test_animate_results_file_and_model_file(tmp_path, pendulum_h5, pendulum_file, capsys,
                                             monkeypatch):
    html = tmp_path / "p.html"
    assert main(["animate", str(pendulum_h5), "-o", str(html)]) == 0
    scene = _scene(html)
    assert [b["name"] for b in scene["bodies"]] == ["pendulum"]
    assert len(scene["t"]) == 16
    assert scene["joints"][0]["name"] == "pivot" and scene["joints"][0]["body"] == -1
    assert scene["bodies"][0]["shapes"][0]["type"] == "cylinder"
    monkeypatch.chdir(tmp_path)
    assert main(["animate", str(pendulum_file), "--t-end", "0.1", "--max-frames", "4",
                 "-q"]) == 0
    scene = _scene(tmp_path / "pendulum.html")                    # default <stem>.html
    assert len(scene["t"]) == 4 and scene["t"][-1] == pytest.approx(0.1)
    csv = tmp_path / "p.csv"
    csv.write_text("t\n0\n")
    assert main(["animate", str(csv)]) == 2
    assert "holds no geometry" in capsys.readouterr().err


# ---------------------------------------------------------------------------------- demo, validate
def test_demo_calls_the_study(tmp_path, monkeypatch, capsys):
    study = pytest.importorskip("spatialmbd.study_ch15")
    seen = {}

    def fake(outdir, quick=False, echo=None):
        seen.update(outdir=outdir, quick=quick)
        return {"report": "study report", "figure": str(outdir / "fig.png")}

    monkeypatch.setattr(study, "run_study", fake)
    assert main(["demo", "--outdir", str(tmp_path / "d"), "--quick"]) == 0
    assert seen == {"outdir": tmp_path / "d", "quick": True}
    assert "study report" in capsys.readouterr().out

    def failing(outdir, quick=False, echo=None):
        return {"report": "study report", "passed": False}

    monkeypatch.setattr(study, "run_study", failing)
    assert main(["demo", "--outdir", str(tmp_path / "d"), "--quiet"]) == 1
    assert "exact solution" in capsys.readouterr().err


def test_validate_exit_status(tmp_path, monkeypatch, capsys):
    validation = pytest.importorskip("spatialmbd.validation")
    from spatialmbd.validation.core import CaseResult, Check

    def case(name, error):
        return CaseResult(name, f"case {name}", "made up",
                          checks=[Check("x", 1.0, 1.0 + error, error, 1e-6)], runtime=0.01)

    cases = [case("a", 0.0), case("b", 1e-9)]
    calls = []

    def fake(full=False, out=None, cases=None, progress=None, method=None):
        calls.append((full, out, cases))
        for c in fake_cases:
            progress(c)
        return list(fake_cases)

    fake_cases = cases
    monkeypatch.setattr(validation, "run_validation", fake)
    assert main(["validate"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("a: pass (0.0 s)\nb: pass")
    assert "all 2 validation cases passed" in out
    assert main(["validate", "--full", "--out", str(tmp_path), "a", "b"]) == 0
    assert calls == [(False, None, None), (True, str(tmp_path), ["a", "b"])]
    capsys.readouterr()
    fake_cases = cases + [case("c", 1.0)]
    assert main(["validate", "--quiet"]) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == "error: 1 of 3 validation case(s) failed: c\n"


def test_validate_unknown_case_and_a_real_one(capsys):
    pytest.importorskip("spatialmbd.validation")
    assert main(["validate", "no_such_case"]) == 2
    assert "unknown validation case" in capsys.readouterr().err
    assert main(["validate", "slider_crank_kinematics"]) == 0
    out = capsys.readouterr().out
    assert "Slider-crank kinematics: pass" in out and "all 1 validation cases passed" in out


def test_warmup_and_the_cold_cache_notice(capsys):
    """`spatialmbd warmup` compiles everything (here: loads it); a cold cache is announced at
    once and then every few seconds, never silent."""
    import io
    import time
    from spatialmbd.jit import cache_is_warm, compile_notice
    assert main(["warmup"]) == 0
    out = capsys.readouterr().out
    assert "[1/" in out and "ready in" in out
    assert cache_is_warm()
    stream = io.StringIO()
    with compile_notice(stream=stream, every=0.05, force=True):
        time.sleep(0.18)
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("compiling the numerical kernels")
    assert sum("still compiling" in ln for ln in lines) >= 2
    assert lines[-1].startswith("compiled in")
    stream = io.StringIO()
    with compile_notice(stream=stream):            # warm: nothing said
        pass
    assert stream.getvalue() == ""


# ---------------------------------------------------------------------------- cold start
def test_cold_start_runs_interpreted_while_compiling(tmp_path, pendulum_file, monkeypatch,
                                                     capsys):
    """A cold cache: the command runs in a child with the kernels interpreted while the
    compile goes on in the background; the interpreted result is the compiled one."""
    monkeypatch.setattr(cli, "_cold", lambda args: True)
    monkeypatch.setattr(cli, "WARMUP_ARGV", [sys.executable, "-c",
                                             "import time; time.sleep(20)"])
    monkeypatch.setattr("spatialmbd.jit.cache_is_warm", lambda: False)
    fast, slow = tmp_path / "compiled.csv", tmp_path / "interpreted.csv"
    assert main(["run", str(pendulum_file), "-q", "-o", str(fast)]) == 0
    assert cli._cold(None) is True
    monkeypatch.setenv("SPATIALMBD_NO_RACE", "")
    assert main(["run", str(pendulum_file), "-o", str(slow)]) == 0
    err = capsys.readouterr().err
    assert "compiling the numerical kernels in the background" in err
    assert "still being built in the background" in err
    a, b = pd.read_csv(fast), pd.read_csv(slow)
    assert list(a.columns) == list(b.columns) and len(a) == len(b) == 16
    assert np.allclose(a.to_numpy(), b.to_numpy(), rtol=1e-9, atol=1e-12)


def test_cold_start_switches_to_the_compiled_kernels_when_they_are_ready(
        tmp_path, pendulum_file, monkeypatch, capsys):
    monkeypatch.setattr(cli, "_cold", lambda args: True)
    monkeypatch.setattr(cli, "WARMUP_ARGV", [sys.executable, "-c",
                                             "import time; time.sleep(5)"])
    start = time.perf_counter()
    monkeypatch.setattr("spatialmbd.jit.cache_is_warm",
                        lambda: time.perf_counter() - start > 0.5)
    out = tmp_path / "out.csv"
    assert main(["run", str(pendulum_file), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "compiled kernels ready after" in err and "running compiled" in err
    assert len(pd.read_csv(out)) == 16
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "pendulum.yaml") == \
        ["out.csv"]                                     # the stopped child left nothing
