"""Issue 16: every bad input a clean error, resource limits and budgets, the diagnosis of
singular positions, plausibility warnings, and nothing lost when a run or a write fails."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from spatialmbd import guards, models
from spatialmbd.budget import MAX_FIXED_STEPS, Budget
from spatialmbd.errors import ModelError
from spatialmbd.io import results_io
from spatialmbd.io.modelfile import ModelFileError, load_model
from spatialmbd.io.results_io import load_results, read_results, save_all, write_csv
from spatialmbd.model import ModelBuilder
from spatialmbd.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "examples" / "pendulum_ch15.yaml"
SRC = str(ROOT / "src")


def pendulum_dict() -> dict:
    return yaml.safe_load(PENDULUM.read_text(encoding="utf-8"))


def problems_of(source, tmp_path=None, suffix=".yaml") -> list:
    """The problems of a ModelFileError raised by loading ``source`` (dict, text or bytes)."""
    if isinstance(source, (str, bytes)):
        path = tmp_path / f"model{suffix}"
        path.write_bytes(source.encode("utf-8") if isinstance(source, str) else source)
        source = path
    with pytest.raises(ModelFileError) as info:
        load_model(source)
    return info.value.problems


@pytest.fixture(scope="module")
def pendulum():
    return load_model(PENDULUM)[0]


# ============================================================================ file encodings
@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16", "utf-32"])
def test_utf8_bom_and_utf16_with_bom_are_read(tmp_path, encoding):
    text = PENDULUM.read_text(encoding="utf-8")
    path = tmp_path / "p.yaml"
    path.write_bytes(text.encode(encoding))
    model, _ = load_model(path)
    assert model.body_names == load_model(PENDULUM)[0].body_names


@pytest.mark.parametrize("encoding, words", [("utf-16-le", "UTF-16 or UTF-32 without a "
                                              "byte-order mark"),
                                             ("latin-1", "another encoding")])
def test_other_encodings_are_named_and_utf8_required(tmp_path, encoding, words):
    text = PENDULUM.read_text(encoding="utf-8").replace("name: pendulum",
                                                        "name: pendul\u00e9")
    (problem,) = problems_of(text.encode(encoding), tmp_path)
    assert words in problem and "must be UTF-8" in problem and problem.startswith("line ")


def test_ascii_utf16_without_bom_is_named(tmp_path):
    (problem,) = problems_of(PENDULUM.read_text(encoding="utf-8").encode("utf-16-le"),
                             tmp_path)
    assert "UTF-16 or UTF-32 without a byte-order mark" in problem and "UTF-8" in problem


def test_binary_junk_names_line_and_character(tmp_path):
    (problem,) = problems_of("spatialmbd: 1\nname: a\x00b\n", tmp_path)
    assert problem.startswith("line 2, column 8") and "U+0000" in problem


# ============================================================================ size limits
@pytest.mark.parametrize("suffix", [".yaml", ".json"])
@pytest.mark.parametrize("opener, closer", [("[", "]"), ('{"a": ', "}")])
def test_deep_nesting_is_refused(tmp_path, suffix, opener, closer):
    text = '{"spatialmbd": 1, "bodies": ' + opener * 1000 + "1" + closer * 1000 + "}"
    (problem,) = problems_of(text, tmp_path, suffix)
    assert "nested more than 64 levels" in problem or "nested too deeply" in problem


def test_unbalanced_brackets_are_a_syntax_error(tmp_path):
    for suffix in (".yaml", ".json"):
        (problem,) = problems_of('{"spatialmbd": 1, "x": ' + "[" * 100_000, tmp_path, suffix)
        assert problem.startswith("line ") or problem.startswith("(top level)")


def test_billion_laughs_is_refused_quickly(tmp_path):
    lines = ['spatialmbd: 1', 'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for k in "bcdefghi":
        prev = chr(ord(k) - 1)
        lines.append(f"{k}: &{k} [" + ",".join([f"*{prev}"] * 9) + "]")
    lines.append("bodies: *i")
    start = time.process_time()
    (problem,) = problems_of("\n".join(lines) + "\n", tmp_path)
    assert "aliases are expanded" in problem and problem.startswith("line ")
    assert time.process_time() - start < 5


def test_recursive_alias_and_many_aliases(tmp_path):
    (problem,) = problems_of("spatialmbd: 1\nbodies: &x [*x]\n", tmp_path)
    assert "contains it" in problem
    text = "spatialmbd: 1\nv: &v 1\nw: [" + ", ".join(["*v"] * 1001) + "]\n"
    (problem,) = problems_of(text, tmp_path)
    assert "more than 1000 YAML aliases" in problem


def test_huge_integers_and_file_size(tmp_path, monkeypatch):
    for suffix in (".yaml", ".json"):
        text = '{"spatialmbd": ' + "9" * 5000 + "}"
        (problem,) = problems_of(text, tmp_path, suffix)
        assert "5000 digits" in problem
    from spatialmbd.io import source
    monkeypatch.setattr(source, "MAX_FILE_BYTES", 100)
    (problem,) = problems_of(PENDULUM.read_text(encoding="utf-8"), tmp_path)
    assert "the limit is 100" in problem


# ============================================================================ numbers
@pytest.mark.parametrize("where, value, words", [
    (("spatialmbd",), float("nan"), "schema version must be an integer"),
    (("spatialmbd",), 10 ** 40, "schema version"),
    (("analysis", "t_end"), float("inf"), "expected a finite number"),
    (("analysis", "t_end"), 10 ** 40, "out of range"),
    (("analysis", "output_step"), float("nan"), "expected a finite number"),
    (("gravity", 2), 1e300, "out of range for a gravity"),
    (("bodies", 0, "position", 0), 1e300, "out of range for a length"),
    (("bodies", 0, "mass"), 5e-324, "too small for a mass"),
    (("bodies", 0, "inertia", 0), 1e300, "out of range for an inertia"),
    (("bodies", 0, "name"), ["a", "b"], "expected a body name"),
    (("joints", 0, "type"), {"x": 1}, "unknown joint type"),
    (("joints", 0, "body_i"), ["ground"], "expected the name of a body"),
])
def test_bad_numbers_and_types_are_located(where, value, words):
    data = pendulum_dict()
    target = data
    for key in where[:-1]:
        target = target[key]
    target[where[-1]] = value
    problems = problems_of(data)
    place = "".join(f"[{k}]" if isinstance(k, int) else f".{k}" for k in where).lstrip(".")
    assert any(p.startswith(place) and words in p for p in problems), problems


def test_absurd_driver_coefficients_are_range_errors():
    data = yaml.safe_load((ROOT / "examples" / "slider_crank.yaml").read_text())
    data["drivers"][0]["law"] = {"type": "polynomial", "coefficients": [0.0, 1e300]}
    problems = problems_of(data)
    assert any(p.startswith("drivers[0].law.coefficients[1]") and "out of range" in p
               for p in problems)


def test_extreme_values_do_not_reach_the_builder_checks():
    data = pendulum_dict()
    data["bodies"][0]["inertia"] = [6.7e-05, 1e308, 0.08]     # eigvalsh failed on this
    (problem,) = problems_of(data)
    assert problem.startswith("bodies[0].inertia[1]: 1e+308 kg m^2 is out of range")


def test_principal_inertias_violating_the_triangle_inequality_are_an_error():
    data = pendulum_dict()
    data["bodies"][0]["inertia"] = [1.0, 1.0, 3.0]
    (problem,) = problems_of(data)
    assert problem.startswith("bodies[0].inertia") and "triangle inequality" in problem


def test_a_deep_python_dict_is_refused():
    data = pendulum_dict()
    deep = 1
    for _ in range(500):
        deep = [deep]
    data["gravity"] = deep
    (problem,) = problems_of(data)
    assert "nested more than" in problem


# ============================================================================ Python API
def test_unknown_point_and_body_name_the_choices(pendulum):
    res = simulate(pendulum, 0.01, output_step=0.005)
    with pytest.raises(ModelError, match=r"unknown point 'tip'; valid names: pendulum\."):
        res.point("tip")
    with pytest.raises(ModelError, match="unknown body 'pendulm' \\(did you mean 'pendulum'"):
        res.body("pendulm")
    with pytest.raises(ModelError, match="ground does not move"):
        res.body("ground")
    with pytest.raises(ModelError, match="unknown point"):
        res.point(["a"])


def test_method_and_integrator_names_and_options(pendulum):
    with pytest.raises(ModelError, match=r"unknown method 'penalti' \(did you mean 'penalty'"
                                         r"\?\); valid names: penalty, "):
        simulate(pendulum, 0.01, method="penalti")
    with pytest.raises(ModelError, match=r"unknown integrator 'rk5' .*; valid names: rk45"):
        simulate(pendulum, 0.01, integrator="rk5")
    with pytest.raises(ModelError, match=r"method 'baumgarte' takes no option 'alpah' \(did "
                                         r"you mean 'alpha'\?\); its options are alpha, "):
        simulate(pendulum, 0.01, method="baumgarte", method_options={"alpah": 1.0})
    with pytest.raises(ModelError, match="takes no stpe"):
        simulate(pendulum, 0.01, integrator="rk4", integrator_options={"stpe": 1e-3})
    with pytest.raises(ModelError, match="method: expected a method name"):
        simulate(pendulum, 0.01, method=["standard"])
    with pytest.raises(ModelError, match="integrator_options: expected a dict"):
        simulate(pendulum, 0.01, integrator_options=[1])
    with pytest.raises(ModelError, match="penalty alpha: expected a number, got 'big'"):
        simulate(pendulum, 0.01, method="penalty", method_options={"alpha": "big"})


def test_initial_state_checks(pendulum):
    q0 = np.array(pendulum.q0)
    q0[0, 3:] = 0.0
    with pytest.raises(ModelError, match=r"q0\[0, 3:7\] \(body 'pendulum'\): the Euler "
                                         "parameters .* have zero length"):
        simulate(pendulum, 0.01, q0=q0)
    with pytest.raises(ModelError, match=r"v0: expected 1 x 6"):
        simulate(pendulum, 0.01, v0=np.zeros(5))
    v0 = np.zeros((1, 6))
    v0[0, 2] = np.nan
    with pytest.raises(ModelError, match=r"v0\[0, 2\] .* finite"):
        simulate(pendulum, 0.01, v0=v0)
    with pytest.raises(ModelError, match="t_end: expected a finite number"):
        simulate(pendulum, float("nan"))
    with pytest.raises(ModelError, match="model: expected a Model"):
        simulate("pendulum.yaml", 0.01)


def test_hold_and_kinematic_times_are_checked():
    from spatialmbd.kinematics import kinematic_analysis
    model, _ = load_model(ROOT / "examples" / "four_bar.yaml")
    with pytest.raises(ModelError, match="hold: expected a mapping"):
        simulate(model, 0.01, hold=["crank"])
    with pytest.raises(ModelError, match=r"hold\['crank'\]: unknown coordinate 'zz' \(did "
                                         r"you mean 'z'\?\)"):
        simulate(model, 0.01, hold={"crank": ["zz"]})
    with pytest.raises(ModelError, match="hold: unknown body 'crnk'"):
        simulate(model, 0.01, hold={"crnk": ["x"]})
    with pytest.raises(ModelError, match="t: expected output times"):
        kinematic_analysis(load_model(ROOT / "examples" / "slider_crank.yaml")[0], "abc")


# ============================================================================ limits, budgets
def test_output_sample_limit_is_checked_before_allocating(pendulum):
    start = time.process_time()
    with pytest.raises(ModelError, match=r"output_step 1e-15 s over 1 s asks for 1e\+15 output "
                                         r"samples \(about .* PB of memory\)"):
        simulate(pendulum, 1.0, output_step=1e-15)
    assert time.process_time() - start < 2
    with pytest.raises(ModelError, match="limit is 10"):
        simulate(pendulum, 1.0, output_step=0.01, budget=Budget(max_outputs=10))


def test_fixed_step_limit_gives_an_estimate_and_a_budget_allows_it(pendulum):
    with pytest.raises(ModelError, match=r"takes 1e\+0?9 steps, about .* of computing and .* of "
                                         r"memory for its outputs; the "
                                         r"limit without a step budget is"):
        simulate(pendulum, 100.0, integrator="rk4", step=1e-7, output_step=1.0)
    res = simulate(pendulum, 3.0, integrator="rk4", step=1e-7, output_step=1e-6,
                   max_steps=50)
    assert res.status == "budget" and "max_steps=50" in res.message
    # the 50th step ends the run: its outputs are kept, those of steps 0, 10, ..., 50 (every
    # 10th step is one; the integration driver samples an accepted step before the budget
    # check of its progress hook)
    assert res.counters["steps"] == 50 and len(res.t) == 6 and res.t[-1] == pytest.approx(5e-6)
    assert MAX_FIXED_STEPS < 1e9


def test_wall_time_budget_returns_partial_results(pendulum):
    res = simulate(pendulum, 1e3, integrator="rk4", step=1e-5, output_step=1e-2,
                   budget={"max_wall_time": 0.3})
    assert res.status == "budget" and "wall-time budget" in res.message
    assert 0 < len(res.t) < 100_001 and np.all(np.isfinite(res.q))
    assert res.wall_time < 3.0
    with pytest.raises(ModelError, match="did you mean 'max_steps'"):
        simulate(pendulum, 0.01, budget={"max_step": 3})


def _force_model(kind):
    """The pendulum with a user force that raises ``kind`` after t = 0.05 s."""
    from spatialmbd.io.modelfile import load_builder
    builder, analysis = load_builder(PENDULUM)

    def force(t, q, v):
        if t > 0.05:
            if kind == "interrupt":
                raise KeyboardInterrupt
            raise ValueError("On entry to DGESDD parameter number 5 had an illegal value")
        return np.zeros((1, 3)), np.zeros((1, 3))

    builder.add_force("user", "flaky", function=force)
    return builder.compile(), analysis


@pytest.mark.parametrize("kind, status", [("lapack", "failed"), ("interrupt", "interrupted")])
def test_any_exception_or_ctrl_c_mid_run_keeps_the_results(kind, status):
    model, _ = _force_model(kind)
    res = simulate(model, 0.2, output_step=0.01)
    assert res.status == status and 4 <= len(res.t) <= 6
    if kind == "lapack":
        assert "ValueError: On entry to DGESDD" in res.message
    assert np.all(np.isfinite(res.q))


def test_cli_writes_interrupted_runs_with_exit_130(tmp_path, monkeypatch, capsys):
    from spatialmbd import cli
    monkeypatch.setattr(cli.common, "load", lambda path: _force_model("interrupt"))
    out = tmp_path / "r.csv"
    assert cli.main(["run", str(PENDULUM), "-q", "-o", str(out)]) == 130
    assert out.read_text().startswith("# status: interrupted")
    df = read_results(out)
    assert df.attrs["status"] == "interrupted" and len(df) >= 2
    assert df["t"].iloc[-1] <= 0.05


def test_cli_budget_options(tmp_path, capsys):
    from spatialmbd import cli
    out = tmp_path / "r.h5"
    code = cli.main(["run", str(PENDULUM), "-q", "-o", str(out), "--integrator", "rk4",
                     "--step", "1e-4", "--max-steps", "30"])
    assert code == 1 and "step budget" in capsys.readouterr().err
    loaded = load_results(out)
    assert loaded.status == "budget" and len(loaded.t) >= 1


# ============================================================================ singular positions
def dead_centre_slider_crank(rate=1.0):
    """A planar slider-crank (crank 1 m, rod 2 m, revolute axes z) whose slider is pushed at
    ``rate`` m/s towards the dead centre x = 3 m, reached after (3 - x0) / rate s."""
    th = np.radians(60.0)
    A = np.array([np.cos(th), np.sin(th), 0.0])
    x0 = A[0] + np.sqrt(4.0 - A[1] ** 2)
    B = np.array([x0, 0.0, 0.0])
    ph = np.arctan2(-A[1], x0 - A[0])

    def rot(a):
        return [[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]]

    b = ModelBuilder("dead_centre", [0.0, 0.0, 0.0])
    b.add_body("crank", 1.0, [0.1, 0.1, 0.1], r=A / 2, A=rot(th))
    b.add_body("rod", 1.0, [0.1, 0.4, 0.4], r=(A + B) / 2, A=rot(ph))
    b.add_body("slider", 1.0, [0.1, 0.1, 0.1], r=B)
    b.add_joint("revolute", "O", "ground", "crank", point=[0, 0, 0], axis=[0, 0, 1])
    b.add_joint("revolute", "A", "crank", "rod", point=A.tolist(), axis=[0, 0, 1])
    b.add_joint("revolute", "B", "rod", "slider", point=B.tolist(), axis=[0, 0, 1])
    b.add_joint("translational", "S", "ground", "slider", point=B.tolist(), axis=[1, 0, 0])
    b.add_driver("translation", "push", {"type": "constant_velocity", "rate": rate,
                                         "initial": 0.0}, joint="S")
    return b.compile(), (3.0 - x0) / rate


def test_a_run_stopping_at_a_singular_position_is_diagnosed():
    model, t_dead = dead_centre_slider_crank()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(model, 1.0, output_step=0.01)
    assert res.status == "failed"
    assert abs(res.t[-1] - t_dead) < 0.011             # up to the last output before it
    msg = res.message
    assert "singular position near t = 0.6972" in msg
    assert "near rank deficiency 1" in msg
    assert "joint(s) A, B, O, push" in msg
    # the driver takes part in the dependency: it demands a motion the mechanism cannot make
    # there, so the way out is another driver or law, not another method
    assert "The driver(s) push take part in the dependency" in msg
    assert "drive another joint" in msg and "method='penalty'" not in msg


def test_a_failure_away_from_singular_positions_has_no_diagnosis():
    model, _ = _force_model("lapack")
    res = simulate(model, 0.2, output_step=0.01)
    assert res.status == "failed" and "singular" not in res.message


# ============================================================================ plausibility
def test_large_initial_correction_warns_with_the_amounts():
    model, _ = load_model(ROOT / "examples" / "four_bar.yaml")
    q0 = np.array(model.q0)
    q0[1, 1] += 0.6                                 # the coupler 0.6 m off its joints
    with pytest.warns(guards.PlausibilityWarning,
                      match=r"coupler moved 0\.[3-6]\d* m and turned .* rad") as record:
        res = simulate(model, 0.01, q0=q0)
    size = guards.model_size(model, model.q0)
    moved = np.linalg.norm(res.correction.dr[1])
    assert moved > guards.CORRECTION_WARN_FRACTION * size and f"{size:.3g} m" in \
        str(record[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error", guards.PlausibilityWarning)
        simulate(model, 0.01)                       # a consistent model does not warn


def test_wrong_units_warn():
    data = pendulum_dict()
    data["bodies"][0]["mass"] *= 1000.0             # grams given as kg
    data["bodies"][0]["inertia"] = [x * 1000.0 for x in data["bodies"][0]["inertia"]]
    model, _ = load_model(data)
    with pytest.warns(guards.PlausibilityWarning, match="density of .* check the units"):
        simulate(model, 0.01)
    data = pendulum_dict()
    data["bodies"][0]["inertia"] = [x * 1e6 for x in data["bodies"][0]["inertia"]]
    model, _ = load_model(data)
    assert any("radius of gyration" in w for w in guards.unit_warnings(model))
    assert guards.unit_warnings(load_model(PENDULUM)[0]) == []


def test_a_body_drawn_by_a_mesh_is_not_judged_by_its_marker_spheres():
    """An imported robot's foot: a mesh (no volume measured) beside four 5 mm marker spheres.
    The spheres alone would mean 1e5 kg/m^3; the check must not warn from a part of the body."""
    data = pendulum_dict()
    marker = {"type": "sphere", "radius": 0.005, "center": [0.0, 0.0, 0.0]}
    data["bodies"][0]["shapes"] = [marker]
    assert any("density" in w for w in guards.unit_warnings(load_model(data)[0]))
    data["bodies"][0]["shapes"] = [
        {"type": "mesh", "vertices": [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]],
         "faces": [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]}, marker]
    assert guards.unit_warnings(load_model(data)[0]) == []


# ============================================================================ results files
def test_partial_csv_carries_its_status_and_reads_back(tmp_path, pendulum):
    res = simulate(pendulum, 1.0, output_step=0.1, max_steps=5)
    assert res.status == "budget"
    path = write_csv(res, tmp_path / "r.csv")
    first = path.read_text().splitlines()[0]
    assert first.startswith("# status: budget; t = ")
    assert read_results(path).attrs["status"] == "budget"
    loaded = load_results(path)
    assert loaded.status == "budget" and "step budget" in loaded.message
    assert len(loaded.t) == len(res.t)
    ok = write_csv(simulate(pendulum, 0.05), tmp_path / "ok.csv")
    assert ok.read_text().startswith("t,") and load_results(ok).status == "success"


def test_stale_temporaries_of_a_killed_writer_are_removed(tmp_path, pendulum):
    target = tmp_path / "r.csv"
    # the temporary a writer killed mid-write leaves: .<name>.<pid of a dead process>.*.tmp
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    stale = tmp_path / f".r.csv.{dead}.k2j4.tmp"
    stale.write_text("half")
    live = tmp_path / f".r.csv.{os.getpid()}.x.tmp"          # a writer still running
    live.write_text("busy")
    other = tmp_path / ".other.csv.1.x.tmp"                   # another target's
    other.write_text("not ours")
    write_csv(simulate(pendulum, 0.05), target)
    assert not stale.exists() and live.exists() and other.exists() and target.exists()


def test_file_size_limit_while_writing_hdf5_keeps_the_previous_file(tmp_path, pendulum):
    source = tmp_path / "source.h5"
    results_io.write_hdf5(simulate(pendulum, 0.5, output_step=1e-3), source)
    target = tmp_path / "r.h5"
    target.write_text("previous")
    # HDF5's own writes crashed the process (SIGSEGV) at a file-size limit; now an OSError
    code = f"""
import resource, signal, sys
sys.path.insert(0, {SRC!r})
from spatialmbd.io.results_io import load_results, write_hdf5
res = load_results({str(source)!r})
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))
try:
    write_hdf5(res, {str(target)!r})
except OSError as exc:
    print("OSError:", exc)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert f"cannot write {target}: File too large (the previous file" in out.stdout
    assert target.read_text() == "previous"
    assert not list(tmp_path.glob(".r.h5.*"))


def test_ctrl_c_during_the_hdf5_write_is_honoured(tmp_path, pendulum, monkeypatch):
    res = simulate(pendulum, 1.0, output_step=1e-3)
    target = tmp_path / "r.h5"
    target.write_text("previous")
    monkeypatch.setattr(results_io.hdf5_file, "WRITE_BLOCK", 4096)
    real_open = open
    writes = []

    class Slow:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, data):
            writes.append(len(data))
            if len(writes) == 3:
                os.kill(os.getpid(), signal.SIGINT)      # Ctrl-C in the middle of the file
            return self.fh.write(data)

    def fake_open(path, mode="r", *args, **kwargs):
        fh = real_open(path, mode, *args, **kwargs)
        return Slow(fh) if mode == "wb" else fh

    monkeypatch.setattr(results_io.hdf5_file, "open", fake_open, raising=False)
    with pytest.raises(KeyboardInterrupt):
        results_io.write_hdf5(res, target)
    assert 3 <= len(writes) < 10
    assert target.read_text() == "previous" and not list(tmp_path.glob(".r.h5.*"))


def test_several_outputs_are_all_from_one_run(tmp_path, pendulum, monkeypatch):
    csv, h5 = tmp_path / "r.csv", tmp_path / "r.h5"
    first = save_all(simulate(pendulum, 0.05), [csv, h5])
    assert set(first) == {csv, h5}
    before = csv.read_bytes(), h5.read_bytes()

    def broken(self):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(results_io._H5Sink, "close", broken)
    with pytest.raises(OSError, match=r"cannot write .*r\.h5: No space left on device \(the "
                                      "previous files are kept\\)"):
        save_all(simulate(pendulum, 0.1), [csv, h5])
    assert (csv.read_bytes(), h5.read_bytes()) == before     # neither file was replaced
    assert not list(tmp_path.glob(".*.tmp"))
    monkeypatch.undo()
    save_all(simulate(pendulum, 0.1), [csv, h5])
    import h5py
    with h5py.File(h5) as f:
        assert len(f.attrs["run_id"]) == 32
        assert json.loads(f.attrs["outputs"]) == [str(csv), str(h5)]


def test_chunked_table_equals_the_whole_table(tmp_path, monkeypatch):
    model, _ = load_model(ROOT / "examples" / "double_pendulum.yaml")
    res = simulate(model, 0.5, output_step=0.004)
    whole = results_io.to_dataframe(res)
    monkeypatch.setattr(results_io.table, "_chunk_rows", lambda results: 30)
    parts = list(results_io.iter_table(res))
    assert len(parts) == 5 and len(res.t) == 126
    chunked = pd.concat(parts, ignore_index=True)
    pd.testing.assert_frame_equal(chunked, whole, rtol=0, atol=1e-12)
    results_io.write_hdf5(res, tmp_path / "r.h5")
    pd.testing.assert_frame_equal(read_results(tmp_path / "r.h5"), whole, rtol=0,
                                  atol=1e-12)
    write_csv(res, tmp_path / "r.csv")
    pd.testing.assert_frame_equal(read_results(tmp_path / "r.csv"), whole, rtol=1e-15,
                                  check_dtype=False)


def test_the_worked_example_of_docs_reliability_runs(tmp_path, monkeypatch, capsys):
    import re
    text = (ROOT / "docs" / "reliability.md").read_text()
    code = re.findall(r"```python\n(.*?)```", text, flags=re.S)[0]   # the first example
    monkeypatch.chdir(tmp_path)
    code = code.replace('"examples/', f'"{ROOT}/examples/')
    namespace = {}
    exec(compile(code, "docs/reliability.md", "exec"), namespace)
    out = capsys.readouterr().out
    assert "takes 1e+09 steps" in out and "did you mean 'alpha'" in out
    assert namespace["res"].status == "budget"
    assert (tmp_path / "run.csv").read_text().startswith("# status: budget")


def test_output_times_before_the_start_are_a_model_error():
    """Found by the long API fuzz run: t_eval starting before t0 reached the integrator's
    ValueError."""
    model = models.pendulum_ch15().compile()
    with pytest.raises(ModelError, match="before the start time t0"):
        simulate(model, 0.001, t0=0.02, t_eval=[0.0, 0.01])


@pytest.mark.parametrize("t_end, step, n", [(0.03, 1e-4, 301), (1.0, 0.1, 11), (10.0, 0.02, 501),
                                            (1.05, 0.1, 12), (1.0, 0.3, 5), (0.3, 0.1, 4)])
def test_the_output_grid_ends_exactly_on_t_end(t_end, step, n):
    """300 x 1e-4 is 0.030000000000000002 in floating point: the grid's last time is t_end
    itself (the run ends where it was asked to, and res.t[-1] == t_end), and a remainder
    shorter than the step gets its own output."""
    from spatialmbd.simulate import output_times
    t = output_times(t_end, step, None)
    assert t.size == n and t[-1] == t_end and np.all(np.diff(t) > 0)
    assert np.allclose(np.diff(t)[:-1], step, rtol=1e-12, atol=0)
