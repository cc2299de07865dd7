"""Couplers (constraints.couplers): the kernel against finite differences, a gear train over
many revolutions (kinematics and dynamics against closed forms), rack and pinion, the reaction
torques of a gear pair, model files, MJCF joint equalities, bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder, ModelError
from spatialmbd.io.modelfile import ModelFileError, load_model, model_to_dict, save_model
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.motion import ConstantVelocity
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate

from fd_check import WrapJump, derivative_errors, random_state


def gears(ratio=-0.5, I1=0.2, I2=0.3, torque=None):
    b = ModelBuilder("gears", gravity=(0, 0, 0))
    b.add_body("g1", 1.0, (0.15, 0.15, I1))
    b.add_body("g2", 1.0, (0.2, 0.2, I2), r=(0.3, 0, 0))
    b.add_joint("revolute", "j1", "ground", "g1", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "j2", "ground", "g2", point=(0.3, 0, 0), axis=(0, 0, 1))
    b.add_coupler("gear", "mesh", "j1", "j2", ratio=ratio)
    if torque is not None:
        b.add_force("torque", "motor", body="g1", direction=(0, 0, 1), magnitude=torque)
    return b


def rack_pinion(radius=0.05, m=2.0, I=0.01, force=None):
    b = ModelBuilder("rack", gravity=(0, 0, 0))
    b.add_body("pinion", 0.5, (I, I, I))
    b.add_body("rack", m, (0.01, 0.02, 0.02), r=(0, -radius, 0))
    b.add_joint("revolute", "shaft", "ground", "pinion", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "slide", "ground", "rack", point=(0, -radius, 0),
                axis=(1, 0, 0))
    b.add_coupler("rack_pinion", "teeth", "shaft", "slide", radius=radius)
    if force is not None:
        b.add_force("point_force", "push", body="rack", direction=(1, 0, 0), magnitude=force)
    return b


def z_angle(q):
    A = A_from_p(q[3:])
    return math.atan2(A[1, 0], A[0, 0])


@pytest.mark.parametrize("make", [gears, rack_pinion])
def test_kernel_matches_finite_differences(make):
    """Random states of the two bodies (the joints violated as much as anything else)."""
    model = make().compile()
    group = [g for g in model.constraint_groups if g.coupler][0]
    rng = np.random.default_rng(11)
    checked = 0
    while checked < 20:
        q0, v = random_state(rng, model.nb)
        try:
            e1, e2, scale = derivative_errors(group, q0, v, t0=0.0)
        except WrapJump:                   # an angle's wrap inside the stencil: draw again
            continue
        assert e1 < 1e-8 * scale and e2 < 1e-6 * scale, (e1, e2, scale)
        checked += 1


def test_gear_train_kinematics_over_many_revolutions():
    model = gears(ratio=-0.5)
    model.add_driver("angle", "input", ConstantVelocity(3.0), joint="j1")
    model = model.compile()
    t = np.linspace(0.0, 10.0, 201)                       # 30 rad in: almost 5 turns
    kin = kinematic_analysis(model, t)
    th1 = np.unwrap([z_angle(q) for q in kin.q[:, 0]])
    th2 = np.unwrap([z_angle(q) for q in kin.q[:, 1]])
    assert np.abs(th1 - 3.0 * t).max() < 1e-10
    assert np.abs(th2 + 0.5 * th1).max() < 1e-10
    assert np.abs(kin.v[:, 1, 5] + 1.5).max() < 1e-12
    assert np.abs(kin.vdot[:, 1, 5]).max() < 1e-10


def test_geared_flywheels_accelerate_with_the_reflected_inertia():
    """Torque tau on gear 1: (I1 + r^2 I2) alpha1 = tau, alpha2 = r alpha1 (energy: the
    coupler does no work); 5 revolutions, the coupling held to round-off."""
    I1, I2, r, tau = 0.2, 0.3, -0.5, 2.0
    model = gears(r, I1, I2, tau).compile()
    res = simulate(model, 3.0, rtol=1e-10, atol=1e-12, output_step=0.01)
    assert res.success, res.message
    a1 = tau / (I1 + r * r * I2)
    th1 = np.unwrap([z_angle(q) for q in res.q[:, 0]])
    th2 = np.unwrap([z_angle(q) for q in res.q[:, 1]])
    assert th1[-1] == pytest.approx(0.5 * a1 * 9.0, rel=1e-9)       # 32.7 rad
    assert np.abs(th2 - r * th1).max() < 1e-9
    assert np.abs(res.v[:, 0, 5] - a1 * res.t).max() < 1e-9
    assert res.constraint_violation()["position"].max() < 1e-9       # unwrapped along
    assert np.abs(res.energy()["error"]).max() < 1e-9
    # reactions: the mesh torque on gear 2 drives it, I2 alpha2; on gear 1 it is I1 a1 - tau
    rx = res.reactions()["mesh"]
    assert np.allclose(rx.moment_i[:, 2], I1 * a1 - tau, atol=1e-8)
    assert np.allclose(rx.moment_j[:, 2], I2 * r * a1, atol=1e-8)


def test_rack_and_pinion():
    R, m, I, F = 0.05, 2.0, 0.01, 3.0
    b = rack_pinion(R, m, I)
    b.add_driver("angle", "turn", ConstantVelocity(2.0), joint="shaft")
    kin = kinematic_analysis(b.compile(), np.linspace(0, 5, 51))           # 10 rad
    x = kin.q[:, 1, 0]
    assert np.abs(x - R * 2.0 * np.linspace(0, 5, 51)).max() < 1e-12
    # a force on the rack: a = F / (m + I / R^2)
    res = simulate(rack_pinion(R, m, I, F).compile(), 2.0, rtol=1e-10, atol=1e-12,
                   output_step=0.1)
    a = F / (m + I / R ** 2)
    assert np.abs(res.q[:, 1, 0] - 0.5 * a * res.t ** 2).max() < 1e-9


def test_model_files_and_bad_input(tmp_path):
    model = gears(torque=1.0).compile()
    path = save_model(model, tmp_path / "gears.yaml")
    back, _ = load_model(path)
    assert model_to_dict(back) == model_to_dict(model)
    d = model_to_dict(model)
    for change, match in [(dict(joint2="nope"), "unknown joint 'nope'"),
                          (dict(type="bevel"), "unknown coupler type 'bevel'"),
                          (dict(ratio=0.0), "must not be zero"),
                          (dict(radius=1.0), "radius")]:
        bad = {**d, "couplers": [dict(d["couplers"][0], **change)]}
        with pytest.raises(ModelFileError, match=match):
            load_model(bad)
    b = gears()
    with pytest.raises(ModelError, match="needs a translational joint"):
        b.add_coupler("rack_pinion", "x", "j1", "j2", radius=0.1)
    b.add_body("carrier", 1.0, (0.1, 0.1, 0.1))
    b.add_joint("revolute", "j3", "carrier", "g1", point=(0, 0, 0), axis=(0, 0, 1))
    with pytest.raises(ModelError, match="at most two moving bodies"):
        b.add_coupler("gear", "planet", "j3", "j2", ratio=2.0)


MJCF_COUPLED = """<mujoco><option gravity="0 0 -9.81" timestep="1e-4" integrator="RK4"/>
<worldbody>
  <body name="a" pos="0 0 0"><joint name="ha" type="hinge" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02" density="1000"/></body>
  <body name="b" pos="0 0.3 0"><joint name="hb" type="hinge" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" density="1000"/></body>
</worldbody>
<equality><joint joint1="hb" joint2="ha" polycoef="0 -0.5 0 0 0" solref="0.0005 1"/></equality>
</mujoco>"""


def test_mjcf_joint_equality_becomes_an_exact_coupler():
    """Two pendulums on hinges coupled q_b = -q_a / 2 (MJCF joint equality): imported as a
    coupler; the motion agrees with MuJoCo's own (stiff soft equality, RK4 at 1e-4 s) to the
    accuracy its soft coupling allows."""
    mujoco = pytest.importorskip("mujoco")
    import warnings
    from spatialmbd.importers.mjcf import read_mjcf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        imp = read_mjcf(MJCF_COUPLED)
    assert [c.type for c in imp.builder.couplers.values()] == ["coupler"]
    model = imp.builder.compile()
    res = simulate(model, 0.5, rtol=1e-10, atol=1e-12, output_step=0.05)
    m, d = imp.mj_model, mujoco.MjData(imp.mj_model)
    qa, qb = [], []
    for k in range(len(res.t)):
        while d.time < res.t[k] - 1e-12:
            mujoco.mj_step(m, d)
        qa.append(d.qpos[0])
        qb.append(d.qpos[1])
    def about_y(k, body):               # rotation about y since t = 0 (hinge angle)
        R = A_from_p(res.q[k, body, 3:]) @ A_from_p(res.q[0, body, 3:]).T
        return math.atan2(R[0, 2], R[0, 0])
    ours_a = np.array([about_y(k, 0) for k in range(len(res.t))])
    ours_b = np.array([about_y(k, 1) for k in range(len(res.t))])
    assert np.abs(ours_b + 0.5 * ours_a).max() < 1e-9                 # exact here
    assert np.abs(ours_a - np.array(qa)).max() < 5e-3                 # MuJoCo's is soft
    assert np.abs(ours_b - np.array(qb)).max() < 5e-3
    assert ours_a[-1] > 0.3                                          # it did swing


def test_batch_integration_refuses_couplers():
    from spatialmbd.sweep.batch import BatchSetup
    with pytest.raises(ModelError, match="couplers \\(mesh\\)"):
        BatchSetup(gears().compile(), "standard", {})


def test_gear_train_example_with_rack():
    """models.gear_train: gear 1 -> gear 2 (ratio -1/2) -> rack (radius 0.2): the motor torque
    tau sees I1 + r^2 I2 + (r R)^2 m_rack; the rack moves r R theta1."""
    from spatialmbd import models
    res = simulate(models.gear_train(2.0).compile(), 3.0, rtol=1e-10, atol=1e-12,
                   output_step=0.05)
    a1 = 2.0 / (0.2 + 0.25 * 0.3 + 0.25 * 0.04 * 1.5)
    assert np.abs(res.v[:, 0, 5] - a1 * res.t).max() < 1e-8
    assert np.abs(res.q[:, 2, 0] - 0.3 - 0.5 * a1 * res.t ** 2 * (-0.5) * 0.2).max() < 1e-8


def test_analyses_leave_the_shared_references_as_found():
    """constraint_violation and kinematic_analysis unwrap the gear angles in the model's
    shared assembler; afterwards a position solve at the assembled state must not move it."""
    from spatialmbd.kinematics import solve_positions
    model = gears(torque=2.0).compile()
    res = simulate(model, 3.0, rtol=1e-10, atol=1e-12, output_step=0.01)   # 5 turns
    res.constraint_violation()
    q, _ = solve_positions(model, model.q0, 0.0, 1e-12, 30)
    assert np.abs(q - model.q0).max() < 1e-12
    driven = gears()
    driven.add_driver("angle", "input", ConstantVelocity(3.0), joint="j1")
    driven = driven.compile()
    kinematic_analysis(driven, np.linspace(0.0, 10.0, 101))
    q, _ = solve_positions(driven, driven.q0, 0.0, 1e-12, 30)
    assert np.abs(q - driven.q0).max() < 1e-12
