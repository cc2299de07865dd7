"""Joint friction proportional to the joint's reaction (forces/joint_friction.py with ``mu``,
the loop of dynamics/reaction_friction.py): closed-form stops of a block on a slide and on an
incline, of a wheel on its axle (with side and axial loads) and of a ball in its socket, in the
body-coordinate methods; LuGre's stick; the energy balance; the loads against the reactions of
the results; a loop that cannot converge; bad input and refused methods."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError, SpatialMBDError
from spatialmbd.outputs import force_outputs
from spatialmbd.simulate import simulate

G = 9.81
EXACT = ("standard", "baumgarte", "projection", "augmented_lagrangian")
TIGHT = dict(rtol=1e-10, atol=1e-12)


def block(mu, v0, incline=0.0, **law):
    """A 2 kg block on a translational joint along a slope of angle ``incline`` (rad; the
    slide axis points down the slope), launched down it at v0."""
    b = ModelBuilder("block", gravity=(0, 0, -G))
    axis = (math.cos(incline), 0.0, -math.sin(incline))
    b.add_body("block", 2.0, (0.1, 0.1, 0.1), rdot=tuple(v0 * a for a in axis))
    b.add_joint("translational", "slide", "ground", "block", point=(0, 0, 0), axis=axis)
    b.add_force("joint_friction", "fr", joint="slide", mu=mu, **law)
    return b.compile()


@pytest.mark.parametrize("method", EXACT + ("penalty",))
def test_block_stops_at_v0_squared_over_2_mu_g(method):
    """N = m g, so the block decelerates at mu g: it stops at v0^2 / (2 mu g) (the penalty
    method's multipliers are its reactions only to O(1/alpha): 1e-8 m there). It stops at
    v0 / (mu g) = 0.510 s; the run ends 0.04 s later, some 1e5 time constants of the creep law
    (m creep_velocity / (mu m g) = 3.4e-7 s) of standing still (sticking is the stiff, slow
    part of the run: to 0.8 s it took 7 times as long and ended within 1e-16 m of this)."""
    mu, v0 = 0.3, 1.5
    res = simulate(block(mu, v0, creep_velocity=1e-6), 0.55, method=method, output_step=0.01,
                   **TIGHT)
    assert res.success
    x = res.body("block")["r"][-1, 0]
    assert x == pytest.approx(v0 ** 2 / (2 * mu * G), abs=1e-8 if method == "penalty" else 1e-10)
    level = force_outputs(res, "fr")["level"]
    assert np.allclose(level, mu * 2.0 * G, rtol=1e-6 if method == "penalty" else 1e-10)


def test_block_on_an_incline():
    """Sliding down a 30 degree slope with mu < tan 30: x(T) = v0 T + g (sin a - mu cos a)
    T^2 / 2, the normal reaction m g cos a (not m g) setting the friction level."""
    a, mu, v0, T = math.radians(30.0), 0.25, 0.5, 1.0
    res = simulate(block(mu, v0, a, creep_velocity=1e-6), T, method="standard",
                   output_step=0.05, **TIGHT)
    r = res.body("block")["r"][-1]
    s = math.hypot(r[0], r[2])
    assert s == pytest.approx(v0 * T + 0.5 * G * (math.sin(a) - mu * math.cos(a)) * T ** 2,
                              abs=1e-10)
    level = force_outputs(res, "fr")["level"]
    assert np.allclose(level, mu * 2.0 * G * math.cos(a), rtol=1e-10)


def wheel(mu, radius, omega0, side=0.0, axial=0.0, **extra):
    """A 2 kg disk of radius 0.2 m (I = m R^2 / 2 = 0.04 kg m^2 about its axle) on a
    horizontal revolute axle along y through its centre, spinning at omega0; side: a constant
    horizontal force (N) on the centre across the axle, axial: one along it."""
    m, R = 2.0, 0.2
    b = ModelBuilder("wheel", gravity=(0, 0, -G))
    b.add_body("disk", m, (m * R * R / 4, m * R * R / 2, m * R * R / 4),
               omega=(0, omega0, 0))
    b.add_joint("revolute", "axle", "ground", "disk", point=(0, 0, 0), axis=(0, 1, 0))
    b.add_force("joint_friction", "bearing", joint="axle", mu=mu, radius=radius,
                creep_velocity=1e-6, **extra)
    for name, load, d in (("side", side, (1, 0, 0)), ("thrust", axial, (0, 1, 0))):
        if load:
            b.add_force("point_force", name, body="disk", direction=d, magnitude=load)
    return b.compile()


def turned(res):
    """The disk's rotation angle about y (rad) at every output (p = (cos, 0, sin, 0) of half
    of it)."""
    p = res.body("disk")["p"]
    return 2.0 * np.unwrap(np.arctan2(p[:, 2], p[:, 0]))


@pytest.mark.parametrize("side, axial, axial_radius", [(0.0, 0.0, 0.0), (15.0, 0.0, 0.0),
                                                       (0.0, 12.0, 0.03)])
def test_wheel_on_its_axle_stops_after_the_closed_form_angle(side, axial, axial_radius):
    """T = mu (r |radial reaction| + r_a |axial reaction|) with the radial reaction
    sqrt(P^2 + (m g)^2): the disk stops after omega0^2 I / (2 T)."""
    mu, r, omega0, m, I = 0.2, 0.01, 3.0, 2.0, 0.04
    extra = dict(axial_radius=axial_radius) if axial_radius else {}
    model = wheel(mu, r, omega0, side, axial, **extra)
    torque = mu * (r * math.hypot(side, m * G) + axial_radius * axial)
    t_stop = omega0 * I / torque
    # 0.04 s of sticking after the stop (the stiff, slow part of the run), as for the block
    res = simulate(model, t_stop + 0.04, method="standard", output_step=0.01, **TIGHT)
    assert res.success
    angle = turned(res)[-1]
    assert angle == pytest.approx(omega0 ** 2 * I / (2 * torque), abs=1e-8)
    assert np.allclose(force_outputs(res, "bearing")["level"], torque, rtol=1e-10)


def test_energy_balance_closes_with_the_friction_dissipation():
    """The work of the friction (integrated with the run) is the kinetic energy lost."""
    res = simulate(wheel(0.2, 0.01, 3.0), 2.0, method="standard", output_step=0.01, **TIGHT)
    energy = res.energy()
    assert energy["work_nonconservative"][-1] < -0.1
    assert np.abs(energy["error"]).max() < 1e-9
    power = force_outputs(res, "bearing")["power"]
    assert np.all(power <= 0.0)


def test_ball_in_its_socket_stops_after_the_closed_form_angle():
    """A 2 kg ball (I = 0.032 kg m^2) held at its centre by a spherical joint, spinning about
    the vertical: the reaction is m g, the moment mu r m g."""
    mu, r, omega0, m, I = 0.3, 0.02, 2.0, 2.0, 0.032
    b = ModelBuilder("ball", gravity=(0, 0, -G))
    b.add_body("ball", m, (I, I, I), omega=(0, 0, omega0))
    b.add_joint("spherical", "socket", "ground", "ball", point=(0, 0, 0))
    b.add_force("joint_friction", "fr", joint="socket", mu=mu, radius=r, creep_velocity=1e-6)
    torque = mu * r * m * G
    res = simulate(b.compile(), omega0 * I / torque + 0.04, method="projection",
                   output_step=0.01, **TIGHT)
    p = res.body("ball")["p"]
    angle = 2.0 * np.unwrap(np.arctan2(p[:, 3], p[:, 0]))[-1]
    assert angle == pytest.approx(omega0 ** 2 * I / (2 * torque), abs=1e-8)


def test_lugre_sticks_without_creep_on_an_incline():
    """mu_static > tan a: a LuGre block put on a 20 degree slope settles on its bristles
    (z = m g sin a / sigma_0) and then does not move."""
    a = math.radians(20.0)
    model = block(0.5, 0.0, a, friction="lugre", bristle_stiffness=1e5, bristle_damping=600.0)
    res = simulate(model, 1.0, method="standard", output_step=0.01, **TIGHT)
    r = res.body("block")["r"]
    s = np.hypot(r[:, 0], r[:, 2])
    assert abs(s[-1] - s[50]) < 1e-10
    bristle = force_outputs(res, "fr")["bristle"]
    assert bristle[-1] == pytest.approx(2.0 * G * math.sin(a) / 1e5, rel=1e-6)


def test_the_loads_are_the_reactions_of_the_results():
    """A pendulum whose pin friction depends on the radial reaction, which its swing changes:
    the friction reported at the outputs is mu r |radial reaction| of Results.reactions()."""
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("link", 1.5, (0.01, 0.05, 0.05), r=(0.4, 0, 0))
    b.add_joint("revolute", "pin", "ground", "link", point=(0, 0, 0), axis=(0, 1, 0))
    b.add_force("joint_friction", "fr", joint="pin", mu=0.3, radius=0.02, creep_velocity=1e-3)
    res = simulate(b.compile(), 1.0, method="standard", output_step=0.05, **TIGHT)
    f = res.reactions()["pin"].force_i
    radial = np.hypot(f[:, 0], f[:, 2])
    level = force_outputs(res, "fr")["level"]
    assert np.allclose(level, 0.3 * 0.02 * radial, rtol=1e-9)
    assert np.ptp(radial) > 5.0                     # the reaction does change
    # and the accelerations at the outputs are those of that friction
    slip = force_outputs(res, "fr")["slip"]
    moment = force_outputs(res, "fr")["friction"]
    assert np.allclose(np.abs(moment), level * np.tanh(np.abs(slip) / 1e-3), rtol=1e-9)


def test_a_loop_that_cannot_converge_stops_with_a_message():
    """A pin far larger than the link (mu r / l = 5): the fixed point iteration diverges."""
    b = ModelBuilder("bad", gravity=(0, 0, -G))
    b.add_body("link", 1.0, (0.001, 0.01, 0.01), r=(0.1, 0, 0), omega=(0, 5.0, 0))
    b.add_joint("revolute", "pin", "ground", "link", point=(0, 0, 0), axis=(0, 1, 0))
    b.add_force("joint_friction", "fr", joint="pin", mu=1.0, radius=0.5)
    with pytest.raises(SpatialMBDError, match=r"'fr'|\bfr\b") as info:
        res = simulate(b.compile(), 0.1, method="standard")
        if not res.success:
            raise SpatialMBDError(res.message)
    assert "did not converge" in str(info.value) and "radius" in str(info.value)


@pytest.mark.parametrize("params, words", [
    (dict(mu=-0.1, radius=0.01), ("forces['fr'].mu", "-0.1", ">= 0")),
    (dict(mu=0.1, radius=-0.01), ("forces['fr'].radius", "-0.01", ">= 0")),
    (dict(mu=0.1), ("forces['fr'].radius", "radius of the pin")),
    (dict(mu=0.1, radius=0.0), ("forces['fr'].radius", "> 0")),
    (dict(mu=0.1, radius=0.01, frictionloss=1.0), ("frictionloss", "one of them")),
    (dict(frictionloss=1.0, radius=0.01), ("forces['fr'].radius", "'mu'")),
    (dict(mu=0.1, radius=0.01, axial_radius=-1.0), ("axial_radius", "-1.0")),
    (dict(mu=0.1, radius=0.01, friction="viscous", viscous=1.0), ("viscous", "'mu'")),
])
def test_bad_input_names_the_element_the_value_and_the_fix(params, words):
    b = ModelBuilder(gravity=(0, 0, -G))
    b.add_body("disk", 1.0, (1, 1, 1))
    b.add_joint("revolute", "axle", "ground", "disk", point=(0, 0, 0), axis=(0, 1, 0))
    with pytest.raises(ModelError) as info:
        b.add_force("joint_friction", "fr", joint="axle", **params)
        b.compile()
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_a_radius_on_a_translation_is_refused():
    with pytest.raises(ModelError, match="no radius"):
        block(0.3, 1.0, radius=0.1)


@pytest.mark.parametrize("method, options, words", [
    ("recursive", {}, ("'fr'", "method 'standard'")),
    ("standard", dict(solver="kkt"), ("'fr'", "solver='schur'")),
])
def test_methods_without_multipliers_are_refused(method, options, words):
    with pytest.raises(ModelError) as info:
        simulate(block(0.3, 1.0), 0.1, method=method, method_options=options)
    for word in words:
        assert word in str(info.value)


def test_cosimulation_closes_the_loop_as_simulate_does():
    """FMI co-simulation steps the same right-hand side: the block stops at the same place
    (at 0.510 s; six steps of 0.1 s end in the stiff sticking after it, as the block test)."""
    from spatialmbd.fmi.cosim import CoSimulation
    mu, v0 = 0.3, 1.5
    sim = CoSimulation(block(mu, v0, creep_velocity=1e-6), outputs=["block.x"],
                       method="standard", rtol=1e-10, atol=1e-12)
    for k in range(6):
        sim.do_step(0.1 * k, 0.1)
    assert sim.output("block.x") == pytest.approx(v0 ** 2 / (2 * mu * G), abs=1e-9)


@pytest.mark.parametrize("analysis", ["inverse_dynamics", "linearize"])
def test_analyses_that_do_not_close_the_loop_refuse_it(analysis):
    from spatialmbd import analyses
    run = getattr(analyses, analysis)
    with pytest.raises(ModelError, match=r"does not close the loop .*\('fr'\).*frictionloss"):
        run(block(0.3, 1.0), **({"t": [0.0, 0.1]} if analysis == "inverse_dynamics" else {}))
