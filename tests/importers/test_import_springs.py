"""Joint springs with reference positions (MJCF ``stiffness``, ``springref``, ``damping``,
issue 28 item 3) against the closed-form oscillation.

MuJoCo's spring pulls a hinge or slide towards ``qpos_spring`` = ``springref``, a value of
``qpos`` -- measured from the joint's zero, not from the start: with ``ref`` the body as
written sits at qpos = ref, and a keyframe moves the start, not the spring's reference. On one
body with inertia I about the hinge axis (mass m on a slide) and armature J, without gravity,

    (I + J) q'' = -k (q - q_spring) - c q',

so x = q - q_spring from x0 = q_start - q_spring at rest moves as
x(t) = x0 e^(-zeta w t) (cos(wd t) + zeta w / wd sin(wd t)), w = sqrt(k / (I + J)),
zeta = c / (2 (I + J) w), wd = w sqrt(1 - zeta^2).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

from spatialmbd.importers import read_mjcf  # noqa: E402
from spatialmbd.simulate import simulate  # noqa: E402

#: a body of mass 2 kg with its centre 0.3 m from a hinge about z (I = 2 0.3^2 + 0.01)
HINGE = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/>
  <worldbody><body name="arm">
    <joint name="h" type="hinge" axis="0 0 1" stiffness="4" springref="0.5" damping="DAMP"
           armature="0.06" REF/>
    <inertial mass="2" pos="0.3 0 0" diaginertia="0.01 0.01 0.01"/>
  </body></worldbody>KEYS</mujoco>"""

SLIDE = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/>
  <worldbody><body name="block">
    <joint name="s" type="slide" axis="1 0 0" stiffness="50" springref="0.04" damping="DAMP"
           armature="0.5" REF/>
    <inertial mass="1.5" pos="0 0.1 0" diaginertia="0.01 0.01 0.01"/>
  </body></worldbody>KEYS</mujoco>"""


def closed_form(t, x0, k, c, inertia):
    w = math.sqrt(k / inertia)
    zeta = c / (2.0 * inertia * w)
    wd = w * math.sqrt(1.0 - zeta * zeta)
    return x0 * np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))


def run(xml, keyframe=None):
    imported = read_mjcf(xml, keyframe=keyframe)
    assert imported.left_out == [] or [x.kind for x in imported.left_out] == ["keyframe"]
    t = np.linspace(0.0, 3.0, 61)
    res = simulate(imported.builder.compile(), 3.0, t_eval=t, integrator="rk45",
                   rtol=1e-11, atol=1e-13)
    assert res.status == "success", res.message
    return t, res.q[:, 0, :3]


@pytest.mark.parametrize("damping", [0.0, 0.3])
@pytest.mark.parametrize("ref, start", [(0.0, None), (0.3, None), (0.0, 0.2)])
def test_hinge_spring_oscillates_about_springref(damping, ref, start):
    """Start at qpos0 = ref (or a keyframe's qpos); the centre's angle about the axis is
    q - ref (the body is written at qpos = ref)."""
    keys = "" if start is None else f'<keyframe><key name="k" qpos="{start}"/></keyframe>'
    xml = HINGE.replace("DAMP", str(damping)).replace("REF", f'ref="{ref}"').replace(
        "KEYS", keys)
    t, com = run(xml, None if start is None else "k")
    q = np.unwrap(np.arctan2(com[:, 1], com[:, 0])) + ref
    q_start = ref if start is None else start
    expected = 0.5 + closed_form(t, q_start - 0.5, 4.0, damping, 2 * 0.3 ** 2 + 0.01 + 0.06)
    assert np.abs(np.hypot(com[:, 0], com[:, 1]) - 0.3).max() < 1e-9
    assert np.abs(q - expected).max() < 1e-8, np.abs(q - expected).max()
    assert np.ptp(q) > 0.1


@pytest.mark.parametrize("damping", [0.0, 2.0])
@pytest.mark.parametrize("ref, start", [(0.0, None), (0.01, None), (0.0, -0.03)])
def test_slide_spring_oscillates_about_springref(damping, ref, start):
    keys = "" if start is None else f'<keyframe><key name="k" qpos="{start}"/></keyframe>'
    xml = SLIDE.replace("DAMP", str(damping)).replace("REF", f'ref="{ref}"').replace(
        "KEYS", keys)
    t, com = run(xml, None if start is None else "k")
    x = com[:, 0] + ref                       # the body is written at qpos = ref
    x_start = ref if start is None else start
    expected = 0.04 + closed_form(t, x_start - 0.04, 50.0, damping, 1.5 + 0.5)
    assert np.abs(com[:, 1:] - [0.1, 0.0]).max() < 1e-10
    assert np.abs(x - expected).max() < 1e-9, np.abs(x - expected).max()
    assert np.ptp(x) > 0.01
