"""One rank decision for the determinacy of reactions: on a planar slider-crank built from
spatial joints (all revolute axes along z), the redundant equations form a self-stress that
reaches every joint of the loop. Inverse dynamics, statics and quasi-statics must all name
every joint of the loop as non-unique (inverse dynamics named only A and D before; statics and
quasi-statics called every reaction unique)."""
from __future__ import annotations

import warnings

import numpy as np

from spatialmbd.analyses.inverse import inverse_dynamics
from spatialmbd.analyses.statics import quasi_static, static_equilibrium
from spatialmbd.model.builder import ModelBuilder
from spatialmbd.motion import ConstantVelocity
from spatialmbd.rank import nonunique_rows, row_rank

LOOP = {"A", "B", "C", "D"}


def planar_slider_crank(driver=None):
    b = ModelBuilder("planar_slider_crank", gravity=(0.0, -9.81, 0.0))
    b.add_body("crank", 1.0, (0.01, 0.001, 0.01), r=(0.0, 0.1, 0.0))
    b.add_body("rod", 2.0, (0.05, 0.002, 0.05), r=(0.15, 0.1, 0.0))
    b.add_body("slider", 3.0, (0.01, 0.01, 0.01), r=(0.3, 0.0, 0.0))
    b.add_joint("revolute", "A", "ground", "crank", point=(0, 0, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "B", "crank", "rod", point=(0, 0.2, 0), axis=(0, 0, 1))
    b.add_joint("revolute", "C", "rod", "slider", point=(0.3, 0, 0), axis=(0, 0, 1))
    b.add_joint("translational", "D", "ground", "slider", point=(0.3, 0, 0), axis=(1, 0, 0))
    if driver == "drive":
        b.add_driver("angle", "drive", ConstantVelocity(rate=1.0), joint="A")
    elif driver == "spring":
        b.add_force("rotational_spring_damper", "spring", joint="A", stiffness=20.0)
    return b.compile()


def test_self_stress_reaches_every_joint_of_the_loop():
    model = planar_slider_crank()
    D = model.assembler.evaluate(model.q0, None, 0.0).D
    D = D.toarray() if hasattr(D, "toarray") else np.asarray(D)
    rank = row_rank(D)
    assert rank.dependent.size == 3            # the loop's out-of-plane equations: 3 redundant
    named = {model.equation_labels[r][0] for r in nonunique_rows(D, rank)}
    assert named == LOOP


def test_inverse_dynamics_statics_and_quasi_statics_agree_on_the_nonunique_reactions():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        inv = inverse_dynamics(planar_slider_crank("drive"), np.linspace(0, 0.5, 3), warn=False)
        stat = static_equilibrium(planar_slider_crank("spring"))
        quasi = quasi_static(planar_slider_crank("drive"), np.linspace(0, 0.5, 3))
    for res in (inv, stat, quasi):
        loose = {name for name, r in res.reactions.items() if not r.unique}
        assert loose == LOOP, (type(res).__name__, loose)
    assert inv.unique                            # the driver effort is unique all the same
