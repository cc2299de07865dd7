"""Parameter sweeps (spatialmbd.sweep): spaces and paths, outputs, schedulers (serial, process
pool, a real Dask LocalCluster), failing members, the batch engine, sensitivities, the CLI."""
from pathlib import Path

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.models import slider_crank
from spatialmbd.sweep import (QUIET_WORKERS, forward_sensitivities, get_path, grid,
                              latin_hypercube, local_cluster, parse_range, peak, period,
                              points, save_result, sensitivities, set_path, sweep, to_dataframe,
                              trough)

xr = pytest.importorskip("xarray")

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PENDULUM = EXAMPLES / "pendulum_ch15.yaml"

# compound pendulum of chapter 15: 1 m solid cylinder, pivot at one end (ERRATA reading)
MASS, I_CM, D, G = 7.02, 0.5855265, 0.5, 9.81


def pendulum_at(amplitude_deg):
    """The chapter-15 pendulum released at rest amplitude_deg from the downward vertical
    (revolute axis x at the origin, centre of mass D below the pivot when hanging)."""
    th = np.radians(amplitude_deg)
    a = th - np.pi / 2                        # rotation about x taking body y to the rod line
    A = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("rod", mass=MASS, inertia=(I_CM, 0.001053, I_CM),
               r=D * np.array([0.0, np.sin(th), -np.cos(th)]), A=A)
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    return b.compile()


# ------------------------------------------------------------------------------ spaces, paths
def test_grid_points_and_latin_hypercube():
    g = grid({"a": [1, 2], "b": "0:1:3"})
    assert g.values.tolist() == [[1, 0], [1, 0.5], [1, 1], [2, 0], [2, 0.5], [2, 1]]
    assert [a.tolist() for a in g.axes] == [[1, 2], [0, 0.5, 1]]
    p = points({"a": [1, 2, 3], "b": [4, 5, 6]})
    assert p.values.tolist() == [[1, 4], [2, 5], [3, 6]]
    assert points([{"a": 1, "b": 2}, {"b": 3, "a": 4}]).values.tolist() == [[1, 2], [4, 3]]
    with pytest.raises(ModelError, match="same number"):
        points({"a": [1, 2], "b": [1]})
    lhs = latin_hypercube({"m": (1.0, 3.0), "k": (10.0, 20.0)}, 50, seed=3)
    for j, (lo, hi) in enumerate(((1.0, 3.0), (10.0, 20.0))):
        strata = np.floor((lhs.values[:, j] - lo) / (hi - lo) * 50).astype(int)
        assert sorted(strata.tolist()) == list(range(50))      # one sample per stratum
    assert np.array_equal(lhs.values, latin_hypercube({"m": (1.0, 3.0), "k": (10.0, 20.0)},
                                                      50, seed=3).values)
    assert np.allclose(parse_range("1:100:3:log"), [1, 10, 100])
    with pytest.raises(ModelError, match="start:stop:count"):
        parse_range("1:2", "x")


def test_paths_by_name_index_and_errors():
    data = {"bodies": [{"name": "a", "mass": 1.0, "inertia": [1, 2, 3]},
                       {"name": "b", "mass": 2.0}], "gravity": [0, 0, -9.81],
            "analysis": {"integrator": {"name": "rk45"}}}
    set_path(data, "bodies.b.mass", 5.0)
    set_path(data, "bodies.a.inertia.1", 7.0)
    set_path(data, "bodies.b.angular_velocity.2", 3.0)       # missing vector starts at zero
    set_path(data, "analysis.integrator.rtol", 1e-8)
    assert data["bodies"][1]["mass"] == 5.0 and data["bodies"][0]["inertia"] == [1, 7.0, 3]
    assert data["bodies"][1]["angular_velocity"] == [0.0, 0.0, 3.0]
    assert get_path(data, "analysis.integrator.rtol") == 1e-8
    with pytest.raises(ModelError, match="no item named 'c'; names here: a, b"):
        set_path(data, "bodies.c.mass", 1.0)
    with pytest.raises(ModelError, match="index 5 is out of range"):
        set_path(data, "gravity.5", 1.0)
    with pytest.raises(ModelError, match=r"give one component with an index, e.g. gravity.0"):
        set_path(data, "gravity", 1.0)
    with pytest.raises(ModelError, match="no item named 'nope'"):
        sweep(PENDULUM, {"bodies.nope.mass": [1, 2]}, ["max(pendulum.z)"])


def test_period_of_sampled_sine_and_output_errors():
    t = np.linspace(0.0, 10.0, 401)
    assert period(t, np.sin(2 * np.pi * t / 2.7 + 0.3)) == pytest.approx(2.7, rel=1e-7)
    assert np.isnan(period(t, np.ones_like(t)))
    with pytest.raises(ModelError, match="unknown reduction 'median'"):
        sweep(PENDULUM, {"bodies.pendulum.mass": [1]}, ["median(pendulum.z)"])


def test_peak_and_trough_between_the_samples():
    """peak / trough: the extreme sample refined by the local cubic, O(dt^4) against the
    samples' O(dt^2); never inside the samples' range; a monotonic signal's end sample."""
    errors = []
    for dt in (0.1, 0.05, 0.025):
        t = np.arange(0.0, 3.0, dt)
        x = 2.0 * np.sin(2.0 * t + 0.3) + 0.5
        assert peak(t, x) >= x.max() and trough(t, x) <= x.min()
        errors.append((abs(peak(t, x) - 2.5), abs(trough(t, x) + 1.5), 2.5 - x.max()))
    e = np.array(errors)
    assert np.all(e[:, :2] < 2e-2 * e[:, 2:])                  # far inside the sample error
    assert np.all(e[:-1, 0] / e[1:, 0] > 10)                   # ~ 16 per halving: 4th order
    t = np.linspace(0.0, 1.0, 11)
    assert peak(t, t ** 3 + t) == 2.0 and trough(t, t ** 3 + t) == 0.0   # the end samples
    assert trough(t, t ** 2) == pytest.approx(0.0, abs=1e-15)          # x' = 0 at the end
    assert peak(t[:2], t[:2]) == 0.1                                   # two samples
    # a parabola is reproduced exactly, its vertex between two samples
    assert peak(t, 1.0 - (t - 0.537) ** 2) == pytest.approx(1.0, abs=1e-14)
    # a sampled step: the documented overshoot (6 % of the jump), above the samples
    step = np.where(t < 0.45, -5.0, 4.0)
    assert 4.0 < peak(t, step) < 4.0 + 0.07 * 9.0


# ------------------------------------------------------------------------------ physics
def test_pendulum_period_against_elliptic_integral():
    """T = 4 sqrt(L_eq / g) K(k), k = sin(theta0 / 2), L_eq = I_pivot / (m d): the exact period
    of the compound pendulum, against the zero crossings of omega_x of the batch engine."""
    from scipy.special import ellipk
    amplitudes = [10.0, 60.0, 120.0, 170.0]
    analysis = dict(type="dynamic", t_end=10.5, output_step=0.01,
                    integrator=dict(name="rk45", rtol=1e-10, atol=1e-12))
    ds = sweep(pendulum_at, {"amplitude_deg": amplitudes}, ["period(rod.wx)"], analysis,
               engine="batch")
    assert (ds["status"] == "success").all()
    L_eq = (I_CM + MASS * D**2) / (MASS * D)
    k = np.sin(np.radians(amplitudes) / 2)
    exact = 4 * np.sqrt(L_eq / G) * ellipk(k**2)              # scipy's ellipk takes m = k^2
    assert np.allclose(ds["period(rod.wx)"].values, exact, rtol=1e-8, atol=0)
    # the small-amplitude limit and the growth with amplitude are there
    assert exact[0] == pytest.approx(2 * np.pi * np.sqrt(L_eq / G), rel=2e-3)
    assert np.all(np.diff(ds["period(rod.wx)"].values) > 0)


# ------------------------------------------------------------------------------ schedulers
def test_schedulers_give_identical_ordered_results_and_failures_are_recorded():
    pytest.importorskip("distributed")
    params = points({"bodies.pendulum.mass": [1.0, 2.0, -1.0, 4.0, 5.0, 0.0],
                     "analysis.t_end": [0.6, 0.5, 0.5, 0.4, 0.7, 0.5]})
    outs = ["min(pendulum.wx)", "final(pendulum.z)", "pivot.pendulum.fz"]
    kw = dict(chunk_size=2, progress=False)
    serial = sweep(PENDULUM, params, outs, scheduler="serial", **kw)
    procs = sweep(PENDULUM, params, outs, scheduler="processes", workers=2, **kw)
    import dask as dask_
    with local_cluster(2) as client:
        dask = sweep(PENDULUM, params, outs, scheduler=client, **kw)
        # the workers run with the compute-bound settings (no profiler sampling the task)
        conf = client.run(lambda: [dask_.config.get(k) for k in QUIET_WORKERS])
        assert list(conf.values()) == [list(QUIET_WORKERS.values())] * 2
    assert client.status == "closed"
    status = serial["status"].values.tolist()
    assert status == ["success", "success", "failed", "success", "success", "failed"]
    assert "bodies[0].mass: must be positive" in str(serial["message"].values[2])
    assert np.all(np.isnan(serial["min(pendulum.wx)"].values[[2, 5]]))
    assert np.all(np.isfinite(serial["min(pendulum.wx)"].values[[0, 1, 3, 4]]))
    for other in (procs, dask):
        assert other["status"].values.tolist() == status
        assert other["message"].values.tolist() == serial["message"].values.tolist()
        for o in outs:
            assert np.array_equal(other[o].values, serial[o].values, equal_nan=True)
    assert len(set(serial["min(pendulum.wx)"].values[[0, 1, 3, 4]].tolist())) == 4
    assert dask.attrs["scheduler"] == "dask" and procs.attrs["scheduler"] == "processes"


# ------------------------------------------------------------------------------ batch engine
@pytest.mark.parametrize("integrator,method", [("rk45", "standard"), ("rk4", "standard"),
                                               ("rk45", "projection"), ("rk4", "projection"),
                                               ("dop853", "projection")])
def test_batch_equals_separate_runs_slider_crank(integrator, method):
    from spatialmbd.io import Analysis
    from spatialmbd.sweep.batch import simulate_batch
    base = slider_crank(driven=False)
    models = []
    for mass, speed in ((0.5, 6.0), (0.8, 4.0), (1.2, 7.0)):
        b = slider_crank(driven=False, crank_speed=speed)
        b.bodies["rod"].mass = mass
        models.append(b.compile())
    an = Analysis(t_end=0.3, output_step=0.01, integrator=integrator, method=method,
                  rtol=1e-8 if integrator != "rk4" else None,
                  atol=1e-10 if integrator != "rk4" else None,
                  step=2e-3 if integrator == "rk4" else None)
    out = simulate_batch(models, an)
    for model, member in zip(models, out):
        ref = an.run(model)
        assert member.status == "success"
        np.testing.assert_allclose(member.q, ref.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(member.v, ref.v, rtol=0, atol=1e-10)
        np.testing.assert_allclose(member.lam, ref.lam, rtol=1e-9, atol=1e-9)
        if integrator != "rk4":
            assert member.counters["steps"] == ref.counters["steps"]
            assert member.counters["nfev"] == ref.counters["nfev"]
    assert not np.allclose(out[0].q, out[1].q)
    other = ModelBuilder("x")
    other.add_body("a", 1.0, (1, 1, 1))
    with pytest.raises(ModelError, match="differs in topology"):
        simulate_batch([models[0], other.compile()], an)
    with pytest.raises(ModelError, match="drivers"):
        simulate_batch([base.compile() if False else slider_crank(driven=True).compile()], an)


def _batch_equals_simulate(model, params, outs, analysis, distinct, rtol):
    """Every member succeeds, the members differ (``distinct`` values of the first output)
    and the batch engine's outputs equal the simulate engine's."""
    a = sweep(model, params, outs, analysis, engine="simulate")
    b = sweep(model, params, outs, analysis, engine="batch")
    assert (b["status"] == "success").all()
    assert len(set(np.round(b[outs[0]].values.ravel(), 9))) == distinct
    for o in outs:
        np.testing.assert_allclose(b[o].values, a[o].values, rtol=rtol, atol=1e-12)


def test_batch_engine_in_a_sweep_matches_simulate_and_records_failures():
    params = {"bodies.pendulum.mass": [2.0, -3.0, 7.0]}
    analysis = dict(type="dynamic", t_end=1.0, output_step=0.05, method="projection",
                    integrator=dict(name="rk45", rtol=1e-9, atol=1e-11))
    outs = ["min(pendulum.z)", "final(pendulum.wx)", "pivot.pendulum.fz"]
    a = sweep(PENDULUM, params, outs, analysis, engine="simulate")
    b = sweep(PENDULUM, params, outs, analysis, engine="batch")
    assert a["status"].values.tolist() == b["status"].values.tolist() == \
        ["success", "failed", "success"]
    for o in outs:
        np.testing.assert_allclose(b[o].values, a[o].values, rtol=1e-12, atol=1e-12)
    # joint geometry (the packed frames of the revolute) and initial velocities reach the batch
    geo = {"joints.pivot.axis.1": [0.0, 0.2], "bodies.pendulum.angular_velocity.0": [0.0, 1.5]}
    _batch_equals_simulate(PENDULUM, geo, outs, analysis, distinct=4, rtol=1e-12)
    # compiled force elements: their parameters are packed per member
    springs = {"forces.spring_A.stiffness": [1e5, 4e5], "forces.spring_B.damping": [2e4, 5e4]}
    fly_an = dict(type="dynamic", t_end=0.02, output_step=0.005, method="projection",
                  integrator=dict(name="rk45", rtol=1e-8, atol=1e-10))
    _batch_equals_simulate(EXAMPLES / "flyball_governor.yaml", springs,
                           ["final(slider.z)", "min(rod_A.wz)", "final(rod_A.tip.x)"], fly_an,
                           distinct=4, rtol=1e-10)
    # what the batch cannot integrate is a failed member naming it, not an exception
    ball = EXAMPLES / "bouncing_ball.yaml"
    c = sweep(ball, {"bodies.ball.mass": [1.0]}, ["min(ball.z)"],
              dict(type="dynamic", t_end=0.01), engine="batch")
    assert c["status"].values[0] == "failed" and "contact" in str(c["message"].values[0])


def test_a_builder_sweeps_and_the_batch_rolls_the_bicycle():
    """A ModelBuilder (what spatialmbd.models gives) is a sweep's model like a Model; the
    batch engine integrates a model with rolling (nonholonomic) joints, member for member as
    simulate does: the benchmark bicycle pushed sideways, rider mass varied."""
    from spatialmbd.models import whipple_bicycle
    builder = whipple_bicycle(4.6, 0.5)
    params = {"bodies.rear_frame.mass": [80.0, 90.0]}
    analysis = dict(type="dynamic", t_end=0.5, output_step=0.05, method="projection",
                    integrator=dict(name="rk45", rtol=1e-8, atol=1e-10))
    outs = ["max(rear_frame.wz)", "final(rear_frame.y)"]
    a = sweep(builder, params, outs, analysis, engine="simulate")
    b = sweep(builder, params, outs, analysis, engine="batch")
    assert list(a["status"].values) == list(b["status"].values) == ["success"] * 2
    for o in outs:
        np.testing.assert_allclose(b[o].values, a[o].values, rtol=1e-11, atol=1e-13)
    assert a["final(rear_frame.y)"].values[0] != a["final(rear_frame.y)"].values[1]


def test_batch_recursive_and_direct_members_equal_separate_runs(monkeypatch):
    """With method "auto" the batch integrates the pendulum (a tree) in joint coordinates,
    as simulate() does; members differing only in masses, inertias, gravity or initial
    velocities are written into the packs without building their models (one build plus one
    probe per parameter); invalid values still fail with the build's message."""
    from spatialmbd.sweep import batch
    from spatialmbd.sweep.core import SweepJob
    builds = []
    real_build = SweepJob.build
    monkeypatch.setattr(SweepJob, "build", lambda self, m: builds.append(m) or
                        real_build(self, m))
    analysis = dict(type="dynamic", t_end=1.0, output_step=0.05, method="auto",
                    integrator=dict(name="rk45", rtol=1e-8, atol=1e-10))
    outs = ["min(pendulum.z)", "final(pendulum.wx)", "pivot.pendulum.fz",
            "max(energy.kinetic)"]
    direct = {"bodies.pendulum.mass": [2.0, 5.0, 7.0], "gravity.2": [-9.81, -5.0],
              "bodies.pendulum.inertia.1": [0.001, 0.002]}
    a = sweep(PENDULUM, direct, outs, analysis, engine="simulate")
    builds.clear()
    b = sweep(PENDULUM, direct, outs, analysis, engine="batch", chunk_size=12)
    assert len(builds) == 1 + 3                  # the prototype and one probe per parameter
    assert (b["status"] == "success").all()
    for o in outs:
        np.testing.assert_allclose(b[o].values, a[o].values, rtol=1e-12, atol=1e-12)
    # (the moment about the rod's own axis, inertia.1, does not change the swing)
    assert len(set(np.round(b[outs[1]].values.ravel(), 9))) == 6
    # the joint coordinates: the batch member is the recursive run of simulate()
    model0, an0 = real_build(_job(direct, analysis), {n: v[0] for n, v in direct.items()})
    assert batch.BatchSetup(model0, an0.method, an0.method_options, an0.integrator).recursive
    # an initial velocity is direct too (its member's state is corrected, as simulate does)
    spin = {"bodies.pendulum.angular_velocity.0": [0.0, 1.0, 2.5]}
    a = sweep(PENDULUM, spin, outs, analysis, engine="simulate")
    builds.clear()
    b = sweep(PENDULUM, spin, outs, analysis, engine="batch", chunk_size=3)
    assert len(builds) == 2 and (b["status"] == "success").all()
    for o in outs:
        np.testing.assert_allclose(b[o].values, a[o].values, rtol=1e-12, atol=1e-12)
    # invalid values are built, so the member fails with the build's own message
    bad = sweep(PENDULUM, {"bodies.pendulum.mass": [2.0, -3.0, 7.0, 1e30]}, outs, analysis,
                engine="batch")
    assert bad["status"].values.tolist() == ["success", "failed", "success", "failed"]
    assert "must be positive" in str(bad["message"].values[1])
    assert "out of range" in str(bad["message"].values[3])
    # a joint axis is not a direct value: every member is built (and still recursive)
    builds.clear()
    geo = {"joints.pivot.axis.1": [0.0, 0.1, 0.2]}
    _batch_equals_simulate(PENDULUM, geo, outs, analysis, distinct=3, rtol=1e-12)
    # the DOP853 pair runs in the recursive batch too
    dop = dict(analysis, integrator=dict(name="dop853", rtol=1e-10, atol=1e-12))
    _batch_equals_simulate(PENDULUM, spin, outs, dop, distinct=3, rtol=1e-12)


def _job(params, analysis):
    from spatialmbd.sweep.core import _make_job
    from spatialmbd.sweep.outputs import parse_outputs
    from spatialmbd.sweep.params import as_space
    return _make_job(PENDULUM, as_space(params), parse_outputs(["final(pendulum.z)"]),
                     analysis, "batch", {})


# ------------------------------------------------------------------------------ results
def test_result_formats_dataframe_and_files(tmp_path):
    ds = sweep(PENDULUM, {"bodies.pendulum.mass": [1.0, 2.0], "analysis.t_end": [0.2, 0.3]},
               {"zmin": "min(pendulum.z)", "z": "pendulum.z"}, progress=False)
    assert ds["zmin"].dims == ("bodies.pendulum.mass", "analysis.t_end")
    assert ds["z"].dims == ("bodies.pendulum.mass", "analysis.t_end", "time")
    # the shorter runs are padded with NaN after their end time
    assert np.isnan(ds["z"].sel({"analysis.t_end": 0.2}).values[:, -1]).all()
    df = to_dataframe(ds)
    assert set(["bodies.pendulum.mass", "analysis.t_end", "zmin", "status", "time", "z"]) \
        <= set(df.columns)
    flat = sweep(PENDULUM, {"bodies.pendulum.mass": [1.0, 2.0]}, ["min(pendulum.z)"],
                 format="dataframe", analysis=dict(type="dynamic", t_end=0.2))
    assert len(flat) == 2 and flat["status"].tolist() == ["success", "success"]
    for name in ("s.nc", "s.csv"):
        save_result(ds, tmp_path / name)
    back = xr.open_dataset(tmp_path / "s.nc")
    assert np.array_equal(back["zmin"].values, ds["zmin"].values)
    with pytest.raises(ModelError, match=".nc, .csv or .parquet"):
        save_result(ds, tmp_path / "s.txt")


# ------------------------------------------------------------------------------ sensitivities
def test_sensitivities_finite_differences_against_forward():
    analysis = dict(type="dynamic", t_end=3.2, output_step=0.02, method=dict(name="standard"),
                    integrator=dict(name="rk4", step=4e-3))
    params = {"bodies.pendulum.mass": None, "bodies.pendulum.inertia.0": None}
    outs = ["final(pendulum.z)", "max(pendulum.wx)", "period(pendulum.wx)",
            "mean(pendulum.y)", "trough(pendulum.wx)", "rms(pendulum.vy)"]
    fd = sensitivities(PENDULUM, params, outs, analysis, engine="batch")
    fw = forward_sensitivities(PENDULUM, params, outs, analysis)
    assert (fd["status"] == "success").all()
    # a thin rod: I_xx must stay within I_zz -+ I_yy; the 1 % steps leave that range and fail,
    # the smaller steps are used
    assert "triangle inequality" in str(fd["message"].values[1]) and fd.attrs["n_failed"] == 6
    assert np.all(fd["step"].values[:, 1] < 1e-2 * 0.5855265)
    assert fd["value"].values.tolist() == [7.02, 0.5855265]
    d_fd, d_fw, err = fd["derivative"].values, fw["derivative"].values, fd["error"].values
    assert np.all(np.abs(d_fw) > 1e-3)
    assert np.all(np.abs(d_fd - d_fw) <= 1e-6 * np.abs(d_fw) + 10 * err)
    assert np.all(err < 1e-5 * np.abs(d_fw))
    np.testing.assert_allclose(fw["nominal"].values, fd["nominal"].values, rtol=1e-12)
    with pytest.raises(ModelError, match="projection step"):
        forward_sensitivities(PENDULUM, ["bodies.pendulum.mass"], ["final(pendulum.z)"],
                              dict(analysis, method=dict(name="projection")))
    # the period of a compound pendulum depends on I_pivot / (m d): dT/dI_cm > 0, dT/dm < 0
    k = outs.index("period(pendulum.wx)")
    assert d_fw[k, 0] < 0 < d_fw[k, 1]


# ------------------------------------------------------------------------------ command line
def test_cli_sweep_writes_results_and_plot(tmp_path, capsys):
    from spatialmbd.cli import main
    out, fig = tmp_path / "s.csv", tmp_path / "s.png"
    code = main(["sweep", str(PENDULUM), "--param", "bodies.pendulum.mass=1:3:3",
                 "--param", "bodies.pendulum.inertia.0=0.585,-1", "--output",
                 "min(pendulum.z)", "--t-end", "0.2", "--scheduler", "serial", "-o", str(out),
                 "--plot", str(fig)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "6 members (3 succeeded, 3 failed)" in captured.out
    assert "inertia" in captured.err
    import pandas as pd
    table = pd.read_csv(out)
    assert len(table) == 6 and fig.stat().st_size > 0
    assert main(["sweep", str(PENDULUM), "--param", "bodies.pendulum.mass", "--output",
                 "min(pendulum.z)"]) == 2
    assert "write PATH=VALUES" in capsys.readouterr().err


# ------------------------------------------------------------------------------ examples
def _example(name):
    import importlib.util
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / "sweeps" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_example_pendulum_period_runs(capsys):
    assert _example("pendulum_period").main(["--members", "3"]) == 0
    assert "max relative error" in capsys.readouterr().out


@pytest.mark.slow
def test_examples_slider_crank_and_flyball_run(tmp_path, capsys):
    assert _example("slider_crank_torque").main(["--quick"]) == 0
    assert _example("flyball_stiffness").main(["--members", "2", "--t-end", "0.05", "-o",
                                               str(tmp_path / "k.csv")]) == 0
    out = capsys.readouterr().out
    assert "d(output)/d(mass)" in out and "sleeve" in out


def test_docs_page_examples_run(monkeypatch):
    """The Python blocks of docs/sweeps.md run, and the page's claim holds (about 1e-11..1e-9)."""
    import contextlib
    import io
    import sys
    root = EXAMPLES.parent
    monkeypatch.chdir(root)
    monkeypatch.setattr(sys, "path", [str(root / "tests")] + sys.path)
    from test_docs import _examples, printed_matches      # the pages' own check of prints
    blocks = _examples("sweeps.md")
    assert len(blocks) == 3
    namespace = {}
    for k, (code, shown) in enumerate(blocks):
        # the local_cluster block runs under __main__ only (a script's guard for spawn): here
        # it is compiled, and local_cluster itself runs in the scheduler test above
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(code, "docs/sweeps.md", "exec"), namespace)
        assert shown is not None or not out.getvalue().strip(), out.getvalue()
        if shown is not None:
            problem = printed_matches(shown, out.getvalue())
            assert not problem, f"sweeps.md[{k}]: {problem}\n{out.getvalue()}"
    assert callable(namespace["local_cluster"])
    rel = namespace["ds"]["period(rod.wx)"].values / namespace["exact"] - 1
    assert np.all(np.abs(rel) < 1e-8)
    assert (namespace["fd"]["status"] == "success").all()
