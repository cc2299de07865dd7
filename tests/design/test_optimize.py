"""Design optimization (spatialmbd.design.optimize): the slider-crank counterweight that
minimises the peak crank torque -- the balanced case against its closed form, the IFToMM
masses against a dense scan -- constraints, forward-sensitivity gradients, bad input."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from spatialmbd.design import optimize
from spatialmbd.errors import ModelError
from spatialmbd.sweep import sweep

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
spec = importlib.util.spec_from_file_location("counterweight",
                                              EXAMPLES / "design" / "counterweight.py")
cw = importlib.util.module_from_spec(spec)
spec.loader.exec_module(cw)
T = cw.TORQUE
PEAK_ABS = [f"peak({T})", f"-trough({T})"]


def test_balanced_case_closed_form():
    # rod and slider (nearly) massless, the rod without inertia: the crank's weight is the
    # only load and the peak torque vanishes at m_w = m_c r_c / RADIUS = 0.12 kg x 0.04 m / 0.04 m
    def light(counterweight):
        return cw.slider_crank_counterweight(counterweight, rod_mass=1e-6, slider_mass=1e-6,
                                             rod_inertia=(1e-9, 1e-8, 1e-8))
    best = optimize(light, PEAK_ABS, {"counterweight": 0.05},
                    bounds={"counterweight": (0.0, 1.0)}, analysis=cw.ANALYSIS)
    assert best.success, best.report()
    exact = 0.12 * 0.04 / cw.RADIUS
    assert best.x[0] == pytest.approx(exact, rel=1e-3), best.report()
    start = abs(best.history[0][1])
    assert best.objective < 1e-3 * start          # 0.12 kg x g x 0.04 m ~ 0.047 N m before


def test_iftomm_masses_against_dense_scan():
    best = optimize(cw.slider_crank_counterweight, PEAK_ABS, {"counterweight": 0.1},
                    bounds={"counterweight": (0.0, 2.0)}, analysis=cw.ANALYSIS)
    assert best.success, best.report()
    m = np.linspace(best.x[0] - 0.05, best.x[0] + 0.05, 21)    # 5 g apart around it
    ds = sweep(cw.slider_crank_counterweight, {"counterweight": m},
               {"hi": f"peak({T})", "lo": f"trough({T})"}, cw.ANALYSIS)
    peak = np.maximum(ds["hi"].values, -ds["lo"].values)
    assert best.objective <= peak.min() + 1e-9         # no scanned mass does better
    assert abs(m[int(np.argmin(peak))] - best.x[0]) <= 0.0051
    # at the minimax optimum the peak and the trough balance
    hi, lo = best.outputs[f"peak({T})"], best.outputs[f"trough({T})"]
    assert hi == pytest.approx(-lo, rel=1e-5)


def test_constraint_and_forward_gradient():
    # maximise the rms swing rate of the damped pendulum (less damping, faster swing) with
    # the rms rate held at most at its value for damping 0.8 N m s: the constraint is active
    # and the optimum is damping 0.8 exactly -- by forward sensitivities and by differences
    model = EXAMPLES / "design" / "pendulum_damped.yaml"
    an = dict(type="dynamic", t_end=1.0, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk4", step=0.005))
    ref = sweep(model, {"forces.pivot_damper.damping": [0.8]}, ["rms(pendulum.wx)"], an)
    target = float(ref["rms(pendulum.wx)"].values[0])
    for jac in ("forward", "fd"):
        best = optimize(model, "-rms(pendulum.wx)", {"forces.pivot_damper.damping": 2.0},
                        constraints=[f"rms(pendulum.wx) <= {target!r}"],
                        bounds={"forces.pivot_damper.damping": (0.1, 5.0)}, analysis=an,
                        jacobian=jac)
        assert best.success, best.report()
        assert best.x[0] == pytest.approx(0.8, rel=1e-5), (jac, best.report())
    with pytest.raises(ModelError, match="forward sensitivities need"):
        optimize(model, f"peak({T})", ["bodies.pendulum.mass"], analysis=an,
                 jacobian="forward")


def test_governor_spring_for_target_speed_closed_form():
    spec = importlib.util.spec_from_file_location("governor",
                                                  EXAMPLES / "design" / "governor.py")
    gov = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gov)
    best = optimize(gov.governor, gov.height_error, {"stiffness": 2.0},
                    bounds={"stiffness": (0.5, 10.0)}, analysis=gov.ANALYSIS, tol=1e-14)
    assert best.success, best.report()
    # k* = M D sin(phi) (D w^2 cos(phi) - g) / phi = 2.374341 N m/rad
    assert best.x[0] == pytest.approx(gov.exact_stiffness(), rel=1e-5), best.report()
    assert best.outputs["height_error"] < 1e-14


def test_bad_input():
    model = EXAMPLES / "design" / "pendulum_damped.yaml"
    with pytest.raises(ModelError, match="does not exist in the model"):
        optimize(model, "final(pendulum.z)", ["bodies.pendulum.mas"])
    with pytest.raises(ModelError, match="exclude the start value"):
        optimize(model, "final(pendulum.z)", ["bodies.pendulum.mass"],
                 bounds={"bodies.pendulum.mass": (8.0, 9.0)})
    with pytest.raises(ModelError, match="write 'output >= value'"):
        optimize(model, "final(pendulum.z)", ["bodies.pendulum.mass"],
                 constraints=["final(pendulum.z) > 1"])
    with pytest.raises(ModelError, match="method must be"):
        optimize(model, "final(pendulum.z)", ["bodies.pendulum.mass"], method="BFGS")
