"""Static equilibrium, stability and quasi-static analysis against independent solutions."""
import numpy as np
import pytest
from scipy.optimize import brentq

from spatialmbd import ModelBuilder, models
from spatialmbd.analyses import quasi_static, static_equilibrium
from spatialmbd.analyses.statics import NoEquilibriumError

G = 9.81


def spring_pendulum(k=10.0, m=2.0, L=0.8):
    """Uniform rod pinned at the origin about global x, along +y at theta = 0, torsional spring
    k (rest at theta = 0); gravity -z. theta rotates +y towards +z."""
    b = ModelBuilder("spring_pendulum", gravity=(0, 0, -G))
    b.add_body("rod", m, (m * L**2 / 12, 1e-4, m * L**2 / 12), r=(0, L / 2, 0))
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("rotational_spring_damper", "spring", joint="pivot", stiffness=k)
    return b.compile()


def test_pendulum_with_torsional_spring_matches_scalar_equilibrium():
    """Equilibrium: k theta + m g (L/2) cos(theta) = 0 (the spring balances the gravity moment);
    stable: k - m g (L/2) sin(theta) > 0."""
    k, m, L = 10.0, 2.0, 0.8
    sol = static_equilibrium(spring_pendulum(k, m, L))
    th = brentq(lambda x: k * x + m * G * L / 2 * np.cos(x), -np.pi / 2, 0.0)
    assert np.allclose(sol.q[0, :3], [0, L / 2 * np.cos(th), L / 2 * np.sin(th)], atol=1e-9)
    assert sol.residual < 1e-7 and sol.stable
    assert sol.classification == ["stable"]
    # pivot force carries the weight
    assert np.allclose(sol.reactions["pivot"].force_j, [[0, 0, m * G]], atol=1e-8)
    assert "STABLE" in sol.summary()


def test_inverted_pendulum_is_an_unstable_equilibrium_named_as_such():
    b = ModelBuilder("inverted", gravity=(0, 0, -G))
    b.add_body("rod", 1.0, (1 / 12, 1 / 12, 1e-4), r=(0, 0, 0.5))
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    sol = static_equilibrium(b.compile())
    assert np.allclose(sol.q[0, :3], [0, 0, 0.5], atol=1e-12)
    assert not sol.stable
    assert sol.classification == ["unstable"]
    # reduced stiffness about the pivot: -m g l (N m/rad): the basis vector is the unit
    # rotation about x together with the translation of the CoM it implies (|n|^2 = 1 + l^2)
    assert sol.stiffness[0] == pytest.approx(-G * 0.5 / (1 + 0.25), rel=1e-6)
    assert "rod: rotation about axis (1, 0, 0)" in sol.unstable_directions[0] or \
        "rod: rotation about axis (-1, 0, 0)" in sol.unstable_directions[0]


def test_seek_stable_leaves_the_inverted_position_for_the_hanging_one():
    b = ModelBuilder("inverted", gravity=(0, 0, -G))
    b.add_body("rod", 1.0, (1 / 12, 1 / 12, 1e-4), r=(0, 0, 0.5))
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    sol = static_equilibrium(b.compile(), seek_stable=True)
    assert sol.stable and np.allclose(sol.q[0, :3], [0, 0, -0.5], atol=1e-9)
    assert "stable search" in sol.method


def _rod_chain(phi0, L=1.0, m=1.0):
    nodes = np.zeros((len(phi0) + 1, 3))
    for k, p in enumerate(phi0):
        nodes[k + 1] = nodes[k] + L * np.array([np.cos(p), 0, np.sin(p)])
    b = ModelBuilder("hanging_chain", gravity=(0, 0, -G))
    for k in range(len(phi0)):
        d = (nodes[k + 1] - nodes[k]) / L
        A = np.column_stack([d, [0, 1, 0], np.cross(d, [0, 1, 0])])
        b.add_body(f"rod{k}", m, (1e-4, m * L**2 / 12, m * L**2 / 12),
                   r=(nodes[k] + nodes[k + 1]) / 2, A=A)
    prev = "ground"
    for k in range(len(phi0) + 1):
        nxt = f"rod{k}" if k < len(phi0) else "ground"
        b.add_joint("spherical", f"n{k}", prev, nxt, point=nodes[k])
        prev = nxt
    return b.compile(), nodes[-1, 0]


def test_chain_of_rods_between_two_pins_matches_discrete_catenary():
    """N uniform rods (m, L) hang between spherical pins at the same height, span a.
    Independent solution: horizontal tension H is the same at every pin; the vertical force
    on rod k from its left pin is T_k = N m g / 2 - k m g (symmetry, weights); the moment of
    rod k about its left pin gives tan(phi_k) = (m g / 2 - T_k) / H; H from
    sum L cos(phi_k) = a."""
    N, m, L = 5, 1.0, 1.0
    model, a = _rod_chain([-0.9, -0.5, 0.0, 0.5, 0.9], L, m)
    sol = static_equilibrium(model)
    T = N * m * G / 2 - np.arange(N) * m * G
    H = brentq(lambda H: np.sum(np.cos(np.arctan((m * G / 2 - T) / H))) - a / L, 1e-3, 1e4)
    phi = np.arctan((m * G / 2 - T) / H)
    x = np.concatenate([[0], np.cumsum(L * np.cos(phi))])
    z = np.concatenate([[0], np.cumsum(L * np.sin(phi))])
    centres = np.column_stack([(x[:-1] + x[1:]) / 2, np.zeros(N), (z[:-1] + z[1:]) / 2])
    assert np.abs(sol.q[:, :3] - centres).max() < 1e-9
    # pin reactions: on rod 0 at the left pin (-H, 0, T_0); on rod N-1 at the right (H, 0, T_0)
    assert np.allclose(sol.reactions["n0"].force_j, [[-H, 0, T[0]]], atol=1e-8)
    assert np.allclose(sol.reactions["n5"].force_i, [[H, 0, T[0]]], atol=1e-8)
    # stable; each rod spins freely about its own axis between its two spherical joints
    assert sol.stable
    assert sol.classification.count("zero") == N
    spins = sol.zero_stiffness_directions
    for k in range(N):
        axis = np.array([np.cos(phi[k]), 0, np.sin(phi[k])])
        match = [s for s in spins if s.startswith(f"rod{k}: rotation about axis")]
        assert len(match) == 1
        text = match[0].split("(")[1].split(")")[0]
        got = np.array([float(c) for c in text.split(",")])
        assert abs(abs(got @ axis) - 1) < 1e-3


def test_free_body_under_gravity_has_no_equilibrium():
    b = ModelBuilder("free", gravity=(0, 0, -G))
    b.add_body("ball", 1.0, (0.1, 0.1, 0.1))
    with pytest.raises(NoEquilibriumError, match=r"ball: translation along \(0, 0, -1\)"):
        static_equilibrium(b.compile(), load_steps=(), minimise=False)
    # the fallbacks (load stepping, energy minimisation) do not hide it either
    with pytest.raises(NoEquilibriumError, match="no equilibrium exists"):
        static_equilibrium(b.compile())


def test_load_stepping_finds_large_deflection_when_newton_alone_fails():
    """A soft spring: Newton from theta = 0 with 3 iterations fails; load increments succeed."""
    k, m, L = 3.0, 2.0, 0.8
    model = spring_pendulum(k, m, L)
    sol = static_equilibrium(model, max_iter=3, load_steps=(40,), minimise=False)
    assert sol.method.startswith("load stepping")
    th = brentq(lambda x: k * x + m * G * L / 2 * np.cos(x), -np.pi / 2, 0.0)
    assert np.allclose(sol.q[0, 1:3], [L / 2 * np.cos(th), L / 2 * np.sin(th)], atol=1e-9)


def test_energy_minimisation_fallback():
    k, m, L = 3.0, 2.0, 0.8
    sol = static_equilibrium(spring_pendulum(k, m, L), max_iter=3, load_steps=())
    assert "minimisation" in sol.method
    th = brentq(lambda x: k * x + m * G * L / 2 * np.cos(x), -np.pi / 2, 0.0)
    assert np.allclose(sol.q[0, 1:3], [L / 2 * np.cos(th), L / 2 * np.sin(th)], atol=1e-9)


def test_quasi_static_slider_crank_torque_against_virtual_work():
    """Static crank torque: tau = dV/dtheta with V = g (m_crank z_crank + m_rod z_rod),
    z_crank = 0.12 + 0.04 cos(theta), z_rod = (B_z + 0)/2 = 0.06 + 0.04 cos(theta) (the slider
    stays at z = 0), so tau = -0.04 g (m_crank + m_rod) sin(theta)."""
    omega = 6.0
    model = models.slider_crank(crank_speed=omega).compile()
    t = np.linspace(0.0, 2 * np.pi / omega, 13)
    qs = quasi_static(model, t)
    th = omega * t
    tau = -0.04 * G * (0.12 + 0.5) * np.sin(th)
    assert np.abs(qs.efforts["crank_drive"].to_numpy() - tau).max() < 1e-8
    # slider position from the closed-form kinematics
    x, _, _ = models.slider_crank_exact(th, omega)
    assert np.abs(qs.q[:, model.body_index("slider"), 0] - x).max() < 1e-9
    assert qs.stable.all()


def test_translation_driver_effort_sign_holding_a_weight():
    """A 3 kg slider on a vertical guide (axis +z) held by a translation driver: the effort
    pushes it up along +z, positive (it would do positive work lifting the slider), 3 g N; with
    the guide axis -z the same support is a negative effort."""
    for axis, sign in (((0, 0, 1), 1.0), ((0, 0, -1), -1.0)):
        b = ModelBuilder("lift", gravity=(0, 0, -G))
        b.add_body("slider", 3.0, (0.1, 0.1, 0.1), r=(0, 0, 1.0))
        b.add_joint("translational", "guide", "ground", "slider", point=(0, 0, 1.0), axis=axis)
        b.add_driver("translation", "jack", 0.0, joint="guide")
        sol = static_equilibrium(b.compile())
        assert sol.efforts["jack"] == pytest.approx(sign * 3.0 * G, rel=1e-10)
        assert sol.units["jack"] == "N"


def test_quasi_static_with_a_free_spring_loaded_joint():
    """Shoulder driven through theta(t) = 0.8 t (from +y towards +z, about x); the forearm
    hangs on a torsional spring k at the elbow (relative angle phi, rest 0). Per time:
    d V/d phi = m2 g (L2/2) cos(theta + phi) + k phi = 0 (forearm), and the holding torque
    tau = dV/dtheta = m1 g (L1/2) cos(theta) + m2 g (L1 cos(theta) + (L2/2) cos(theta + phi))."""
    from spatialmbd.motion import ConstantVelocity
    m1, L1, m2, L2, k = 2.0, 1.0, 1.5, 0.8, 30.0
    b = ModelBuilder("arm", gravity=(0, 0, -G))
    b.add_body("upper", m1, (m1 * L1**2 / 12, 1e-4, m1 * L1**2 / 12), r=(0, L1 / 2, 0))
    b.add_body("fore", m2, (m2 * L2**2 / 12, 1e-4, m2 * L2**2 / 12), r=(0, L1 + L2 / 2, 0))
    b.add_joint("revolute", "shoulder", "ground", "upper", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_joint("revolute", "elbow", "upper", "fore", point=(0, L1, 0), axis=(1, 0, 0))
    b.add_force("rotational_spring_damper", "spring", joint="elbow", stiffness=k)
    b.add_driver("angle", "motor", ConstantVelocity(rate=0.8), joint="shoulder")
    t = np.linspace(0.0, 2.0, 9)
    qs = quasi_static(b.compile(), t)
    theta = 0.8 * t
    phi = np.array([brentq(lambda p: m2 * G * L2 / 2 * np.cos(th + p) + k * p, -3, 3)
                    for th in theta])
    tau = m1 * G * L1 / 2 * np.cos(theta) + m2 * G * (L1 * np.cos(theta)
                                                       + L2 / 2 * np.cos(theta + phi))
    assert np.abs(qs.efforts["motor"].to_numpy() - tau).max() < 1e-7
    fore = qs.q[:, 1, :3]
    expected = np.column_stack([np.zeros_like(t),
                                L1 * np.cos(theta) + L2 / 2 * np.cos(theta + phi),
                                L1 * np.sin(theta) + L2 / 2 * np.sin(theta + phi)])
    assert np.abs(fore - expected).max() < 1e-9
    assert qs.stable.all()


def test_spatial_double_pendulum_comes_to_rest_at_the_energy_minimum():
    """models.double_pendulum: bar 1 (1 m, 1 kg) pinned about x, bar 2 pinned at its tip about
    bar 1's own axis. With bar 1 at alpha below the horizontal, bar 2 can at best point along
    the lowest direction normal to bar 1's axis, whose height is -cos(alpha), so
    V / (m g) = -1.5 sin(alpha) - 0.5 cos(alpha): minimum at tan(alpha) = 3. Started from the
    horizontal (zero stiffness there: Newton cannot start), the energy minimisation finds it."""
    model = models.double_pendulum().compile()
    sol = static_equilibrium(model)
    a = np.arctan(3.0)
    tip = np.array([0, np.cos(a), -np.sin(a)])
    axis = tip                                      # bar 1's axis, unit length
    down = np.array([0, 0, -1.0])
    low = down - (down @ axis) * axis               # lowest direction normal to the axis
    low /= np.linalg.norm(low)
    assert np.allclose(sol.q[0, :3], tip / 2, atol=1e-8)
    assert np.allclose(sol.q[1, :3], tip + low / 2, atol=1e-8)
    assert sol.stable and "minimisation" in sol.method
