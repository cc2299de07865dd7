"""Linearization and modes against closed forms derived here."""
import numpy as np
import pytest
import scipy.linalg as sla

from spatialmbd import ModelBuilder
from spatialmbd.analyses import linearize, modes, static_equilibrium
from spatialmbd.analyses.linearize import NotEquilibriumError
from spatialmbd.models import HEAVY_TOP, heavy_top

G = 9.81


def double_pendulum(m=1.0, L=1.0):
    """Two uniform rods (m, L) hanging along -z, revolute joints about global x."""
    b = ModelBuilder("double_pendulum_rods", gravity=(0, 0, -G))
    inertia = (m * L**2 / 12, m * L**2 / 12, 1e-6)
    b.add_body("bar1", m, inertia, r=(0, 0, -L / 2))
    b.add_body("bar2", m, inertia, r=(0, 0, -1.5 * L))
    b.add_joint("revolute", "shoulder", "ground", "bar1", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_joint("revolute", "elbow", "bar1", "bar2", point=(0, 0, -L), axis=(1, 0, 0))
    return b.compile()


def test_double_pendulum_of_uniform_rods_matches_closed_form_frequencies():
    """Small angles theta1, theta2 from the vertical: T gives M = m L^2 [[4/3, 1/2], [1/2, 1/3]],
    V gives K = m g L diag(3/2, 1/2); det(K - w^2 M) = 0 is 7 l^2 - 42 l + 27 = 0 with
    l = w^2 L / g."""
    m, L = 1.0, 1.0
    md = modes(double_pendulum(m, L))
    lam = np.array([3 - np.sqrt(1008) / 14, 3 + np.sqrt(1008) / 14])
    omega = np.sqrt(lam * G / L)
    assert np.allclose(md.table["omega_n"], omega, rtol=1e-8)
    assert np.allclose(md.frequencies_hz, omega / (2 * np.pi), rtol=1e-8)
    assert list(md.table["kind"]) == ["oscillatory", "oscillatory"]
    assert np.allclose(md.table["damping_ratio"], 0.0)
    # mode shapes: theta2/theta1 from (K - w^2 M) phi = 0, first row
    Mc = m * L**2 * np.array([[4 / 3, 1 / 2], [1 / 2, 1 / 3]])
    Kc = m * G * L * np.diag([1.5, 0.5])
    for k in range(2):
        ratio = -(Kc[0, 0] - omega[k]**2 * Mc[0, 0]) / (Kc[0, 1] - omega[k]**2 * Mc[0, 1])
        shape = md.shapes[:, k].real.reshape(2, 6)
        assert shape[1, 3] / shape[0, 3] == pytest.approx(ratio, rel=1e-6)
    # the same frequencies with partitioned coordinates, named after body coordinates
    lin = linearize(double_pendulum(m, L), coordinates="partition")
    assert all("." in c for c in lin.coordinates)
    w2 = sla.eigh(lin.K, lin.M, eigvals_only=True)
    assert np.allclose(np.sqrt(w2), omega, rtol=1e-8)


def _top(spin):
    return heavy_top(theta=0.0, spin=spin, precession=0.0).compile()


def test_sleeping_top_stability_threshold_matches_gyroscopic_closed_form():
    """Top on its tip, axis vertical, spin Omega. Small tilts x, y of the axis:
    A x'' + C Omega y' - m g l x = 0, A y'' - C Omega x' - m g l y = 0 (A = I1 + m l^2 about
    the tip, C = I3); x + i y = e^{i w t} needs A w^2 - C Omega w + m g l = 0: real w, stable,
    iff C^2 Omega^2 > 4 A m g l."""
    p = HEAVY_TOP
    m, l, I1, C = p["mass"], p["l"], p["I1"], p["I3"]
    A = I1 + m * l**2
    critical = np.sqrt(4 * A * m * G * l) / C
    assert modes(_top(1.02 * critical), steady=True).stable
    below = modes(_top(0.98 * critical), steady=True)
    assert not below.stable and (below.table["kind"] == "unstable").sum() == 1
    spin = 50.0
    md = modes(_top(spin), steady=True)
    w = np.sort(np.roots([A, -C * spin, m * G * l]).real)
    osc = np.sort(md.table.loc[md.table["kind"] == "oscillatory", "omega_n"].to_numpy())
    assert np.allclose(osc, w, rtol=1e-7)
    # the spin about the axis itself is a rigid-body mode
    assert (md.table["kind"] == "rigid-body").sum() == 1


def test_analytic_and_finite_difference_derivatives_agree():
    lin_a = linearize(_top(37.0), steady=True)
    lin_f = linearize(_top(37.0), steady=True, derivatives="fd")
    assert np.abs(lin_a.A - lin_f.A).max() < 1e-6 * np.abs(lin_a.A).max()
    assert np.abs(lin_a.C).max() > 0.1                          # gyroscopic terms present
    # a tilted spinning rotor with spring, damper and gravity, off its principal axes
    b = ModelBuilder("rotor", gravity=(0, 0, -G))
    c, s = np.cos(0.3), np.sin(0.3)
    b.add_body("rotor", 3.0, (0.2, 0.3, 0.4), r=(0, 0, 0), A=[[c, 0, s], [0, 1, 0], [-s, 0, c]],
               omega=(0, 0, 8.0))
    b.add_joint("revolute", "bearing", "ground", "rotor", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_force("rotational_spring_damper", "spring", joint="bearing", stiffness=5.0,
                damping=0.4)
    model = b.compile()
    la = linearize(model, steady=True)
    lf = linearize(model, steady=True, derivatives="fd")
    for key in ("M", "C", "K"):
        ref = max(np.abs(getattr(la, key)).max(), 1e-12)
        assert np.abs(getattr(la, key) - getattr(lf, key)).max() < 1e-6 * ref, key
    # one DoF: I_zz theta'' + c theta' + k theta = 0 (I_zz of the tilted body about z)
    Izz = 0.2 * s**2 + 0.4 * c**2
    assert la.M[0, 0] / la.K[0, 0] == pytest.approx(Izz / 5.0, rel=1e-8)
    assert la.C[0, 0] / la.K[0, 0] == pytest.approx(0.4 / 5.0, rel=1e-6)


def test_driver_effort_input_and_driver_output_give_the_static_compliance():
    """Compound pendulum hanging at rest with its angle driver as the input: I_O theta'' +
    m g (L/2) theta = tau, so the static gain y/u = C (-A^-1) B = 1 / (m g L / 2)."""
    m, L = 2.0, 0.8
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("rod", m, (m * L**2 / 12, m * L**2 / 12, 1e-4), r=(0, 0, -L / 2))
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_driver("angle", "motor", 0.0, joint="pivot")
    model = b.compile()
    lin = linearize(model, inputs=["motor"], outputs=["motor", "rod.y", "motor.rate"])
    assert lin.n == 1
    gain = lin.C_out @ np.linalg.solve(-lin.A, lin.B)
    assert gain[0, 0] == pytest.approx(1 / (m * G * L / 2), rel=1e-8)
    # a rotation theta about +x moves the CoM at (0, 0, -L/2) by e_x x (0, 0, -L/2) theta =
    # +(L/2) theta along y
    assert gain[1, 0] == pytest.approx((L / 2) / (m * G * L / 2), rel=1e-8)
    assert abs(gain[2, 0]) < 1e-12
    w = np.sqrt(m * G * L / 2 / (m * L**2 / 3))
    assert np.sort(np.abs(np.linalg.eigvals(lin.A).imag)) == pytest.approx([w, w], rel=1e-8)
    frames = lin.frames()
    assert list(frames["B"].columns) == ["motor"]


def test_non_equilibrium_states_are_refused():
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("rod", 1.0, (1 / 12, 1e-4, 1 / 12), r=(0, 0.5, 0))
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    model = b.compile()
    with pytest.raises(NotEquilibriumError, match="not an equilibrium.*static_equilibrium"):
        linearize(model)
    with pytest.raises(NotEquilibriumError, match="steady=True"):
        linearize(_top(40.0))
    # from the static solution it works: hanging pendulum, w^2 = m g (L/2) / (m L^2 / 3)
    sol = static_equilibrium(model)
    md = modes(model, sol.q, np.zeros(6))
    assert md.table["omega_n"][0] == pytest.approx(np.sqrt(1.5 * G), rel=1e-7)


def test_free_body_has_six_rigid_body_modes_and_mode_motion_is_animatable():
    b = ModelBuilder("free", gravity=(0, 0, 0))
    b.add_body("box", 2.0, (0.1, 0.2, 0.25))
    md = modes(b.compile())
    assert list(md.table["kind"]) == ["rigid-body"] * 6
    # shown as the three translations and three rotations, each moving one coordinate
    assert np.allclose(np.sort(np.abs(md.shapes.real), axis=0)[-1], 1.0)
    assert np.abs(np.sort(np.abs(md.shapes.real), axis=0)[:-1]).max() < 1e-9
    assert sorted(np.argmax(np.abs(md.shapes.real), axis=0)) == list(range(6))
    md2 = modes(double_pendulum())
    res = md2.motion(1, amplitude=1e-3)
    viol = res.constraint_violation()["position"]
    assert viol.max() < 1e-5                       # second order in the amplitude
    # it moves: the largest shape entry (a rotation about x, rad) swings by +-amplitude;
    # the rotation angle about x is 2 e1 to first order
    swing = np.ptp(2 * res.q[:, :, 4], axis=0).max()
    assert swing == pytest.approx(2e-3, rel=1e-2)


def test_damped_pendulum_damping_ratio_matches_closed_form():
    """Rod hanging from a pin with a rotational damper c and spring k:
    I_O theta'' + c theta' + (k + m g L/2) theta = 0, so omega_n^2 = (k + m g L/2) / I_O and
    zeta = c / (2 sqrt((k + m g L/2) I_O))."""
    m, L, k, c = 1.5, 0.6, 4.0, 0.9
    b = ModelBuilder("damped", gravity=(0, 0, -G))
    b.add_body("rod", m, (m * L**2 / 12, m * L**2 / 12, 1e-4), r=(0, 0, -L / 2))
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("rotational_spring_damper", "damper", joint="pivot", stiffness=k, damping=c)
    md = modes(b.compile())
    I_O = m * L**2 / 3
    stiffness = k + m * G * L / 2
    assert md.table["omega_n"][0] == pytest.approx(np.sqrt(stiffness / I_O), rel=1e-7)
    assert md.table["damping_ratio"][0] == pytest.approx(c / (2 * np.sqrt(stiffness * I_O)),
                                                         rel=1e-7)
    assert md.table["kind"][0] == "oscillatory"


def test_pendulum_on_a_driven_shaft_in_the_turning_frame():
    """Rod (m, L) pinned at its top end to a shaft driven at Omega about z, swinging about the
    shaft's x axis. With theta from the downward vertical, body axes x (pin), y, z (rod):
    T = I_x theta'^2/2 + Omega^2 (I_y sin^2 + I_z cos^2)/2, V = -m g (L/2) cos(theta), so
    about theta = 0: I_x theta'' + (m g L/2 - Omega^2 (I_y - I_z)) theta = 0 (moments about
    the pin). A fixed frame cannot describe this relative equilibrium (warning); the frame
    turning with the shaft gives the closed form."""
    from spatialmbd.analyses.linearize import TurningNullSpaceWarning
    from spatialmbd.motion import ConstantVelocity
    m, L, Omega, axial = 2.0, 0.9, 3.0, 1e-3
    b = ModelBuilder("shaft_pendulum", gravity=(0, 0, -G))
    b.add_body("shaft", 1.0, (0.01, 0.01, 0.02), r=(0, 0, 0.5), omega=(0, 0, Omega))
    b.add_body("rod", m, (m * L**2 / 12, m * L**2 / 12, axial), r=(0, 0, -L / 2),
               omega=(0, 0, Omega))
    b.add_joint("revolute", "spin", "ground", "shaft", point=(0, 0, 0.5), axis=(0, 0, 1))
    b.add_joint("revolute", "pin", "shaft", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_driver("angle", "motor", ConstantVelocity(rate=Omega), joint="spin")
    model = b.compile()
    I_x = I_y = m * L**2 / 3
    w2 = (m * G * L / 2 - Omega**2 * (I_y - axial)) / I_x
    with pytest.warns(TurningNullSpaceWarning, match="frame_rate"):
        linearize(model, steady=True)
    md = modes(model, steady=True, frame_rate=(0, 0, Omega))
    assert md.table["omega_n"][0] == pytest.approx(np.sqrt(w2), rel=1e-8)
    # above Omega^2 = m g L / 2 / (I_y - I_z) the hanging position is unstable
    b2 = model.to_builder()
    fast = 1.05 * np.sqrt(m * G * L / 2 / (I_y - axial))
    for name in ("shaft", "rod"):
        b2.bodies[name].omega[:] = (0, 0, fast)
    b2.drivers["motor"].law = ConstantVelocity(rate=fast)
    assert not modes(b2.compile(), steady=True, frame_rate=(0, 0, fast)).stable


def test_heavy_top_in_steady_precession_nutation_frequency_by_routh_reduction():
    """Tilted top precessing steadily (models.heavy_top): with the conserved momenta
    a = C w3 and b = A Omega sin^2(theta0) + a cos(theta0), theta obeys A theta'' = -V'(theta),
    V = (b - a cos)^2 / (2 A sin^2) + m g l cos; the nutation frequency is sqrt(V''/A). In the
    frame turning at the precession rate the linear model is constant and gives it."""
    p = HEAVY_TOP
    m, l, I1, C = p["mass"], p["l"], p["I1"], p["I3"]
    A = I1 + m * l**2
    th0, spin = p["theta"], p["spin"]
    qa, qb, qc = A * np.cos(th0), -C * spin, m * G * l
    Omega = (-qb - np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)       # as models.heavy_top
    a = C * spin
    b = A * Omega * np.sin(th0)**2 + a * np.cos(th0)

    def V(th):
        return (b - a * np.cos(th))**2 / (2 * A * np.sin(th)**2) + m * G * l * np.cos(th)
    h = 1e-4
    assert abs(V(th0 + h) - V(th0 - h)) / (2 * h) < 1e-5                # steady: V' = 0
    w_nut = np.sqrt((V(th0 + h) - 2 * V(th0) + V(th0 - h)) / h**2 / A)
    md = modes(heavy_top().compile(), steady=True, frame_rate=(0, 0, Omega))
    osc = md.table[md.table["kind"] == "oscillatory"]
    assert len(osc) == 1
    assert osc["omega_n"].iloc[0] == pytest.approx(w_nut, rel=1e-6)


def _tangent(q, q_ref):
    """(6 nb,) [r - r*, rotation vector of A A*^T] per body."""
    from spatialmbd.rotations import quat_multiply
    dr = q[:, :3] - q_ref[:, :3]
    rel = quat_multiply(q[:, 3:], q_ref[:, 3:] * np.array([1, -1, -1, -1]))
    rel *= np.sign(rel[:, :1])
    s = np.linalg.norm(rel[:, 1:], axis=1, keepdims=True)
    angle = 2 * np.arctan2(s, rel[:, :1])
    rv = np.where(s > 0, rel[:, 1:] / np.where(s > 0, s, 1) * angle, 0.0)
    return np.concatenate([dr, rv], axis=1).reshape(-1)


def test_linear_response_matches_nonlinear_simulation_of_a_spatial_arm():
    """Six-DoF robot arm with joint springs and dampers, at its static equilibrium: a small
    displacement N z0 evolves as expm(A t) [z0, 0] in the nonlinear simulation too (up to
    O(eps) relative, and the integrator's error)."""
    from scipy.linalg import expm
    from spatialmbd import models
    from spatialmbd.analyses.common import perturb
    from spatialmbd.simulate import simulate
    model = models.robot_arm().compile()
    sol = static_equilibrium(model)
    lin = linearize(model, sol.q, np.zeros(6 * model.nb))
    assert lin.n == 6
    eps = 1e-5
    z0 = eps * np.random.default_rng(1).normal(size=lin.n)
    t = np.linspace(0, 0.5, 11)
    res = simulate(model, 0.5, t_eval=t, q0=perturb(sol.q, lin.basis @ z0),
                   v0=np.zeros((model.nb, 6)), rtol=1e-11, atol=1e-14)
    assert res.success
    x0 = np.concatenate([z0, np.zeros(lin.n)])
    err = max(np.abs(lin.basis.T @ _tangent(res.q[k], sol.q)
                     - (expm(lin.A * tk) @ x0)[:lin.n]).max() for k, tk in enumerate(t))
    assert err < 1e-4 * eps


def test_linear_response_about_a_steady_spin_matches_nonlinear_simulation():
    """Sleeping top at 40 rad/s: tilt it by N z0; in the fixed frame the tangent coordinates
    relative to the reference spin q*(t) (the initial pose turned by Omega t about z) follow
    expm(A t) [z0, 0] -- this checks the W = omega*~ terms of the steady linearization."""
    from scipy.linalg import expm
    from spatialmbd.analyses.common import perturb
    from spatialmbd.rotations import quat_multiply
    from spatialmbd.simulate import simulate
    spin = 40.0
    model = _top(spin)
    lin = linearize(model, steady=True,
                    outputs=["top.tip.x", "top.tip.vx", "top.tip.vy", "top.tip.vz", "top.vx"])
    # the tip stays on the spherical joint: its position and velocity outputs vanish
    assert np.abs(lin.C_out[:4]).max() < 1e-9
    assert np.abs(lin.C_out[4]).max() > 1e-3
    eps = 1e-5
    z0 = eps * np.random.default_rng(2).normal(size=lin.n)
    dx = lin.basis @ z0
    q0 = perturb(model.q0, dx)
    # the same velocity perturbation as the linear model: dv = dx' - W dx with dx' = 0
    v0 = model.v0.reshape(-1) - np.concatenate([np.zeros(3), np.cross(model.v0[0, 3:],
                                                                      dx[3:])])
    t = np.linspace(0, 0.3, 7)
    res = simulate(model, 0.3, t_eval=t, q0=q0, v0=v0.reshape(1, 6), rtol=1e-11, atol=1e-14,
                   correct_initial=False)
    assert res.success
    x0 = np.concatenate([z0, np.zeros(lin.n)])
    err = 0.0
    for k, tk in enumerate(t):
        turn = np.array([[np.cos(spin * tk / 2), 0, 0, np.sin(spin * tk / 2)]])
        ref = model.q0.copy()
        ref[:, 3:] = quat_multiply(turn, model.q0[:, 3:])
        x = expm(lin.A * tk) @ x0
        z = lin.basis.T @ _tangent(res.q[k], ref)
        err = max(err, np.abs(z - x[:lin.n]).max())
        # CoM velocity output against the simulation (reference CoM at rest on the axis)
        err = max(err, abs(res.v[k, 0, 0] - (lin.C_out @ x)[4]) / spin)
    assert err < 1e-3 * eps


def test_n_four_bar_with_redundant_joints_hanging_frequency():
    """IFToMM A02 parallelogram (N = 2, spatial revolutes about z: redundant equations).
    seek_stable moves it from the upright equilibrium of q0 to the hanging one; there every
    crank angle obeys I phi'' = -K phi with I = 3 I_O + 2 m L^2 (couplers translate),
    I_O = m (L^2 + a^2)/12 + m L^2/4 (square section a = 0.02 m), K = m g L (3/2 + 2)."""
    from spatialmbd import models
    model = models.n_four_bar(2).compile()
    first = static_equilibrium(model)
    assert not first.stable
    sol = static_equilibrium(model, seek_stable=True)
    assert sol.stable and np.allclose(sol.q[0, :3], [0, -0.5, 0], atol=1e-9)
    md = modes(model, sol.q, np.zeros(6 * model.nb))
    inertia = 3 * ((1 + 0.02**2) / 12 + 0.25) + 2
    assert md.table["omega_n"][0] == pytest.approx(np.sqrt(G * 3.5 / inertia), rel=1e-9)


def test_motor_holding_a_rod_below_horizontal_as_input():
    """Rod held by its motor at theta0 = -0.6 rad (from +y towards +z, about x): the holding
    torque u* = m g l cos(theta0) stays applied, u is the deviation. I_O theta'' =
    u* + u - m g l cos(theta) gives I_O dtheta'' - m g l sin(theta0) dtheta = u, so
    w^2 = m g l sin(0.6) / I_O and the static gain 1 / (m g l sin 0.6)."""
    m, L, th0 = 2.0, 0.8, -0.6
    b = ModelBuilder("held", gravity=(0, 0, -G))
    b.add_body("rod", m, (m * L**2 / 12, 1e-4, m * L**2 / 12), r=(0, L / 2, 0),
               points={"tip": (0, L / 2, 0)})
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_driver("angle", "motor", th0, joint="pivot")
    model = b.compile()
    sol = static_equilibrium(model)
    lin = linearize(model, sol.q, np.zeros(6), inputs=["motor"],
                    outputs=["motor", "rod.tip.z", "rod.tip.vz"])
    l, I_O = L / 2, m * L**2 / 3
    assert lin.input_reference[0] == pytest.approx(m * G * l * np.cos(th0), rel=1e-9)
    w = np.sqrt(m * G * l * np.sin(-th0) / I_O)
    assert np.abs(np.linalg.eigvals(lin.A).imag).max() == pytest.approx(w, rel=1e-7)
    gain = lin.C_out @ np.linalg.solve(-lin.A, lin.B)
    assert gain[0, 0] == pytest.approx(1 / (m * G * l * np.sin(-th0)), rel=1e-7)
    # the tip rises by L cos(theta0) dtheta
    assert gain[1, 0] == pytest.approx(L * np.cos(th0) * gain[0, 0], rel=1e-7)
    assert abs(gain[2, 0]) < 1e-12


def test_robot_arm_joint_torque_input_and_joint_angle_output():
    """The robot arm's base turns about the vertical: gravity does no work on that rotation,
    so the static compliance from a torque at joint 1 (rotational spring element drive1) to
    the angle of joint 1 is 1 / k1 = 1/2000 rad per N m (every other joint angle stays)."""
    from spatialmbd import models
    model = models.robot_arm().compile()
    sol = static_equilibrium(model)
    lin = linearize(model, sol.q, np.zeros(6 * model.nb), inputs=["drive1"],
                    outputs=["joint1.angle", "joint2.angle", "joint1.angle_rate"])
    gain = lin.C_out @ np.linalg.solve(-lin.A, lin.B)
    assert gain[0, 0] == pytest.approx(1 / 2000.0, rel=1e-7)
    assert abs(gain[1, 0]) < 1e-10 and abs(gain[2, 0]) < 1e-12
    from spatialmbd.errors import ModelError
    with pytest.raises(ModelError, match="joint1.angel"):
        linearize(model, sol.q, np.zeros(6 * model.nb), outputs=["joint1.angel"])


# ------------------------------------------------------------------------------ nonholonomic
def rolling_coin(speed, R=0.1, m=0.5):
    """A thin uniform coin (axial moment C = m R^2 / 2, diametral A = m R^2 / 4) rolling
    upright along x at ``speed``, axis along y, on the ground z = 0."""
    b = ModelBuilder("coin", gravity=(0, 0, -G))
    b.add_body("coin", m, (m * R * R / 2, m * R * R / 4, m * R * R / 4), r=(0, 0, R),
               A=np.column_stack([[0, 1.0, 0], [-1.0, 0, 0], [0, 0, 1.0]]),
               rdot=(speed, 0, 0), omega=(0, speed / R, 0))
    b.add_joint("rolling_disc", "roll", "coin", "ground", point=(0, 0, R), axis=(0, 1, 0),
                point2=(0, 0, 0), axis2=(0, 0, 1), radius=R)
    return b.compile()


@pytest.mark.parametrize("speed", [0.0, 0.5, 1.0, 2.0])
def test_rolling_coin_lean_eigenvalues_match_the_closed_form(speed):
    """Upright rolling disc at spin Omega = v / R, small lean theta and heading psi (Routh;
    e.g. Neimark & Fufaev, Dynamics of Nonholonomic Systems):
    (A + m R^2) theta'' + (C + m R^2) Omega psi' - m g R theta = 0,  A psi'' = C Omega theta',
    so s^2 = (m g R - C (C + m R^2) Omega^2 / A) / (A + m R^2): falling at rest, stable above
    v^2 = g R / 3 (thin disc). Five position and three velocity coordinates (two slip rows);
    every other eigenvalue is zero."""
    R, m = 0.1, 0.5
    A, C = m * R * R / 4, m * R * R / 2
    lin = linearize(rolling_coin(speed), steady=speed > 0)
    assert lin.nonholonomic and (lin.n, lin.n_velocity) == (5, 3)
    assert lin.C is None and lin.K is None and lin.A.shape == (8, 8)
    Om = speed / R
    s2 = (m * G * R - C * (C + m * R * R) * Om**2 / A) / (A + m * R * R)
    ev = np.linalg.eigvals(lin.A)
    ev = ev[np.argsort(np.abs(ev))]
    expected = np.sort_complex(np.sqrt(complex(s2)) * np.array([1, -1]))
    assert np.allclose(np.sort_complex(ev[-2:]), expected, rtol=1e-8, atol=1e-8)
    assert np.abs(ev[:-2]).max() < 1e-5 * np.abs(ev[-1])
    md = modes(lin)
    assert md.stable == (s2 < 0)


def test_partitioned_coordinates_with_nonholonomic_constraints():
    """coordinates='partition': chosen body coordinates for the positions and chosen body
    velocities for the velocities (named <body>.<vx..wz>); the same eigenvalues as the
    orthonormal bases."""
    from spatialmbd.models import whipple_bicycle
    model = whipple_bicycle(5.0).compile()
    a = linearize(model, steady=True)
    b = linearize(model, steady=True, coordinates="partition")
    assert len(b.coordinates) == 7 and len(b.velocity_coordinates) == 3
    assert all(c.rsplit(".", 1)[1] in ("vx", "vy", "vz", "wx", "wy", "wz")
               for c in b.velocity_coordinates)
    ev = [np.linalg.eigvals(m.A) for m in (a, b)]
    big = [np.sort_complex(e[np.argsort(np.abs(e))[-4:]]) for e in ev]
    assert np.abs(big[0] - big[1]).max() < 1e-9


def test_bicycle_linearization_analytic_and_differenced_agree_and_frames_label_it():
    from spatialmbd.models import whipple_bicycle
    model = whipple_bicycle(5.0).compile()
    a = linearize(model, steady=True, outputs=["steer.angle"], inputs=["front_frame.mz"])
    f = linearize(model, steady=True, derivatives="fd", outputs=["steer.angle"],
                  inputs=["front_frame.mz"])
    assert np.allclose(a.A, f.A, atol=1e-6 * np.abs(a.A).max())
    assert np.allclose(a.B, f.B, atol=1e-9) and np.abs(a.B).max() > 0
    fr = a.frames()
    assert set(fr) == {"M", "B_u", "A", "B", "C_out", "D_out"}
    assert list(fr["A"].index) == [f"z{k}" for k in range(7)] + [f"w{k}" for k in range(3)]
    assert "7 independent position and 3 velocity coordinates" in a.summary()


@pytest.mark.parametrize("speed, stable", [(3.0, False), (5.0, True), (7.0, False)])
def test_bicycle_self_stability_by_speed(speed, stable):
    """Meijaard et al. (2007): the benchmark bicycle runs hands-free only between its weave
    speed 4.29 m/s (below, the lean-steer oscillation grows) and its capsize speed 6.02 m/s
    (above, it slowly falls over: an unstable real mode)."""
    from spatialmbd.models import whipple_bicycle
    md = modes(whipple_bicycle(speed).compile(), steady=True)
    assert md.stable == stable
    unstable = md.table[md.table["kind"] == "unstable"]
    if speed < 4:
        assert (unstable["imag"].abs() > 1).all() and len(unstable) == 1      # weave
    if speed > 6.5:
        assert (unstable["imag"] == 0).all() and len(unstable) == 1          # capsize


def test_coin_in_steady_circular_motion_in_the_turning_frame_matches_nonlinear_simulation():
    """The coin of models.rolling_disc rolls on a circle, its whole motion turning at the
    precession rate Omega about z: a relative equilibrium. In the frame turning at Omega
    (frame_rate) the tangent spaces stand still (no warning, where the fixed frame warns), and
    a small kick dv (in the null space of D) evolves as expm(A t) [0, N_v^T dv]: the simulated
    coin's tangent coordinates about the reference q*(t) (the start turned by Omega t about z,
    spun by the spin rate about its axis), turned back into the frame, follow it."""
    import warnings
    from scipy.linalg import expm
    from spatialmbd.analyses.common import perturb  # noqa: F401  (tangent space convention)
    from spatialmbd.analyses.linearize import TurningNullSpaceWarning
    from spatialmbd.models import rolling_disc, rolling_disc_steady
    from spatialmbd.rotations import quat_multiply
    from spatialmbd.simulate import simulate
    Om, spin = rolling_disc_steady()
    model = rolling_disc().compile()
    with pytest.warns(TurningNullSpaceWarning):
        linearize(model, steady=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", TurningNullSpaceWarning)
        lin = linearize(model, steady=True, frame_rate=(0, 0, Om))
    assert lin.nonholonomic and modes(lin).stable
    eps = 1e-5
    dv = lin.velocity_basis @ (lin.velocity_basis.T @ (eps * np.array([0, 0, 0, 0, 1.0, 0])))
    x0 = np.concatenate([np.zeros(lin.n), lin.velocity_basis.T @ dv])
    t = np.linspace(0, 1.0, 11)
    res = simulate(model, 1.0, t_eval=t, v0=(model.v0.reshape(-1) + dv).reshape(1, 6),
                   method="projection", rtol=1e-11, atol=1e-14, correct_initial=False)
    assert res.success
    u = np.array([1.0, 0, 0])                                    # the coin's axis, body x
    err = 0.0
    for k, tk in enumerate(t):
        turn = np.array([np.cos(Om * tk / 2), 0, 0, np.sin(Om * tk / 2)])
        own = np.concatenate([[np.cos(spin * tk / 2)], np.sin(spin * tk / 2) * u])
        ref = model.q0.copy()
        c, s = np.cos(Om * tk), np.sin(Om * tk)
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        ref[0, :3] = Rz @ model.q0[0, :3]
        ref[0, 3:] = quat_multiply(quat_multiply(turn, model.q0[0, 3:]), own)
        dx = _tangent(res.q[k], ref).reshape(2, 3) @ Rz                   # into the frame
        a = lin.basis.T @ dx.reshape(-1)
        err = max(err, np.abs(a - (expm(lin.A * tk) @ x0)[:lin.n]).max())
    assert err < 1e-3 * eps
