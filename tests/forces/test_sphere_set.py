"""The sphere_set element (forces.contact.sphere_set): many spheres found by the broad phase.

It must equal ``contact`` elements declared for every pair (to round-off), its conservative
part must be the gradient of its energy (finite differences along the motion), and spheres
must settle where statics puts them, with the energy balance closed by the dissipated work."""
import itertools

import numpy as np
import pytest

from fd_check import q_along
from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

WALLS = [{"normal": [0, 0, 1], "point": [0, 0, 0]},
         {"normal": [-1, 0, 0], "point": [0.35, 0, 0]}]


def _bodies(rng, n, spread=0.3):
    b = ModelBuilder("spheres", gravity=(0, 0, -9.81))
    pos = rng.uniform(-spread, spread, (n, 3)) + np.array([0, 0, 0.4])
    for k in range(n):
        b.add_body(f"b{k}", 1.0 + k, (0.01, 0.02, 0.03), r=tuple(pos[k]),
                   omega=tuple(rng.normal(size=3)), rdot=tuple(rng.normal(size=3)))
    return b


def _forces(model, q, v, t=0.0):
    s = BodyState.from_qv(q, v, t)
    parts = [grp._run(s, t) for grp in model.force_groups]
    return (sum(p[0] for p in parts), sum(p[1].sum() for p in parts),
            sum(p[2].sum() for p in parts))


def test_equals_contact_elements_for_every_pair():
    n, law = 7, dict(law="linear", stiffness=1e4, damping=20.0, mu=0.4, creep_velocity=1e-3)
    radii = [0.1 + 0.01 * k for k in range(n)]
    center = [0.01, -0.02, 0.005]
    a = _bodies(np.random.default_rng(0), n)
    a.add_force("sphere_set", "grains", bodies=[f"b{k}" for k in range(n)], radius=radii,
                center=center, walls=WALLS, **law)
    b = _bodies(np.random.default_rng(0), n)
    for i, j in itertools.combinations(range(n), 2):
        b.add_force("contact", f"c{i}_{j}", body_i=f"b{i}", body_j=f"b{j}",
                    shape_i={"type": "sphere", "radius": radii[i], "center": center},
                    shape_j={"type": "sphere", "radius": radii[j], "center": center}, **law)
    for i in range(n):
        for w, wall in enumerate(WALLS):
            b.add_force("contact", f"w{i}_{w}", body_i="ground", body_j=f"b{i}",
                        shape_i={"type": "plane", **wall},
                        shape_j={"type": "sphere", "radius": radii[i], "center": center},
                        **law)
    ma, mb = a.compile(), b.compile()
    rng = np.random.default_rng(5)
    q0 = np.array(ma.q0).reshape(n, 7)
    touching = 0
    for _ in range(5):
        q = q0.copy()
        q[:, :3] += rng.normal(scale=0.03, size=(n, 3))
        v = rng.normal(size=(n, 6))
        ga, ea, pa = _forces(ma, q, v)
        gb, eb, pb = _forces(mb, q, v)
        assert np.allclose(ga, gb, rtol=1e-12, atol=1e-9)
        assert ea == pytest.approx(eb, rel=1e-12) and pa == pytest.approx(pb, rel=1e-12)
        touching += ea > 0
    assert touching >= 3                      # the states do have contacts


def test_conservative_part_is_the_gradient_of_its_energy():
    """Without damping and friction, the power of the forces is -dV/dt along any motion."""
    rng = np.random.default_rng(2)
    b = ModelBuilder("pile", gravity=(0, 0, 0))
    grid = np.stack(np.meshgrid(*[np.arange(4) * 0.13] * 2, np.arange(3) * 0.13,
                                indexing="ij"), axis=-1).reshape(-1, 3)
    pos = grid + np.array([0, 0, 0.07]) + rng.uniform(-0.005, 0.005, grid.shape)
    n = len(pos)
    for k in range(n):
        b.add_body(f"b{k}", 1.0, (0.01, 0.01, 0.01), r=tuple(pos[k]))
    b.add_force("sphere_set", "grains", bodies=[f"b{k}" for k in range(n)],
                radius=list(rng.uniform(0.05, 0.07, n)), center=[0.002, 0.0, -0.002],
                walls=[{"normal": [0, 0, 1], "point": [0, 0, 0.025]}], law="hertz",
                stiffness=1e6)
    model = b.compile()
    q0 = np.array(model.q0).reshape(n, 7)
    v = rng.normal(size=(n, 6))
    h = 1e-6

    def V(dt):
        return _forces(model, q_along(q0, v, dt), v)[1]

    dV = (V(-2 * h) - 8 * V(-h) + 8 * V(h) - V(2 * h)) / (12 * h)
    g, energy, power = _forces(model, q0, v)
    assert energy > 0 and power == 0.0
    assert dV == pytest.approx(-np.sum(g[:n] * v), rel=1e-6)


def test_spheres_settle_where_statics_puts_them_and_the_energy_balance_closes():
    """A row of spheres dropped on the floor (linear law): each rests at z = R - m g / K."""
    R, K, m = 0.05, 1e5, 2.0
    b = ModelBuilder("row", gravity=(0, 0, -9.81))
    names = []
    for k in range(4):
        names.append(b.add_body(f"s{k}", m, (0.4 * m * R * R,) * 3,
                                r=(0.12 * k, 0.0, R + 0.02 * (k + 1))))
    b.add_force("sphere_set", "grains", bodies=names, radius=R, walls=WALLS[:1],
                law="linear", stiffness=K, damping=80.0, mu=0.3, creep_velocity=1e-3)
    res = simulate(b.compile(), 2.0, method="standard", output_step=0.01, rtol=1e-10,
                   atol=1e-12)
    assert res.status == "success"
    assert np.allclose(res.q[-1, :, 2], R - m * 9.81 / K, atol=1e-7)
    E = res.energy()
    assert E["work_nonconservative"][-1] < -0.5          # the drop's energy was dissipated
    # energy + dissipated work: integration error only (3.6e-5 J at rtol 1e-8, 7e-7 J at
    # 1e-10: it converges with the tolerance), against 7.8 J of initial energy
    assert np.abs(E["error"]).max() < 1e-6 * abs(E["total"][0])


def test_bad_input_is_a_model_error():
    b = _bodies(np.random.default_rng(0), 3, spread=1.0)
    names = ["b0", "b1", "b2"]
    cases = [
        (dict(law="hunt_crossley", stiffness=1e5), "impact velocity"),
        (dict(law="linear"), "stiffness"),
        (dict(law="linear", stiffness=1e5, walls=[{"normal": [0, 0, 0]}]), "must not be zero"),
        (dict(law="linear", stiffness=-1.0), "stiffness"),
        (dict(law="linear", stiffness=1e5, mu=-0.1), "mu"),
    ]
    for params, text in cases:
        with pytest.raises(ModelError, match=text):
            b.add_force("sphere_set", "g", bodies=names, radius=0.1, **params)
    with pytest.raises(ModelError, match="repeated"):
        b.add_force("sphere_set", "g", bodies=["b0", "b0"], radius=0.1, stiffness=1.0)
    with pytest.raises(ModelError, match="one radius per body"):
        b.add_force("sphere_set", "g", bodies=names, radius=[0.1, 0.2], stiffness=1.0)
    with pytest.raises(ModelError, match="no body named"):
        b.add_force("sphere_set", "g", bodies=["nope"], radius=0.1, stiffness=1.0)
    deep = ModelBuilder("deep")
    deep.add_body("a", 1.0, (1, 1, 1), r=(0, 0, 1))
    deep.add_body("b", 1.0, (1, 1, 1), r=(0.05, 0, 1))
    deep.add_force("sphere_set", "g", bodies=["a", "b"], radius=0.1, stiffness=1.0)
    with pytest.raises(ModelError, match="interpenetrate"):
        deep.compile()


def test_spheres_in_box_example_settles_inside_the_box():
    """models.spheres_in_box (the example's 64 spheres; 27 here, for time) with the example's
    settings: everything ends inside the box, resting (no sphere deeper into the floor than its
    static compression under the whole pile), and energy + dissipated work is conserved."""
    from spatialmbd import models
    b = models.spheres_in_box(n_side=3)
    model = b.compile()
    res = simulate(model, 1.0, method="standard", integrator="rk45", rtol=1e-5, atol=1e-7,
                   output_step=0.05)
    assert res.status == "success"
    z = res.q[-1, :, 2]
    R, m, K = 0.02, 0.03, 2e4
    assert z.min() > R - model.nb * m * 9.81 / K                 # within the floor's reach
    assert np.abs(res.v[-1, :, :3]).max() < 0.05                   # settled
    E = res.energy()
    # integration error only: rtol 1e-5 gives about 10 rtol of the energy (5e-5 of 0.77 J)
    assert np.abs(E["error"]).max() < 1e-4 * abs(E["total"][0])
