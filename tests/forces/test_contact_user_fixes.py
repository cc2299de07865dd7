"""What a new user found (issue 29, item 7). The README's claim on creep: with the default
creep velocity (1e-4 m/s, no key given) a regularised Coulomb contact that should stick
creeps, at v_eps atanh(F_t / (mu f_N)) ~ 1e-4 m/s; with LuGre the same block holds still
(tests/forces/test_contact_physics.py). And ``carvalho_martins`` has a second name,
``exact_restitution``, for what it is."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.forces.contact.laws import C_VEPS
from spatialmbd.simulate import simulate

G = 9.81


def test_default_coulomb_creeps_at_about_1e_4_m_per_s():
    th, m, K = math.radians(20.0), 2.0, 1e6
    mu = 1.1 * math.tan(th)                          # should stick: mu > tan(theta)
    hx, hy, hz = 0.1, 0.1, 0.05
    g = (G * math.sin(th), 0, -G * math.cos(th))     # the incline: gravity tilted
    b = ModelBuilder(gravity=g)
    dz = G * math.cos(th) * m / (4 * K)
    b.add_body("block", m, m / 3 * np.array([hy * hy + hz * hz, hx * hx + hz * hz,
                                             hx * hx + hy * hy]), r=(0, 0, hz - dz))
    b.add_force("contact", "c", body_i="ground", body_j="block",
                shape_i={"type": "plane", "normal": (0, 0, 1)},
                shape_j={"type": "box", "half_extents": (hx, hy, hz)}, law="linear",
                stiffness=K, damping=2 * math.sqrt(K * m / 4), friction="coulomb", mu=mu)
    model = b.compile()
    assert np.all(model.force_groups[0].param[:, C_VEPS] == 1e-4)      # the default
    res = simulate(model, 1.0, output_step=0.05, rtol=1e-9, atol=1e-11)
    creep = 1e-4 * math.atanh(math.tan(th) / mu)     # 1.52e-4 m/s
    assert res.v[-1, 0, 0] == pytest.approx(creep, rel=1e-3)
    assert 1e-4 < res.v[-1, 0, 0] < 2e-4


def test_exact_restitution_is_the_other_name_of_carvalho_martins():
    """Both names give the one law (chi the exact root of the restitution relation), whose
    produced restitution is the e prescribed -- unlike the closed-form chi of the same name
    some peers implement; the summary names the law by its first name."""
    from spatialmbd.forces.contact import laws as L
    models = []
    for law in ("carvalho_martins", "exact_restitution"):
        b = ModelBuilder(gravity=(0, 0, -G))
        b.add_body("ball", 1.0, (0.004,) * 3, r=(0, 0, 0.3))
        b.add_force("contact", "floor", body_i="ground", body_j="ball",
                    shape_i={"type": "plane", "normal": (0, 0, 1)},
                    shape_j={"type": "sphere", "radius": 0.1}, law=law, restitution=0.5,
                    stiffness=1e7)
        models.append(b.compile())
    a, b_ = (m.force_groups[0].param for m in models)
    assert np.array_equal(a, b_)
    chi = a[0, L.C_C]
    assert L.produced_restitution(chi) == pytest.approx(0.5, abs=1e-12)
    assert "floor: 1 point(s), carvalho_martins" in models[1].summary()
    from spatialmbd.errors import ModelError
    with pytest.raises(ModelError, match="valid: .*exact_restitution"):
        b = ModelBuilder()
        b.add_body("ball", 1.0, (0.004,) * 3)
        b.add_force("contact", "floor", body_i="ground", body_j="ball",
                    shape_i={"type": "plane", "normal": (0, 0, 1)},
                    shape_j={"type": "sphere", "radius": 0.1}, law="exact", stiffness=1e7)
