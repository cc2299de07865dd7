"""Contact physics against closed forms derived here: Hertz impact, the rebound ratio each
hysteresis law produces, elastic bounces, Coulomb sliding, sliding to rolling, the incline,
step-size independence, the energy balance, and bad input."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from spatialmbd import ModelBuilder, ModelError
from spatialmbd.forces.contact.memory import contact_table
from spatialmbd.simulate import simulate

G = 9.81
PLANE = {"type": "plane", "normal": (0, 0, 1.0)}


def ball(z0=0.5, vz=0.0, vx=0.0, gravity=(0, 0, -G), radius=0.1, mass=1.0, omega=(0, 0, 0),
         **law):
    b = ModelBuilder(gravity=gravity)
    J = 0.4 * mass * radius ** 2
    b.add_body("ball", mass, (J, J, J), r=(0, 0, z0), rdot=(vx, 0, vz), omega=omega)
    b.add_force("contact", "c", body_i="ground", body_j="ball", shape_i=PLANE,
                shape_j={"type": "sphere", "radius": radius}, **law)
    return b.compile()


# ------------------------------------------------------------------ Hertz impact
def test_hertz_impact_closed_form():
    """Sphere (R, m, E, nu) on a rigid flat at v0, no gravity. Energy: m v0^2 / 2 =
    2/5 K d_max^(5/2), K = 4/3 E* sqrt(R), E* = E / (1 - nu^2); peak force K d_max^(3/2);
    duration T = 2 (d_max / v0) int_0^1 dx / sqrt(1 - x^(5/2)) (time to d_max and back)."""
    R, m, E, nu, v0 = 0.1, 1.0, 2.0e11, 0.3, 1.0
    model = ball(z0=R + 1e-3, vz=-v0, gravity=(0, 0, 0), radius=R, mass=m, law="hertz",
                 young_j=E, poisson_j=nu)
    K = 4.0 / 3.0 * E / (1 - nu ** 2) * math.sqrt(R)
    assert model.force_groups[0].param[0, 9] == pytest.approx(K, rel=1e-14)
    dmax = (5.0 * m * v0 ** 2 / (4.0 * K)) ** 0.4
    T = 2.0 * dmax / v0 * quad(lambda x: 1.0 / math.sqrt(1.0 - x ** 2.5), 0, 1)[0]
    t_touch = 1e-3 / v0
    sep = lambda t, s: s.r[0, 2] - R                                       # noqa: E731
    sep.direction, sep.name = 1.0, "separation"
    t_eval = np.concatenate([[0.0], t_touch + np.linspace(0.0, 1.2 * T, 4001)])
    res = simulate(model, t_eval=t_eval, rtol=1e-11, atol=1e-13, events=[sep], event_tol=1e-14)
    assert res.status == "success"
    ct = contact_table(res)["c"]
    assert res.contact_log[0][0] == pytest.approx(t_touch, abs=1e-12)
    assert res.contact_log[0][2] == pytest.approx(v0, rel=1e-9)
    assert ct["penetration"].max() == pytest.approx(dmax, rel=1e-5)
    assert ct["normal_force"].max() == pytest.approx(K * dmax ** 1.5, rel=1e-5)
    t_sep = [e["t"] for e in res.events if e["name"] == "separation"][0]
    assert t_sep - t_touch == pytest.approx(T, rel=1e-6)
    assert res.v[-1, 0, 2] == pytest.approx(v0, rel=1e-7)                  # elastic


# ------------------------------------------------------------------ restitution
def produced(chi):
    """m d'' = -K d^n (1 + chi d'/v0): with u = d', z = K d^(n+1) / ((n+1) m),
    u du/dz = -(1 + chi u / v0). Integrating from (v0, 0) to (0, z_max) and from (0, z_max)
    to (-e v0, 0): chi - ln(1 + chi) = -chi e - ln(1 - chi e) (any K, n, m, v0)."""
    f = lambda e: chi - math.log(1 + chi) + chi * e + math.log(1 - chi * e)  # noqa: E731
    return brentq(f, 0.0, min(1.0, (1 - 1e-14) / chi), xtol=1e-15)


CHI = {"hunt_crossley": lambda e: 1.5 * (1 - e),
       "lankarani_nikravesh": lambda e: 0.75 * (1 - e * e),
       "flores": lambda e: 1.6 * (1 - e) / e, "gonthier": lambda e: (1 - e * e) / e}


def rebound_ratio(law, e, exponent=1.5, v0=1.0):
    model = ball(z0=0.1 + 1e-3, vz=-v0, gravity=(0, 0, 0), law=law, stiffness=1e7,
                 exponent=exponent, restitution=e)
    res = simulate(model, 0.02, output_step=0.01, rtol=1e-10, atol=1e-12)
    assert res.status == "success" and res.q[-1, 0, 2] > 0.1
    return res.v[-1, 0, 2] / v0


@pytest.mark.parametrize("law", sorted(CHI))
def test_rebound_ratio_each_law(law):
    for e in (0.3, 0.8):
        assert rebound_ratio(law, e) == pytest.approx(produced(CHI[law](e)), abs=2e-6)


def test_rebound_ratio_independent_of_exponent_and_speed():
    ref = produced(CHI["lankarani_nikravesh"](0.6))
    assert rebound_ratio("lankarani_nikravesh", 0.6, exponent=1.0, v0=0.3) == \
        pytest.approx(ref, abs=2e-6)


@pytest.mark.slow
@pytest.mark.parametrize("law", sorted(CHI))
def test_rebound_ratio_range(law):
    for e in (0.1, 0.2, 0.4, 0.5, 0.6, 0.7, 0.9, 0.95):
        assert rebound_ratio(law, e) == pytest.approx(produced(CHI[law](e)), abs=2e-6)


@pytest.mark.parametrize("e", [0.1, 0.5, 0.9])
def test_carvalho_martins_produces_the_prescribed_restitution(e):
    """Its chi is the exact inverse of the relation above: the rebound ratio is e itself."""
    assert rebound_ratio("carvalho_martins", e) == pytest.approx(e, abs=2e-6)


def test_elastic_bounces_conserve_energy():
    """100 Hertz bounces from 2 cm: the apex stays at 2 cm, total energy constant."""
    h = 0.02
    model = ball(z0=0.1 + h, law="hertz", stiffness=1e8)
    period = 2 * math.sqrt(2 * h / G)
    res = simulate(model, 102 * period, output_step=period / 40, rtol=1e-10, atol=1e-12)
    assert res.status == "success"
    assert len(res.contact_log) >= 100          # the contact time lengthens the period a bit
    assert [r[2] for r in res.contact_log] == pytest.approx([math.sqrt(2 * G * h)] * len(
        res.contact_log), rel=1e-6)   # the energy drift of 100 bounces at rtol 1e-10
    en = res.energy()
    assert abs(en["error"]).max() < 1e-6 * (1.0 * G * h)   # ~1e-8 per bounce at rtol 1e-10
    assert res.q[:, 0, 2].max() == pytest.approx(0.1 + h, abs=1e-8)
    assert res.q[-400:, 0, 2].max() == pytest.approx(0.1 + h, abs=2e-5)  # sampled apexes


def test_step_size_independence_and_energy_with_dissipation():
    """Flores law, e = 0.5, two tolerances: the same bounce times and heights; total energy
    plus dissipated work constant."""
    runs = []
    for tol in (1e-8, 1e-11):
        model = ball(z0=0.3, law="flores", stiffness=1e7, restitution=0.5)
        res = simulate(model, 0.8, output_step=0.01, rtol=tol, atol=tol * 1e-2)
        runs.append(res)
        en = res.energy()
        assert abs(en["error"]).max() < 200 * tol * (G * 0.2)
        assert en["work_nonconservative"][-1] < -0.5 * G * 0.2         # most energy dissipated
    a, b = runs
    assert np.abs(a.q[:, 0, 2] - b.q[:, 0, 2]).max() < 1e-6
    assert [r[0] for r in a.contact_log] == pytest.approx([r[0] for r in b.contact_log],
                                                          abs=100 * 1e-8)


# ------------------------------------------------------------------ friction
def block(vx=0.0, gravity=(0, 0, -G), m=2.0, K=1e6, **fric):
    hx, hy, hz = 0.1, 0.08, 0.05
    b = ModelBuilder(gravity=gravity)
    dz = abs(gravity[2]) * m / (4 * K)              # static penetration of the 4 lower vertices
    J = m / 3 * np.array([hy * hy + hz * hz, hx * hx + hz * hz, hx * hx + hy * hy])
    b.add_body("block", m, J, r=(0, 0, hz - dz), rdot=(vx, 0, 0))
    c = 2 * math.sqrt(K * m / 4)                     # critical damping per vertex
    b.add_force("contact", "c", body_i="ground", body_j="block", shape_i=PLANE,
                shape_j={"type": "box", "half_extents": (hx, hy, hz)}, law="linear",
                stiffness=K, damping=c, **fric)
    return b.compile()


def test_block_slides_to_the_coulomb_distance():
    """v0 = 2 m/s, mu = 0.3: deceleration mu g, stops after v0^2 / (2 mu g) at v0 / (mu g)."""
    mu, v0 = 0.3, 2.0
    model = block(vx=v0, friction="coulomb", mu=mu, creep_velocity=1e-4)
    res = simulate(model, 1.0, output_step=0.01, rtol=1e-9, atol=1e-11)
    assert res.status == "success"
    d, t_stop = v0 ** 2 / (2 * mu * G), v0 / (mu * G)
    assert res.q[-1, 0, 0] == pytest.approx(d, rel=1e-4)
    k = np.searchsorted(res.t, 0.5 * t_stop)
    assert res.v[k, 0, 0] == pytest.approx(v0 - mu * G * res.t[k], rel=1e-4)
    en = res.energy()
    assert abs(en["error"]).max() < 1e-6 * (0.5 * 2.0 * v0 ** 2)
    ct = contact_table(res)
    assert ct["n_active"][-1] == 4
    total = sum(ct[f"c[{k}]"]["normal_force"][-1] for k in range(8))
    assert total == pytest.approx(2.0 * G, rel=1e-6)


@pytest.mark.parametrize("ratio", [1.1, 0.9])
def test_block_on_incline_sticks_iff_mu_at_least_tan(ratio):
    """Incline theta = 20 deg (gravity tilted). mu = 1.1 tan(theta): sticks, creeping at
    v_eps atanh(tan(theta) / mu); mu = 0.9 tan(theta): slides at g (sin - mu cos)."""
    th = math.radians(20.0)
    mu, veps = ratio * math.tan(th), (1e-4 if ratio > 1 else 1e-5)
    model = block(gravity=(G * math.sin(th), 0, -G * math.cos(th)), friction="coulomb", mu=mu,
                  creep_velocity=veps)
    res = simulate(model, 1.0, output_step=0.05, rtol=1e-9, atol=1e-11)
    x = res.q[-1, 0, 0]
    if ratio > 1:
        creep = veps * math.atanh(math.tan(th) / mu)
        assert 0 < x < 1.1 * creep * 1.0            # creep speed plus the start's transient
        assert res.v[-1, 0, 0] == pytest.approx(creep, rel=1e-3)
    else:
        assert x == pytest.approx(0.5 * G * (math.sin(th) - mu * math.cos(th)), rel=1e-3)


def test_sphere_sliding_starts_rolling():
    """Solid sphere launched at v0 without spin, mu: v = v0 - mu g t, omega R = 5/2 mu g t;
    rolling from t* = 2 v0 / (7 mu g) at v* = 5/7 v0 (impulse-momentum)."""
    R, m, mu, v0, K = 0.1, 1.0, 0.2, 2.0, 1e9
    dz = (m * G / K) ** (2 / 3)
    model = ball(z0=R - dz, vx=v0, radius=R, law="hertz", stiffness=K, friction="coulomb",
                 mu=mu, creep_velocity=1e-4)
    res = simulate(model, 0.6, output_step=0.002, rtol=1e-9, atol=1e-12)
    assert res.status == "success"
    t_star = 2 * v0 / (7 * mu * G)
    slip = contact_table(res)["c"]["slip_speed"]
    k = np.argmax(slip < 0.01)                       # slip falls linearly at 7/2 mu g
    t_cross = res.t[k - 1] + (slip[k - 1] - 0.01) / (slip[k - 1] - slip[k]) * (res.t[k] -
                                                                               res.t[k - 1])
    assert t_cross == pytest.approx((v0 - 0.01) / (3.5 * mu * G), abs=1e-4)
    assert t_cross < t_star
    assert res.v[-1, 0, 0] == pytest.approx(5 / 7 * v0, rel=1e-4)
    assert res.v[-1, 0, 4] * R == pytest.approx(5 / 7 * v0, rel=1e-4)       # v = omega x R e_z
    en = res.energy()
    assert abs(en["error"]).max() < 1e-6


# ------------------------------------------------------------------ bad input
def add(b, **kw):
    params = dict(body_i="ground", body_j="ball", shape_i=PLANE,
                  shape_j={"type": "sphere", "radius": 0.1}, law="hertz", stiffness=1e6)
    params.update(kw)
    b.add_force("contact", "bad", **params)
    return b


def builder(z=0.5):
    b = ModelBuilder()
    b.add_body("ball", 1.0, (0.004,) * 3, r=(0, 0, z))
    return b


@pytest.mark.parametrize("kw, words", [
    (dict(stiffness=-1.0), "stiffness"),
    (dict(law="hunt_crossley", restitution=0.0), "restitution"),
    (dict(law="hunt_crossley", restitution=1.2), "restitution"),
    (dict(law="hunt_crossley"), "restitution"),
    (dict(friction="coulomb", mu=-0.1), "mu"),
    (dict(law="sticky"), "law"),
    (dict(shape_j={"type": "cone"}), "shape_j.type"),
    (dict(shape_j={"type": "box", "half_extents": (1, 1, 1)},
          shape_i={"type": "socket", "radius": 1.0}), "no contact geometry"),
])
def test_bad_parameters_name_the_element(kw, words):
    with pytest.raises(ModelError, match=r"forces\['bad'\].*" + words.split(".")[0]):
        add(builder(), **kw)


def test_deep_interpenetration_at_start():
    b = add(builder(z=0.02))
    with pytest.raises(ModelError, match=r"forces\['bad'\].*interpenetrate"):
        b.compile()
    add(builder(z=0.099)).compile()                   # shallow: fine


def test_contact_outputs_and_columns(tmp_path):
    """res.contacts() and the output columns (CSV through the outputs machinery) agree; the
    impact velocity and the active flag follow the bounces."""
    from spatialmbd.outputs import compute_outputs
    model = ball(z0=0.2, law="hunt_crossley", stiffness=1e7, restitution=0.9)
    res = simulate(model, 0.7, output_step=0.001, rtol=1e-9, atol=1e-11, outputs="forces")
    c = res.contacts()
    cols = compute_outputs(res)
    assert np.array_equal(cols["c.normal_force"], c["c"]["normal_force"])
    assert np.array_equal(cols["c.active"] > 0.5, c["c"]["active"])
    assert np.array_equal(c["n_active"], c["c"]["active"].astype(int))
    v0 = math.sqrt(2 * G * 0.1)
    assert res.contact_log[0][2] == pytest.approx(v0, rel=1e-7)
    after = res.t > res.contact_log[0][0]
    assert np.allclose(c["c"]["impact_velocity"][after][:5], res.contact_log[0][2])
    active = c["c"]["active"]
    assert np.all(c["c"]["normal_force"][~active] == 0) and np.all(
        c["c"]["normal_force"][active] >= 0)
    assert np.allclose(c["c"]["penetration"][active], -c["c"]["gap"][active])
    df = res.to_dataframe()
    assert "c.normal_force" in df.columns
    # the accelerations at the outputs use the impact velocity of their own bounce
    assert np.allclose(res.vdot[:, 0, 2], c["c"]["normal_force"] / 1.0 - G, rtol=1e-12,
                       atol=1e-9)
    assert len(res.contact_log) >= 2 and res.contact_log[1][2] < res.contact_log[0][2]
    res.contact_log = None          # e.g. results read back from a file: no impact records
    assert np.all(np.isnan(res.contacts()["c"]["normal_force"]))


def test_viscous_friction_decays_exponentially():
    """Viscous friction only, c_v at each of the 4 closed vertex contacts:
    m v' = -4 c_v v, v = v0 exp(-4 c_v t / m)."""
    model = block(vx=1.0, friction="viscous", viscous=3.0)
    res = simulate(model, 0.5, output_step=0.05, rtol=1e-10, atol=1e-12)
    # (the friction acts hz below the centre of mass and tilts the block on its compliant
    # contacts by ~1e-6 rad, a few 1e-6 of the velocity: the rigid closed form holds to that)
    assert np.allclose(res.v[:, 0, 0], np.exp(-4 * 3.0 * res.t / 2.0), rtol=2e-5, atol=1e-8)


def test_stribeck_static_holds_dynamic_does_not():
    """tan(theta) between mu_dynamic and mu_static: from rest the block stays (creeps); launched
    faster than the Stribeck velocity it slides on with g (sin - mu_d cos) (mu(s) -> mu_d)."""
    th = math.radians(20.0)
    gravity = (G * math.sin(th), 0, -G * math.cos(th))
    fr = dict(friction="stribeck", mu_static=1.3 * math.tan(th), mu_dynamic=0.8 * math.tan(th),
              stribeck_velocity=0.01, creep_velocity=1e-4)
    rest = simulate(block(gravity=gravity, **fr), 0.5, output_step=0.05, rtol=1e-9, atol=1e-11)
    assert abs(rest.q[-1, 0, 0]) < 1e-4
    moving = simulate(block(gravity=gravity, vx=0.5, **fr), 0.5, output_step=0.05, rtol=1e-9,
                      atol=1e-11)
    a = G * (math.sin(th) - 0.8 * math.tan(th) * math.cos(th))
    assert moving.v[-1, 0, 0] == pytest.approx(0.5 + a * 0.5, rel=1e-6)


def test_model_file_contacts_section(tmp_path):
    from spatialmbd.io.modelfile import load_model
    text = """spatialmbd: 1
name: drop
gravity: [0, 0, -9.81]
bodies:
  - name: ball
    mass: 1.0
    inertia: [0.004, 0.004, 0.004]
    position: [0, 0, 0.3]
contacts:
  - name: floor
    body_i: ground
    body_j: ball
    shape_i: {type: plane, normal: [0, 0, 1]}
    shape_j: {type: sphere, radius: 0.1}
    law: gonthier
    restitution: RESTITUTION
    stiffness: 1.0e+7
"""
    path = tmp_path / "drop.yaml"
    path.write_text(text.replace("RESTITUTION", "0.7"))
    model, _ = load_model(path)
    assert model.force_groups[0].names == ("floor",)
    path.write_text(text.replace("RESTITUTION", "1.5"))
    with pytest.raises(ModelError,
                       match=r"contacts\[0\]\.restitution: must be in \(0, 1\].*line 16"):
        load_model(path)
    path.write_text(text.replace("RESTITUTION", "0.7").replace("body_j: ball", "body_j: bal"))
    with pytest.raises(ModelError, match=r"contacts\[0\]\.body_j.*bal"):
        load_model(path)


def test_round_trip_and_methods_without_compiled_kernels(tmp_path):
    """A model with contacts writes (as a contact force element) and reads back; a hysteresis
    law on a right-hand side without compiled kernels (solver="kkt") is refused by name."""
    from spatialmbd.io.modelfile import load_model, save_model
    model = ball(law="flores", stiffness=1e7, restitution=0.6, friction="coulomb", mu=0.4)
    save_model(model, tmp_path / "m.yaml")
    again, _ = load_model(tmp_path / "m.yaml")
    assert np.array_equal(again.force_groups[0].param, model.force_groups[0].param)
    with pytest.raises(ModelError, match=r"forces\['c'\].*hysteresis.*kkt"):
        simulate(model, 0.1, method_options={"solver": "kkt"}, method="standard")


def test_equal_spheres_exchange_velocities():
    """Central elastic impact of equal free spheres (Hertz, no gravity): the moving one stops,
    the other leaves at its speed (momentum and energy conservation); then the Newton's-cradle
    pair of a Hunt-Crossley contact: the relative rebound is the produced restitution."""
    for law, e_rel in ((dict(law="hertz"), 1.0),
                       (dict(law="hunt_crossley", restitution=0.7), produced(1.5 * 0.3))):
        b = ModelBuilder(gravity=(0, 0, 0))
        for name, x, vx in (("a", 0.0, 1.0), ("b", 0.21, 0.0)):
            b.add_body(name, 1.0, (0.004,) * 3, r=(x, 0, 0), rdot=(vx, 0, 0))
        b.add_force("contact", "ab", body_i="a", body_j="b", shape_i={"type": "sphere",
                    "radius": 0.1}, shape_j={"type": "sphere", "radius": 0.1},
                    stiffness=1e7, **law)
        res = simulate(b.compile(), 0.05, output_step=0.01, rtol=1e-10, atol=1e-12)
        va, vb = res.v[-1, 0, 0], res.v[-1, 1, 0]
        assert va + vb == pytest.approx(1.0, abs=1e-9)                    # momentum
        assert vb - va == pytest.approx(e_rel, abs=2e-6)                  # restitution


def test_clearance_joints_conserve_energy_when_elastic():
    """A pendulum on a radial-clearance revolute joint (journal in bearing + planar joint) and
    a ball-in-socket pendulum, elastic Hertz contacts without friction: rattling in the
    clearance, total energy constant."""
    import math as m_
    th = m_.radians(30)
    for pair in ("bearing", "socket"):
        b = ModelBuilder(gravity=(0, 0, -G))
        b.add_body("rod", 1.0, (0.02, 0.02, 1e-4), r=(-0.25 * m_.sin(th), 0, -0.25 * m_.cos(th)),
                   p=(m_.cos(th / 2), 0, m_.sin(th / 2), 0))
        if pair == "bearing":
            b.add_joint("planar", "plane", body_i="ground", body_j="rod", point=(0, 0, 0),
                        axis=(0, 1, 0))
            shape_i = {"type": "bearing", "radius": 0.01, "axis": (0, 1, 0)}
            shape_j = {"type": "journal", "radius": 0.0095, "center": (0, 0, 0.25)}
        else:
            shape_i = {"type": "socket", "radius": 0.01}
            shape_j = {"type": "sphere", "radius": 0.0095, "center": (0, 0, 0.25)}
        b.add_force("contact", "gap", body_i="ground", body_j="rod", shape_i=shape_i,
                    shape_j=shape_j, law="hertz", stiffness=1e8)
        res = simulate(b.compile(), 0.3, output_step=0.01, rtol=1e-9, atol=1e-12)
        assert res.status == "success"
        en = res.energy()
        assert len(res.contact_log) >= 1
        assert abs(en["error"]).max() < 1e-6 * abs(en["gravitational"][0])
        assert res.contacts()["gap"]["active"].any()


# ------------------------------------------------------------------ LuGre friction
def _lugre_block(mu, th, sigma0=1e5):
    m = 2.0
    return block(gravity=(G * math.sin(th), 0, -G * math.cos(th)), m=m, friction="lugre",
                 mu=mu, bristle_stiffness=sigma0,
                 bristle_damping=2 * math.sqrt(sigma0 * m / 4))


def test_lugre_block_on_incline_sticks_without_creep():
    """mu = 1.1 tan(theta): with bristles the block stops dead -- no creep velocity, unlike the
    regularised Coulomb law -- held by the bristles' deflection: sum sigma_0 z = m g sin."""
    th, m, sigma0 = math.radians(20.0), 2.0, 1e5
    model = _lugre_block(1.1 * math.tan(th), th, sigma0)
    res = simulate(model, 1.0, output_step=0.05, rtol=1e-9, atol=1e-11)
    assert res.status == "success"
    half = res.t >= 0.5
    assert np.abs(res.v[half, 0, :3]).max() < 1e-9                   # at rest, no creep
    assert np.ptp(res.q[half, 0, 0]) < 1e-10
    from spatialmbd.forces.kernels import STATE_WIDTH               # z, then 2 energies
    z = res.force_states[-1].reshape(-1, STATE_WIDTH)[:, :3]          # one per box vertex
    assert sigma0 * z[:, 0].sum() == pytest.approx(m * G * math.sin(th), rel=1e-6)
    c = res.contacts()
    fN = {k: v["normal_force"][-1] for k, v in c.items() if k != "n_active"}
    for k, zk in enumerate(z):                                       # each under its limit
        assert sigma0 * abs(zk[0]) <= 1.1 * math.tan(th) * fN[f"c[{k}]"] + 1e-12
    E = res.energy()
    assert np.abs(E["error"]).max() < 1e-8 * abs(E["total"][0]) + 1e-9


def test_lugre_block_on_incline_slides_at_coulomb_deceleration():
    """mu = 0.9 tan(theta): after the presliding instant the block slides with
    a = g (sin - mu cos); the friction of the four contacts sums to mu m g cos."""
    th, m = math.radians(20.0), 2.0
    mu = 0.9 * math.tan(th)
    res = simulate(_lugre_block(mu, th), 1.0, output_step=0.05, rtol=1e-9, atol=1e-11)
    a = (res.v[-1, 0, 0] - res.v[10, 0, 0]) / (res.t[-1] - res.t[10])
    assert a == pytest.approx(G * (math.sin(th) - mu * math.cos(th)), rel=1e-5)
    c = res.contacts()
    friction = sum(v["friction"][-1, 0] for k, v in c.items() if k != "n_active")
    assert friction == pytest.approx(-mu * m * G * math.cos(th), rel=1e-5)
    E = res.energy()
    assert E["work_nonconservative"][-1] < -0.5
    assert np.abs(E["error"]).max() < 1e-8 * abs(E["work_nonconservative"][-1])


def test_lugre_bad_input():
    with pytest.raises(ModelError, match="bristle_stiffness"):
        block(friction="lugre", mu=0.3)
    with pytest.raises(ModelError, match="bristle_damping.*lugre"):
        block(friction="coulomb", mu=0.3, bristle_damping=1.0)
