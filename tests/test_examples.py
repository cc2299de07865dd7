"""Every example model file runs from the command line (shortened to keep CI fast)."""
from pathlib import Path

import numpy as np
import pytest

from spatialmbd.cli import main
from spatialmbd.io import load_model

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.yaml"))


def test_the_issue_list_of_examples_is_there():
    names = {p.stem for p in EXAMPLES}
    assert {"pendulum_ch15", "double_pendulum", "four_bar", "slider_crank", "flyball_governor",
            "bricard", "heavy_top", "robot_arm"} <= names


def test_the_generated_examples_match_their_generator(tmp_path):
    """The model files written from models.EXAMPLES are what write_examples() writes today
    (a changed model or writer shows up here, not as a stale example)."""
    from spatialmbd.io.writer import write_examples
    root = EXAMPLES[0].parent
    for path in write_examples(tmp_path):
        assert (root / path.name).read_text() == path.read_text(), path.name


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_runs_from_the_cli(path, tmp_path, capsys):
    _, analysis = load_model(path)
    t_end = min(analysis.t_end, 0.05)
    out = tmp_path / f"{path.stem}.csv"
    code = main(["run", str(path), "--t-end", str(t_end), "--output-step", str(t_end / 5),
                 "-o", str(out), "--quiet"])
    assert code == 0, capsys.readouterr().err
    assert out.exists() and out.stat().st_size > 0
    assert main(["info", str(path)]) == 0


def test_n_four_bar_example_runs_through_its_singular_positions():
    """examples/n_four_bar.yaml with its own settings: 10 s through the flat (singular)
    positions, on the parallelogram branch, against its exact 1-DoF motion
    I phi'' = K sin phi (I = m L^2 ((N+1)/3 + N), K = m g L ((N+1)/2 + N), N = 2)."""
    import warnings
    from scipy.integrate import solve_ivp
    from spatialmbd.io.modelfile import load_model
    model, analysis = load_model(Path(__file__).resolve().parents[1] / "examples"
                                 / "n_four_bar.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = analysis.run(model)
    assert res.status == "success" and res.t[-1] == 10.0, res.message
    N = 2
    I, K = (N + 1) / 3 + N, 9.81 * ((N + 1) / 2 + N)
    exact = solve_ivp(lambda t, y: [y[1], K / I * np.sin(y[0])], (0, 10), [0.0, -1.0],
                      rtol=1e-12, atol=1e-12, dense_output=True)
    quats = [res.q[:, model.body_index(f"crank{k}"), 3:] for k in range(N + 1)]
    phi = np.unwrap(2 * np.arctan2(quats[0][:, 3], quats[0][:, 0]))
    assert np.abs(phi - exact.sol(res.t)[0]).max() < 2e-3      # 14 singular passages
    for qk in quats[1:]:                                          # all cranks share one angle
        assert np.abs(qk - quats[0]).max() < 1e-8


def test_andrews_squeezer_example_reaches_the_test_set_reference():
    """examples/andrews_squeezer.yaml (IFToMM A03) with its own settings: the seven angles at
    t = 0.03 s within 5e-9 rad of the Test Set for IVP Solvers' reference (itself good to about
    1.5e-9 rad: validation/data/references.json), the rates within 2e-6 rad/s, and the three
    planar loops closed to the projection tolerance."""
    import json
    import warnings

    from spatialmbd import models
    from spatialmbd.rotations import A_from_p
    from spatialmbd.validation import reference_dir
    ref = json.loads((reference_dir() / "references.json").read_text())["iftomm_a03"]
    model, analysis = load_model(Path(__file__).resolve().parents[1] / "examples"
                                 / "andrews_squeezer.yaml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = analysis.run(model)
    assert res.status == "success" and res.t[-1] == ref["t_s"], res.message
    A = A_from_p(res.q[:, :, 3:])
    theta = np.unwrap(np.arctan2(A[:, :, 1, 0], A[:, :, 0, 0]), axis=0)
    assert np.abs(models.andrews_coordinates(theta[-1]) - ref["angles_rad"]).max() < 5e-9
    assert np.abs(models.andrews_coordinates(res.v[-1, :, 5]) - ref["rates_rad_s"]).max() < 2e-6
    assert res.constraint_violation()["position"].max() < 1e-10   # the projection tolerance
    # the model's own inverse pair of coordinate maps
    q = np.array(models.ANDREWS["angles0"])
    assert np.allclose(models.andrews_coordinates(models.andrews_body_angles(q)), q, atol=0)


@pytest.mark.parametrize("integrator", ["bdf4", "abm4"])
def test_andrews_squeezer_under_a_multistep_integrator_with_projection(integrator):
    """The multistep integrators build on earlier states: with the projection method, a
    projection stopped at its threshold (1e-10 m, about atol here) left on/off corrections in
    bdf4's history that its error test could not step below (step size underflow at
    t = 0.0299 s). Projected to 1e-3 atol instead, the run reaches the Test Set reference
    to the accuracy rtol 1e-8 gives here (bdf4 2.0e-6 rad, abm4 1.0e-7 rad)."""
    import json
    import warnings

    from spatialmbd import models
    from spatialmbd.rotations import A_from_p
    from spatialmbd.simulate import simulate
    from spatialmbd.validation import reference_dir
    ref = json.loads((reference_dir() / "references.json").read_text())["iftomm_a03"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate(models.andrews_squeezer().compile(), 0.03, output_step=1e-3,
                       method="projection", integrator=integrator, rtol=1e-8, atol=1e-10)
    assert res.success, res.message
    A = A_from_p(res.q[-1, :, 3:])
    theta = np.arctan2(A[:, 1, 0], A[:, 0, 0])
    err = models.andrews_coordinates(theta) - np.asarray(ref["angles_rad"])
    err = (err + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(err).max() < 5e-6


def test_door_closer_example_shuts_the_door_against_its_frame():
    """examples/door_closer.yaml with its own settings: the closer swings the door onto the
    frame stop (a located touch), where it comes to rest pressed by the closer's preload
    (20 N m/rad x 0.2 rad = 4 N m, give or take the hinge friction), and the energy balance closes."""
    from spatialmbd.outputs import force_outputs
    model, analysis = load_model(Path(__file__).resolve().parents[1] / "examples"
                                 / "door_closer.yaml")
    res = analysis.run(model)
    assert res.success, res.message
    assert len(res.contact_log) >= 1
    stop = force_outputs(res, "frame")
    assert stop["active"][-1] == 1.0
    assert 4.0 - 0.3 - 1e-3 <= stop["force"][-1] <= 4.0 + 0.3 + 1e-3
    assert abs(res.v[-1, 0, 5]) < 1e-3
    assert np.abs(res.energy()["error"]).max() < 1e-5


def test_robot_arm_servos_example_script_runs(tmp_path, capsys):
    """The arm follows its trajectory (within the gravity droop m g l / kp of a PD servo, a
    few degrees), the servos' work closes the energy balance, and the figure is written."""
    import runpy
    script = runpy.run_path(str(Path(__file__).resolve().parents[1] / "examples"
                                / "robot_arm_servos.py"))
    tracking, energy_error, res = script["main"](tmp_path)
    assert res.status == "success"
    assert tracking < np.radians(3.0)
    assert energy_error < 1e-8 * np.abs(res.work).max()
    assert (tmp_path / "robot_arm_servos.png").stat().st_size > 1000


def test_slider_crank_bearing_friction_example_matches_its_closed_form(tmp_path, capsys):
    """examples/slider_crank_bearing_friction.py: the crank bearing's reaction-proportional
    friction loss per turn is 4 mu r P K((R/L)^2) (quasi-static two-force rod) and the slider
    guide's 4 R P; the energy balance closes; the figure is written."""
    import runpy
    script = runpy.run_path(str(Path(__file__).resolve().parents[1] / "examples"
                                / "slider_crank_bearing_friction.py"))
    out = script["main"](tmp_path)
    assert out["errors"]["bearing"] < 1e-8 and out["errors"]["guide"] < 1e-6
    assert out["balance"] < 1e-7
    assert (tmp_path / "slider_crank_bearing_friction.png").stat().st_size > 1000
    assert "relative error" in capsys.readouterr().out
