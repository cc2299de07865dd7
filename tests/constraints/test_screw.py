"""Screw joint: finite-difference check of its kernel, the closed-form fall of a nut on a
vertical screw, drivers on it, files and bad input."""
import math
import zlib

import numpy as np
import pytest

from spatialmbd import ModelBuilder, ModelError
from spatialmbd.constraints import JOINT_TYPES
from spatialmbd.io.modelfile import load_model, model_to_dict
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.motion import ConstantVelocity
from spatialmbd.simulate import simulate

from fd_check import WrapJump, derivative_errors, random_geometry, random_state
from test_constraints import NB, PAIRS, angle_well_defined


def test_screw_kernel_matches_finite_differences():
    rng = np.random.default_rng(zlib.crc32(b"screw"))
    cls = JOINT_TYPES["screw"]
    for trial in range(20):
        geom = random_geometry(rng, len(PAIRS), 1)
        geom.param[:, 0] *= rng.choice([-1.0, 1.0], size=len(PAIRS))   # both thread hands
        group = cls([f"s{k}" for k in range(len(PAIRS))], PAIRS[:, 0], PAIRS[:, 1], geom)
        while True:
            q0, v = random_state(rng, NB)
            if not angle_well_defined(group, q0):
                continue
            try:
                e1, e2, scale = derivative_errors(group, q0, v, t0=0.0)
                break
            except WrapJump:            # the thread's wrap inside the stencil: draw again
                pass
        assert e1 < 1e-8 * scale and e2 < 1e-6 * scale, (e1, e2)


def nut_on_screw(pitch, m=2.0, Iz=0.05):
    b = ModelBuilder("nut", gravity=(0, 0, -9.81))
    b.add_body("nut", mass=m, inertia=(0.03, 0.03, Iz), r=(0, 0, 1.0))
    b.add_joint("screw", "thread", "ground", "nut", point=(0, 0, 1.0), axis=(0, 0, 1),
                pitch=pitch)
    return b


@pytest.mark.parametrize("pitch", [0.05, -0.2])
def test_nut_falls_with_the_closed_form_acceleration(pitch):
    """Energy: 1/2 m zdot^2 + 1/2 I thetadot^2 = m g (z0 - z), thetadot = 2 pi zdot / h, so
    zddot = -m g / (m + I (2 pi / h)^2) and theta = 2 pi (z - z0) / h."""
    m, Iz, g = 2.0, 0.05, 9.81
    model = nut_on_screw(pitch, m, Iz).compile()
    assert model.grubler_dof == 1
    res = simulate(model, 1.0, method="projection", integrator="rk45", rtol=1e-10,
                   atol=1e-12, output_step=0.1)
    assert res.success, res.message
    a = -m * g / (m + Iz * (2 * math.pi / pitch) ** 2)
    z = res.body("nut")["r"][:, 2]
    assert np.abs(z - (1.0 + 0.5 * a * res.t ** 2)).max() < 1e-8
    # the turn angle about z follows the thread (through several revolutions for h = 0.05)
    p = res.body("nut")["p"]
    turn = np.unwrap(2 * np.arctan2(p[:, 3], p[:, 0]))
    assert np.abs(turn - 2 * math.pi * (z - 1.0) / pitch).max() < 1e-7
    # the thread carries the weight: axial reaction force m (g + a) on the nut
    rx = res.reactions()["thread"]
    assert np.abs(rx.force_j[:, 2] - m * (g + a)).max() < 1e-6 * m * g


def test_angle_driver_on_a_screw_drives_the_translation():
    b = nut_on_screw(0.1)
    b.add_driver("angle", "motor", ConstantVelocity(4.0), joint="thread")
    kin = kinematic_analysis(b.compile(), np.linspace(0, 3.0, 31))
    z = kin.body("nut")["r"][:, 2]
    assert np.abs(z - (1.0 + 0.1 * 4.0 * kin.t / (2 * math.pi))).max() < 1e-10


def test_screw_in_model_files_and_bad_input():
    model = nut_on_screw(0.05).compile()
    d = model_to_dict(model)
    assert d["joints"][0]["pitch"] == 0.05
    again, _ = load_model(d)
    assert again.constraint_groups[0].geometry.param[0, 0] == 0.05
    d["joints"][0]["pitch"] = 0
    with pytest.raises(ModelError, match="pitch"):
        load_model(d)
    del d["joints"][0]["pitch"]
    with pytest.raises(ModelError, match="needs pitch"):
        load_model(d)
    b = nut_on_screw(0.05)
    with pytest.raises(ModelError, match="pitch"):
        b.add_joint("helical", "t2", "ground", "nut", point=(0, 0, 1), axis=(0, 0, 1),
                    pitch=float("nan"))
    with pytest.raises(ModelError, match="unknown geometry keyword"):
        b.add_joint("revolute", "r2", "ground", "nut", point=(0, 0, 1), axis=(0, 0, 1),
                    pitch=0.1)
