"""FMI co-simulation (spatialmbd.fmi, docs/fmi.md): an exported FMU run in fmpy reproduces the
direct simulation; an FMU written with pythonfmu drives a model through import.

The model: a spatial slider-crank (the IFToMM benchmark geometry of examples/slider_crank.yaml)
whose crank is turned by a motor instead of the driver; the motor's command (N m) is the FMU's
input, from a table."""
import math
import zipfile

import fmpy
import numpy as np
import pytest
import yaml
from fmpy.validation import validate_fmu

from spatialmbd.cli import main
from spatialmbd.errors import ModelError
from spatialmbd.fmi.controller import FMUController
from spatialmbd.fmi.cosim import CoSimulation
from spatialmbd.fmi.export import export_fmu
from spatialmbd.forces.actuators.controller import SampledController
from spatialmbd.io import load_model
from spatialmbd.outputs import joint_coordinates
from spatialmbd.simulate import simulate

CRANK = """
spatialmbd: 1
name: crank_motor
gravity: [0.0, 0.0, -9.81]
bodies:
  - {name: crank, mass: 0.12, inertia: [0.0001, 0.0001, 1.0e-05], position: [0.0, 0.1, 0.16]}
  - name: rod
    mass: 0.5
    inertia: [0.0004, 0.004, 0.004]
    position: [0.1, 0.05, 0.1]
    orientation:
      euler_parameters: [0.9091823043491487, 0.08198091724118012, 0.3472767382914235,
                         -0.21462882776630182]
  - {name: slider, mass: 2.0, inertia: [0.0001, 0.0001, 0.0001], position: [0.2, 0.0, 0.0]}
joints:
  - {name: A, type: revolute, body_i: ground, body_j: crank, point: [0.0, 0.1, 0.12],
     axis: [1.0, 0.0, 0.0]}
  - {name: B, type: spherical, body_i: crank, body_j: rod, point: [0.0, 0.1, 0.2]}
  - {name: C, type: universal, body_i: rod, body_j: slider, point: [0.2, 0.0, 0.0],
     axis: [0.4472135954999579, 0.8944271909999159, 0.0], axis2: [0.0, 0.0, 1.0]}
  - {name: D, type: translational, body_i: ground, body_j: slider, point: [0.2, 0.0, 0.0],
     axis: [1.0, 0.0, 0.0]}
controls:
  - {name: drive, type: motor, joint: A, command: 0.0}
fmu:
  inputs: [drive]
  outputs: [A.angle, A.angle_rate, D.translation, slider.x]
  parameters: [bodies.slider.mass]
  step: 0.01
  rtol: 1.0e-10
  atol: 1.0e-12
"""
TOL = dict(rtol=1e-10, atol=1e-12)
T_END = 0.4
TABLE_T = np.linspace(0.0, T_END, 9)                  # the torque table (N m), linear between
TABLE_U = 0.3 * np.sin(8.0 * TABLE_T) + 0.1


def crank_dict(command=0.0, **values):
    data = yaml.safe_load(CRANK)
    data["controls"][0]["command"] = command
    for body, mass in values.items():
        next(b for b in data["bodies"] if b["name"] == body)["mass"] = mass
    return data


def crank_model(command=0.0, **values):
    data = crank_dict(command, **values)
    data.pop("fmu")
    return load_model(data)[0]


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("fmi") / "crank_motor.yaml"
    path.write_text(CRANK)
    return path


@pytest.fixture(scope="module")
def crank_fmu(model_file):
    return export_fmu(model_file, model_file.with_suffix(".fmu"))


def fmpy_run(fmu, h, start_values=None):
    """The FMU in fmpy: fixed communication step h, the torque table as input."""
    table = np.array(list(zip(TABLE_T, TABLE_U)), dtype=[("time", float), ("drive", float)])
    return fmpy.simulate_fmu(str(fmu), stop_time=T_END, step_size=h, output_interval=h,
                             input=table, start_values=start_values or {},
                             output=["A.angle", "A.angle_rate", "D.translation", "slider.x"])


def zoh_reference(h, masses=None, **tolerances):
    """The direct simulation with the table sampled every h and held (zero-order hold)."""
    tk = np.arange(round(T_END / h)) * h
    law = {"type": "time_series", "times": tk.tolist(),
           "values": np.interp(tk, TABLE_T, TABLE_U).tolist(), "interpolation": "zoh"}
    return simulate(crank_model(law, **(masses or {})), t_end=T_END, method="projection",
                    output_step=h, **(tolerances or TOL))


def test_model_description_passes_fmpy_validation(crank_fmu):
    assert validate_fmu(str(crank_fmu)) == []
    md = fmpy.read_model_description(str(crank_fmu))
    kinds = {v.name: v.causality for v in md.modelVariables}
    assert kinds == {"drive": "input", "A.angle": "output", "A.angle_rate": "output",
                     "D.translation": "output", "slider.x": "output",
                     "bodies.slider.mass": "parameter"}
    assert md.coSimulation is not None and md.fmiVersion == "2.0"


def test_fmu_reproduces_the_zero_order_hold_simulation(crank_fmu):
    """Each doStep restarts the integrator at the communication point with the input held:
    the same problem as a direct simulation whose command is the table sampled every h and
    held. Both agree with a tight direct run (rtol 1e-12) to within the direct run's own
    integrator error at rtol 1e-10 (measured, not assumed)."""
    h = 0.005
    run = fmpy_run(crank_fmu, h)
    ref = zoh_reference(h)
    tight = zoh_reference(h, rtol=1e-12, atol=1e-14)
    assert np.allclose(run["time"], ref.t, rtol=0, atol=1e-12)
    for joint, coordinate in (("A", "angle"), ("A", "angle_rate"), ("D", "translation")):
        direct = joint_coordinates(ref, joint)[coordinate]
        exact = joint_coordinates(tight, joint)[coordinate]
        integrator_error = np.abs(direct - exact).max()
        fmu = run[f"{joint}.{coordinate}"]
        print(f"{joint}.{coordinate}: |FMU - direct| {np.abs(fmu - direct).max():.3g}, "
              f"|FMU - tight| {np.abs(fmu - exact).max():.3g}, |direct - tight| "
              f"{integrator_error:.3g}")
        assert integrator_error < 1e-6
        assert np.abs(fmu - exact).max() <= integrator_error
        assert np.abs(fmu - direct).max() <= 2.0 * integrator_error
    assert np.abs(run["slider.x"] - tight.q[:, 2, 0]).max() <= \
        np.abs(ref.q[:, 2, 0] - tight.q[:, 2, 0]).max() + 1e-15


def test_communication_step_error_is_first_order(crank_fmu):
    """Against the direct simulation with the table's own (linear) input, the co-simulation's
    zero-order hold errs by O(h): the fitted slope of log(error) over log(h) is 1."""
    law = {"type": "time_series", "times": TABLE_T.tolist(), "values": TABLE_U.tolist()}
    exact = simulate(crank_model(law), t_end=T_END, method="projection", output_step=0.02,
                     **TOL)
    angle = joint_coordinates(exact, "A")["angle"]
    steps = np.array([0.02, 0.01, 0.005, 0.0025])
    errors = []
    for h in steps:
        run = fmpy_run(crank_fmu, h)
        every = int(round(0.02 / h))
        errors.append(np.abs(run["A.angle"][::every] - angle).max())
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    print(f"errors {np.array(errors)} rad, slope {slope:.3f}")
    assert abs(slope - 1.0) < 0.05
    assert errors[-1] > 1e3 * 1e-8                 # far above the integrator's error




def test_parameter_sets_a_model_value(crank_fmu):
    """bodies.slider.mass set in fmpy before initialisation = the model with that mass."""
    h = 0.01
    run = fmpy_run(crank_fmu, h, start_values={"bodies.slider.mass": 3.0})
    heavy = zoh_reference(h, masses={"slider": 3.0}, rtol=1e-12, atol=1e-14)
    light = zoh_reference(h, rtol=1e-12, atol=1e-14)
    angle_heavy = joint_coordinates(heavy, "A")["angle"]
    assert np.abs(run["A.angle"] - angle_heavy).max() < 1e-7
    assert np.abs(joint_coordinates(light, "A")["angle"] - angle_heavy).max() > 1e-2


def test_compiled_joint_outputs_match_spatialmbd_outputs():
    """The co-simulation's compiled joint coordinates (fmi.joint_kernel) = outputs.
    joint_coordinates on every state of a run (revolute A, translational D)."""
    model = crank_model({"type": "time_series", "times": TABLE_T.tolist(),
                         "values": TABLE_U.tolist()})
    res = simulate(model, t_end=T_END, method="projection", output_step=0.01, **TOL)
    names = ["A.angle", "A.angle_rate", "D.translation", "D.translation_rate"]
    sim = CoSimulation(model, outputs=names)
    values = []
    for k in range(len(res.t)):                      # set the state, evaluate the outputs
        sim.y[:7 * model.nb] = res.q[k].reshape(-1)
        sim.y[7 * model.nb:13 * model.nb] = res.v[k].reshape(-1)
        sim.t = float(res.t[k])
        values.append(sim._evaluate())
    values = np.array(values)
    for m, name in enumerate(names):
        joint, coordinate = name.split(".")
        ref = joint_coordinates(res, joint)[coordinate]
        assert np.abs(values[:, m] - ref).max() <= 1e-12 * max(1.0, np.abs(ref).max())
    assert values[:, 0].max() > math.pi + 1.0      # continuous past the branch cut at pi


PI_SCRIPT = '''
import ctypes

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

# pythonfmu's loader releases this module's dict once per instance: take a reference each time
ctypes.pythonapi.Py_IncRef(ctypes.py_object(globals()))


class PIController(Fmi2Slave):
    """u = kp e + ki integral(e), e = reference - angle, the integral by forward Euler."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.angle = 0.0
        self.torque = 0.0
        self.kp, self.ki, self.reference = 0.5, 2.0, 1.0
        self.integral = 0.0
        self.register_variable(Real("angle", causality=Fmi2Causality.input,
                                    variability=Fmi2Variability.continuous))
        self.register_variable(Real("torque", causality=Fmi2Causality.output,
                                    variability=Fmi2Variability.continuous))
        for name in ("kp", "ki", "reference"):
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed))

    def do_step(self, current_time, step_size):
        error = self.reference - self.angle
        self.integral += error * step_size
        self.torque = self.kp * error + self.ki * self.integral
        return True
'''


@pytest.fixture(scope="module")
def pi_fmu(tmp_path_factory):
    from pythonfmu.builder import FmuBuilder
    folder = tmp_path_factory.mktemp("pi")
    script = folder / "pi_controller.py"
    script.write_text(PI_SCRIPT)
    return FmuBuilder.build_FMU(script, dest=folder)


def python_pi(h, kp, ki, reference):
    state = {"integral": 0.0}

    def pi(t, y):
        error = reference - y[0]
        state["integral"] += error * h
        return [kp * error + ki * state["integral"]]
    return pi


def test_pi_controller_fmu_drives_the_crank_like_the_python_loop(pi_fmu):
    h = 0.002
    model = crank_model()
    fmu = FMUController(pi_fmu, inputs_from={"angle": "drive.coordinate"},
                        outputs_to={"torque": "drive"}, step=h,
                        parameters={"kp": 0.8, "reference": 1.5})
    python = SampledController(python_pi(h, 0.8, 2.0, 1.5), actuators=["drive"], rate=1 / h)
    runs = [simulate(model, t_end=1.0, method="projection", output_step=0.01,
                     controllers=[c], **TOL) for c in (fmu, python)]
    assert [r.status for r in runs] == ["success", "success"]
    angles = [joint_coordinates(r, "A")["angle"] for r in runs]
    commands = [r.control_log["drive"] for r in runs]
    assert commands[0].shape == commands[1].shape == (500, 2)
    assert np.array_equal(commands[0][:, 0], commands[1][:, 0])
    assert np.abs(commands[0][:, 1] - commands[1][:, 1]).max() <= 1e-12
    assert np.abs(angles[0] - angles[1]).max() <= 1e-12
    assert abs(angles[0][-1]) > 0.5                       # the loop moved the crank
    again = simulate(model, t_end=0.1, method="projection", output_step=0.01,
                     controllers=[fmu], **TOL)            # a new run: a fresh FMU instance
    assert np.abs(joint_coordinates(again, "A")["angle"] - angles[0][:11]).max() <= 1e-12
    fmu.close()


def test_command_line_writes_the_fmu(model_file, tmp_path, capsys):
    out = tmp_path / "crank.fmu"
    assert main(["fmu", str(model_file), "--output", "slider.x", "--input", "drive",
                 "--step", "0.001", "-o", str(out)]) == 0
    assert "1 input(s), 1 output(s), 1 parameter(s)" in capsys.readouterr().out
    md = fmpy.read_model_description(str(out))
    assert [v.name for v in md.modelVariables] == ["drive", "slider.x", "bodies.slider.mass"]
    assert md.defaultExperiment.stepSize == "0.001"
    assert validate_fmu(str(out)) == []


@pytest.mark.parametrize("option, value, message", [
    ("--input", "motor", "input 'motor' is not a point_force, torque or actuator element of "
                         "the model (inputs it can take: drive)"),
    ("--output", "A.angel", "output 'A.angel': joint 'A' (revolute) has the coordinates angle"),
    ("--output", "crank.speed", "output 'crank.speed' is not a result column of the model"),
    ("--step", "0", "the communication step must be a positive number of seconds, got 0.0"),
    ("--step", "-1e-3", "the communication step must be a positive number of seconds"),
    ("--parameter", "bodies.slider.mas", "parameter 'bodies.slider.mas': no key 'mas'"),
    ("--parameter", "bodies.slider.name", "parameter 'bodies.slider.name' is 'slider', not a "
                                          "number"),
])
def test_command_line_bad_input_names_the_item(model_file, tmp_path, capsys, option, value,
                                               message):
    out = tmp_path / "bad.fmu"
    assert main(["fmu", str(model_file), f"{option}={value}", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_bad_step_and_names_in_python(crank_fmu, pi_fmu):
    sim = CoSimulation(crank_model(), ["drive"], ["A.angle"])
    for h in (0.0, -0.01, math.nan, math.inf):
        with pytest.raises(ModelError, match="communication step must be a positive number"):
            sim.do_step(0.0, h)
    with pytest.raises(ModelError, match="'torque' is not an input"):
        sim.set_input("torque", 1.0)
    with pytest.raises(ModelError, match="communication step must be a positive number of "
                                         "seconds, got 0.0"):
        FMUController(pi_fmu, {"angle": "drive"}, {"torque": "drive"}, step=0.0)
    with pytest.raises(ModelError, match="'speed' is not an input of the FMU \\(inputs: "
                                         "angle\\)"):
        FMUController(pi_fmu, {"speed": "drive"}, {"torque": "drive"}, step=1e-3)
    with pytest.raises(ModelError, match="'force' is not an output of the FMU \\(outputs: "
                                         "torque\\)"):
        FMUController(pi_fmu, {"angle": "drive"}, {"force": "drive"}, step=1e-3)
    with pytest.raises(ModelError, match="'drive.speed': give '<actuator>.coordinate'"):
        FMUController(pi_fmu, {"angle": "drive.speed"}, {"torque": "drive"}, step=1e-3)
    ctl = FMUController(pi_fmu, {"angle": "drive"}, {"torque": "spindle"}, step=1e-3)
    with pytest.raises(ModelError, match="'spindle' is not an actuator of the model "
                                         "\\(actuators: drive\\)"):
        simulate(crank_model(), t_end=0.01, method="projection", controllers=[ctl])


def test_fmu_without_a_binary_for_this_platform_is_refused(pi_fmu, tmp_path):
    """An FMU that carries only a Windows binary: the error names the file, this platform
    and the binaries it has."""
    foreign = tmp_path / "windows_only.fmu"
    with zipfile.ZipFile(pi_fmu) as zin, zipfile.ZipFile(foreign, "w") as zout:
        for item in zin.infolist():
            if item.filename.startswith("binaries/") and "win64" not in item.filename:
                continue
            zout.writestr(item, zin.read(item))
    with pytest.raises(ModelError) as info:
        FMUController(foreign, {"angle": "drive"}, {"torque": "drive"}, step=1e-3)
    text = str(info.value)
    assert "windows_only.fmu" in text and f"no binary for this platform ({fmpy.platform})" \
        in text and "its binaries: win64" in text
    with pytest.raises(ModelError, match="does not exist"):
        FMUController(tmp_path / "missing.fmu", {"angle": "drive"}, {"torque": "drive"},
                      step=1e-3)


def test_a_second_independent_importer_runs_the_fmu(crank_fmu):
    """libcosim (Open Simulation Platform; FMI Library underneath) steps the exported FMU to
    the same outputs as fmpy: a constant torque, h = 10 ms, 0.2 s."""
    libcosimpy = pytest.importorskip("libcosimpy", reason="libcosimpy: Linux/Windows wheels")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave
    assert libcosimpy
    log_output_level(CosimLogLevel.ERROR)
    refs = {v.name: v.valueReference for v in
            fmpy.read_model_description(str(crank_fmu)).modelVariables}
    execution = CosimExecution.from_step_size(step_size=10_000_000)          # ns
    slave = execution.add_local_slave(CosimLocalSlave(fmu_path=str(crank_fmu),
                                                      instance_name="crank"))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    execution.real_initial_value(slave, refs["drive"], 0.2)
    assert execution.step(20)
    names = ["A.angle", "A.angle_rate", "slider.x"]
    values = observer.last_real_values(slave, [refs[n] for n in names])
    run = fmpy.simulate_fmu(str(crank_fmu), stop_time=0.2, step_size=0.01,
                            start_values={"drive": 0.2})
    assert np.allclose(values, [run[n][-1] for n in names], rtol=0, atol=1e-12)
    direct = simulate(crank_model(0.2), t_end=0.2, method="projection", output_step=0.01,
                      rtol=1e-12, atol=1e-14)
    assert abs(values[0] - joint_coordinates(direct, "A")["angle"][-1]) < 1e-7


PENDULUM = {
    "spatialmbd": 1, "name": "pendulum", "gravity": [0.0, 0.0, -9.81],
    "bodies": [{"name": "link", "mass": 1.0, "inertia": [0.1, 0.1, 0.01],
                "position": [0.0, 0.5, 0.0]}],
    "joints": [{"name": "pivot", "type": "revolute", "body_i": "ground", "body_j": "link",
                "point": [0.0, 0.0, 0.0], "axis": [1.0, 0.0, 0.0]}],
    "forces": [{"name": "twist", "type": "torque", "body": "link", "direction": [1, 0, 0],
                "magnitude": 0.0},
               {"name": "push", "type": "point_force", "body": "link", "point": [0, 0.5, 0],
                "direction": [0, 0, 1], "magnitude": 0.0}],
}


def test_torque_and_point_force_magnitudes_as_inputs():
    """Inputs held on a torque and a point force = the direct run with those laws held."""
    h, n = 0.02, 25
    tk = np.arange(n) * h
    twist, push = 0.5 * np.cos(3 * tk), 2.0 * np.sin(5 * tk)
    data = yaml.safe_load(yaml.safe_dump(PENDULUM))
    for force, values in zip(data["forces"], (twist, push)):
        force["magnitude"] = {"type": "time_series", "times": tk.tolist(),
                              "values": values.tolist(), "interpolation": "zoh"}
    direct = simulate(load_model(data)[0], t_end=n * h, method="projection", output_step=h,
                      rtol=1e-12, atol=1e-14)
    sim = CoSimulation(load_model(PENDULUM)[0], ["twist", "push"], ["pivot.angle", "link.z"],
                       **TOL)
    out = [sim.output_values()]
    for t, a, b in zip(tk, twist, push):
        sim.set_input("twist", a)
        sim.set_input("push", b)
        sim.do_step(t, h)
        out.append(sim.output_values())
    out = np.array(out)
    assert np.abs(out[:, 0] - joint_coordinates(direct, "pivot")["angle"]).max() < 1e-8
    assert np.abs(out[:, 1] - direct.q[:, 0, 2]).max() < 1e-8
    assert np.ptp(out[:, 0]) > 0.1                        # the inputs moved the pendulum


def test_the_fmu_section_is_checked_with_the_file():
    from spatialmbd.io.schema import ModelFileError
    data = crank_dict()
    data["fmu"]["ouputs"] = data["fmu"].pop("outputs")
    data["fmu"]["step"] = -1
    with pytest.raises(ModelFileError) as info:
        load_model(data)
    assert info.value.problems == [
        "fmu.ouputs: unknown key 'ouputs' (did you mean 'outputs'?); valid keys: inputs, "
        "outputs, parameters, start_time, stop_time, step, method, integrator, rtol, atol",
        "fmu.step: must be > 0, got -1"]


def test_reactions_and_accelerations_as_outputs():
    """<joint>.<body>.fx..mz and <body>.ax.. at the communication points = the results table
    of the direct run (a constant torque: no input jumps)."""
    model = crank_model(0.2)
    names = ["A.crank.fy", "A.ground.mz", "D.slider.fz", "B.rod.fx", "slider.ax",
             "crank.alphax"]
    sim = CoSimulation(model, ["drive"], names, **TOL)
    sim.set_input("drive", 0.2)
    h, n = 0.01, 20
    out = [sim.output_values()]
    for k in range(n):
        sim.do_step(k * h, h)
        out.append(sim.output_values())
    out = np.array(out)
    table = simulate(model, t_end=n * h, method="projection", output_step=h,
                     rtol=1e-12, atol=1e-14).to_dataframe()
    for m, name in enumerate(names):
        ref = table[name].to_numpy()
        assert np.abs(out[:, m] - ref).max() <= 1e-6 * np.abs(ref).max(), name
    with pytest.raises(ModelError, match="joint 'A' joins 'ground' and 'crank'"):
        CoSimulation(model, outputs=["A.slider.fx"])


def test_contact_impacts_inside_a_communication_step():
    """A ball bouncing on the floor (examples/bouncing_ball.yaml, Lankarani-Nikravesh with
    restitution 0.8): the impacts fall inside communication steps, where the integrator
    locates the first touch as in a simulation; the co-simulation's heights = the direct run's."""
    from pathlib import Path
    model, _ = load_model(Path(__file__).resolve().parents[2] / "examples" /
                          "bouncing_ball.yaml")
    h, n = 0.05, 24
    sim = CoSimulation(model, outputs=["ball.z", "ball.vz"], **TOL)
    out = [sim.output_values()]
    for k in range(n):
        sim.do_step(k * h, h)
        out.append(sim.output_values())
    out = np.array(out)
    direct = simulate(model, t_end=n * h, method="projection", output_step=h, rtol=1e-12,
                      atol=1e-14)
    assert out[:, 1].max() > 2.0                        # it bounced (upward speed)
    assert np.abs(out[:, 0] - direct.q[:, 0, 2]).max() < 1e-6
    assert np.abs(out[:, 1] - direct.v[:, 0, 2]).max() < 1e-5


def test_export_from_a_model_object(tmp_path):
    """export_fmu(Model, ...): the model is written into the FMU as a model file."""
    path = export_fmu(crank_model(), tmp_path / "from_model.fmu", inputs=["drive"],
                      outputs=["A.angle"], step=0.01)
    assert validate_fmu(str(path)) == []
    with zipfile.ZipFile(path) as z:
        assert "resources/model.json" in z.namelist()
    run = fmpy.simulate_fmu(str(path), stop_time=0.1, step_size=0.01,
                            start_values={"drive": 0.2})
    direct = simulate(crank_model(0.2), t_end=0.1, method="projection", output_step=0.01,
                      rtol=1e-12, atol=1e-14)
    assert np.abs(run["A.angle"] - joint_coordinates(direct, "A")["angle"]).max() < 1e-6


def test_model_file_controllers_run_an_fmu_from_the_command_line(pi_fmu, tmp_path, capsys):
    """``analysis.controllers`` names the PI FMU (its path relative to the model file):
    ``spatialmbd run`` closes the loop through it, as FMUController does from Python (the
    same angles to 1e-12); the section survives a save and reload; bad entries are located."""
    import shutil

    from spatialmbd.io.modelfile import save_model
    h = 0.002
    shutil.copy(pi_fmu, tmp_path / "pi.fmu")
    data = crank_dict()
    data.pop("fmu")
    data["analysis"] = {"type": "dynamic", "t_end": 0.3, "output_step": 0.01,
                        "method": {"name": "projection"},
                        "integrator": {"name": "rk45", **TOL},
                        "controllers": [{"type": "fmu", "file": "pi.fmu",
                                         "inputs_from": {"angle": "drive.coordinate"},
                                         "outputs_to": {"torque": "drive"}, "step": h,
                                         "parameters": {"kp": 0.8, "reference": 1.5}}]}
    path = tmp_path / "crank_pi.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "r.csv"
    assert main(["run", str(path), "-o", str(out), "-q"]) == 0, capsys.readouterr().err
    import pandas as pd
    table = pd.read_csv(out, comment="#")
    model, analysis = load_model(path)
    assert analysis.controllers[0]["file"] == str(tmp_path / "pi.fmu")
    fmu = FMUController(tmp_path / "pi.fmu", inputs_from={"angle": "drive.coordinate"},
                        outputs_to={"torque": "drive"}, step=h,
                        parameters={"kp": 0.8, "reference": 1.5})
    direct = simulate(model, t_end=0.3, method="projection", output_step=0.01,
                      controllers=[fmu], **TOL)
    fmu.close()
    angle = joint_coordinates(direct, "A")["angle"]
    assert abs(angle[-1]) > 0.05                                   # the loop moved the crank
    q = table[[c for c in table.columns if c.startswith("crank.") and c.endswith(".x")]
              or ["crank.x"]].to_numpy()[:, 0]
    assert np.abs(q - direct.q[:, model.body_index("crank"), 0]).max() <= 1e-12
    # round trip of the section, and located errors
    again = tmp_path / "again.yaml"
    save_model(model, again, analysis=analysis)
    assert load_model(again)[1].controllers == analysis.controllers
    data["analysis"]["controllers"][0]["step"] = -1.0
    path.write_text(yaml.safe_dump(data))
    assert main(["run", str(path), "-o", str(out), "-q"]) == 2
    assert "analysis.controllers[0].step" in capsys.readouterr().err


def test_fmu_state_is_saved_restored_and_serialized(crank_fmu):
    """fmi2GetFMUstate / fmi2SetFMUstate (and the serialized form): a state taken at t = 0.1 s,
    stepped on with one input, restored and stepped with the same input again gives the same
    outputs bit for bit; restored from its serialized bytes, too."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(str(crank_fmu))
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(str(crank_fmu))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="s")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    h, t = 0.01, 0.0
    outputs = [vr["A.angle"], vr["slider.x"]]
    for _ in range(10):
        fmu.setReal([vr["drive"]], [0.2])
        fmu.doStep(t, h)
        t += h
    saved = fmu.getFMUstate()
    blob = fmu.serializeFMUstate(saved)

    def go_on():
        fmu.setReal([vr["drive"]], [0.3])
        fmu.doStep(0.1, h)
        fmu.doStep(0.11, h)
        return fmu.getReal(outputs)
    first = go_on()
    fmu.setFMUstate(saved)
    assert go_on() == first
    fmu.setFMUstate(fmu.deSerializeFMUstate(blob))
    assert go_on() == first
    fmu.setFMUstate(saved)
    fmu.setReal([vr["drive"]], [-0.3])                  # another input: another motion
    fmu.doStep(0.1, h)
    fmu.doStep(0.11, h)
    assert fmu.getReal(outputs) != first
    fmu.freeFMUstate(saved)
    fmu.terminate()
    fmu.freeInstance()


def test_imu_outputs_match_spatialmbd_outputs():
    """<body>.<point>.imu.<quantity> outputs of the co-simulation (acceleration, specific force,
    angular velocity of a point, body axes) = spatialmbd.outputs.imu of a run at its states;
    an unknown point or quantity is named."""
    from spatialmbd.outputs import imu
    data = crank_dict(0.1)
    data.pop("fmu")
    data["bodies"][0]["points"] = {"tip": [0.0, 0.0, 0.04]}
    model = load_model(data)[0]
    res = simulate(model, t_end=0.2, method="projection", output_step=0.02, **TOL)
    names = ["crank.tip.imu.ax", "crank.tip.imu.sfz", "crank.tip.imu.wx", "crank.x"]
    sim = CoSimulation(model, outputs=names)
    ref = imu(res, "crank.tip")
    for k in range(len(res.t)):
        sim.y[:7 * model.nb] = res.q[k].reshape(-1)
        sim.y[7 * model.nb:13 * model.nb] = res.v[k].reshape(-1)
        sim.t = float(res.t[k])
        values = sim._evaluate()
        for m, quantity in enumerate(("ax", "sfz", "wx")):
            assert abs(values[m] - ref[quantity][k]) <= 1e-9 * max(1.0, abs(ref[quantity][k]))
    assert abs(ref["sfz"]).max() > 1.0                   # gravity is in the specific force
    with pytest.raises(ModelError, match="no named point 'crank.toe'"):
        CoSimulation(model, outputs=["crank.toe.imu.ax"])
    with pytest.raises(ModelError, match="an IMU measures"):
        CoSimulation(model, outputs=["crank.tip.imu.speed"])


def test_force_element_outputs_match_spatialmbd_outputs():
    """<element>.<quantity> outputs (an actuator's effort and power, a spring's torque) of the
    co-simulation = spatialmbd.outputs.force_outputs of a run at its states; a quantity the
    element does not have is named."""
    from spatialmbd.outputs import force_outputs
    data = crank_dict(0.1)
    data.pop("fmu")
    data.setdefault("forces", []).append({"name": "k", "type": "rotational_spring_damper",
                                          "joint": "A", "stiffness": 0.5, "damping": 0.01})
    model = load_model(data)[0]
    res = simulate(model, t_end=0.2, method="projection", output_step=0.02, **TOL)
    names = ["drive.effort", "drive.power", "k.torque"]
    sim = CoSimulation(model, outputs=names)
    refs = [force_outputs(res, "drive")["effort"], force_outputs(res, "drive")["power"],
            force_outputs(res, "k")["torque"]]
    for k in range(len(res.t)):
        sim.y[:7 * model.nb] = res.q[k].reshape(-1)
        sim.y[7 * model.nb:13 * model.nb] = res.v[k].reshape(-1)
        sim.t = float(res.t[k])
        values = sim._evaluate()
        for m, ref in enumerate(refs):
            assert abs(values[m] - ref[k]) <= 1e-12 * max(1.0, abs(ref[k]))
    assert np.abs(refs[2]).max() > 0.0
    with pytest.raises(ModelError, match="has the outputs"):
        CoSimulation(model, outputs=["drive.speed"])
