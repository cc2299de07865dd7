"""Where actuator commands come from: time series (CSV, linear or zero-order hold), sampled
Python controllers (zero-order hold, steps landing on the samples), model files (controls:,
paths relative to the file) and MJCF actuators (the gain/bias mapping)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.forces.actuators.controller import SampledController
from spatialmbd.io.modelfile import load_model, save_model
from spatialmbd.motion import TimeSeries
from spatialmbd.outputs import force_outputs, joint_coordinates
from spatialmbd.simulate import simulate

I_ROTOR = 0.2


def rotor(kind="motor", name="act", **kw):
    b = ModelBuilder("rotor", gravity=(0, 0, 0))
    b.add_body("rotor", mass=1.0, inertia=(I_ROTOR, 1.0, 1.0), position=(0, 0, 0))
    b.add_joint("revolute", "pivot", "ground", "rotor", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force(kind, name, joint="pivot", **kw)
    return b


def piecewise_constant(times, torques, t, inertia=I_ROTOR):
    """theta(t) of a rotor from rest under torque torques[k] on [times[k], times[k+1])."""
    theta = omega = 0.0
    edges = list(times) + [math.inf]
    for k, tau in enumerate(torques):
        dt = min(t, edges[k + 1]) - edges[k]
        if dt <= 0:
            break
        a = tau / inertia
        theta += omega * dt + 0.5 * a * dt * dt
        omega += a * dt
    return theta


def write_csv(path, rows, header="t,value"):
    with open(path, "w") as fh:
        if header:
            fh.write(header + "\n")
        for row in rows:
            fh.write(",".join(str(x) for x in row) + "\n")


# ------------------------------------------------------------------------- time series
def test_zero_order_hold_series_is_integrated_piecewise_exactly(tmp_path):
    """A torque held at 0.3, -0.2, 0.5 N m from t = 0, 0.25, 0.6: the steps land on the
    jumps, so the angle is the piecewise-quadratic closed form to integration accuracy."""
    path = tmp_path / "torque.csv"
    write_csv(path, [(0.0, 0.3), (0.25, -0.2), (0.6, 0.5)])
    model = rotor(command=TimeSeries(file=str(path), interpolation="zoh")).compile()
    res = simulate(model, t_end=1.0, method="projection", rtol=1e-12, atol=1e-14,
                   output_step=0.05, outputs=["forces"])
    exact = [piecewise_constant([0.0, 0.25, 0.6], [0.3, -0.2, 0.5], t) for t in res.t]
    assert np.abs(joint_coordinates(res, "pivot")["angle"] - exact).max() < 2e-11
    out = force_outputs(res, "act")
    assert np.allclose(out["command"], np.where(res.t < 0.25, 0.3,
                                                np.where(res.t < 0.6, -0.2, 0.5)))
    assert np.abs(res.energy()["error"]).max() < 1e-10


def test_linear_series_gives_its_ramp():
    """A torque ramp 0 -> 2 N m over [0, 1] then held: theta = t^3 / (3 I) on the ramp."""
    model = rotor(command=TimeSeries(times=[0.0, 1.0], values=[0.0, 2.0])).compile()
    res = simulate(model, t_end=1.5, method="standard", rtol=1e-12, atol=1e-14,
                   output_step=0.05)
    theta = joint_coordinates(res, "pivot")["angle"]
    ramp = res.t <= 1.0
    assert np.abs(theta[ramp] - res.t[ramp] ** 3 / (3 * I_ROTOR)).max() < 2e-11
    t2 = res.t[~ramp] - 1.0
    after = 1 / (3 * I_ROTOR) + (1 / I_ROTOR) * t2 + 0.5 * (2 / I_ROTOR) * t2 ** 2
    assert np.abs(theta[~ramp] - after).max() < 2e-11


def test_series_errors_name_the_file_and_the_sample(tmp_path):
    back = tmp_path / "back.csv"
    write_csv(back, [(0.0, 1.0), (0.5, 2.0), (0.4, 3.0)])
    with pytest.raises(ModelError, match=r"increase strictly; t\[2\] = 0.4 follows"):
        TimeSeries(file=str(back))
    nan = tmp_path / "nan.csv"
    write_csv(nan, [(0.0, 1.0), (0.5, "nan")])
    with pytest.raises(ModelError, match="sample 1 is not finite"):
        TimeSeries(file=str(nan))
    with pytest.raises(ModelError, match="not found"):
        TimeSeries(file=str(tmp_path / "missing.csv"))
    bad = tmp_path / "bad.csv"
    write_csv(bad, [(0.0, 1.0), ("x", 2.0)])
    with pytest.raises(ModelError, match="line 3: expected two numbers"):
        TimeSeries(file=str(bad))
    with pytest.raises(ModelError, match="'linear' or 'zoh'"):
        TimeSeries(times=[0, 1], values=[0, 1], interpolation="cubic")
    with pytest.raises(ModelError, match="forces\\['act'\\].command"):
        rotor(command={"type": "time_series", "file": str(tmp_path / "missing.csv")})


def test_model_file_controls_section_and_relative_series_path(tmp_path):
    """Actuators are written under controls:, a time series file is found relative to the
    model file, and the model reads back to the same motion."""
    folder = tmp_path / "model"
    folder.mkdir()
    write_csv(folder / "ref.csv", [(0.0, 0.0), (0.5, 0.4)])
    text = """spatialmbd: 1
name: rotor
gravity: [0, 0, 0]
bodies:
  - {name: rotor, mass: 1.0, inertia: [0.2, 1.0, 1.0], position: [0, 0, 0]}
joints:
  - {name: pivot, type: revolute, body_i: ground, body_j: rotor, point: [0, 0, 0],
     axis: [1, 0, 0]}
controls:
  - name: servo
    type: position_servo
    joint: pivot
    kp: 20.0
    kv: 1.0
    forcerange: [-3, 3]
    reference: {type: time_series, file: ref.csv, interpolation: zoh}
"""
    (folder / "rotor.yaml").write_text(text)
    model, _ = load_model(folder / "rotor.yaml")
    assert [g.name for g in model.force_groups] == ["position_servo"]
    res = simulate(model, t_end=1.0, method="projection", rtol=1e-12, atol=1e-14,
                   output_step=0.1)
    assert res.status == "success"
    out = tmp_path / "again.yaml"
    save_model(model, out)
    written = out.read_text()
    assert "controls:" in written and "forces:" not in written
    again = simulate(load_model(out)[0], t_end=1.0, method="projection", rtol=1e-12, atol=1e-14,
                     output_step=0.1)
    assert np.array_equal(res.q, again.q)
    bad = text.replace("type: position_servo", "type: spring_damper")
    (folder / "bad.yaml").write_text(bad)
    with pytest.raises(ModelError, match="controls"):
        load_model(folder / "bad.yaml")


# ------------------------------------------------------------------------- controllers
def test_sampled_controller_holds_its_commands_between_samples():
    """A controller at 10 Hz commanding 0.1 (k + 1) N m at sample k: the motion is the
    piecewise-quadratic closed form, the controller ran exactly at the sample times, it sees
    the joint angle and rate of the state there, and the outputs report the held commands."""
    seen = []

    def bang(t, y):
        seen.append((t, y[0], y[1]))
        return [0.1 * (round(t * 10) + 1)]
    model = rotor(gear=2.0).compile()
    res = simulate(model, t_end=1.0, method="standard", rtol=1e-12, atol=1e-14,
                   output_step=0.05, outputs=["forces"],
                   controllers=[SampledController(bang, ["act"], rate=10.0)])
    assert res.status == "success", res.message
    times = [s[0] for s in seen]
    assert times == [k / 10 for k in range(10)]
    torques = [2.0 * 0.1 * (k + 1) for k in range(10)]
    exact = np.array([piecewise_constant(times, torques, t) for t in res.t])
    assert np.abs(joint_coordinates(res, "pivot")["angle"] - exact).max() < 2e-11
    for t, q, qd in seen:
        assert q == pytest.approx(piecewise_constant(times, torques, t), abs=2e-11)
    out = force_outputs(res, "act")
    # held from the last sample at or before t (none is taken at t_end itself)
    assert np.allclose(out["command"], 0.1 * np.minimum(np.floor(res.t * 10 + 1e-9) + 1, 10))
    assert np.abs(res.energy()["error"]).max() < 1e-10
    assert np.array_equal(res.control_log["act"][:, 0], times)
    assert np.allclose(res.control_log["act"][:, 1], 0.1 * np.arange(1, 11))


def test_controller_drives_a_servo_in_every_body_coordinate_method():
    """A discrete PD law at 200 Hz on a motor reaches the set point like the continuous servo
    within the sampling delay; every body-coordinate method gives the same motion."""
    def pd(t, y):
        return [20.0 * (0.5 - y[0]) - 1.0 * y[1]]
    model = rotor().compile()
    runs = {}
    for method in ("standard", "baumgarte", "penalty", "augmented_lagrangian", "projection"):
        res = simulate(model, t_end=2.0, method=method, rtol=1e-12, atol=1e-14,
                       output_step=0.05, controllers=[SampledController(pd, ["act"], 200.0)])
        assert res.status == "success", res.message
        runs[method] = joint_coordinates(res, "pivot")["angle"]
    for method, theta in runs.items():
        assert np.abs(theta - runs["projection"]).max() < 1e-7, method
    assert abs(runs["projection"][-1] - 0.5) < 0.02
    with pytest.raises(ModelError, match="recursive"):
        simulate(model, t_end=0.1, method="recursive",
                 controllers=[SampledController(pd, ["act"], 200.0)])


@pytest.mark.parametrize("fault, message", [
    ("raise", r"controller 'faulty' raised ZeroDivisionError"),
    ("nan", r"controller 'faulty' returned a command that is not finite"),
    ("shape", r"controller 'faulty' returned 2 command\(s\); expected 1"),
])
def test_a_failing_controller_stops_the_run_and_keeps_its_results(fault, message):
    def faulty(t, y):
        if t >= 0.3:
            if fault == "raise":
                return 1 / 0
            if fault == "nan":
                return [math.nan]
            return [1.0, 2.0]
        return [1.0]
    model = rotor().compile()
    res = simulate(model, t_end=1.0, method="projection", output_step=0.05,
                   controllers=[SampledController(faulty, ["act"], rate=10.0)])
    assert res.status == "failed"
    assert re.search(message, res.message) and "t = 0.3" in res.message
    # the outputs up to the failed sample (0.3 itself when the output time is not a hair later)
    assert 0.25 <= res.t[-1] <= 0.3 and np.all(np.diff(res.t) > 0)
    assert res.q.shape[0] == len(res.t)


def test_controller_input_errors():
    with pytest.raises(ModelError, match="rate must be a positive"):
        SampledController(lambda t, y: [0.0], ["act"], rate=0.0)
    with pytest.raises(ModelError, match="not an actuator of the model"):
        simulate(rotor().compile(), t_end=0.1,
                 controllers=[SampledController(lambda t, y: [0.0], ["nope"], rate=10.0)])


# ------------------------------------------------------------------------- MJCF mapping
MJCF = """<mujoco>
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="1 0 0"/>
      <geom size=".1" mass="1"/>
      <body pos="0 0 -0.3">
        <joint name="slide" type="slide" axis="0 0 1"/>
        <geom size=".05" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="pos" joint="hinge" kp="20" kv="2" ctrlrange="-1 1" forcerange="-5 5"
              gear="2"/>
    <velocity name="vel" joint="slide" kv="3"/>
    <motor name="mot" joint="hinge" gear="4" ctrlrange="-1 1"/>
    <general name="gen" joint="hinge" gainprm="7" biasprm="1 2 3" biastype="affine"/>
    <position name="pos0" joint="hinge" kp="10"/>
  </actuator>
</mujoco>"""


def test_mujoco_actuators_map_one_to_one():
    mujoco = pytest.importorskip("mujoco")
    from spatialmbd.forces.actuators.mujoco import actuator_spec_from_mujoco
    m = mujoco.MjModel.from_xml_string(MJCF)
    specs = [actuator_spec_from_mujoco(m, a, "J") for a in range(m.nu)]
    assert specs[0] == dict(type="position_servo", joint="J", coordinate="angle", gear=2.0,
                            kp=20.0, kv=2.0, velocity_feedforward=False,
                            ctrlrange=[-1.0, 1.0], forcerange=[-5.0, 5.0])
    assert specs[1] == dict(type="velocity_servo", joint="J", coordinate="translation",
                            kv=3.0)
    assert specs[2] == dict(type="motor", joint="J", coordinate="angle", gear=4.0,
                            ctrlrange=[-1.0, 1.0])
    assert specs[3] == dict(type="general", joint="J", coordinate="angle", gain=7.0,
                            bias=[1.0, 2.0, 3.0])
    assert specs[4] == dict(type="position_servo", joint="J", coordinate="angle", kp=10.0,
                            kv=0.0, velocity_feedforward=False)
    # the mapped actuators produce MuJoCo's joint forces: qfrc_actuator at a random state
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    d.qpos[:] = [0.4, 0.05]
    d.qvel[:] = rng.normal(size=2)
    d.ctrl[:] = [0.7, -0.2, 0.3, 0.5, -0.4]
    mujoco.mj_forward(m, d)
    ours = np.zeros(2)
    for a, spec in enumerate(specs):
        spec = dict(spec)
        kind = spec.pop("type")
        joint = 0 if spec["coordinate"] == "angle" else 1
        b = ModelBuilder(gravity=(0, 0, 0))
        b.add_body("b", 1.0, (1, 1, 1))
        jtype = "revolute" if joint == 0 else "translational"
        b.add_joint(jtype, "J", "ground", "b", point=(0, 0, 0), axis=(1, 0, 0))
        key = "reference" if kind.endswith("servo") else "command"
        b.add_force(kind, "a", **spec, **{key: float(d.ctrl[a])})
        group = b.compile().force_groups[0]
        from spatialmbd.state import BodyState
        q = np.array([[0, 0, 0, 1.0, 0, 0, 0]])
        v = np.zeros((1, 6))
        if joint == 0:
            half = 0.5 * d.qpos[0]
            q[0, 3:] = [math.cos(half), math.sin(half), 0, 0]
            v[0, 3] = d.qvel[0]
        else:
            q[0, 0], v[0, 0] = d.qpos[1], d.qvel[1]
        ours[joint] += group.details(BodyState.from_qv(q, v, 0.0), 0.0)[0, 3]
    assert np.allclose(ours, d.qfrc_actuator, rtol=1e-12, atol=1e-12)
    with pytest.raises(ModelError, match="activation dynamics"):
        bad = mujoco.MjModel.from_xml_string(MJCF.replace(
            '<motor name="mot"', '<general dyntype="filter" dynprm="0.1" name="mot"'))
        actuator_spec_from_mujoco(bad, 2, "J")


import re  # noqa: E402
