"""Results files: CSV table, self-describing HDF5, atomic writing (spatialmbd.io.results_io)."""
from __future__ import annotations

import json
import os

import h5py
import numpy as np
import pandas as pd
import pytest

import spatialmbd
from spatialmbd import models
from spatialmbd.io import results_io
from spatialmbd.io.results_io import (FORMAT_NAME, load_results, read_results, save_results,
                                      to_dataframe)
from spatialmbd.kinematics import kinematic_analysis, point_kinematics
from spatialmbd.simulate import simulate


@pytest.fixture(scope="module")
def pendulum_results():
    model = models.pendulum_ch15().compile()
    return simulate(model, 0.5, output_step=0.05, rtol=1e-8, atol=1e-10)


@pytest.fixture(scope="module")
def crank_results():
    model = models.slider_crank(driven=True).compile()
    return kinematic_analysis(model, np.linspace(0.0, 0.5, 26))


def _listing(directory):
    return sorted(p.name for p in directory.iterdir())


# ---------------------------------------------------------------------------------- tables
def test_dynamic_table_columns(pendulum_results):
    r = pendulum_results
    df = to_dataframe(r)
    assert len(df) == len(r.t)
    assert df.columns[0] == "t"
    for c in ("pendulum.x", "pendulum.z", "pendulum.e0", "pendulum.e3", "pendulum.wx",
              "pendulum.alphax", "pendulum.tip.z", "pendulum.tip.vz", "pendulum.tip.az",
              "pivot.ground.fz", "pivot.pendulum.fz", "pivot.pendulum.mx",
              "violation.position", "violation.velocity", "violation.phi_squared",
              "energy.total", "energy.error"):
        assert c in df.columns, c
    assert len(set(df.columns)) == len(df.columns)
    np.testing.assert_allclose(df["pendulum.z"], r.q[:, 0, 2])
    # the tip is 0.5 m from the centre of mass along body y
    tip = r.point("pendulum.tip")
    np.testing.assert_allclose(df["pendulum.tip.z"], tip["r"][:, 2], atol=1e-12)
    np.testing.assert_allclose(df["pendulum.tip.vz"], tip["rdot"][:, 2], atol=1e-12)
    # point acceleration against the kinematic-analysis formula, state by state
    body, local = r.model.points["pendulum.tip"]
    for k, state in enumerate(r.states()):
        _, _, rdd = point_kinematics(state, r.vdot[k], body, local)
        np.testing.assert_allclose(df.loc[k, ["pendulum.tip.ax", "pendulum.tip.ay",
                                              "pendulum.tip.az"]].to_numpy(float), rdd,
                                   atol=1e-12)
    np.testing.assert_allclose(df["violation.phi_squared"], df["violation.position"] ** 2)
    # at rest at t = 0: the pivot carries the weight (reaction on the pendulum, +z)
    assert df["pivot.pendulum.fz"].iloc[0] > 0


def test_kinematic_table(crank_results):
    r = crank_results
    df = to_dataframe(r)
    assert len(df) == len(r.t)
    for c in ("t", "crank.x", "slider.x", "slider.vx", "slider.ax", "crank.B.x", "crank.B.vz",
              "crank.B.az", "violation.position", "violation.velocity", "newton.iterations"):
        assert c in df.columns, c
    x, xd, xdd = models.slider_crank_exact(6.0 * r.t)
    np.testing.assert_allclose(df["slider.x"], x, atol=1e-8)
    np.testing.assert_allclose(df["slider.vx"], xd, atol=1e-7)
    np.testing.assert_allclose(df["slider.ax"], xdd, atol=1e-6)
    assert df["violation.position"].max() < 1e-8


def test_csv_round_trip(tmp_path, pendulum_results):
    path = save_results(pendulum_results, tmp_path / "p.csv")
    assert path.exists()
    back = pd.read_csv(path)
    df = to_dataframe(pendulum_results)
    assert list(back.columns) == list(df.columns)
    np.testing.assert_allclose(back.to_numpy(), df.to_numpy(), rtol=1e-15, atol=0)
    pd.testing.assert_frame_equal(read_results(path), back)
    assert _listing(tmp_path) == ["p.csv"]


# ---------------------------------------------------------------------------------- HDF5
def test_hdf5_round_trip(tmp_path, pendulum_results):
    r = pendulum_results
    analysis = {"type": "dynamic", "t_end": 0.5, "output_step": 0.05}
    path = save_results(r, tmp_path / "p.h5", analysis=analysis)
    loaded = load_results(path)
    assert loaded.kind == "dynamic"
    for key in ("t", "q", "v", "vdot", "lam", "work"):
        np.testing.assert_array_equal(getattr(loaded, key), getattr(r, key))
    assert loaded.status == r.status == "success"
    assert loaded.message == r.message
    assert loaded.version == spatialmbd.__version__
    assert loaded.counters == json.loads(json.dumps(r.counters))
    assert loaded.settings["method"] == r.settings["method"]
    assert loaded.settings["integrator"] == r.settings["integrator"]
    assert loaded.settings["integrator_options"]["rtol"] == pytest.approx(1e-8)
    assert loaded.wall_time == pytest.approx(r.wall_time)
    assert loaded.body_names == ["pendulum"]
    assert loaded.metadata["correction"]["summary"].startswith("initial conditions")
    assert loaded.analysis == analysis
    scene = loaded.scene
    assert scene["bodies"][0]["name"] == "pendulum"
    assert scene["bodies"][0]["shapes"][0]["type"] == "cylinder"
    df = to_dataframe(r)
    pd.testing.assert_frame_equal(read_results(path), df)
    pd.testing.assert_frame_equal(loaded.to_dataframe(), df)
    with h5py.File(path, "r") as f:                    # the documented plain-h5py access
        assert f.attrs["format"] == FORMAT_NAME
        assert f.attrs["spatialmbd_version"] == spatialmbd.__version__
        assert f.attrs["status"] == "success"
        cols = json.loads(f["table"].attrs["columns"])
        plain = pd.DataFrame({c: f["table"][c][()] for c in cols})
    pd.testing.assert_frame_equal(plain, df)
    assert _listing(tmp_path) == ["p.h5"]


def test_hdf5_stores_the_model_file_dict(tmp_path, pendulum_results):
    modelfile = pytest.importorskip("spatialmbd.io.modelfile")
    path = save_results(pendulum_results, tmp_path / "p.h5")
    loaded = load_results(path)
    stored = loaded.model_dict
    assert stored, loaded.metadata.get("model_note")
    expected = json.loads(json.dumps(modelfile.model_to_dict(pendulum_results.model),
                                     cls=results_io._Encoder))
    for key in expected:
        if key != "analysis":
            assert stored[key] == expected[key], key
    model, _ = loaded.load_model()
    assert model.body_names == pendulum_results.model.body_names
    np.testing.assert_allclose(model.mass, pendulum_results.model.mass)
    np.testing.assert_allclose(model.q0, pendulum_results.model.q0, atol=1e-12)


def test_hdf5_kinematic_round_trip(tmp_path, crank_results):
    path = save_results(crank_results, tmp_path / "k.hdf5")
    loaded = load_results(path)
    assert loaded.kind == "kinematic"
    np.testing.assert_array_equal(loaded.q, crank_results.q)
    np.testing.assert_array_equal(loaded.newton_iterations, crank_results.newton_iterations)
    assert loaded.counters["outputs"] == len(crank_results.t)
    assert [b["name"] for b in loaded.scene["bodies"]] == ["crank", "rod", "slider"]
    pd.testing.assert_frame_equal(loaded.table, to_dataframe(crank_results))


def test_load_results_from_csv_rebuilds_arrays(tmp_path, pendulum_results):
    path = save_results(pendulum_results, tmp_path / "p.csv")
    loaded = load_results(path)
    assert loaded.body_names == ["pendulum"]
    np.testing.assert_allclose(loaded.q, pendulum_results.q, rtol=1e-15)
    np.testing.assert_allclose(loaded.vdot, pendulum_results.vdot, rtol=1e-15)


def test_bad_files(tmp_path, pendulum_results):
    with pytest.raises(ValueError, match="csv or .h5"):
        save_results(pendulum_results, tmp_path / "p.txt")
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(ValueError, match="not a spatialmbd results file"):
        load_results(other)
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(ValueError, match="HDF5"):
        read_results(tmp_path / "junk.h5")
    with pytest.raises(FileNotFoundError):
        load_results(tmp_path / "missing.h5")
    with pytest.raises(FileNotFoundError):
        save_results(pendulum_results, tmp_path / "no_dir" / "p.csv")


# ---------------------------------------------------------------------------------- atomicity
class Boom(Exception):
    pass


@pytest.mark.parametrize("exc", [Boom, KeyboardInterrupt])
def test_interrupted_csv_leaves_nothing(tmp_path, monkeypatch, pendulum_results, exc):
    table = to_dataframe(pendulum_results)
    real = pd.DataFrame.to_csv

    def half_then_fail(self, path, *a, **k):
        real(self.iloc[:3], path, *a, **k)              # part of the file is on disk
        raise exc("crash while writing")

    monkeypatch.setattr(pd.DataFrame, "to_csv", half_then_fail)
    with pytest.raises(exc):
        save_results(pendulum_results, tmp_path / "p.csv", table=table)
    assert _listing(tmp_path) == []                     # no target, no temporary file


def test_interrupted_write_keeps_old_file(tmp_path, monkeypatch, pendulum_results):
    target = tmp_path / "p.h5"
    save_results(pendulum_results, target)
    before = target.read_bytes()
    calls = []

    def fail_later(group, name, arr):
        calls.append(name)
        if len(calls) > 3:
            raise Boom("disk full")
        group.create_dataset(name, data=arr)

    monkeypatch.setattr(results_io.hdf5_file, "_dataset", fail_later)
    with pytest.raises(Boom):
        save_results(pendulum_results, target)
    assert target.read_bytes() == before
    assert _listing(tmp_path) == ["p.h5"]
    monkeypatch.undo()
    assert len(load_results(target).t) == len(pendulum_results.t)


def test_atomic_write_replaces_and_keeps_permissions(tmp_path):
    target = tmp_path / "x.txt"
    target.write_text("old")
    os.chmod(target, 0o640)
    with results_io.atomic_write(target) as tmp:
        assert tmp.parent == tmp_path and tmp != target
        tmp.write_text("new")
        assert target.read_text() == "old"
    assert target.read_text() == "new"
    assert (target.stat().st_mode & 0o777) == 0o640
    assert _listing(tmp_path) == ["x.txt"]


def test_partial_results_of_a_failed_run_are_written(tmp_path):
    b = models.pendulum_ch15()

    def nan_after(t, q, v):
        f = np.zeros((1, 3))
        if t > 0.1:
            f[:] = np.nan
        return f, np.zeros((1, 3))

    b.add_force("user", "bad", function=nan_after)
    r = simulate(b.compile(), 0.5, output_step=0.02)
    assert r.status == "failed"
    assert 0.05 < r.t[-1] <= 0.12
    path = save_results(r, tmp_path / "fail.h5")
    loaded = load_results(path)
    assert loaded.status == "failed" and loaded.message == r.message != ""
    assert len(loaded.t) == len(r.t)
    assert "model not stored" in loaded.metadata["model_note"] or loaded.model_dict
