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


