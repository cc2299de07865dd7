"""Armature (rotor inertia on a joint coordinate, forces.armature): its rows B, gamma_B against
finite differences, closed forms in every method (a pendulum with a geared rotor moves as one
of inertia I + J; a slider as one of mass m + J), the energy balance with the rotor's kinetic
energy, and bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.dynamics.augmented_lagrangian import AugmentedLagrangian
from spatialmbd.dynamics.standard import Standard
from spatialmbd.dynamics.system import System
from spatialmbd.errors import ModelError
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate

from fd_check import q_along, random_state

METHODS = ("standard", "baumgarte", "penalty", "augmented_lagrangian", "projection",
           "recursive")
G = 9.81
MASS, LENGTH, I0 = 1.3, 0.5, 0.02      # the pendulum: kg, m to the centre of mass, kg m^2
J_ROTOR = 0.17                         # kg m^2 reflected to the pin


def pendulum(J=0.0, extra_inertia=0.0):
    """A compound pendulum about the global y axis through the origin, centre of mass at
    (LENGTH, 0, 0) (horizontal at t = 0); with an armature J on its pin, or with its own
    inertia about y raised by extra_inertia."""
    b = ModelBuilder("pendulum", gravity=(0.0, 0.0, -G))
    b.add_body("arm", MASS, (0.3, I0 + extra_inertia, 0.3), r=(LENGTH, 0.0, 0.0))
    b.add_joint("revolute", "pin", "ground", "arm", point=(0, 0, 0), axis=(0, 1, 0))
    if J:
        b.add_force("armature", "rotor", joint="pin", inertia=J)
    return b.compile()


def slider(J=0.0, mass=2.0):
    """A block on a translational joint along x, pulled by gravity along x."""
    b = ModelBuilder("slider", gravity=(G, 0.0, 0.0))
    b.add_body("block", mass, (0.1, 0.1, 0.1), r=(0.0, 0.0, 0.0))
    b.add_joint("translational", "rail", "ground", "block", point=(0, 0, 0), axis=(1, 0, 0))
    if J:
        b.add_force("armature", "rotor", joint="rail", inertia=J)
    return b.compile()


def run(model, method, t_end=1.0, **kw):
    res = simulate(model, t_end, method=method, rtol=1e-11, atol=1e-13, output_step=0.05,
                   **kw)
    assert res.status == "success", res.message
    return res


# ----------------------------------------------------------------------------- the rows
def _rows(model, q, v):
    """(B (na, 12), gamma_B (na,)) of the System's armature rows at (q, v)."""
    sys_ = System(model)
    sys_.evaluate(0.0, np.concatenate([q.ravel(), v.ravel()]), False)
    m = sys_.m
    return sys_.fields(None, "D_all")[m:].copy(), sys_.fields(None, "gamma_all")[m:].copy()


def _coordinates(model, q):
    """The armatures' coordinates from the bodies' poses, computed here: the joint angle
    atan2(b_i . a_j, a_i . a_j) or the slide u_i . (P_j - P_i) (forces.armature)."""
    grp = next(g for g in model.force_groups if g.name == "armature")
    nb = model.nb
    A = np.concatenate([A_from_p(q[:, 3:]), np.eye(3)[None]])
    r = np.concatenate([q[:, :3], np.zeros((1, 3))])
    out = []
    for k in range(grp.n):
        i, j = grp.bi[k], grp.bj[k]
        Ri, Rj = A[i] @ grp.R_i[k], A[j] @ grp.R_j[k]
        if grp.param[k, 0] == 0:
            out.append(math.atan2(Ri[:, 2] @ Rj[:, 1], Ri[:, 1] @ Rj[:, 1]))
        else:
            d = (r[j] + A[j] @ grp.s_j[k]) - (r[i] + A[i] @ grp.s_i[k])
            out.append(Ri[:, 0] @ d)
    assert nb == q.shape[0]
    return np.array(out)


def test_armature_rows_against_finite_differences():
    """theta' = B v and theta'' = B vdot - gamma_B along motions with constant v (vdot = 0):
    central differences of theta (computed from the poses here) and of B v."""
    b = ModelBuilder(gravity=(0, 0, 0))
    for n in ("a", "c", "e"):
        b.add_body(n, 1.0, (1, 1, 1))
    b.add_joint("revolute", "pin", "ground", "a", point=(0.1, 0.2, 0.3), axis=(0.3, 0.4, 1))
    b.add_joint("translational", "rail", "a", "c", point=(0.5, 0, 0), axis=(1, 0.2, 0))
    b.add_joint("cylindrical", "cyl", "c", "e", point=(0, 0.4, 0), axis=(0, 1, 0.3))
    b.add_force("armature", "r1", joint="pin", inertia=0.3)
    b.add_force("armature", "r2", joint="rail", inertia=2.0)
    b.add_force("armature", "r3", joint="cyl", coordinate="angle", inertia=0.1)
    b.add_force("armature", "r4", joint="cyl", coordinate="translation", inertia=0.5)
    model = b.compile()
    grp = model.force_groups[0]
    rng = np.random.default_rng(7)
    h = 1e-3
    checked = 0
    while checked < 20:
        q0, v = random_state(rng, 3)
        qs = [q_along(q0, v, k * h) for k in (-2, -1, 0, 1, 2)]
        x = np.array([_coordinates(model, q) for q in qs])
        if np.any(np.abs(np.diff(x, axis=0)) > 1.0):      # an angle wrapped inside the stencil
            continue
        vij = lambda bb: np.concatenate([v, np.zeros((1, 6))])[bb]  # noqa: E731
        rates = []
        for q in qs:
            B, _ = _rows(model, q, v)
            rates.append(np.einsum("ak,ak->a", B, np.concatenate([vij(grp.bi), vij(grp.bj)],
                                                                 axis=1)))
        rates = np.array(rates)
        _, gamma_B = _rows(model, q0, v)
        d1 = (x[0] - 8 * x[1] + 8 * x[3] - x[4]) / (12 * h)
        d2 = (rates[0] - 8 * rates[1] + 8 * rates[3] - rates[4]) / (12 * h)
        scale = max(1.0, np.abs(d2).max())
        assert np.abs(d1 - rates[2]).max() < 1e-8 * scale, (d1, rates[2])
        assert np.abs(d2 + gamma_B).max() < 1e-7 * scale, (d2, -gamma_B)
        checked += 1


# ----------------------------------------------------------------------------- closed forms
def _method(name):
    """The method of a closed-form test: the standard one with its dense KKT solver ("kkt"),
    the augmented Lagrangian iterated to 1e-12 (its default tolerance, 1e-8 on vdot, alone
    leaves some 3e-9 between two runs), or the method of that name."""
    if name == "kkt":
        return Standard(solver="kkt")
    if name == "augmented_lagrangian":
        return AugmentedLagrangian(tolerance=1e-12, floor=1e-11)
    return name


@pytest.mark.parametrize("method", METHODS + ("kkt",))
def test_pendulum_with_a_rotor_moves_as_one_of_inertia_I_plus_J(method):
    """Released horizontal: theta'' = m g L / (I_O + J) at the start (I_O = I0 + m L^2), and
    the whole motion that of the same pendulum with J added to its own inertia about the pin
    (the same method)."""
    options = dict(method=_method(method))
    with_rotor = run(pendulum(J_ROTOR), **options)
    heavier = run(pendulum(extra_inertia=J_ROTOR), **options)
    alpha = MASS * G * LENGTH / (I0 + MASS * LENGTH ** 2 + J_ROTOR)
    start = abs(with_rotor.vdot[0, 0, 4])
    if method == "penalty":
        # the penalty method's own compliance (alpha = 1e7) moves the start; the rotor adds
        # nothing to it: the same method on the heavier pendulum starts identically
        assert start == pytest.approx(abs(heavier.vdot[0, 0, 4]), rel=1e-12)
    elif method == "augmented_lagrangian":           # to its iteration's tolerance
        assert start == pytest.approx(alpha, rel=1e-10)
    else:
        assert start == pytest.approx(alpha, rel=1e-12)
    assert np.abs(with_rotor.q - heavier.q).max() < 1e-9
    assert np.abs(with_rotor.v - heavier.v).max() < 1e-9
    # the pin's reaction is the heavier pendulum's: the rotor's moment is not a reaction
    assert np.abs(with_rotor.lam - heavier.lam).max() < 1e-7 * np.abs(heavier.lam).max()
    assert with_rotor.lam.shape == heavier.lam.shape


@pytest.mark.parametrize("method", METHODS + ("kkt",))
def test_slider_with_a_rotor_accelerates_as_mass_m_plus_J(method):
    """x'' = F / (m + J): x(t) = F t^2 / (2 (m + J)) with F = m g."""
    options = dict(method=_method(method))
    mass, J = 2.0, 3.0
    res = run(slider(J, mass), **options)
    a = mass * G / (mass + J)
    assert np.abs(res.q[:, 0, 0] - 0.5 * a * res.t ** 2).max() < 1e-9
    assert np.abs(res.vdot[:, 0, 0] - a).max() < 1e-9 * a


@pytest.mark.parametrize("method", ("standard", "projection", "recursive"))
def test_energy_balance_closes_with_the_rotor(method):
    """A double pendulum with rotors on both pins swings 2 s: bodies + rotors conserve their
    energy (the rotors hold a good part of it)."""
    b = ModelBuilder("double", gravity=(0.0, 0.0, -G))
    b.add_body("upper", 1.0, (0.01, 0.02, 0.01), r=(0.3, 0.0, 0.0))
    b.add_body("lower", 0.7, (0.01, 0.01, 0.01), r=(0.6, 0.0, -0.2))
    b.add_joint("revolute", "shoulder", "ground", "upper", point=(0, 0, 0), axis=(0, 1, 0))
    b.add_joint("revolute", "elbow", "upper", "lower", point=(0.6, 0, 0), axis=(0, 1, 0))
    b.add_force("armature", "m1", joint="shoulder", inertia=0.05)
    b.add_force("armature", "m2", joint="elbow", inertia=0.02)
    res = run(b.compile(), method, t_end=2.0)
    en = res.energy()
    rotors = sum(g.kinetic_energy(s) for s in list(res.states())[-5:]
                 for g in res.model.force_groups)
    assert rotors > 0.05                                # the rotors carry energy
    assert np.abs(en["error"]).max() < 1e-8 * np.abs(en["total"]).max() + 1e-9


def test_rotor_outputs_are_its_moment_energy_and_power():
    """force_outputs of an armature: mu = -J theta'' (the pendulum's closed-form start), its
    kinetic energy J theta'^2 / 2 and the power mu theta' = -dT/dt it takes."""
    from spatialmbd.outputs import force_outputs
    res = run(pendulum(J_ROTOR), "standard")
    out = force_outputs(res, "rotor")
    rate = res.v[:, 0, 4]                        # theta' = omega_y (pin axis +y)
    acc = res.vdot[:, 0, 4]
    np.testing.assert_allclose(out["coordinate_rate"], rate, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["coordinate_acceleration"], acc, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["force"], -J_ROTOR * acc, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["energy"], 0.5 * J_ROTOR * rate ** 2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["power"], -J_ROTOR * acc * rate, rtol=0, atol=1e-9)
    alpha = MASS * G * LENGTH / (I0 + MASS * LENGTH ** 2 + J_ROTOR)
    assert abs(out["force"][0]) == pytest.approx(J_ROTOR * alpha, rel=1e-12)


@pytest.mark.parametrize("analysis", ("linearize", "inverse_dynamics"))
def test_analyses_without_the_rotor_refuse_it_by_name(analysis):
    from spatialmbd import analyses
    with pytest.raises(ModelError, match=rf"{analysis}: the armature element\(s\) rotor"):
        getattr(analyses, analysis)(pendulum(J_ROTOR))


def test_armature_reads_from_a_model_file_and_writes_back(tmp_path):
    from spatialmbd.io import load_model
    data = {"spatialmbd": 1, "name": "m", "gravity": [0, 0, -9.81],
            "bodies": [{"name": "arm", "mass": 1.0, "inertia": [0.1, 0.1, 0.1],
                        "position": [0.5, 0, 0]}],
            "joints": [{"name": "pin", "type": "revolute", "body_i": "ground",
                        "body_j": "arm", "point": [0, 0, 0], "axis": [0, 1, 0]}],
            "forces": [{"name": "rotor", "type": "armature", "joint": "pin",
                        "inertia": 0.4}]}
    model, _ = load_model(data)
    grp = model.force_groups[0]
    assert grp.name == "armature" and grp.inertia.tolist() == [0.4]
    res = simulate(model, 0.01, rtol=1e-10, atol=1e-12)
    assert abs(res.vdot[0, 0, 4]) == pytest.approx(9.81 * 0.5 / (0.1 + 0.25 + 0.4),
                                                   rel=1e-12)
    from spatialmbd.io import save_model
    save_model(model, tmp_path / "m.yaml")
    again, _ = load_model(tmp_path / "m.yaml")
    assert again.force_groups[0].name == "armature"
    assert again.force_groups[0].inertia.tolist() == [0.4]


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kw, match", [
    (dict(joint="pin", inertia=-0.1), r"forces\['r'\]\.inertia: must be a finite number > 0"
                                      r" \(kg m\^2.*got -0\.1"),
    (dict(joint="pin", inertia=float("nan")), r"inertia: must be a finite number > 0.*nan"),
    (dict(joint="pin", inertia=0.0), r"leave the element out for none"),
    (dict(joint="rail", inertia="heavy"), r"\(kg, .*got 'heavy'"),
    (dict(joint="pin"), r"inertia"),
    (dict(joint="nope", inertia=1.0), r"forces\['r'\]\.joint: unknown joint 'nope'"),
    (dict(joint="ball", inertia=1.0), r"'ball' is a spherical joint \(give the rotor as a "
                                      r"body"),
    (dict(joint="weld", inertia=1.0), r"'weld' is a fixed joint"),
    (dict(joint="cyl", inertia=1.0), r"say which"),
    (dict(joint="pin", inertia=1.0, coordinate="translation"), r"not a coordinate"),
    (dict(joint="pin", inertia=1.0, gear=3), r"unknown parameter\(s\) \['gear'\]"),
])
def test_bad_armature_is_refused_naming_the_element(kw, match):
    b = ModelBuilder(gravity=(0, 0, 0))
    for n in ("a", "c", "d", "e", "f"):
        b.add_body(n, 1.0, (1, 1, 1))
    b.add_joint("revolute", "pin", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "rail", "ground", "c", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("spherical", "ball", "ground", "d", point=(0, 0, 0))
    b.add_joint("fixed", "weld", "ground", "e", point=(0, 0, 0))
    b.add_joint("cylindrical", "cyl", "ground", "f", point=(0, 0, 0), axis=(0, 0, 1))
    with pytest.raises(ModelError, match=match):
        b.add_force("armature", "r", **kw)
