"""Bushing force element: exact gradient of its potential, dissipation, closed-form small
oscillations and static deflection, model files and bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder, ModelError
from spatialmbd.forces.bushing import left_jacobian_inverse_T_apply, rotation_vector
from spatialmbd.io.modelfile import load_model, model_to_dict
from spatialmbd.rotations import A_from_p, normalize_p
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

from fd_check import q_along, random_state


def two_bodies(**params):
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(1.0, -0.5, 0.8), bryant=(0.3, -0.2, 0.5))
    axes = A_from_p(normalize_p(np.array([0.9, 0.2, -0.3, 0.1])))
    b.add_force("bushing", "bush", body_i="a", body_j="b", point_i=(0.4, -0.3, 0.2),
                axes=axes, **params)
    return b.compile()


def generalized(model, state, t=0.0):
    g = np.zeros((model.nb + 1, 6))
    for group in model.force_groups:
        group.evaluate(state, t, g)
    return g[:model.nb]


def test_rotation_vector_and_jacobian():
    rng = np.random.default_rng(5)
    axis = rng.normal(size=(50, 3))
    theta = axis / np.linalg.norm(axis, axis=1, keepdims=True) * rng.uniform(0, 3.1, (50, 1))
    theta[0] = 0.0
    theta[1] = [1e-9, -2e-9, 0.5e-9]
    from spatialmbd.rotations import p_from_rotation_vector
    assert np.allclose(rotation_vector(A_from_p(p_from_rotation_vector(theta))), theta,
                       atol=1e-12)
    # thetadot = J_l^-1 w: finite difference of log(exp(h w~) R) against it
    for th in theta[:10]:
        w = rng.normal(size=3)
        R = A_from_p(p_from_rotation_vector(th[None]))[0]
        h = 1e-6
        f = [rotation_vector((A_from_p(p_from_rotation_vector(s * h * w[None]))[0] @ R)[None])[0]
             for s in (-1, 1)]
        fd = (f[1] - f[0]) / (2 * h)
        # J_l^-1 w = J_l(-theta)^-T w
        assert np.allclose(left_jacobian_inverse_T_apply(-th[None], w[None])[0], fd, atol=1e-7)


def test_elastic_part_is_minus_gradient_of_potential():
    """Large deflections too: the torque uses the exact Jacobian of the rotation vector."""
    model = two_bodies(stiffness=(50.0, 80.0, 120.0), rotational_stiffness=(7.0, 3.0, 11.0))
    rng = np.random.default_rng(11)
    for _ in range(20):
        q0, v = random_state(rng, 2)
        h = 1e-5
        V = [sum(gr.potential_energy(BodyState.from_qv(q_along(q0, v, s * h), None, 0.0), 0.0)
                 for gr in model.force_groups) for s in (-1, 1)]
        dV = (V[1] - V[0]) / (2 * h)
        P = float(np.sum(generalized(model, BodyState.from_qv(q0, v, 0.0)) * v))
        assert P == pytest.approx(-dV, rel=1e-6, abs=1e-6)


def test_damping_power_and_action_reaction():
    model = two_bodies(damping=(3.0, 1.0, 2.0), rotational_damping=(0.5, 0.7, 0.2))
    rng = np.random.default_rng(12)
    for _ in range(10):
        q0, v = random_state(rng, 2)
        state = BodyState.from_qv(q0, v, 0.0)
        g = generalized(model, state)
        p_nc = sum(gr.nonconservative_power(state, 0.0) for gr in model.force_groups)
        assert np.sum(g * v) == pytest.approx(p_nc, rel=1e-10, abs=1e-12)
        assert p_nc <= 0
        # internal element: no net force, no net moment about the origin
        assert np.allclose(g[0, :3] + g[1, :3], 0, atol=1e-12)
        moment = sum(np.cross(state.r[k], g[k, :3]) + g[k, 3:] for k in range(2))
        assert np.allclose(moment, 0, atol=1e-10)


def hung_on_bushing(k, kr, m=3.0, J=(0.2, 0.3, 0.4), gravity=(0, 0, 0), **body):
    b = ModelBuilder("mount", gravity=gravity)
    b.add_body("mass", m, J, r=(0, 0, -0.5), **body)
    b.add_force("bushing", "mount", body_i="ground", body_j="mass", point_i=(0, 0, -0.5),
                stiffness=k, rotational_stiffness=kr)
    return b.compile()


def test_small_oscillations_have_the_closed_form_frequencies():
    """Uncoupled axes at the centre of mass: x(t) = x0 cos(sqrt(k/m) t), a twist about z
    oscillates with sqrt(k_r/J_z)."""
    m, k, Jz, kr = 3.0, (300.0, 500.0, 700.0), 0.4, (20.0, 30.0, 40.0)
    model = hung_on_bushing(k, kr, m=m)
    q0 = model.q0.copy()
    q0[0, 0] += 1e-3
    v0 = np.zeros((1, 6))
    v0[0, 5] = 1e-3                                    # small twist rate about z
    res = simulate(model, 1.0, q0=q0, v0=v0, integrator="rk45", rtol=1e-10, atol=1e-13,
                   output_step=0.01)
    assert res.success
    t = res.t
    x = res.body("mass")["r"][:, 0]
    assert np.abs(x - 1e-3 * np.cos(math.sqrt(k[0] / m) * t)).max() < 1e-9
    wz = res.body("mass")["omega"][:, 2]
    wn = math.sqrt(kr[2] / Jz)
    assert np.abs(wz - 1e-3 * np.cos(wn * t)).max() < 1e-9


def test_static_sag_under_gravity():
    m, kz = 2.0, 4000.0
    model = hung_on_bushing((1e3, 1e3, kz), (10, 10, 10), m=m, gravity=(0, 0, -9.81))
    # heavy damping is not needed: the mean of an undamped oscillation is the static sag
    res = simulate(model, 2 * math.pi * math.sqrt(m / kz) * 5, integrator="rk45", rtol=1e-10,
                   atol=1e-13, output_step=1e-3)
    z = res.body("mass")["r"][:, 2] + 0.5
    assert (z.max() + z.min()) / 2 == pytest.approx(-m * 9.81 / kz, rel=1e-4)


def test_bushing_in_files_and_bad_input():
    model = two_bodies(stiffness=(1.0, 2.0, 3.0), damping=0.5)
    d = model_to_dict(model)
    again, _ = load_model(d)
    assert model_to_dict(again) == d
    param = again.force_groups[0].columns()["param"]
    assert np.allclose(param[0, :6], [1, 2, 3, 0.5, 0.5, 0.5])
    d["forces"][0]["stiffness"] = [1.0, -2.0, 3.0]
    with pytest.raises(ModelError, match="stiffness"):
        load_model(d)
    d["forces"][0]["stiffness"] = [1.0, 2.0, 3.0]
    d["forces"][0]["axes"] = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]
    with pytest.raises(ModelError, match="axes"):
        load_model(d)
    d["forces"][0]["axes"] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    d["forces"][0]["stifness"] = 3
    with pytest.raises(ModelError, match="stifness"):
        load_model(d)
