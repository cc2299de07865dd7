"""A sweep checks its optional packages, parameter paths and output columns before it runs any
member: one error naming the bad path or column and the closest valid names (ModelError from
Python, exit status 2 from the command line); the command line varies linked parameters."""
import sys
from pathlib import Path

import numpy as np
import pytest

from spatialmbd.errors import ModelError
from spatialmbd.sweep import core, sweep
from spatialmbd.sweep.plot import log_spaced

pytest.importorskip("xarray")

PENDULUM = Path(__file__).resolve().parents[2] / "examples" / "pendulum_ch15.yaml"
SHORT = dict(type="dynamic", t_end=0.05, output_step=0.01)


@pytest.fixture
def members(monkeypatch):
    """The members run, counted (the serial scheduler runs them in this process)."""
    calls = []
    run = core.SweepJob.run_member

    def counted(self, member):
        calls.append(member)
        return run(self, member)
    monkeypatch.setattr(core.SweepJob, "run_member", counted)
    return calls


BAD = [  # (params, outputs, words the message must hold)
    ({"bodies.pendulum.mas": [1, 2]}, ["max(pendulum.z)"], ["'bodies.pendulum.mas'", "mass"]),
    ({"bodies.pendulm.mass": [1, 2]}, ["max(pendulum.z)"], ["'pendulm'", "pendulum"]),
    ({"analysis.integrator.rtl": [1e-6, 1e-8]}, ["max(pendulum.z)"], ["rtl", "rtol"]),
    ({"bodies.pendulum.mass": [1, 2]}, ["max(pendulum.zz)"], ["'pendulum.zz'", "pendulum.z,"]),
    ({"bodies.pendulum.mass": [1, 2]}, ["max(pivot.pendulum.fq)"],
     ["'pivot.pendulum.fq'", "pivot.pendulum.fx"]),
    ({"bodies.pendulum.mass": [1, 2]}, ["final(pendulum.tip.zz)"], ["pendulum.tip.z"]),
]


@pytest.mark.parametrize("params, outputs, words", BAD)
def test_bad_paths_and_columns_fail_before_any_member(params, outputs, words, members):
    with pytest.raises(ModelError) as info:
        sweep(PENDULUM, params, outputs, SHORT)
    for word in words:
        assert word in str(info.value), str(info.value)
    assert "spatialmbd info" in str(info.value) or "names here" in str(info.value)
    assert members == []


def test_good_paths_and_columns_pass_and_members_run(members):
    ds = sweep(PENDULUM, {"bodies.pendulum.mass": [1, 2], "bodies.pendulum.velocity.2": [0.1],
                          "analysis.integrator.rtol": [1e-7]},
               ["max(pivot.pendulum.fz)", "final(pendulum.tip.vy)", "energy.total",
                "violation.position"], SHORT)
    assert len(members) == 2 and (ds["status"] == "success").all()
    # a bad value (not a bad path) stays the member's failure
    ds = sweep(PENDULUM, {"bodies.pendulum.mass": [-1, 2]}, ["final(pendulum.z)"], SHORT)
    assert ds["status"].values.tolist() == ["failed", "success"]


def test_factory_keywords_are_checked(members):
    from spatialmbd import ModelBuilder

    def factory(mass):
        b = ModelBuilder("pendulum", gravity=(0, 0, -9.81))
        b.add_body("pendulum", mass, (0.1, 0.1, 0.1), r=(0, 0.5, 0))
        b.add_joint("revolute", "pivot", "ground", "pendulum", point=(0, 0, 0), axis=(1, 0, 0))
        return b.compile()
    with pytest.raises(ModelError, match=r"'mas' is not a keyword.*mass"):
        sweep(factory, {"mas": [1.0]}, ["final(pendulum.z)"], SHORT)
    with pytest.raises(ModelError, match="pendulum.z"):
        sweep(factory, {"mass": [1.0]}, ["final(pendulum.zed)"], SHORT)
    assert members == []


def test_a_missing_dask_extra_is_reported_before_any_member(members, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)       # import fails
    with pytest.raises(ModelError, match=r"spatialmbd\[dask\]"):
        sweep(PENDULUM, {"bodies.pendulum.mass": [1, 2]}, ["max(pendulum.z)"], SHORT,
              scheduler="dask")
    assert members == []


def _cli(args):
    from spatialmbd.cli import main
    return main(["sweep", str(PENDULUM), "--t-end", "0.05", "--scheduler", "serial",
                 "--plot", "none", "-q"] + args)


@pytest.mark.parametrize("args, words", [
    (["--param", "bodies.pendulum.mas=1,2", "--output", "max(pendulum.z)"], ["mass"]),
    (["--param", "bodies.pendulum.mass=1,2", "--output", "max(pendulum.zz)"],
     ["pendulum.zz", "pendulum.z,"]),
])
def test_cli_bad_path_or_column_exits_2_before_any_member(args, words, members, tmp_path,
                                                          capsys):
    assert _cli(args + ["-o", str(tmp_path / "s.csv")]) == 2
    err = capsys.readouterr().err
    for word in words:
        assert word in err, err
    assert members == [] and not (tmp_path / "s.csv").exists()


def test_cli_missing_dask_exits_2_before_any_member(members, monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)
    from spatialmbd.cli import main
    code = main(["sweep", str(PENDULUM), "--t-end", "0.05", "--scheduler", "dask", "-q",
                 "--param", "bodies.pendulum.mass=1,2", "--output", "max(pendulum.z)",
                 "-o", str(tmp_path / "s.csv"), "--plot", "none"])
    assert code == 2 and "spatialmbd[dask]" in capsys.readouterr().err
    assert members == []


def test_cli_linked_and_zipped_parameters(tmp_path, members):
    import pandas as pd
    out = tmp_path / "linked.csv"
    assert _cli(["--param", "bodies.pendulum.inertia.0,bodies.pendulum.inertia.2=0.5:0.7:3",
                 "--param", "bodies.pendulum.mass=1,2", "--output", "final(pendulum.z)",
                 "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert len(table) == 6 and len(members) == 6                    # 3 linked x 2
    np.testing.assert_array_equal(table["bodies.pendulum.inertia.0"],
                                  table["bodies.pendulum.inertia.2"])
    assert sorted(set(table["bodies.pendulum.inertia.0"])) == pytest.approx([0.5, 0.6, 0.7])
    out = tmp_path / "zip.csv"
    assert _cli(["--zip", "--param", "bodies.pendulum.mass=1,2,3", "--param",
                 "bodies.pendulum.inertia.0=0.585,0.5855,0.586", "--output", "final(pendulum.z)",
                 "-o", str(out)]) == 0
    table = pd.read_csv(out)
    assert (table["status"] == "success").all()
    assert table[["bodies.pendulum.mass", "bodies.pendulum.inertia.0"]].values.tolist() == \
        [[1, 0.585], [2, 0.5855], [3, 0.586]]
    assert _cli(["--zip", "--param", "bodies.pendulum.mass=1,2,3", "--param",
                 "bodies.pendulum.inertia.0=0.5,0.6", "--output", "final(pendulum.z)"]) == 2


def test_log_spaced_values_get_a_log_axis(tmp_path):
    from spatialmbd.sweep.params import parse_range
    assert log_spaced(parse_range("1e4:1e6:5:log")) and log_spaced(np.geomspace(2e4, 8e5, 5))
    assert not log_spaced(parse_range("1:10:10")) and not log_spaced([1.0, 2.0])
    assert not log_spaced([-1.0, 1.0, 10.0])
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from spatialmbd.sweep.plot import summary_plot
    ds = sweep(PENDULUM, {"bodies.pendulum.mass": "1:100:3:log"}, ["final(pendulum.z)"], SHORT)
    seen = []
    original = plt.Axes.set_xscale
    try:
        plt.Axes.set_xscale = lambda self, v, **kw: (seen.append(v), original(self, v, **kw))
        summary_plot(ds, tmp_path / "s.png")
    finally:
        plt.Axes.set_xscale = original
    assert seen == ["log"] and (tmp_path / "s.png").stat().st_size > 1000
