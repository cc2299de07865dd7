"""Plots (spatialmbd.plotting) and the results -> animation scene glue (spatialmbd.animation)."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.animation import animation_scene, body_shapes, static_scene, write_animation
from spatialmbd.io.results_io import load_results, save_results, to_dataframe
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.plotting import plot_results, plot_violation, select_columns
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate

MAGIC = {".png": b"\x89PNG", ".svg": b"<svg", ".pdf": b"%PDF"}


@pytest.fixture(scope="module")
def runs():
    model = models.pendulum_ch15().compile()
    a = simulate(model, 0.4, output_step=0.02, method="standard")
    b = simulate(model, 0.4, output_step=0.02, method="baumgarte")
    return a, b


def _check_figure(path):
    data = path.read_bytes()
    assert len(data) > 1000
    assert MAGIC[path.suffix] in data[:400]


def test_plot_results_panels(runs):
    fig = plot_results(runs[0], ["pendulum.z", "energy.error", "*.fz", "violation"])
    # one panel per kind: position, energy error, force, the two violations
    assert [ax.get_ylabel().split(" [")[0] for ax in fig.axes] == \
        ["position", "energy balance error", "force", "|Φ| (position violation)",
         "|D v − ν| (velocity violation)"]
    assert [line.get_label() for line in fig.axes[2].lines] == \
        ["pivot.ground.fz", "pivot.pendulum.fz"]
    assert fig.axes[3].get_yscale() == "log" and fig.axes[0].get_yscale() == "linear"


@pytest.mark.parametrize("suffix", [".png", ".svg", ".pdf"])
def test_plot_results_formats(tmp_path, runs, suffix):
    path = tmp_path / f"fig{suffix}"
    plot_results(runs[0], ["pendulum.z"], path)
    _check_figure(path)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_plot_from_loaded_file_and_comparison(tmp_path, runs):
    h5 = save_results(runs[0], tmp_path / "a.h5")
    loaded = load_results(h5)
    fig = plot_results(loaded, ["pendulum"])
    assert [line.get_label() for line in fig.axes[0].lines] == \
        ["pendulum.x", "pendulum.y", "pendulum.z"]
    fig = plot_results([loaded, runs[1]], ["pendulum.z"], tmp_path / "cmp.svg",
                       labels=["standard", "baumgarte"])
    assert [line.get_label() for line in fig.axes[0].lines] == \
        ["standard: pendulum.z", "baumgarte: pendulum.z"]
    _check_figure(tmp_path / "cmp.svg")
    fig = plot_results(to_dataframe(runs[1]), None)
    assert [ax.get_ylabel().split(" [")[0] for ax in fig.axes] == \
        ["position", "energy balance error", "|Φ| (position violation)"]


def test_plot_violation_log(tmp_path, runs):
    path = tmp_path / "viol.png"
    fig = plot_violation(list(runs), ["standard", "baumgarte"], path, log=True)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    assert [line.get_label() for line in ax.lines] == ["standard", "baumgarte"]
    np.testing.assert_allclose(ax.lines[0].get_ydata(),
                               runs[0].constraint_violation()["phi_squared"])
    _check_figure(path)
    fig = plot_violation(runs[0], log=False, quantity="velocity")
    assert fig.axes[0].get_yscale() == "linear"
    np.testing.assert_allclose(fig.axes[0].lines[0].get_ydata(),
                               runs[0].constraint_violation()["velocity"])


def test_select_columns():
    cols = ["t", "a.x", "a.y", "a.z", "a.vx", "j.a.fx", "j.a.fy", "j.a.fz", "j.a.mx",
            "j.ground.fz", "energy.total", "energy.error", "violation.position"]
    assert select_columns(cols, ["a.*"]) == ["a.x", "a.y", "a.z", "a.vx"]
    assert select_columns(cols, ["*.fz"]) == ["j.a.fz", "j.ground.fz"]
    assert select_columns(cols, ["a", "energy.error,a.z"]) == ["a.x", "a.y", "a.z",
                                                               "energy.error"]
    assert select_columns(cols, ["j"]) == ["j.a.fx", "j.a.fy", "j.a.fz", "j.ground.fz"]
    with pytest.raises(ValueError, match=r"'a\.q' \(did you mean a\."):
        select_columns(cols, ["a.q"])


def test_bad_figure_name_writes_nothing(tmp_path, runs):
    with pytest.raises(ValueError, match=r"\.png, \.svg or \.pdf"):
        plot_results(runs[0], ["pendulum.z"], tmp_path / "fig.bmp")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------- animation
def test_body_shapes_reproduce_a_full_inertia_tensor():
    moments = np.array([0.02, 0.03, 0.04])
    R = A_from_p(np.array([0.9, 0.3, -0.2, 0.25]) / np.linalg.norm([0.9, 0.3, -0.2, 0.25]))
    J = R @ np.diag(moments) @ R.T
    (box,) = body_shapes(2.0, J)
    lx, ly, lz = box["size"]
    m = 2.0
    box_inertia = m / 12 * np.diag([ly**2 + lz**2, lx**2 + lz**2, lx**2 + ly**2])
    Rb = A_from_p(np.array(box["p"]))                            # box axes -> body axes
    np.testing.assert_allclose(Rb @ box_inertia @ Rb.T, J, atol=1e-12)
    # a diagonal tensor keeps the box on the body axes
    (box,) = body_shapes(2.0, np.diag(moments))
    assert "p" not in box
    assert box["size"][0] > box["size"][2]                      # smallest Ix -> longest in x


def test_static_scene_and_animation(tmp_path):
    b = ModelBuilder("two", gravity=(0, -9.81, 0))
    b.add_body("a", 1.0, [[0.02, 0.005, 0], [0.005, 0.03, 0], [0, 0, 0.04]], r=(1, 0, 0))
    b.add_body("b", 1.0, (0.01, 0.02, 0.02), r=(2, 0, 0), color="#112233",
               shapes=[{"type": "sphere", "radius": 0.1, "center": np.zeros(3)}])
    b.add_joint("spherical", "s0", "ground", "a", point=(0, 0, 0))
    b.add_joint("spherical", "s1", "a", "b", point=(1.5, 0, 0))
    b.add_ground_shape({"type": "box", "size": [0.2, 0.2, 0.2], "center": [0, 0, 0]})
    model = b.compile()
    scene = static_scene(model)
    json.dumps(scene)                                          # plain JSON values only
    assert scene["gravity"] == [0, -9.81, 0]
    assert "p" in scene["bodies"][0]["shapes"][0]              # turned onto principal axes
    assert scene["bodies"][1]["shapes"][0]["type"] == "sphere"
    assert scene["bodies"][1]["color"] == "#112233"
    assert [(j["name"], j["body"]) for j in scene["joints"]] == [("s0", -1), ("s1", 0)]
    np.testing.assert_allclose(scene["joints"][1]["point_local"], [0.5, 0, 0], atol=1e-12)
    assert len(scene["ground"]) == 1

    r = simulate(model, 0.2, output_step=0.01)
    anim = animation_scene(r, max_frames=11)
    assert len(anim["t"]) == 11 and anim["t"][0] == 0 and anim["t"][-1] == pytest.approx(0.2)
    assert anim["bodies"][1]["r"].shape == (11, 3) and anim["bodies"][1]["p"].shape == (11, 4)
    path = write_animation(r, tmp_path / "two.html", title="two bodies")
    text = path.read_text()
    assert "<title>two bodies</title>" in text
    assert '"s1"' in text and "#112233" in text


def test_animation_from_a_kinematic_results_file(tmp_path):
    model = models.slider_crank(driven=True).compile()
    k = kinematic_analysis(model, np.linspace(0, 0.3, 16))
    loaded = load_results(save_results(k, tmp_path / "k.h5"))
    path = write_animation(loaded, tmp_path / "k.html")
    text = path.read_text()
    scene = json.loads(re.search(r'<script[^>]*application/json[^>]*>(.*?)</script>', text,
                                 re.S).group(1))
    assert [b["name"] for b in scene["bodies"]] == ["crank", "rod", "slider"]
    assert len(scene["t"]) == 16
    from spatialmbd.viewer import decode_float32            # per-frame data: float32, base64
    q = decode_float32(scene["bodies"][2]["q"]).reshape(-1, 7)
    np.testing.assert_allclose(q[:, :3], k.q[:, 2, :3], rtol=1e-6, atol=1e-7)


def test_springs_and_reaction_arrows_in_the_scene(tmp_path):
    b = ModelBuilder("spring_pendulum")
    b.add_body("bob", 2.0, (0.01, 0.01, 0.01), r=(0.5, 0, 0))
    b.add_joint("revolute", "pin", "ground", "bob", point=(0, 0, 0), axis=(0, 1, 0))
    b.add_force("spring_damper", "k", body_i="ground", body_j="bob", point_i=(0.5, 0, 0.4),
                point_j=(0.1, 0, 0), stiffness=50.0, damping=0.5)
    model = b.compile()
    scene = static_scene(model)
    assert scene["springs"] == [{"name": "k", "kind": "spring_damper", "body_i": -1,
                                 "point_i": [0.5, 0.0, 0.4], "body_j": 0,
                                 "point_j": [0.1, 0.0, 0.0]}]
    r = simulate(model, 0.2, output_step=0.02)
    anim = animation_scene(r, reactions=True)
    (arrow,) = anim["arrows"]
    reaction = r.reactions()["pin"]                            # on body i = ground -> drawn on j
    assert arrow["name"] == "pin" and arrow["body"] == 0
    np.testing.assert_allclose(arrow["vectors"], reaction.force_j)
    np.testing.assert_allclose(arrow["point_local"], [-0.5, 0, 0], atol=1e-12)
    write_animation(r, tmp_path / "s.html", reactions=True)
    with pytest.raises(ValueError, match="cannot give the joint reactions"):
        animation_scene(load_results(save_results(r, tmp_path / "r.h5")), reactions=True)


def test_mode_shape_scene():
    from spatialmbd.animation import mode_shape_scene
    from spatialmbd.rotations import A_from_p
    model = models.double_pendulum().compile()
    shape = np.zeros((model.nb, 6))
    shape[0, :3] = [0.0, 0.0, 2.0]                              # body 0 moves along z
    shape[1, 3:] = [0.0, 1.0, 0.0]                              # body 1 turns about y
    scene = mode_shape_scene(model, model.q0, shape, amplitude=0.1, n_frames=5, frequency=2.0)
    np.testing.assert_allclose(scene["t"], [0, 0.125, 0.25, 0.375, 0.5])
    r0 = model.q0[0, :3]
    # s(t) = 0.1 / 2 sin(2 pi t / T): +0.05 at the quarter period
    np.testing.assert_allclose(scene["bodies"][0]["r"][1], r0 + [0, 0, 0.1], atol=1e-12)
    np.testing.assert_allclose(scene["bodies"][0]["r"][2], r0, atol=1e-12)
    A0, A1 = A_from_p(model.q0[1, 3:]), A_from_p(scene["bodies"][1]["p"][1])
    c, s = np.cos(0.05), np.sin(0.05)
    Ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])           # 0.05 rad about global y
    np.testing.assert_allclose(A1, Ry @ A0, atol=1e-12)


def test_scene_draws_distance_constraints_as_links_and_no_contact_as_a_spring():
    """A pendulum on a string (spherical-spherical: a distance constraint) is drawn as a link
    between its points; a contact element (the journal-bearing clearance of the slider-crank)
    and a joint limit are not drawn as coil springs."""
    b = ModelBuilder("string_pendulum", gravity=(0, 0, -9.81))
    b.add_body("bob", 1.0, (0.01, 0.01, 0.01), r=(0.0, 0.0, -1.0))
    b.add_joint("spherical_spherical", "string", "ground", "bob", point=(0, 0, 0),
                point2=(0, 0, -1.0))
    scene = static_scene(b.compile())
    (link,) = scene["springs"]
    assert link["kind"] == "link" and link["name"] == "string"
    assert link["body_i"] == -1 and link["body_j"] == 0
    np.testing.assert_allclose(link["point_i"], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(link["point_j"], [0, 0, 0], atol=1e-12)   # the bob's centre
    crank = models.slider_crank_clearance()
    crank.add_force("joint_limit", "stop", joint="A", lower=-1.0, upper=1.0, law="linear",
                    stiffness=1e3)
    assert static_scene(crank.compile())["springs"] == []
