"""The joint_limit coordinate 'rotation' of a spherical joint (forces/kernel_tools.py
rotation_angle): the whole relative rotation angle against its closed form and its rate
against finite differences along random motions; a stop that holds a spinning ball at the
limit angle; bad input."""
import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.errors import ModelError
from spatialmbd.outputs import force_outputs
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate
from spatialmbd.state import BodyState

from fd_check import q_along, random_state


def two_bodies(**limit):
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 2.0, (1, 2, 2.5), r=(0.1, 0.2, 0.3))
    b.add_body("b", 1.0, (0.5, 0.6, 0.7), r=(1.0, -0.5, 0.8))
    b.add_joint("spherical", "j", "a", "b", point=(0.5, 0, 0.5))
    b.add_force("joint_limit", "lim", joint="j", coordinate="rotation", law="linear",
                stiffness=1.0, **limit)
    return b.compile()


def test_angle_is_the_relative_rotation_and_its_rate_the_central_difference():
    model = two_bodies(upper=3.0)
    group = model.force_groups[0]
    q_assembled = np.asarray(model.q0, dtype=float)
    rng = np.random.default_rng(5)
    checked = 0
    while checked < 10:
        q0, v = random_state(rng, 2)
        state = BodyState.from_qv(q0, v, 0.0)
        d = group.details(state)[0]                      # gap, gap rate, v0, x, x', ...
        # closed form: the angle of (A_a A_a0^T)^T (A_b A_b0^T), the relative rotation
        # from the assembly, trace formula
        A = [A_from_p(q0[k, 3:]) @ A_from_p(q_assembled[k, 3:]).T for k in range(2)]
        C = A[0].T @ A[1]
        angle = math.acos(np.clip((np.trace(C) - 1) / 2, -1, 1))
        if not 0.05 < angle < math.pi - 0.05:
            continue
        assert d[3] == pytest.approx(angle, abs=1e-12)
        h = 1e-6
        xp, xm = (group.details(BodyState.from_qv(q_along(q0, v, s), v, 0.0))[0, 3]
                  for s in (h, -h))
        assert d[4] == pytest.approx((xp - xm) / (2 * h), rel=1e-6, abs=1e-7)
        checked += 1


def test_the_stop_holds_a_spinning_body_near_its_angle():
    """A ball (isotropic inertia) spun about a tilted axis from its assembly (no gravity) turns
    until the stop at 0.8 rad, which reflects it (linear law, no damping: elastic): it leaves
    with the opposite spin, after a penetration w sqrt(I / K)."""
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("ball", 1.0, (0.1, 0.1, 0.1), omega=(0.0, 1.2, 1.6))
    b.add_joint("spherical", "socket", "ground", "ball", point=(0, 0, 0))
    b.add_force("joint_limit", "stop", joint="socket", coordinate="rotation", upper=0.8,
                law="linear", stiffness=500.0)
    res = simulate(b.compile(), 1.0, method="standard", rtol=1e-10, atol=1e-12,
                   output_step=0.0005)                 # one bounce (the next near 1.25 s)
    stop = force_outputs(res, "stop")
    assert stop["active"].any()
    # elastic stop: the spin reverses at the same speed (omega = 2 rad/s about a fixed axis);
    # the penetration the stiffness gives: I w^2 = K d^2 -> d = w sqrt(I / K)
    assert stop["penetration"].max() == pytest.approx(2.0 * math.sqrt(0.1 / 500.0), rel=1e-3)
    assert np.allclose(res.v[-1, 0, 3:], (0.0, -1.2, -1.6), rtol=1e-8, atol=1e-8)
    assert np.abs(res.energy()["error"]).max() < 1e-8        # of 0.2 J (rtol 1e-10)


@pytest.mark.parametrize("params, word", [(dict(upper=3.5), "(0, pi)"),
                                          (dict(lower=0.1, upper=1.0), "only upper")])
def test_bad_input(params, word):
    with pytest.raises(ModelError, match=re_escape(word)):
        two_bodies(**params)


def re_escape(text):
    import re
    return re.escape(text)


def test_rotation_is_not_a_coordinate_of_a_revolute_joint():
    b = ModelBuilder(gravity=(0, 0, 0))
    b.add_body("a", 1.0, (1, 1, 1))
    b.add_joint("revolute", "j", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1))
    with pytest.raises(ModelError, match="'rotation' is not a coordinate"):
        b.add_force("joint_limit", "lim", joint="j", coordinate="rotation", upper=1.0,
                    law="linear", stiffness=1.0)
        b.compile()
