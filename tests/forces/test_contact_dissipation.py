"""Per-contact outputs: the powers of the normal damping and of the friction, the energies each
contact has dissipated (integrated with the run when ``track_dissipation`` is set, or with
LuGre friction), the stiffness and damping in use, ``Model.summary()``; the ``margin`` key.

References: a free ball of mass m bouncing on a rigid plane loses 1/2 m (v_a^2 - v_b^2)
between two impacts at speeds v_a and v_b (the flight between them is conservative); a block
sliding to rest from v0 on a plane dissipates 1/2 m v0^2 by friction."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.forces.contact import laws as L
from spatialmbd.forces.kernels import evaluate_forces
from spatialmbd.simulate import simulate

G = 9.81


def _ball(track=True, **law):
    b = ModelBuilder("ball", gravity=(0, 0, -G))
    b.add_body("ball", 1.0, (0.004, 0.004, 0.004), r=(0, 0, 0.3))
    law = law or dict(law="flores", restitution=0.8, young_j=2e11, poisson_j=0.3)
    b.add_force("contact", "floor", body_i="ground", body_j="ball",
                shape_i={"type": "plane", "normal": (0, 0, 1)},
                shape_j={"type": "sphere", "radius": 0.1}, track_dissipation=track, **law)
    return b.compile()


def test_bouncing_ball_dissipates_what_each_bounce_loses():
    model = _ball()
    res = simulate(model, 1.0, output_step=1e-3, rtol=1e-10, atol=1e-12)
    c = res.contacts()["floor"]
    en = res.energy()
    lost = en["total"][0] - en["total"]
    # the contact is the only non-conservative element: its two integrated energies are the
    # whole work W (the same integrator, linear quadratures: equal to round-off)
    np.testing.assert_allclose(c["dissipated_normal"] + c["dissipated_friction"], -res.work,
                               rtol=0, atol=1e-14)
    assert np.all(c["dissipated_friction"] == 0.0)
    assert abs(c["dissipated_normal"][-1] - lost[-1]) < 1e-7 * lost[-1]
    assert np.all(np.diff(c["dissipated_normal"]) >= -1e-15)            # never gives back
    # between touches: 1/2 m (v_a^2 - v_b^2), v_a, v_b the recorded impact speeds
    log = res.contact_log
    assert len(log) >= 3
    for (ta, _, va), (tb, _, vb) in zip(log[:-1], log[1:]):
        between = (res.t > ta + 2e-3) & (res.t < tb)
        d = c["dissipated_normal"][between]
        assert d.size and np.ptp(d) < 1e-12                                # flight: constant
        before = c["dissipated_normal"][res.t < ta - 1e-9]
        d0 = before[-1] if before.size else 0.0
        expected = 0.5 * 1.0 * (va ** 2 - vb ** 2)
        assert abs(d[0] - d0 - expected) < 1e-6 * expected


def test_sliding_block_dissipates_its_kinetic_energy_by_friction():
    m, v0, mu, K = 2.0, 1.0, 0.4, 1e6
    b = ModelBuilder("block", gravity=(0, 0, -G))
    h = 0.05
    z0 = h - m * G / (4 * K)                         # resting at its static compression
    b.add_body("block", m, (0.01, 0.01, 0.01), r=(0, 0, z0), rdot=(v0, 0, 0))
    zeta = 1.0
    c = 2 * zeta * np.sqrt(K * m / 4)
    b.add_force("contact", "floor", body_i="ground", body_j="block",
                shape_i={"type": "plane", "normal": (0, 0, 1)},
                shape_j={"type": "box", "half_extents": (0.1, 0.1, h)}, law="linear",
                stiffness=K, damping=c, friction="coulomb", mu=mu, creep_velocity=1e-4,
                track_dissipation=True)
    model = b.compile()
    t_stop = v0 / (mu * G)
    res = simulate(model, 1.5 * t_stop, output_step=1e-3, rtol=1e-9, atol=1e-12)
    table = res.contacts()
    names = [n for n in table if n != "n_active"]
    assert len(names) == 8
    friction = sum(table[n]["dissipated_friction"] for n in names)
    normal = sum(table[n]["dissipated_normal"] for n in names)
    np.testing.assert_allclose(friction + normal, -res.work, rtol=0, atol=1e-13)
    kinetic = 0.5 * m * np.sum(res.v[:, 0, :3] ** 2, axis=1)
    # it stops (creeping at ~1e-4 m/s at most): the contacts took 1/2 m v0^2, the friction all
    # of it but the normal damping of the block's pitching as it starts and stops (4e-6)
    assert kinetic[-1] < 1e-7
    total = 0.5 * m * v0 ** 2
    assert abs(friction[-1] + normal[-1] - total) < 1e-6 * total + kinetic[-1]
    assert 0 < normal[-1] < 1e-5 * total
    en = res.energy()
    assert abs(friction[-1] + normal[-1] - (en["total"][0] - en["total"][-1])) < 1e-8
    # while sliding, the friction power is -mu m g v (all four touching corners)
    k = np.searchsorted(res.t, 0.5 * t_stop)
    power = sum(table[n]["power_friction"][k] for n in names)
    speed = res.v[k, 0, 0]
    assert abs(power + mu * m * G * speed) < 1e-5 * mu * m * G * speed
    # the damping in use of the linear law: c at every point, open or closed
    assert all(np.all(table[n]["damping"] == c) for n in names)
    assert all(table[n]["stiffness"] == K and table[n]["exponent"] == 1.0 for n in names)


def test_powers_are_the_kernels_power_split():
    """power_normal = (f_N - K delta^n) g' and power_friction = f_t . v_t at every output,
    and their sum is the power the compiled kernel gives the energy balance."""
    model = _ball(track=False, law="hunt_crossley", restitution=0.5, stiffness=1e7,
                  friction="coulomb", mu=0.3)
    b = model.to_builder()
    b.bodies["ball"].rdot = np.array([0.5, 0.0, 0.0])
    model = b.compile()
    res = simulate(model, 0.4, output_step=2e-4, rtol=1e-9, atol=1e-12)
    c = res.contacts()["floor"]
    closed = np.flatnonzero(c["active"])
    assert closed.size > 5
    group = model.force_groups[0]
    for k in closed[:: max(1, closed.size // 10)]:
        delta, rate = c["penetration"][k], -c["gap_rate"][k]
        el = 1e7 * delta ** 1.5
        assert c["power_normal"][k] == pytest.approx((c["normal_force"][k] - el) * -rate,
                                                     rel=1e-12, abs=1e-12)
        assert c["power_friction"][k] == pytest.approx(c["friction"][k] @ c["slip"][k],
                                                       rel=1e-12, abs=1e-15)
        chi = L.chi_hunt_crossley(0.5)
        assert c["damping"][k] == pytest.approx(el * chi / c["impact_velocity"][k], rel=1e-12)
        state = list(res.states())[k]
        table = group.table(memory=np.array([c["impact_velocity"][k]]))
        g, energy, power = np.zeros(6 * (model.nb + 1)), np.zeros(1), np.zeros(1)
        evaluate_forces(table.kind, state.arrays(), table.G, g, energy, power,
                        np.zeros((1, 12)))
        assert power[0] == pytest.approx(c["power_normal"][k] + c["power_friction"][k],
                                         rel=1e-12, abs=1e-12)
        assert table.law[0, 6] == -c["power_normal"][k]          # the rates of the states
        assert table.law[0, 7] == -c["power_friction"][k]
    # not tracked: no integrated energies (NaN), the powers are there
    assert np.all(np.isnan(c["dissipated_normal"]))
    assert np.all(np.isfinite(c["power_normal"]))


def test_summary_states_the_laws_in_use():
    text = _ball().summary()
    assert "floor: 1 point(s), flores, K = " in text
    e_p = L.produced_restitution(L.chi_flores(0.8))
    assert f"e_p = {e_p:.4g}" in text
    lin = _ball(law="linear", stiffness=1e6, damping=300.0, friction="coulomb",
                mu=0.5).summary()
    assert "K = 1e+06 N/m per point, damping c = 300 N s/m" in lin
    assert "friction mu 0.5, creep velocity 0.0001 m/s" in lin


def test_margin_rests_the_ball_that_far_above():
    K, margin = 1e5, 0.002
    model = _ball(law="linear", stiffness=K, damping=2 * np.sqrt(K), margin=margin)
    res = simulate(model, 2.0, output_step=1e-2, rtol=1e-9, atol=1e-12)
    assert abs(res.q[-1, 0, 2] - (0.1 + margin - G / K)) < 1e-8


def test_bad_keys():
    with pytest.raises(ModelError, match=r"forces\['floor'\].track_dissipation: expected "
                                         r"true or false, got 'yes'"):
        _ball(track="yes")
    with pytest.raises(ModelError, match=r"forces\['floor'\].margin: must be >= 0"):
        _ball(law="linear", stiffness=1e5, margin=-1e-3)
