"""Contact pair geometry and the contact kernel: the gap rate n . v_rel against finite
differences of the gap along random motions for every pair type; the wrench, the elastic energy
and the dissipated power from one evaluation against the rate of the energy."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.forces.contact.element import Contact
from spatialmbd.forces.kernels import evaluate_group
from spatialmbd.state import BodyState

from fd_check import q_along
from spatialmbd.rotations import normalize_p

PLANE = {"type": "plane", "normal": (0.2, -0.3, 1.0), "point": (0.1, 0.0, 0.05)}
SPHERE = {"type": "sphere", "radius": 0.3, "center": (0.05, -0.1, 0.02)}
CAPSULE = {"type": "capsule", "radius": 0.2, "half_length": 0.5, "axis": (1.0, 0.5, -0.2)}
BOX = {"type": "box", "half_extents": (0.3, 0.4, 0.5), "center": (0.0, 0.1, 0.0),
       "axes": np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])}

# (shape_i, shape_j, scale of the relative position, apart at the start)
PAIRS = {
    "plane-sphere": (PLANE, SPHERE, 1.0, True),
    "sphere-sphere": (SPHERE, {"type": "sphere", "radius": 0.4}, 1.0, True),
    "capsule-capsule": (CAPSULE, {"type": "capsule", "radius": 0.25, "half_length": 0.4}, 1.0,
                        True),
    "capsule-sphere": (CAPSULE, SPHERE, 1.0, True),
    "box-sphere": (BOX, {"type": "sphere", "radius": 0.2}, 1.0, True),
    "box-sphere-inside": (BOX, {"type": "sphere", "radius": 0.45}, 0.35, True),
    "plane-box": (PLANE, BOX, 1.0, True),
    "plane-capsule": (PLANE, CAPSULE, 1.0, True),
    "socket-ball": ({"type": "socket", "radius": 0.5}, {"type": "sphere", "radius": 0.45}, 0.15,
                    False),
    "bearing-journal": ({"type": "bearing", "radius": 0.5, "axis": (0, 1.0, 0.3)},
                        {"type": "journal", "radius": 0.45}, 0.15, False),
}


def pair_model(shape_i, shape_j, apart, **law):
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(5.0, 0.0, 0.0) if apart else (0.1, 0.2, 0.3))
    law = law or dict(law="linear", stiffness=1e3)
    b.add_force("contact", "c", body_i="a", body_j="b", shape_i=shape_i, shape_j=shape_j, **law)
    return b.compile()


def states(model, scale, rng, want_contact, n=6):
    """Random states with body b near body a; want_contact: some gap in (-0.05, 0)."""
    group = model.force_groups[0]
    out = []
    for _ in range(20000):
        q = np.zeros((2, 7))
        q[:, 3:] = normalize_p(rng.normal(size=(2, 4)))
        q[0, :3] = rng.normal(size=3) * 0.1
        q[1, :3] = q[0, :3] + rng.normal(size=3) * scale
        v = rng.normal(size=(2, 6))
        g = group.gaps(BodyState.from_qv(q, v))
        if not want_contact or np.any((g < 0) & (g > -0.05)):
            out.append((q, v))
            if len(out) == n:
                return out
    raise AssertionError("no state found")


@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_gap_rate_is_normal_relative_velocity(pair):
    shape_i, shape_j, scale, apart = PAIRS[pair]
    model = pair_model(shape_i, shape_j, apart)
    group = model.force_groups[0]
    assert isinstance(group, Contact)
    rng = np.random.default_rng(sum(map(ord, pair)))
    h = 1e-4
    for q0, v in states(model, scale, rng, want_contact=True):
        def gap(dt):
            return group.gaps(BodyState.from_qv(q_along(q0, v, dt), v))
        g = [gap(k * h) for k in (-2, -1, 1, 2)]
        fd = (g[0] - 8 * g[1] + 8 * g[2] - g[3]) / (12 * h)
        d = group.details(BodyState.from_qv(q0, v))
        assert np.allclose(fd, d[:, 1], atol=1e-7 * (1 + np.abs(fd).max())), pair
        # the normal is a unit vector and the contact point lies between the surfaces
        assert np.allclose(np.linalg.norm(d[:, 13:16], axis=1), 1.0)


@pytest.mark.parametrize("pair", ["plane-sphere", "capsule-capsule", "box-sphere", "plane-box",
                                  "socket-ball", "bearing-journal"])
def test_wrench_energy_and_power(pair):
    """Sum over bodies of g . v = -dE/dt + P_diss: the force is applied where the energy and
    the power say (elastic part exactly minus the gradient of the energy)."""
    shape_i, shape_j, scale, apart = PAIRS[pair]
    for law in (dict(law="linear", stiffness=1e3),
                dict(law="hunt_crossley", stiffness=2e4, restitution=0.6, friction="stribeck",
                     mu_static=0.5, mu_dynamic=0.3, stribeck_velocity=0.2, creep_velocity=0.5,
                     viscous=2.0)):
        model = pair_model(shape_i, shape_j, apart, **law)
        group = model.force_groups[0]
        rng = np.random.default_rng(7)
        h = 1e-5
        for q0, v in states(model, scale, rng, want_contact=True, n=4):
            def energy(dt):
                s = BodyState.from_qv(q_along(q0, v, dt), v)
                return evaluate_group(group, s, 0.0)[1].sum()
            e = [energy(k * h) for k in (-2, -1, 1, 2)]
            dE = (e[0] - 8 * e[1] + 8 * e[2] - e[3]) / (12 * h)
            gen, en, power = evaluate_group(group, BodyState.from_qv(q0, v), 0.0)
            delivered = np.sum(gen[:2] * v)
            assert delivered == pytest.approx(-dE + power.sum(), abs=1e-6 * (1 + abs(dE)))
            if law["law"] == "linear":
                assert np.all(power == 0.0)
            else:
                assert np.all(power <= 1e-12)
            # no tensile force
            assert np.all(group.details(BodyState.from_qv(q0, v))[:, 3] >= 0.0)


@pytest.mark.parametrize("pair", ["plane-sphere", "capsule-capsule", "plane-box"])
def test_margin_shifts_the_gap_and_the_kernel_stays_consistent(pair):
    """With ``margin`` m the gap is the distance less m at every state (the same normal and
    rate), and the wrench still delivers -dE/dt + P_diss (finite differences of the energy)."""
    shape_i, shape_j, scale, apart = PAIRS[pair]
    m = 0.02
    plain = pair_model(shape_i, shape_j, apart).force_groups[0]
    model = pair_model(shape_i, shape_j, apart, law="linear", stiffness=1e3, damping=5.0,
                       margin=m)
    group = model.force_groups[0]
    rng = np.random.default_rng(11)
    h = 1e-5
    for q0, v in states(model, scale, rng, want_contact=True, n=4):
        s = BodyState.from_qv(q0, v)
        d, d0 = group.details(s), plain.details(s)
        assert np.allclose(d[:, 0], d0[:, 0] - m, rtol=0, atol=1e-15)
        assert np.allclose(d[:, 1], d0[:, 1], rtol=0, atol=1e-15)

        def energy(dt):
            return evaluate_group(group, BodyState.from_qv(q_along(q0, v, dt), v), 0.0)[1].sum()
        e = [energy(k * h) for k in (-2, -1, 1, 2)]
        dE = (e[0] - 8 * e[1] + 8 * e[2] - e[3]) / (12 * h)
        gen, en, power = evaluate_group(group, s, 0.0)
        assert np.sum(gen[:2] * v) == pytest.approx(-dE + power.sum(), abs=1e-6 * (1 + abs(dE)))
