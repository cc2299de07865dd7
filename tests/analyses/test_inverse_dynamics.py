"""Inverse dynamics: driver efforts and reactions against closed forms derived here."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.analyses import inverse_dynamics
from spatialmbd.analyses.inverse import NonUniqueEffortsWarning
from spatialmbd.errors import ModelError
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.motion import ConstantVelocity, UserFunction
from spatialmbd.simulate import simulate

G = 9.81
M_ROD, L_ROD = 2.0, 0.8
# theta(t) = t + t^2/2 - 0.3 t^3 (rad)
POLY = [0.0, 1.0, 0.5, -0.3]


def theta(t):
    return t + 0.5 * t**2 - 0.3 * t**3


def theta_d(t):
    return 1.0 + t - 0.9 * t**2


def theta_dd(t):
    return 1.0 - 1.8 * t


def pendulum(driven=True, spring=None):
    """Uniform rod (m = 2 kg, L = 0.8 m) pinned at one end at the origin about global x, lying
    along +y at theta = 0; gravity -z. theta rotates +y towards +z."""
    b = ModelBuilder("compound_pendulum", gravity=(0, 0, -G))
    b.add_body("rod", M_ROD, (M_ROD * L_ROD**2 / 12, 1e-4, M_ROD * L_ROD**2 / 12),
               r=(0, L_ROD / 2, 0), points={"tip": (0, L_ROD / 2, 0)})
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    if driven:
        b.add_driver("angle", "motor", {"type": "polynomial", "coefficients": POLY},
                     joint="pivot")
    if spring:
        b.add_force("rotational_spring_damper", "spring", joint="pivot", **spring)
    return b


def pendulum_torque(t):
    """Closed form: I_O theta'' = tau - m g (L/2) cos(theta), I_O = m L^2 / 3; the CoM height
    is (L/2) sin(theta)."""
    return M_ROD * L_ROD**2 / 3 * theta_dd(t) + M_ROD * G * L_ROD / 2 * np.cos(theta(t))


def test_driven_compound_pendulum_torque_matches_closed_form_at_every_time():
    model = pendulum().compile()
    t = np.linspace(0.0, 2.0, 41)
    res = inverse_dynamics(model, t)
    assert res.unique and res.status == "success"
    assert np.abs(res.efforts["motor"].to_numpy() - pendulum_torque(t)).max() < 1e-10
    # sign convention: power = effort * d(theta)/dt, so positive effort while theta increases
    # does positive work
    assert np.allclose(res.power["motor"], pendulum_torque(t) * theta_d(t), atol=1e-10)
    # the pivot reaction balances the rod: f = m a_G - m g - (driver force, zero)
    a = res.results.body("rod")["rddot"]
    f_pivot = res.reactions["pivot"].force_j
    assert np.allclose(f_pivot, M_ROD * a - M_ROD * np.array([0, 0, -G]), atol=1e-9)
    assert res.units["motor"] == "N m"
    assert "motor" in res.summary()


def test_energy_balance_with_spring_and_damper():
    model = pendulum(spring=dict(stiffness=15.0, damping=0.7, rest_angle=0.2)).compile()
    t = np.linspace(0.0, 2.0, 201)
    res = inverse_dynamics(model, t)
    en = res.energy()
    scale = np.abs(en["work_efforts"]).max()
    assert scale > 1.0
    assert np.abs(en["error"]).max() < 1e-6 * scale
    # the efforts now also carry the spring and damper: closed form
    th = theta(t)
    tau = pendulum_torque(t) + 15.0 * (th - 0.2) + 0.7 * theta_d(t)
    assert np.abs(res.efforts["motor"].to_numpy() - tau).max() < 1e-9


def test_unbalanced_rotor_has_zero_drive_torque_and_closed_form_bearing_moment():
    """A body spinning at constant Omega about global z through its centre of mass, principal
    axes tilted by alpha about y. J e_z = ((I3 - I1) s c, 0, I1 s^2 + I3 c^2) in the
    assembled pose, so the bearing moment omega x J omega has magnitude
    Omega^2 |I3 - I1| sin(alpha) cos(alpha), normal to the axis, and no drive torque."""
    I1, I2, I3, alpha, Omega = 0.3, 0.5, 0.7, 0.35, 12.0
    c, s = np.cos(alpha), np.sin(alpha)
    b = ModelBuilder("rotor", gravity=(0, 0, -G))
    b.add_body("rotor", 5.0, (I1, I2, I3), r=(0, 0, 0.4),
               A=[[c, 0, s], [0, 1, 0], [-s, 0, c]])
    b.add_joint("revolute", "bearing", "ground", "rotor", point=(0, 0, 0.4), axis=(0, 0, 1))
    b.add_driver("angle", "drive", ConstantVelocity(rate=Omega), joint="bearing")
    model = b.compile()
    t = np.linspace(0, 1.0, 23)
    res = inverse_dynamics(model, t)
    assert np.abs(res.efforts["drive"]).max() < 1e-9
    moment = res.reactions["bearing"].moment_j
    expected = Omega**2 * abs(I3 - I1) * s * c
    assert np.allclose(np.linalg.norm(moment, axis=1), expected, rtol=1e-10)
    assert np.abs(moment[:, 2]).max() < 1e-9
    # the bearing force carries the weight only
    assert np.allclose(res.reactions["bearing"].force_j, [[0, 0, 5.0 * G]], atol=1e-9)


def virtual_work_power(model, kin):
    """sum over bodies of (m a - m g) . v + omega . (J omegadot + omega x J omega): the power
    the single driver must deliver, from the kinematic analysis alone (no multipliers)."""
    from spatialmbd.rotations import A_from_p
    power = np.zeros(kin.t.size)
    for k in range(model.nb):
        m = model.mass[k]
        v, a = kin.v[:, k, :3], kin.vdot[:, k, :3]
        w, wd = kin.v[:, k, 3:], kin.vdot[:, k, 3:]
        A = A_from_p(kin.q[:, k, 3:])
        J = A @ model.inertia[k] @ np.swapaxes(A, 1, 2)
        Jw = np.einsum("nij,nj->ni", J, w)
        Jwd = np.einsum("nij,nj->ni", J, wd)
        power += np.sum((m * a - m * model.gravity) * v, axis=1)
        power += np.sum(w * (Jwd + np.cross(w, Jw)), axis=1)
    return power


def test_bricard_with_redundant_joints_has_unique_torque_from_virtual_work():
    """Bricard linkage (one redundant joint equation) driven at joint O: the redundancy is
    among the joints, so the effort is still unique and equals the virtual-work torque."""
    b = models.bricard()
    b.add_driver("angle", "drive", ConstantVelocity(rate=0.8), joint="O")
    model = b.compile()
    t = np.linspace(0.0, 1.5, 16)
    with pytest.warns(NonUniqueEffortsWarning, match="efforts are unique"):
        res = inverse_dynamics(model, t)
    assert res.unique
    tau = virtual_work_power(model, kinematic_analysis(model, t, tol=1e-12)) / 0.8
    assert np.abs(res.efforts["drive"].to_numpy() - tau).max() < 1e-8 * np.abs(tau).max()
    assert not res.reactions["P5"].unique


def test_slider_crank_crank_torque_equals_virtual_work_of_inertia_and_gravity():
    """tau * thetadot = sum over bodies of (m a - m g) . v + omega . (J omegadot + omega x J
    omega), from the kinematic analysis alone (no multipliers)."""
    omega = 6.0
    model = models.slider_crank(crank_speed=omega).compile()
    t = np.linspace(0, 2 * np.pi / omega, 61)
    res = inverse_dynamics(model, t)
    kin = kinematic_analysis(model, t, tol=1e-12)
    power = virtual_work_power(model, kin)
    tau = power / omega
    assert np.abs(res.efforts["crank_drive"].to_numpy() - tau).max() < 1e-9 * max(
        1.0, np.abs(tau).max())
    en = res.energy()
    assert np.abs(en["error"]).max() < 1e-4 * np.abs(en["work_efforts"]).max() + 1e-9


def test_round_trip_efforts_as_forces_reproduce_the_motion():
    """Double pendulum driven at both joints; the efforts applied as forces to the model
    without drivers reproduce the prescribed motion in a forward simulation."""
    b = ModelBuilder("dp", gravity=(0, 0, -G))
    b.add_body("bar1", 1.0, (1 / 12, 1e-4, 1 / 12), r=(0, 0.5, 0))
    b.add_body("bar2", 1.0, (1e-4, 1 / 12, 1 / 12), r=(0.5, 1.0, 0))
    b.add_joint("revolute", "shoulder", "ground", "bar1", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_joint("revolute", "elbow", "bar1", "bar2", point=(0, 1, 0), axis=(0, 1, 0))
    free = b.compile()
    b.add_driver("angle", "d1", {"type": "harmonic", "amplitude": 0.6, "frequency": 3.0},
                 joint="shoulder")
    b.add_driver("angle", "d2", {"type": "polynomial", "coefficients": [0, 0.5, 0.4]},
                 joint="elbow")
    model = b.compile()
    t = np.linspace(0.0, 1.0, 201)
    res = inverse_dynamics(model, t)
    b2 = free.to_builder()
    b2.add_force("user", "efforts", function=res.as_user_force())
    fwd = simulate(b2.compile(), 1.0, t_eval=t, q0=res.q[0], v0=res.v[0], rtol=1e-10,
                   atol=1e-12, correct_initial=False)
    assert fwd.success
    assert np.abs(fwd.q - res.q).max() < 1e-6


def test_prescribed_motion_table_of_joint_angles():
    """Samples of theta(t) for the undriven pendulum's joint "pivot": the spline reproduces the
    closed-form torque between the samples."""
    model = pendulum(driven=False).compile()
    ts = np.linspace(0.0, 2.0, 401)
    table = {"t": ts, "pivot": theta(ts)}
    t_out = np.linspace(0.2, 1.8, 17)
    res = inverse_dynamics(model, t_out, motion=table)
    assert list(res.efforts.columns) == ["t", "pivot_drive"]
    assert np.abs(res.efforts["pivot_drive"].to_numpy() - pendulum_torque(t_out)).max() < 1e-4


def test_redundant_drivers_give_minimum_norm_efforts_and_a_flag():
    """Angle driver plus a consistent z-coordinate driver of the CoM (z = (L/2) sin theta): any
    split with lam_a + lam_z (L/2) cos(theta) = tau balances the rod; the minimum-norm one is
    lam_a = tau / (1 + c^2), lam_z = tau c / (1 + c^2) with c = (L/2) cos(theta)."""
    b = pendulum()
    h = L_ROD / 2
    b.add_driver("coordinate", "lift", UserFunction(
        f=lambda t: h * np.sin(theta(t)),
        fdot=lambda t: h * np.cos(theta(t)) * theta_d(t),
        fddot=lambda t: h * (np.cos(theta(t)) * theta_dd(t) - np.sin(theta(t)) * theta_d(t)**2)),
        body="rod", coordinate="z")
    model = b.compile()
    t = np.linspace(0.0, 1.0, 11)
    with pytest.warns(NonUniqueEffortsWarning):
        res = inverse_dynamics(model, t)
    assert not res.unique
    c = h * np.cos(theta(t))
    tau = pendulum_torque(t)
    assert np.allclose(res.efforts["motor"], tau / (1 + c**2), atol=1e-8)
    assert np.allclose(res.efforts["lift"], tau * c / (1 + c**2), atol=1e-8)


def test_under_driven_mechanism_is_an_error_naming_the_free_joint():
    b = ModelBuilder("dp", gravity=(0, 0, -G))
    b.add_body("bar1", 1.0, (1 / 12, 1e-4, 1 / 12), r=(0, 0.5, 0))
    b.add_body("bar2", 1.0, (1 / 12, 1e-4, 1 / 12), r=(0, 1.5, 0))
    b.add_joint("revolute", "shoulder", "ground", "bar1", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_joint("revolute", "elbow", "bar1", "bar2", point=(0, 1, 0), axis=(1, 0, 0))
    b.add_driver("angle", "d1", 0.0, joint="shoulder")
    with pytest.raises(ModelError, match=r"mobility 2.*1 driver.*elbow"):
        inverse_dynamics(b.compile(), [0.0, 0.1])


def test_motion_table_replaces_a_driver_law():
    """Samples of the crank angle 6 t for the slider-crank's own driver: the same torque as
    with its constant-velocity law (the spline of a straight line is exact)."""
    model = models.slider_crank(crank_speed=6.0).compile()
    t = np.linspace(0.0, 1.0, 21)
    direct = inverse_dynamics(model, t)
    ts = np.linspace(0.0, 1.0, 11)
    table = inverse_dynamics(model, t, motion={"t": ts, "crank_drive": 6.0 * ts})
    assert np.abs(table.efforts["crank_drive"] - direct.efforts["crank_drive"]).max() < 1e-9
    with pytest.raises(ModelError, match="names no driver, joint or body coordinate"):
        inverse_dynamics(model, t, motion={"t": ts, "crank": ts})


def test_motion_table_of_a_body_coordinate():
    """The CoM height z = (L/2) sin(theta(t)) of the undriven pendulum prescribed by a table:
    a vertical force F at the CoM drives it, F (L/2) cos(theta) = tau of the closed form."""
    model = pendulum(driven=False).compile()
    ts = np.linspace(0.0, 1.2, 601)
    t_out = np.linspace(0.1, 1.1, 11)
    res = inverse_dynamics(model, t_out, motion={"t": ts, "rod.z": L_ROD / 2 * np.sin(theta(ts))})
    force = res.efforts["rod_z_drive"].to_numpy()
    assert res.units["rod_z_drive"] == "N"
    expected = pendulum_torque(t_out) / (L_ROD / 2 * np.cos(theta(t_out)))
    assert np.abs(force - expected).max() < 1e-4 * np.abs(expected).max()
