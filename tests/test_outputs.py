"""Engineering outputs (spatialmbd.outputs) against closed forms derived here."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.errors import ModelError
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.motion import SmoothStep
from spatialmbd.outputs import Output, compute_outputs, parse_outputs
from spatialmbd.simulate import simulate

G = 9.81
M, JXX, JYY, JZZ = 7.02, 0.5855265, 0.0010530, 0.5855265
L = 0.5                                     # pivot -> centre of mass (m)


def pendulum(omega0=0.0, spring=None, driver=None):
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("link", mass=M, inertia=(JXX, JYY, JZZ), r=(0, L, 0),
               omega=(omega0, 0, 0), points={"tip": (0, 0.5, 0)})
    b.add_joint("revolute", "pivot", "ground", "link", point=(0, 0, 0), axis=(1, 0, 0))
    if spring is not None:
        b.add_force("rotational_spring_damper", "spiral", joint="pivot", **spring)
    if driver is not None:
        b.add_driver("angle", "motor", driver, joint="pivot")
    return b.compile()


@pytest.fixture(scope="module")
def over_the_top():
    """A pendulum turning over the top several times (I_O w^2 / 2 > m g L from horizontal)."""
    model = pendulum(omega0=8.0)
    return simulate(model, 3.0, rtol=1e-10, atol=1e-12, output_step=0.005,
                    outputs=["joints", "momentum", {"type": "momentum", "of": "link",
                                                    "name": "h_pivot", "about": [0, 0, 0]},
                             "bodies", {"type": "imu", "of": "link.tip"}])


def test_revolute_angle_is_the_body_angle_unwrapped(over_the_top):
    res = over_the_top
    out = res.outputs()
    p = res.q[:, 0, 3:]
    # rotation about x only: p = (cos(phi/2), sin(phi/2), 0, 0)
    phi = np.unwrap(2 * np.arctan2(p[:, 1], p[:, 0]))
    assert phi[-1] > 4 * np.pi                               # several turns: unwrapping matters
    np.testing.assert_allclose(out["pivot.angle"], phi, atol=1e-9)
    np.testing.assert_allclose(out["pivot.angle_rate"], res.v[:, 0, 3], atol=1e-9)


def test_angular_momentum_about_the_pivot_axis(over_the_top):
    """Fixed-axis rotation about x through O, centre of mass at distance L normal to x and x a
    principal axis: h_O = (J_xx + m L^2) omega_x e_x; dh_O/dt = moment of gravity about O
    (the revolute's reaction moment has no component along its axis)."""
    res = over_the_top
    out = res.outputs()
    w = res.v[:, 0, 3]
    np.testing.assert_allclose(out["h_pivot.hx"], (JXX + M * L**2) * w, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out["h_pivot.hy"], 0, atol=1e-8)
    np.testing.assert_allclose(out["h_pivot.hz"], 0, atol=1e-8)
    r = res.q[:, 0, :3]
    moment_x = np.cross(r, M * np.array([0, 0, -G]))[:, 0]
    dt = res.t[1] - res.t[0]
    dh = np.gradient(out["h_pivot.hx"].to_numpy(), dt)
    np.testing.assert_allclose(dh[2:-2], moment_x[2:-2], atol=2e-3 * np.abs(moment_x).max())
    # system momentum about its centre of mass = the body's own J omega (one body)
    np.testing.assert_allclose(out["system.hx"], JXX * w, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out["system.pz"], M * res.v[:, 0, 2], atol=1e-12)


def test_energy_per_body_sums_to_the_energy_balance(over_the_top):
    res = over_the_top
    out = res.outputs()
    en = res.energy()
    w = res.v[:, 0, 3]
    kinetic = 0.5 * M * np.sum(res.v[:, 0, :3] ** 2, axis=1) + 0.5 * JXX * w**2
    np.testing.assert_allclose(out["link.kinetic"], kinetic, rtol=1e-12)
    np.testing.assert_allclose(out["link.potential"], M * G * res.q[:, 0, 2], atol=1e-12)
    np.testing.assert_allclose(out["link.kinetic"], en["kinetic"], rtol=1e-12)
    np.testing.assert_allclose(out["link.potential"], en["gravitational"], atol=1e-12)


def test_imu_on_the_pendulum(over_the_top):
    """Tip at rho = 1 m from the pivot along body y: in body axes (x = axis, y = outward,
    z = tangential) a = (0, -rho w^2, rho wdot); angular velocity (w, 0, 0)."""
    res = over_the_top
    out = res.outputs()
    w, wd = res.v[:, 0, 3], res.vdot[:, 0, 3]
    np.testing.assert_allclose(out["link.tip.imu.ax"], 0, atol=1e-9)
    np.testing.assert_allclose(out["link.tip.imu.ay"], -1.0 * w**2, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out["link.tip.imu.az"], 1.0 * wd, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out["link.tip.imu.wx"], w, atol=1e-12)


def test_imu_at_rest_reads_minus_g_in_body_axes():
    b = ModelBuilder("resting", gravity=(0, 0, -G))
    b.add_body("box", 2.0, (0.1, 0.2, 0.3), r=(0.3, 0.2, 0.1), bryant=(0.4, -0.7, 1.1),
               points={"sensor": (0.1, -0.05, 0.02)})
    b.add_joint("fixed", "weld", "ground", "box", point=(0.3, 0.2, 0.1))
    model = b.compile()
    res = simulate(model, 0.1, output_step=0.05, outputs=[{"type": "imu", "of": "box.sensor"},
                                                          "joints"])
    out = res.outputs()
    c1, s1, c2, s2, c3, s3 = (np.cos(0.4), np.sin(0.4), np.cos(-0.7), np.sin(-0.7),
                              np.cos(1.1), np.sin(1.1))
    Rx = np.array([[1, 0, 0], [0, c1, -s1], [0, s1, c1]])
    Ry = np.array([[c2, 0, s2], [0, 1, 0], [-s2, 0, c2]])
    Rz = np.array([[c3, -s3, 0], [s3, c3, 0], [0, 0, 1]])
    A = Rx @ Ry @ Rz
    expected = A.T @ np.array([0, 0, G])                     # -g = +9.81 up, in body axes
    for c, axis in enumerate("xyz"):
        np.testing.assert_allclose(out[f"box.sensor.imu.sf{axis}"], expected[c], atol=1e-9)
        np.testing.assert_allclose(out[f"box.sensor.imu.a{axis}"], 0, atol=1e-9)
    # a fixed joint: the generic relative pose, all zero
    for q in ("dx", "dy", "dz", "rx", "ry", "rz"):
        np.testing.assert_allclose(out[f"weld.{q}"], 0, atol=1e-9)


def test_momentum_of_a_free_tumbling_body_is_conserved():
    b = ModelBuilder("free", gravity=(0, 0, 0))
    b.add_body("brick", 3.0, (0.04, 0.06, 0.09), r=(1, 2, 3), rdot=(0.3, -0.1, 0.2),
               omega=(1.0, 2.0, 3.0))
    model = b.compile()
    res = simulate(model, 2.0, rtol=1e-10, atol=1e-12, output_step=0.01,
                   outputs=["momentum", {"type": "momentum", "name": "about_O",
                                         "about": [0.5, -1.0, 2.0]}])
    out = res.outputs()
    np.testing.assert_allclose(out["system.px"], 0.9, rtol=1e-12)
    np.testing.assert_allclose(out["system.py"], -0.3, rtol=1e-12)
    A0 = np.eye(3)
    h0 = A0 @ np.diag([0.04, 0.06, 0.09]) @ A0.T @ np.array([1.0, 2.0, 3.0])
    for c, axis in enumerate("xyz"):
        np.testing.assert_allclose(out[f"system.h{axis}"], h0[c], rtol=1e-7, atol=1e-9)
        ho = out[f"about_O.h{axis}"].to_numpy()
        np.testing.assert_allclose(ho, ho[0], atol=1e-8)
    # the body tumbles (omega is not constant), so conservation is not trivial
    assert np.ptp(res.v[:, 0, 3]) > 0.1
    ho0 = h0 + np.cross(np.array([1, 2, 3]) - np.array([0.5, -1.0, 2.0]),
                        3.0 * np.array([0.3, -0.1, 0.2]))
    np.testing.assert_allclose(out[["about_O.hx", "about_O.hy", "about_O.hz"]].to_numpy()[0],
                               ho0, rtol=1e-10)


def test_slider_crank_stroke_and_crank_angle_against_closed_form():
    """Crank about +x at A = (0, 0.1, 0.12), radius 0.08 pointing up at theta = 0:
    B = A + 0.08 (0, -sin th, cos th); the slider point C = (x, 0, 0) with |C - B| = 0.3:
    x = sqrt(0.09 - B_y^2 - B_z^2), x xdot = -(B_y B_y' + B_z B_z')."""
    w = 6.0
    model = models.slider_crank(crank_speed=w).compile()
    t = np.linspace(0, 2 * 2 * np.pi / w, 241)                     # two turns
    kin = kinematic_analysis(model, t)
    kin.output_requests = ["joints", "drivers"]
    out = compute_outputs(kin)
    th = w * t
    By, Bz = 0.1 - 0.08 * np.sin(th), 0.12 + 0.08 * np.cos(th)
    x = np.sqrt(0.09 - By**2 - Bz**2)
    xd = -(By * (-0.08 * np.cos(th) * w) + Bz * (-0.08 * np.sin(th) * w)) / x
    np.testing.assert_allclose(out["D.translation"], x - 0.2, atol=1e-9)
    np.testing.assert_allclose(out["D.translation_rate"], xd, atol=1e-8)
    np.testing.assert_allclose(out["A.angle"], th, atol=1e-9)         # unwrapped past pi
    np.testing.assert_allclose(out["A.angle_rate"], w, atol=1e-9)
    np.testing.assert_allclose(out["crank_drive.coordinate"], th, atol=1e-9)
    np.testing.assert_allclose(out["crank_drive.coordinate_rate"], w, atol=1e-9)
    assert np.all(np.isnan(out["crank_drive.effort"]))          # no multipliers in kinematics
    # every coordinate's rate is its time derivative (spherical B, universal C too)
    dt = t[1] - t[0]
    # (fourth-order central differences; their truncation error here is < 1e-3 of the rate)
    for name in ("B.rx", "B.ry", "B.rz", "C.angle_i", "C.angle_j", "D.translation"):
        x_, xd_ = out[name], out[name + "_rate"]
        fd = (-x_[4:] + 8 * x_[3:-1] - 8 * x_[1:-3] + x_[:-4]) / (12 * dt)
        np.testing.assert_allclose(xd_[2:-2], fd, atol=2e-3 * np.abs(xd_).max(), err_msg=name)
    # universal joint angles start at zero
    assert abs(out["C.angle_i"][0]) < 1e-12 and abs(out["C.angle_j"][0]) < 1e-12


def test_cylindrical_and_planar_coordinates_of_free_motion():
    """No gravity and no forces: the joint coordinates change at constant rates."""
    b = ModelBuilder("slides", gravity=(0, 0, 0))
    b.add_body("pin", 1.0, (0.1, 0.1, 0.2), r=(0, 0, 0), rdot=(0, 0, 0.4), omega=(0, 0, 1.5))
    b.add_joint("cylindrical", "cyl", "ground", "pin", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_body("puck", 1.0, (0.1, 0.1, 0.2), r=(2, 0, 0), rdot=(0.3, -0.2, 0),
               omega=(0, 0, -0.7))
    b.add_joint("planar", "plane", "ground", "puck", point=(2, 0, 0), axis=(0, 0, 1))
    model = b.compile()
    res = simulate(model, 4.0, rtol=1e-10, atol=1e-12, output_step=0.05, outputs="joints")
    out = res.outputs()
    t = res.t
    np.testing.assert_allclose(out["cyl.angle"], 1.5 * t, atol=1e-8)
    np.testing.assert_allclose(out["cyl.translation"], 0.4 * t, atol=1e-8)
    np.testing.assert_allclose(out["cyl.translation_rate"], 0.4, atol=1e-8)
    np.testing.assert_allclose(out["plane.angle"], -0.7 * t, atol=1e-8)
    g, k, _ = model.element("plane")
    a, bb = g.geometry.R_i[k][:, 1], g.geometry.R_i[k][:, 2]       # ground: body = global
    d = np.outer(t, [0.3, -0.2, 0])
    np.testing.assert_allclose(out["plane.translation_a"], d @ a, atol=1e-8)
    np.testing.assert_allclose(out["plane.translation_b"], d @ bb, atol=1e-8)
    np.testing.assert_allclose(out["plane.translation_b_rate"], np.array([0.3, -0.2, 0]) @ bb,
                               atol=1e-8)


def test_spring_damper_outputs_follow_the_spring_law():
    k, c, l0 = 200.0, 3.0, 0.8
    b = ModelBuilder("oscillator", gravity=(0, 0, 0))
    b.add_body("mass", 1.5, (0.01, 0.01, 0.01), r=(1.0, 0, 0))
    b.add_joint("translational", "rail", "ground", "mass", point=(1.0, 0, 0), axis=(1, 0, 0))
    b.add_force("spring_damper", "spring", body_i="ground", body_j="mass",
                point_i=(0, 0, 0), point_j=(0, 0, 0), stiffness=k, damping=c,
                natural_length=l0)
    model = b.compile()
    res = simulate(model, 1.0, rtol=1e-10, atol=1e-12, output_step=0.001,
                   outputs=["forces", "joints"])
    out = res.outputs()
    x, xd = res.q[:, 0, 0], res.v[:, 0, 0]                      # length = x > 0
    np.testing.assert_allclose(out["spring.length"], x, atol=1e-12)
    np.testing.assert_allclose(out["spring.length_rate"], xd, atol=1e-12)
    np.testing.assert_allclose(out["spring.deflection"], x - l0, atol=1e-12)
    np.testing.assert_allclose(out["spring.force"], k * (x - l0) + c * xd, atol=1e-9)
    np.testing.assert_allclose(out["spring.power"], -(k * (x - l0) + c * xd) * xd, atol=1e-9)
    np.testing.assert_allclose(out["spring.energy"], 0.5 * k * (x - l0) ** 2, atol=1e-12)
    np.testing.assert_allclose(out["spring.energy"], res.energy()["elastic"], atol=1e-12)
    np.testing.assert_allclose(out["rail.translation"], x - 1.0, atol=1e-12)
    # the spring does work -int f ldot = -(elastic energy change) - damper losses: check the
    # power against the kinetic energy change (the only body is the mass)
    kin = 0.5 * 1.5 * xd**2
    work = np.concatenate([[0], np.cumsum(0.5 * (out["spring.power"].to_numpy()[1:]
                                                 + out["spring.power"].to_numpy()[:-1])
                                          * np.diff(res.t))])
    # (trapezoidal rule: relative error about (h omega)^2 / 12 = 1e-5 per period)
    np.testing.assert_allclose(work, kin - kin[0], atol=1e-4 * np.abs(kin).max())
    # the spring's force pulls the mass back: the oscillation is about x = l0
    assert x.min() < l0 < x.max() or abs(x[-1] - l0) < abs(x[0] - l0)


def test_rotational_spring_outputs():
    k, c = 40.0, 0.5
    model = pendulum(spring=dict(stiffness=k, damping=c, rest_angle=0.3))
    res = simulate(model, 1.0, rtol=1e-10, atol=1e-12, output_step=0.01,
                   outputs=["forces", "joints"])
    out = res.outputs()
    th, thd = out["pivot.angle"].to_numpy(), out["pivot.angle_rate"].to_numpy()
    np.testing.assert_allclose(out["spiral.angle"], th, atol=1e-12)
    np.testing.assert_allclose(out["spiral.deflection"], th - 0.3, atol=1e-12)
    tau = -(k * (th - 0.3) + c * thd)
    np.testing.assert_allclose(out["spiral.torque"], tau, atol=1e-9)
    np.testing.assert_allclose(out["spiral.power"], tau * thd, atol=1e-9)
    np.testing.assert_allclose(out["spiral.energy"], 0.5 * k * (th - 0.3) ** 2, atol=1e-12)


def test_outputs_of_a_kinematic_analysis_from_a_model_file():
    from spatialmbd.io.modelfile import load_model, model_to_dict
    from spatialmbd.io.results_io import to_dataframe
    data = model_to_dict(models.slider_crank().compile(),
                         {"type": "kinematic", "t_end": 0.5, "output_step": 0.05})
    data["outputs"] = ["joints", "drivers"]
    model, analysis = load_model(data)
    kin = analysis.run(model)
    df = to_dataframe(kin)
    np.testing.assert_allclose(df["A.angle"], 6.0 * df["t"], atol=1e-9)
    np.testing.assert_allclose(df["crank_drive.coordinate_rate"], 6.0, atol=1e-9)
    assert df["crank_drive.effort"].isna().all() and df.attrs["units"]["D.translation"] == "m"


def test_driver_effort_sign_and_power_integrate_to_the_energy_change():
    """A motor raises the hanging... horizontal pendulum to 1.2 rad with a smooth step (the
    angle grows while gravity pulls down): positive work. Frictionless, so the integral of the
    driver power equals the change of T + V."""
    law = SmoothStep(t0=0.0, t1=1.0, f0=0.0, f1=1.2)
    model = pendulum(driver=law)
    res = simulate(model, 1.5, rtol=1e-10, atol=1e-12, output_step=0.001,
                   outputs=["drivers"])
    out = res.outputs()
    np.testing.assert_allclose(out["motor.coordinate"], law.evaluate_many([law], res.t)[0],
                               atol=1e-8)
    power = out["motor.power"].to_numpy()
    work = np.concatenate([[0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(res.t))])
    en = res.energy()
    e = en["kinetic"] + en["gravitational"]
    np.testing.assert_allclose(work, e - e[0], atol=1e-5 * np.abs(e - e[0]).max())
    assert work[-1] > 0.5 * M * G * L * np.sin(1.2)                # lifted against gravity
    # quasi-static check of the sign: at the end the motor holds the link at 1.2 rad against
    # the gravity moment -m g L cos(1.2) about x: the effort is +m g L cos(1.2)
    np.testing.assert_allclose(out["motor.effort"].to_numpy()[-1], M * G * L * np.cos(1.2),
                               rtol=1e-6)
    # the generalized force D^T lam of the driver is the moment effort * u on the link
    react = res.reactions()["motor"]
    np.testing.assert_allclose(react.moment_j[:, 0], out["motor.effort"], atol=1e-8)


def test_requests_are_checked():
    model = pendulum()
    with pytest.raises(ModelError, match="no joint named 'pivt'.*did you mean 'pivot'"):
        parse_outputs(model, [{"type": "joint", "of": "pivt"}])
    with pytest.raises(ModelError, match="kind 'jiont'"):
        Output("jiont", "pivot")
    with pytest.raises(ModelError, match="unknown key"):
        parse_outputs(model, [{"type": "joint", "of": "pivot", "frame": "x"}])
    with pytest.raises(ModelError, match="give one of them a 'name'"):
        parse_outputs(model, [{"type": "momentum", "of": "link"},
                              {"type": "momentum", "of": "link", "about": [0, 0, 0]}])
    with pytest.raises(ModelError, match="no point named"):
        parse_outputs(model, [{"type": "imu", "of": "link.nose"}])
    with pytest.raises(ModelError, match="unknown output 'everything'"):
        parse_outputs(model, ["everything"])
    with pytest.raises(ModelError, match="no joint named"):       # before the run starts
        simulate(model, 0.1, outputs=[{"type": "joint", "of": "nope"}])


def test_outputs_in_the_table_and_xarray(over_the_top):
    from spatialmbd.io.results_io import to_dataframe
    df = to_dataframe(over_the_top)
    assert "pivot.angle" in df.columns and "link.tip.imu.sfz" in df.columns
    assert "pivot.pendulum.fx" not in df.columns and "pivot.link.fx" in df.columns
    xr = pytest.importorskip("xarray")
    ds = over_the_top.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert ds["q"].dims == ("time", "body", "q_component")
    np.testing.assert_allclose(ds["pivot.angle"].values, df["pivot.angle"].to_numpy())
    assert ds["pivot.angle"].attrs["units"] == "rad"
    assert ds["v"].sel(body="link", v_component="wx").values[3] == over_the_top.v[3, 0, 3]


# ------------------------------------------------------------------ model files, files, CLI
PENDULUM_YAML = """\
spatialmbd: 1
name: pendulum
gravity: [0, 0, -9.81]
bodies:
  - name: link
    mass: 7.02
    inertia: [0.5855265, 0.0010530, 0.5855265]
    position: [0, 0.5, 0]
    points: {tip: [0, 0.5, 0]}
joints:
  - {name: pivot, type: revolute, body_i: ground, body_j: link, point: [0, 0, 0], axis: [1, 0, 0]}
forces:
  - {name: spiral, type: rotational_spring_damper, joint: pivot, stiffness: 20.0, damping: 0.1}
analysis:
  type: dynamic
  t_end: 0.5
  output_step: 0.01
  integrator: {name: rk45, rtol: 1.0e-8, atol: 1.0e-10}
outputs:
  - joints
  - {type: force, of: spiral}
  - {type: momentum, of: link, about: [0, 0, 0], name: h_pivot}
  - {type: imu, of: link.tip}
"""


def test_outputs_section_of_a_model_file_round_trip(tmp_path):
    from spatialmbd.io.modelfile import load_model, model_to_dict
    from spatialmbd.io.results_io import load_results, read_results, save_results
    path = tmp_path / "pendulum.yaml"
    path.write_text(PENDULUM_YAML)
    model, analysis = load_model(path)
    assert analysis.outputs[0] == "joints" and analysis.outputs[2]["about"] == [0, 0, 0]
    assert analysis.method == "auto"          # the default: recursive for trees, else projection
    again = model_to_dict(model, analysis)
    assert again["outputs"] == analysis.outputs
    res = analysis.run(model)
    assert res.settings["method"] == "recursive"         # a pendulum: an open tree
    h5, csv = tmp_path / "p.h5", tmp_path / "p.csv"
    save_results(res, h5, analysis=analysis)
    save_results(res, csv)
    df = read_results(h5)
    for c in ("pivot.angle", "spiral.torque", "h_pivot.hx", "link.tip.imu.sfz"):
        assert c in df.columns, c
    assert df.attrs["units"]["spiral.torque"] == "N m"
    assert df.attrs["units"]["pivot.angle_rate"] == "rad/s"
    assert df.attrs["units"]["link.x"] == "m"
    np.testing.assert_allclose(df["pivot.angle"], res.outputs()["pivot.angle"])
    import pandas as pd
    np.testing.assert_allclose(pd.read_csv(csv)["spiral.power"], df["spiral.power"])
    loaded = load_results(h5)
    assert loaded.metadata["outputs"][1] == {"type": "force", "of": "spiral"}
    m2, a2 = loaded.load_model()
    assert a2.outputs == analysis.outputs
    xr = pytest.importorskip("xarray")
    from spatialmbd.outputs import to_xarray
    ds = to_xarray(loaded)                                        # no model needed
    assert isinstance(ds, xr.Dataset) and list(ds["body"].values) == ["link"]
    np.testing.assert_allclose(ds["q"].values, res.q)
    assert ds["spiral.torque"].attrs["units"] == "N m"


def test_outputs_section_problems_are_reported(tmp_path):
    from spatialmbd.io.modelfile import ModelFileError, load_model
    path = tmp_path / "bad.yaml"
    path.write_text(PENDULUM_YAML.replace("{type: force, of: spiral}",
                                          "{type: force, of: spirl}")
                    .replace("- joints", "- {type: joint, of: pivot, frame: body}"))
    with pytest.raises(ModelFileError) as info:
        load_model(path)
    assert any("outputs[0]" in p and "unknown key" in p for p in info.value.problems)
    path.write_text(PENDULUM_YAML.replace("{type: force, of: spiral}",
                                          "{type: force, of: spirl}"))
    with pytest.raises(ModelFileError, match="no force element named 'spirl'.*'spiral'"):
        load_model(path)


def test_cli_plot_against_any_column(tmp_path, capsys):
    from spatialmbd.cli import main
    path = tmp_path / "pendulum.yaml"
    path.write_text(PENDULUM_YAML)
    h5 = tmp_path / "p.h5"
    assert main(["run", str(path), "-q", "-o", str(h5)]) == 0
    fig = tmp_path / "phase.svg"
    assert main(["plot", str(h5), "--x", "pivot.angle", "-y", "pivot.angle_rate",
                 "spiral.torque", "-o", str(fig), "-q"]) == 0
    assert capsys.readouterr().out == ""                          # -q: quiet
    svg = fig.read_text()
    assert "pivot.angle [rad]" in svg and "angle_rate [rad/s]" in svg and "torque [N m]" in svg
    from spatialmbd.io.results_io import load_results
    from spatialmbd.plotting import plot_results
    loaded = load_results(h5)
    f = plot_results(loaded, ["pivot.angle_rate"], x="pivot.angle")
    line = f.axes[0].lines[0]
    np.testing.assert_allclose(line.get_xdata(), loaded.table["pivot.angle"])
    np.testing.assert_allclose(line.get_ydata(), loaded.table["pivot.angle_rate"])
    assert main(["plot", str(h5), "--x", "pivot.angel", "-y", "pivot.angle_rate"]) == 2
    assert "did you mean pivot.angle" in capsys.readouterr().err
    # outputs requested on the command line, on top of the file's
    h5b = tmp_path / "q.h5"
    assert main(["run", str(path), "-q", "--outputs", "energy", "imu:link.tip", "-o",
                 str(h5b)]) == 0
    cols = load_results(h5b).table.columns
    assert "system.kinetic" in cols and "pivot.angle" in cols and "link.tip.imu.wx" in cols
    assert main(["run", str(path), "-q", "--outputs", "joint:pivt"]) == 2
    assert "did you mean 'pivot'" in capsys.readouterr().err
    assert main(["info", str(path)]) == 0
    assert "outputs: joint pivot, force spiral, momentum link, imu link.tip" in \
        capsys.readouterr().out
    # the old spelling -q QUANTITY still works, with a deprecation warning
    with pytest.warns(DeprecationWarning, match="use -y"):
        assert main(["plot", str(h5), "-q", "pivot.angle", "-o", str(tmp_path / "a.png")]) == 0
    assert "figure written" in capsys.readouterr().out


def test_progress_lines_in_logs_and_bar_on_terminals(monkeypatch):
    import io
    from spatialmbd.simulate import progress as sim
    clock = [0.0]
    monkeypatch.setattr(sim.time, "perf_counter", lambda: clock[0])
    log = io.StringIO()
    prog = sim._Progress(0.0, 10.0, stream=log)
    for k in range(2001):                        # 20 s of wall time, a call every 10 ms
        clock[0] = 0.01 * k
        prog(10.0 * k / 2000)
    prog.close()
    text = log.getvalue()
    lines = text.splitlines()
    assert "\r" not in text and 3 <= len(lines) <= 5              # first after 1 s, then 5 s
    assert lines[0].startswith("progress: t = ") and "of 10 s" in lines[0]

    class Terminal(io.StringIO):
        def isatty(self):
            return True
    term = Terminal()
    clock[0] = 0.0
    prog = sim._Progress(0.0, 10.0, stream=term)
    for k in range(300):
        clock[0] = 0.01 * k
        prog(k / 30)
    prog.close()
    assert prog.bar is not None and "\r" in term.getvalue()     # tqdm's bar


def test_point_force_torque_and_user_force_outputs():
    """A free body without gravity pushed by a point force (global x, 2 N at a body point),
    a torque (0.5 N m about body z) and a user force (-c rdot): power = f . v_P, n . omega,
    -c |rdot|^2."""
    c = 0.7

    def drag(t, q, v):
        return -c * v[:, :3], np.zeros((len(q), 3))

    b = ModelBuilder("pushed", gravity=(0, 0, 0))
    b.add_body("puck", 2.0, (0.1, 0.2, 0.25), r=(0, 0, 0), rdot=(0.1, 0.2, 0),
               omega=(0.3, 0, 0.5), points={"edge": (0.2, 0.1, 0)})
    b.add_force("point_force", "push", body="puck", point="edge", direction=(1, 0, 0),
                magnitude=2.0)
    b.add_force("torque", "twist", body="puck", direction=(0, 0, 1), magnitude=0.5,
                frame="body")
    b.add_force("user", "drag", function=drag)
    model = b.compile()
    res = simulate(model, 1.0, rtol=1e-9, atol=1e-11, output_step=0.05, outputs="forces")
    out = res.outputs()
    vP = res.point("puck.edge")["rdot"]
    np.testing.assert_allclose(out["push.fx"], 2.0)
    np.testing.assert_allclose(out["push.power"], 2.0 * vP[:, 0], atol=1e-12)
    from spatialmbd.rotations import A_from_p
    z_body = A_from_p(res.q[:, 0, 3:])[:, :, 2]
    np.testing.assert_allclose(out[["twist.mx", "twist.my", "twist.mz"]].to_numpy(),
                               0.5 * z_body, atol=1e-12)
    np.testing.assert_allclose(out["twist.power"],
                               0.5 * np.einsum("ni,ni->n", z_body, res.v[:, 0, 3:]), atol=1e-12)
    np.testing.assert_allclose(out["drag.power"], -c * np.sum(res.v[:, 0, :3] ** 2, axis=1),
                               atol=1e-12)
    # the three powers are all the power there is: they integrate to the kinetic energy
    power = (out["push.power"] + out["twist.power"] + out["drag.power"]).to_numpy()
    en = res.energy()["kinetic"]
    h = res.t[1] - res.t[0]
    work = np.concatenate([[0], np.cumsum(h / 2 * (power[1:] + power[:-1]))])
    np.testing.assert_allclose(work, en - en[0], atol=2e-3 * np.abs(en - en[0]).max())


def test_bushing_outputs_obey_newton_euler(monkeypatch):
    """A mass held at its centre of mass by a bushing to the ground (axes = global), no
    gravity: the force and moment the bushing reports on the mass are m rddot and
    J omegadot + omega x J omega; its power integrates to the kinetic energy change and its
    energy is 1/2 delta^T K delta + 1/2 theta^T K_r theta."""
    from spatialmbd import outputs as outputs_module
    m, J = 3.0, np.diag([0.2, 0.3, 0.4])
    k, c, kr, cr = (300.0, 500.0, 700.0), (2.0, 1.0, 3.0), (20.0, 30.0, 40.0), (0.1, 0.2, 0.1)
    b = ModelBuilder("mount", gravity=(0, 0, 0))
    b.add_body("mass", m, (0.2, 0.3, 0.4), r=(0, 0, -0.5), rdot=(0.05, -0.02, 0.03),
               omega=(0.4, -0.3, 0.6))
    b.add_force("bushing", "mount", body_i="ground", body_j="mass", point_i=(0, 0, -0.5),
                stiffness=k, damping=c, rotational_stiffness=kr, rotational_damping=cr)
    model = b.compile()
    res = simulate(model, 0.5, rtol=1e-10, atol=1e-12, output_step=0.002, outputs="forces")
    out = res.outputs()
    delta = res.q[:, 0, :3] - np.array([0, 0, -0.5])
    np.testing.assert_allclose(out[["mount.dx", "mount.dy", "mount.dz"]], delta, atol=1e-12)
    f = out[["mount.fx", "mount.fy", "mount.fz"]].to_numpy()
    np.testing.assert_allclose(f, m * res.vdot[:, 0, :3], atol=1e-8)
    from spatialmbd.rotations import A_from_p
    A = A_from_p(res.q[:, 0, 3:])
    Jg = A @ J @ np.swapaxes(A, 1, 2)
    w, wd = res.v[:, 0, 3:], res.vdot[:, 0, 3:]
    moment = np.einsum("nij,nj->ni", Jg, wd) + np.cross(w, np.einsum("nij,nj->ni", Jg, w))
    np.testing.assert_allclose(out[["mount.mx", "mount.my", "mount.mz"]], moment, atol=1e-8)
    theta = out[["mount.rx", "mount.ry", "mount.rz"]].to_numpy()
    np.testing.assert_allclose(out["mount.energy"],
                               0.5 * (delta**2 @ np.array(k) + theta**2 @ np.array(kr)),
                               atol=1e-12)
    kin = res.energy()["kinetic"]
    power = out["mount.power"].to_numpy()
    h = res.t[1] - res.t[0]
    # composite Simpson over pairs of steps: the work at the even output times
    work = np.concatenate([[0], np.cumsum(h / 3 * (power[:-2:2] + 4 * power[1:-1:2]
                                                    + power[2::2]))])
    change = kin[::2][:work.size] - kin[0]
    np.testing.assert_allclose(work, change, atol=1e-6 * np.abs(change).max())
    # a force type without outputs of its own (one element): power and energy of the group
    monkeypatch.delitem(outputs_module.QUANTITIES, "bushing")
    generic = res.outputs()
    assert list(generic.columns) == ["t", "mount.power", "mount.energy"]
    np.testing.assert_allclose(generic["mount.power"], out["mount.power"], atol=1e-10)
    np.testing.assert_allclose(generic["mount.energy"], out["mount.energy"], atol=1e-12)


def test_screw_joint_coordinates_follow_the_thread():
    """A nut falling on a vertical screw of pitch h (m/rev): translation = z - z0 = 1/2 a t^2
    with a = -m g / (m + I_z (2 pi / h)^2) (energy), angle = 2 pi translation / h."""
    m, Iz, g, h = 2.0, 0.05, 9.81, 0.5
    b = ModelBuilder("nut", gravity=(0, 0, -g))
    b.add_body("nut", mass=m, inertia=(0.03, 0.03, Iz), r=(0, 0, 1.0))
    b.add_joint("screw", "thread", "ground", "nut", point=(0, 0, 1.0), axis=(0, 0, 1),
                pitch=h)
    res = simulate(b.compile(), 1.2, rtol=1e-10, atol=1e-12, output_step=0.05,
                   outputs="joints")
    out = res.outputs()
    a = -m * g / (m + Iz * (2 * np.pi / h) ** 2)
    np.testing.assert_allclose(out["thread.translation"], 0.5 * a * res.t**2, atol=1e-8)
    np.testing.assert_allclose(out["thread.translation_rate"], a * res.t, atol=1e-8)
    np.testing.assert_allclose(out["thread.angle"], 2 * np.pi * 0.5 * a * res.t**2 / h,
                               atol=1e-7)                         # several turns: unwrapped
    assert out["thread.angle"].min() < -4 * np.pi


def test_every_column_is_in_the_one_vocabulary(over_the_top):
    """Results.to_dataframe, the results file's table, the sweep's columns and the plots'
    panels use the names and units of one vocabulary (spatialmbd.outputs.vocabulary)."""
    from spatialmbd.io.results_io import to_dataframe
    from spatialmbd.outputs.vocabulary import describe_column
    from spatialmbd.plotting import _kind, _pretty
    from spatialmbd.sweep.outputs import Columns
    res = simulate(pendulum(omega0=2.0, spring=dict(stiffness=3.0, damping=0.2)), 0.2,
                   output_step=0.05, outputs=["joints", "forces", "momentum", "bodies",
                                              {"type": "imu", "of": "link.tip"}])
    for result in (over_the_top, res):
        df = result.to_dataframe()
        units = df.attrs["units"]
        assert any(c.startswith("spiral.") for c in df.columns) or result is over_the_top
        for where, table in (("Results.to_dataframe", df), ("results file", to_dataframe(result))):
            unknown = [c for c in table.columns if describe_column(c, units) is None]
            assert not unknown, (where, unknown)
        columns = Columns(result)                     # a sweep reads each by its name
        for c in df.columns:
            np.testing.assert_array_equal(columns.get(c), df[c].to_numpy())
        for c in df.columns:                          # a plot labels each with its unit
            what, unit = describe_column(c, units)
            if c != "t" and unit != "1":
                assert _pretty(unit) in _kind(c, units)[1], (c, unit, _kind(c, units))
