"""Rolling without slip (constraints.rolling): kernels against finite differences and an
independent evaluation of the contact-point velocity; the physics against closed forms derived
here: a sphere down an incline (a = 5/7 g sin alpha), a ball on a turntable (its centre circles
at 2/7 of the table's rate), a coin in steady circular motion."""
import math

import numpy as np
import pytest

from fd_check import q_along, random_geometry, random_state
from spatialmbd import ModelBuilder, models
from spatialmbd.constraints import CONSTRAINT_TYPES
from spatialmbd.errors import ModelError
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

G = 9.81


def _group(name, rng, n=6, nb=3):
    geo = random_geometry(rng, n, 1)
    bi = rng.integers(0, nb, n)
    bj = (bi + 1 + rng.integers(0, nb, n)) % (nb + 1)        # another body or the ground
    return CONSTRAINT_TYPES[name]([f"c{k}" for k in range(n)], bi, bj, geo), bi, bj


@pytest.mark.parametrize("name", ["rolling_sphere", "rolling_disc"])
def test_kernels_against_finite_differences(name):
    """Along r = r0 + rdot t, A = exp(omega~ t) A0 (vdot = 0): the height row's dPhi/dt = D v
    and d2Phi/dt2 = -gamma; a slip row's d(D v)/dt = -gamma (it has no Phi: phi = 0)."""
    rng = np.random.default_rng(7)
    for _ in range(5):
        grp, bi, bj = _group(name, rng)
        q0, v = random_state(rng, 3)
        h = 1e-3

        def at(dt):
            s = BodyState.from_qv(q_along(q0, v, dt), v, dt)
            ev = grp.evaluate(s, dt)
            vij = np.concatenate([s.rdot[bi], s.omega[bi], s.rdot[bj], s.omega[bj]], axis=1)
            return ev, np.einsum("nmk,nk->nm", ev.D, vij)

        evs = [at(k * h) for k in (-2, -1, 0, 1, 2)]
        phi = np.array([e.phi for e, _ in evs])
        dv = np.array([x for _, x in evs])
        ev0 = evs[2][0]
        d1 = (phi[0] - 8 * phi[1] + 8 * phi[3] - phi[4]) / (12 * h)
        d2 = (-phi[0] + 16 * phi[1] - 30 * phi[2] + 16 * phi[3] - phi[4]) / (12 * h * h)
        ddv = (dv[0] - 8 * dv[1] + 8 * dv[3] - dv[4]) / (12 * h)
        scale = max(1.0, np.abs(ev0.gamma).max())
        assert np.abs(d1[:, 0] - dv[2][:, 0]).max() < 1e-8
        assert np.abs(d2[:, 0] + ev0.gamma[:, 0]).max() < 1e-6 * scale
        assert np.abs(ddv[:, 1:] + ev0.gamma[:, 1:]).max() < 1e-6 * scale
        assert np.all(ev0.phi[:, 1:] == 0.0) and np.all(ev0.nu == 0.0)


def test_slip_rows_are_the_contact_point_velocity():
    """D v of the slip rows = t^T (v_P,i - v_P,j), with P, t and the material velocities
    computed here from the definitions (disc: P = c - R (n - w u) / |n - w u|)."""
    rng = np.random.default_rng(3)
    for name in ("rolling_sphere", "rolling_disc"):
        grp, bi, bj = _group(name, rng)
        q, v = random_state(rng, 3)
        s = BodyState.from_qv(q, v, 0.0)
        ev = grp.evaluate(s, 0.0)
        geo = grp.geometry
        for k in range(grp.n):
            Ai, Aj = s.A[bi[k]], s.A[bj[k]]
            c = s.r[bi[k]] + Ai @ geo.s_i[k]
            n, t1, t2 = (Aj @ geo.R_j[k][:, col] for col in range(3))
            R = geo.param[k, 0]
            if name == "rolling_sphere":
                P = c - R * n
            else:
                u = Ai @ geo.R_i[k][:, 0]
                e = n - (n @ u) * u
                P = c - R * e / np.linalg.norm(e)
            vi = s.rdot[bi[k]] + np.cross(s.omega[bi[k]], P - s.r[bi[k]])
            vj = s.rdot[bj[k]] + np.cross(s.omega[bj[k]], P - s.r[bj[k]])
            vij = np.concatenate([s.rdot[bi[k]], s.omega[bi[k]], s.rdot[bj[k]],
                                  s.omega[bj[k]]])
            assert ev.D[k, 1] @ vij == pytest.approx(t1 @ (vi - vj), abs=1e-12)
            assert ev.D[k, 2] @ vij == pytest.approx(t2 @ (vi - vj), abs=1e-12)
            p = s.r[bj[k]] + Aj @ geo.s_j[k]
            # the height: distance of the body's lowest point above the plane
            assert ev.phi[k, 0] == pytest.approx(n @ (P - p), abs=1e-12)


def test_sphere_rolls_down_an_incline_at_five_sevenths_g_sin_alpha():
    alpha, m, R = 0.3, 2.0, 0.1
    n = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    b = ModelBuilder("incline", gravity=(0.0, 0.0, -G))
    b.add_body("ball", m, (0.4 * m * R * R,) * 3, r=tuple(R * n))
    b.add_joint("rolling_sphere", "roll", "ball", "ground", point=tuple(R * n),
                point2=(0, 0, 0), axis2=tuple(n), radius=R)
    res = simulate(b.compile(), 1.0, output_step=0.05, rtol=1e-10, atol=1e-12)
    down = np.array([math.cos(alpha), 0.0, -math.sin(alpha)])
    travel = (res.q[:, 0, :3] - res.q[0, 0, :3]) @ down
    a = 5.0 / 7.0 * G * math.sin(alpha)            # m a = m g sin - F, F R = (2/5 m R^2) a / R
    assert np.allclose(travel, 0.5 * a * res.t ** 2, atol=1e-10, rtol=0)
    assert np.abs(res.energy()["error"]).max() < 1e-10         # rolling does no work
    # the no-slip multipliers are the friction force F = (2/7) m g sin(alpha) up the slope
    rx = res.reactions()["roll"]
    f = rx.force_i[-1]
    assert f @ (-down) == pytest.approx(2.0 / 7.0 * m * G * math.sin(alpha), rel=1e-8)
    assert f @ n == pytest.approx(m * G * math.cos(alpha), rel=1e-8)


def test_ball_on_a_turntable_circles_at_two_sevenths_of_its_rate():
    """A solid ball (k = I / m R^2 = 2/5) on a table turning at W: the no-slip condition and
    the balance of angular momentum about the contact give rddot = k / (1 + k) W e_z x rdot,
    so the centre's velocity turns at 2W/7 with constant speed."""
    W = 2.0
    model = models.ball_on_turntable(speed=W).compile()
    T = 2 * math.pi / (2 * W / 7)
    res = simulate(model, T, output_step=T / 100, rtol=1e-10, atol=1e-12)
    assert res.status == "success"
    k = model.body_index("ball")
    vel = res.v[:, k, :2]
    angle = np.unwrap(np.arctan2(vel[:, 1], vel[:, 0]))
    assert np.allclose(angle - angle[0], 2 * W / 7 * res.t, atol=1e-8)
    assert np.ptp(np.hypot(vel[:, 0], vel[:, 1])) < 1e-10
    assert np.abs(res.q[-1, k, :3] - res.q[0, k, :3]).max() < 1e-8    # back after a circle
    assert res.constraint_violation()["velocity"].max() < 1e-10


@pytest.mark.parametrize("method", ["projection",
                                    pytest.param("baumgarte", marks=pytest.mark.slow),
                                    pytest.param("augmented_lagrangian", marks=pytest.mark.slow)])
def test_coin_keeps_its_steady_circular_motion(method):
    """The steady motion of a coin (models.rolling_disc_steady): over one revolution its centre
    keeps its circle and height, its tilt stays, and it comes back to its start."""
    omega, spin = models.rolling_disc_steady()
    # the closed form checked here independently: d(H_C)/dt = Omega e_z x H_C equals the torque
    # of the contact force (m a_C - m g) about the centre, at tilt 0.3, b = 0.5, R = 0.1
    m, R, b, th = 0.5, 0.1, 0.5, 0.3
    Ia, Id = m * R * R / 2, m * R * R / 4
    er, ez = np.array([1.0, 0, 0]), np.array([0, 0, 1.0])
    u = math.cos(th) * er + math.sin(th) * ez
    w = omega * ez + spin * u
    H = Ia * (w @ u) * u + Id * (w - (w @ u) * u)
    F = m * (-omega ** 2 * b * er) + m * G * ez
    torque = np.cross(R * (math.sin(th) * er - math.cos(th) * ez), F)
    assert np.allclose(np.cross(omega * ez, H), torque, atol=1e-12)

    model = models.rolling_disc().compile()
    T = 2 * math.pi / omega
    res = simulate(model, T, method=method, output_step=T / 50, rtol=1e-10, atol=1e-12)
    assert res.status == "success"
    c = res.q[:, 0, :3]
    assert np.ptp(np.hypot(c[:, 0], c[:, 1])) < 1e-7
    assert np.ptp(c[:, 2]) < 1e-7
    assert np.abs(c[-1] - c[0]).max() < 1e-6
    tilt = A_from_p(res.q[:, 0, 3:])[:, 2, 0]                  # e_z . u = sin(tilt)
    assert np.ptp(tilt) < 1e-7
    assert np.abs(res.energy()["error"]).max() < 1e-8


def test_bad_input_is_a_model_error():
    b = ModelBuilder("flat")
    b.add_body("coin", 1.0, (1, 1, 1), r=(0, 0, 0.0))
    with pytest.raises(ModelError, match="roll.*lies flat"):
        b.add_joint("rolling_disc", "roll", "coin", "ground", point=(0, 0, 0), axis=(0, 0, 1),
                    point2=(0, 0, 0), axis2=(0, 0, 1), radius=0.1)
        b.compile()
    b = ModelBuilder("neg")
    b.add_body("ball", 1.0, (1, 1, 1), r=(0, 0, 0.1))
    with pytest.raises(ModelError, match="radius"):
        b.add_joint("rolling_sphere", "roll", "ball", "ground", point=(0, 0, 0.1),
                    point2=(0, 0, 0), axis2=(0, 0, 1), radius=-0.1)
        b.compile()


def test_mobility_reports_the_velocity_only_rows():
    from spatialmbd.kinematics import mobility
    mob = mobility(models.rolling_disc().compile())
    assert (mob.dof, mob.n_velocity_only) == (3, 2)
    assert "configuration has 5 DoF and the velocities 3" in mob.report()
