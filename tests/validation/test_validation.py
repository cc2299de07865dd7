"""The validation suite (short version in CI) and the references it relies on."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from spatialmbd.validation import CASE_NAMES, format_table, reference_dir, run_validation
from spatialmbd.validation.adams import Deck, parse_statements, read_table
from spatialmbd.validation.core import adams_dir
from spatialmbd.validation.exact import (AxialMotion, DistancePendulum, EulerFreeBody,
                                         PhysicalPendulum, rotating_pendulum,
                                         symmetric_free_body)
from spatialmbd.validation.references import (ADAMS_CASES, CHRONO_RMS_TOLERANCES,
                                              SPRING_CASES, adams_deck, adams_exact, derive,
                                              spring_table_fit)


# ------------------------------------------------------------------------- the short suite
@pytest.mark.parametrize("name", CASE_NAMES)
def test_short_validation_case_passes(name):
    (result,) = run_validation(cases=[name])
    assert result.error is None, result.error
    assert result.checks, "a case must compare something"
    failed = [c for c in result.checks if not c.passed]
    assert not failed, "\n" + format_table([result], details=True)


@pytest.mark.parametrize("name", ["adams_spherical_case01", "free_asymmetric", "iftomm_a01",
                                  "robot_arm"])
def test_tree_cases_pass_with_the_recursive_method(name):
    """Joint coordinates (spherical, free, revolute joints with springs) against the same
    references; `python -m spatialmbd.validation --method recursive` runs all 19 (the 11
    tree cases with rk45 then take it)."""
    (result,) = run_validation(cases=[name], method="recursive")
    assert result.error is None, result.error
    assert "method(s): recursive" in result.notes
    failed = [c for c in result.checks if not c.passed]
    assert not failed, "\n" + format_table([result], details=True)


def test_format_table_lists_every_check_with_its_tolerance(tmp_path):
    results = run_validation(cases=["slider_crank_kinematics", "iftomm_a04"], out=tmp_path)
    text = format_table(results)
    for word in ("reference", "ours", "error", "tolerance", "pass", "Gruebler count",
                 "slider xddot", "tolerance: cond(D)"):
        assert word in text
    md = (tmp_path / "validation.md").read_text()
    assert md.startswith("| case | quantity | reference | ours |")
    assert "2/2 cases passed" in md


def test_the_case_list_names_every_case_once():
    from spatialmbd.validation.cases import CASES
    assert sorted(CASE_NAMES) == sorted(CASES) and len(set(CASE_NAMES)) == len(CASE_NAMES)


def test_unknown_case_is_rejected():
    with pytest.raises(ValueError, match="unknown validation case"):
        run_validation(cases=["nope"])


@pytest.mark.slow
def test_full_validation_suite_passes(tmp_path):
    results = run_validation(full=True, out=tmp_path)
    assert all(r.passed for r in results), format_table(results)


# ------------------------------------------------------------------------- reference data
def _same(a, b, path=""):
    """Equal structures; floats to 12 digits (the derivation uses SciPy's elliptic functions,
    whose last bits may differ between versions)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), path
        for k in a:
            _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{k}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-300), path
    else:
        assert a == b, path


def test_stored_references_agree_with_their_derivation():
    stored = json.loads((reference_dir() / "references.json").read_text())
    fresh = json.loads(json.dumps(derive(adams_dir())))
    _same(stored, fresh)     # else: python -m spatialmbd.validation.references --write


def test_every_reference_states_source_how_and_precision():
    refs = json.loads((reference_dir() / "references.json").read_text())
    for key, entry in refs.items():
        if key.startswith("_"):
            continue
        for field in ("source", "how", "precision"):
            assert entry.get(field), f"{key} lacks {field}"
    assert (reference_dir() / "adams" / "PROVENANCE.md").is_file()


def test_published_values_entered_as_published():
    refs = json.loads((reference_dir() / "references.json").read_text())
    assert refs["spatial_slider_crank"]["energy_J"] == 0.76643568
    assert (refs["iftomm_a04"]["grubler"], refs["iftomm_a04"]["dof"]) == (0, 1)
    bike = refs["meijaard_bicycle"]
    assert bike["M"][0] == [80.81722, 2.31941332208709] and bike["K2"][1][1] == 2.65431523794604
    assert (bike["weave_speed_m_s"], bike["capsize_speed_m_s"]) == (4.29238253634111,
                                                                    6.02426201538837)
    # the ADAMS runs' accuracy against the exact solution (about 5e-6 m and 8.4e-4 m)
    cases = refs["adams"]["cases"]
    for name in ("Revolute_Case01", "Revolute_Case02", "Spherical_Case02"):
        assert 4e-6 < cases[name]["quantities"]["Pos"]["adams_error_vs_exact_max"] < 6e-6
    for name in ("Spherical_Case01", "Universal_Case01", "Universal_Case02"):
        assert 8e-4 < cases[name]["quantities"]["Pos"]["adams_error_vs_exact_max"] < 9e-4


# ------------------------------------------------------------------------- reading the decks
def test_deck_reading_revolute_case02():
    deck = Deck.read(adams_dir() / "test_Revolute_Case02.adm")
    np.testing.assert_allclose(deck.gravity, [0, 0, -9.80665])
    b = deck.builder()
    (body,) = b.bodies.values()
    assert body.mass == 1.0
    np.testing.assert_allclose(np.diag(body.inertia), [0.04, 0.1, 0.1])
    np.testing.assert_allclose(body.r, [3, 2, 3])
    (joint,) = b.joints.values()
    assert (joint.type, joint.body_i) == ("revolute", "ground")
    np.testing.assert_allclose(joint.geometry["point"], [1, 2, 3])
    np.testing.assert_allclose(joint.geometry["axis"], np.array([0, 1, 1]) / np.sqrt(2),
                               atol=1e-15)
    # the body frame is the CM marker frame: its Euler parameters are ADAMS's first Quat row
    t, quat, cols = read_table(adams_dir() / "Revolute_Case02_ADAMS_Quat.txt")
    assert cols == ["e0", "e1", "e2", "e3"] and len(t) == 501
    np.testing.assert_allclose(body.p, quat[0], atol=1e-6)


def test_deck_reading_hooke_axes():
    deck = Deck.read(adams_dir() / "test_Universal_Case02.adm")
    (joint,) = deck.builder().joints.values()
    assert joint.type == "universal"
    np.testing.assert_allclose(joint.geometry["axis"], [0, 0, -1], atol=1e-15)   # I marker x
    np.testing.assert_allclose(joint.geometry["axis2"], [0, 1, 0], atol=1e-15)   # J marker y


def test_deck_reading_translational_cylindrical_and_distance():
    b = Deck.read(adams_dir() / "test_Prismatic_Case02.adm").builder()
    (joint,) = b.joints.values()
    assert (joint.type, joint.body_i) == ("translational", "ground")
    np.testing.assert_allclose(joint.geometry["point"], [1, 2, 3])
    np.testing.assert_allclose(joint.geometry["axis"], np.array([0, 1, 1]) / np.sqrt(2),
                               atol=1e-15)
    b = Deck.read(adams_dir() / "test_Cylindrical_Case02.adm").builder()
    (joint,) = b.joints.values()
    assert joint.type == "cylindrical"
    np.testing.assert_allclose(joint.geometry["axis"], [0, 1, 0], atol=1e-15)
    deck = Deck.read(adams_dir() / "test_Distance_Case02.adm")
    (gcon,) = deck.joints
    assert (gcon["name"], gcon["type"], gcon["I"], gcon["J"], gcon["length"]) == (
        "gcon1", "DISTANCE", 102, 202, 2.0)
    (joint,) = deck.builder().joints.values()
    assert (joint.type, joint.body_i, joint.body_j) == ("spherical_spherical", "ground",
                                                        "part02")
    np.testing.assert_allclose(joint.geometry["point"], [1, 2, 3])     # ground marker 0102
    np.testing.assert_allclose(joint.geometry["point2"], [1, 4, 3])    # part marker 0202
    assert joint.params["length"] == 2.0


def _deck_text(name, replace):
    text = (adams_dir() / f"test_{name}.adm").read_text()
    for old, new in replace:
        assert old in text
        text = text.replace(old, new)
    return text


def test_deck_reader_rejects_what_it_does_not_model(tmp_path):
    cases = {
        "func": ("Distance_Case01", [("DM(0202, 0102)-2", "DX(0202, 0102)-2")], "GCON/1"),
        "marker": ("Distance_Case01", [("DM(0202, 0102)-2", "DM(0202, 0201)-2")],
                   "one of them the I marker"),
        "vforce": ("Prismatic_Case01", [("ACCGRAV/", "VFORCE/3, I = 0201, J = 0101\nACCGRAV/")],
                   "VFORCE/3 is not supported"),
        "sforce": ("Prismatic_Case01", [("ACCGRAV/", "SFORCE/3, I = 0201, J = 0101\nACCGRAV/")],
                   "SFORCE/3 .* only TRANSLATIONAL or ROTATIONAL"),
        "preload": ("TransSpring_Case01", [(", + 0.0", ", + 5.0")], "preload"),
        "pushing": ("TransSpring_Case01", [(", - 1.0*vr(204,205)", ", + 1.0*vr(204,205)")],
                    "must be negative"),
        "markers": ("TransSpring_Case01", [("dm(204,205)", "dm(204,101)")],
                    "does not measure I = 204 against J = 205"),
        "rest_angle": ("RotSpring_Case01", [("-0.0*DTOR", "-10.0*DTOR")], "rest angle 0"),
        "no_joint": ("RotSpring_Case01", [("JOINT/1\n, REVOLUTE", "JOINT/1\n, SPHERICAL")],
                     "revolute or cylindrical joint"),
        "twisted": ("Prismatic_Case02", [("MARKER/0202, PART = 02\n, QP = 1, 2, 3\n"
                                          ", REULER = 180D, 45D, 180D",
                                          "MARKER/0202, PART = 02\n, QP = 1, 2, 3\n"
                                          ", REULER = 170D, 45D, 190D")], "not aligned"),
    }
    for key, (name, replace, match) in cases.items():
        path = tmp_path / f"test_{key}.adm"
        path.write_text(_deck_text(name, replace))
        with pytest.raises(ValueError, match=match):
            Deck.read(path).builder()


def test_prismatic_reaction_convention_by_hand():
    """Prismatic_Case02: axis n = (0, 1, 1)/sqrt 2 through P = (1, 2, 3), centre of mass 2 m
    along x from it. The body slides with a = (g.n) n; the joint holds it against g_n = g -
    (g.n) n with -m g_n and, as the body does not turn, with the moment (r_c - P) x (-m g_n)
    about the fixed point P. ADAMS reports the opposite (on the ground)."""
    m, g = 1.0, np.array([0, 0, -9.80665])
    n = np.array([0, 1, 1]) / np.sqrt(2)
    P = np.array([1.0, 2, 3])
    gn = g - (g @ n) * n
    t, force, _ = read_table(adams_dir() / "Prismatic_Case02_ADAMS_Rforce.txt")
    _, torque, _ = read_table(adams_dir() / "Prismatic_Case02_ADAMS_Rtorque.txt")
    for k in (0, 250, 500):
        r = np.array([3.0, 2, 3]) + 0.5 * t[k] ** 2 * (g @ n) * n
        np.testing.assert_allclose(force[k], m * gn, atol=1e-5)     # ADAMS: 7 digits
        np.testing.assert_allclose(torque[k], -np.cross(r - P, -m * gn), rtol=1e-5,
                                   atol=1e-5)


def test_exact_solutions_of_the_new_adams_decks():
    """Which decks have a closed form, and the physics of the guided-body solutions: the
    cylindrical joint exerts no force along and no moment about its axis, the distance
    constraint pulls along the link, whose length stays L."""
    none = {c for c in ADAMS_CASES if adams_exact(adams_deck(adams_dir(), c)) is None}
    assert none == set(CHRONO_RMS_TOLERANCES) == {"Distance_Case02", "Distance_Case03",
                                                   "Universal_Case03", "TranSpring_Case02",
                                                   "RotSpring_Case01", "RotSpring_Case02"}
    t = np.linspace(0, 5, 201)
    ax = adams_exact(Deck.read(adams_dir() / "test_Cylindrical_Case03.adm"))
    assert isinstance(ax, AxialMotion) and ax.pendulum is not None
    ex = ax.motion(t)
    np.testing.assert_allclose(ex.force_on_body @ ax.n, 0, atol=1e-12)
    np.testing.assert_allclose(ex.moment_on_body @ ax.n, 0, atol=1e-9)
    np.testing.assert_allclose((ex.r - ax.r0) @ ax.n, 0.5 * (ax.g @ ax.n) * t ** 2, atol=1e-12)
    # energy: the joint does no work
    w = ex.omega
    J = ex.A @ ax.Jc @ np.swapaxes(ex.A, 1, 2)
    T = 0.5 * ax.m * np.sum(ex.rdot ** 2, 1) + 0.5 * np.einsum("ni,nij,nj->n", w, J, w)
    np.testing.assert_allclose(T - ax.m * (ex.r - ax.r0) @ ax.g, 0, atol=1e-10)
    dp = adams_exact(Deck.read(adams_dir() / "test_Distance_Case01.adm"))
    assert isinstance(dp, DistancePendulum) and dp.L == 2.0
    ex = dp.motion(t)
    np.testing.assert_allclose(np.linalg.norm(ex.r - dp.P, axis=1), 2.0, rtol=1e-12)
    np.testing.assert_allclose(np.cross(ex.force_on_body, ex.r - dp.P), 0, atol=1e-12)
    np.testing.assert_allclose(ex.omega, 0)


def test_deck_reading_sforce():
    """The two SFORCE decks as written (their own coefficients): a FUNCTION continued over
    ``,`` lines is one expression; RTOD turns N m/deg into N m/rad."""
    deck = Deck.read(adams_dir() / "test_TransSpring_Case01.adm")
    assert deck.joints == []
    (f,) = deck.forces
    assert f == dict(id=1, name="sforce1", type="TRANSLATIONAL", I=204, J=205,
                     stiffness=100.0, damping=1.0, length=2.0)
    b = deck.builder()
    (spec,) = b.forces.values()
    assert spec.type == "spring_damper"
    assert spec.params["body_i"] == "ground" and spec.params["body_j"] == "part02"
    np.testing.assert_allclose(spec.params["point_i"], 0)
    np.testing.assert_allclose(spec.params["point_j"], 0)       # the J marker is the CM
    deck = Deck.read(adams_dir() / "test_RotSpring_Case01.adm")
    (f,) = deck.forces
    assert f["type"] == "ROTATIONAL" and f["angle"] == 0.0
    assert f["stiffness"] == pytest.approx(180 / np.pi)
    assert f["damping"] == pytest.approx(0.05 * 180 / np.pi)
    assert deck.sforce_joint(f)["name"] == "joint1"
    model = deck.builder().compile()
    assert [g.name for g in model.force_groups] == ["rotational_spring_damper"]


def test_spring_decks_differ_from_the_tables_which_fit_chronos_coefficients():
    """The decks in adams_models/ do not carry the coefficients the tables were computed with;
    a fit of the tables gives those of Chrono's unit tests, which the cases use."""
    for case, spec in SPRING_CASES.items():
        deck = Deck.read(adams_dir() / f"test_{spec['deck']}.adm")
        used = spec["coefficients"]["sforce1"]
        assert (deck.forces[0]["stiffness"], deck.forces[0]["damping"]) != (
            used["stiffness"], used["damping"])
        fit = spring_table_fit(adams_dir(), case)
        assert fit["stiffness_fit"] == pytest.approx(used["stiffness"], rel=1e-5)
        assert fit["damping_fit"] == pytest.approx(used["damping"], rel=1e-5)
        if "nonlinear_stiffness" in used:                  # RotSpring_Case02: 50 + 10 |theta|
            assert fit["stiffness_k1_fit"] == pytest.approx(used["nonlinear_stiffness"][0],
                                                            rel=1e-5)
        assert adams_deck(adams_dir(), case).forces[0]["damping"] == used["damping"]


def test_spring_table_signs_by_hand():
    """TranSpring_Case02 at t = 0.96 s: the spring (k = 100, c = 5, L0 = 2) is stretched, so it
    pulls the ground towards the body: Rforce = (k (l - L0) + c l') u, u from the origin to the
    centre of mass. RotSpring_Case01 at t = 5 s: the ground receives the spring's torque
    k theta + c theta' about +y (k = 200, c = 10), theta the pendulum's drop below the
    horizontal x axis (the body sags: gravity turns it about +y)."""
    t, pos, _ = read_table(adams_dir() / "TranSpring_Case02_ADAMS_Pos.txt")
    _, vel, _ = read_table(adams_dir() / "TranSpring_Case02_ADAMS_Vel.txt")
    _, force, _ = read_table(adams_dir() / "TranSpring_Case02_ADAMS_Rforce.txt")
    k = int(np.argmin(abs(t - 0.96)))
    ell = np.linalg.norm(pos[k])
    u = pos[k] / ell
    assert ell > 2.0
    np.testing.assert_allclose(force[k], (100 * (ell - 2) + 5 * vel[k] @ u) * u, atol=2e-4)
    _, pos, _ = read_table(adams_dir() / "RotSpring_Case01_ADAMS_Pos.txt")
    _, avel, _ = read_table(adams_dir() / "RotSpring_Case01_ADAMS_Avel.txt")
    _, torque, _ = read_table(adams_dir() / "RotSpring_Case01_ADAMS_Rtorque.txt")
    theta = np.arctan2(-pos[-1, 2], pos[-1, 0])
    assert theta > 0
    assert torque[-1, 1] == pytest.approx(200 * theta + 10 * avel[-1, 1], rel=1e-5)


def test_revspherical_reaction_convention_by_hand():
    """The RevSpherical tables (no deck): Rforce_Body2 is the force on the pendulum,
    m (a - g) by Newton's law, applied at the spherical point Q (Rtorque_Body2 = 0: a ball
    joint carries no moment); Rforce/Rtorque_Body1 the opposite force on the ground, its moment
    taken about the revolute point P, (Q - P) x F1, normal to the axis (no moment about a
    revolute axis). Q from Pos and Quat, its offset from the centre of mass fixed in the body
    (identity at t = 0). Tolerances: 7 printed digits and ADAMS's constraint residual
    (|u.(Q - P)| up to 8.3e-6 m) times the force, 1e-5 |F|max."""
    from spatialmbd.rotations import A_from_p
    from spatialmbd.validation.chrono_models import REVSPH_GEOMETRY, link_length
    m, g = 1.0, np.array([0, 0, -9.80665])
    for name, geo in REVSPH_GEOMETRY.items():
        tab = {q: read_table(adams_dir() / f"{name}_ADAMS_{q}.txt")[1]
               for q in ("Pos", "Acc", "Quat", "Rforce_Body1", "Rtorque_Body1",
                         "Rforce_Body2", "Rtorque_Body2")}
        P = np.array(geo["revolute_point"])
        u = np.array(geo["axis"]) / np.linalg.norm(geo["axis"])
        s = np.array(geo["spherical_point"]) - np.array(geo["cm"])
        Q = tab["Pos"] + np.einsum("tij,j->ti", A_from_p(tab["Quat"]), s)
        np.testing.assert_allclose(np.linalg.norm(Q - P, axis=1), link_length(name), atol=1e-5)
        np.testing.assert_allclose((Q - P) @ u, 0, atol=1e-5)
        F1, F2 = tab["Rforce_Body1"], tab["Rforce_Body2"]
        assert np.abs(F1).max() > 500                    # large forces: a real check
        tol = 1e-5 * np.abs(F1).max()
        np.testing.assert_allclose(F2, m * (tab["Acc"] - g), atol=tol)
        np.testing.assert_allclose(F1, -F2, atol=1e-12)
        np.testing.assert_allclose(tab["Rtorque_Body2"], 0, atol=1e-12)
        np.testing.assert_allclose(tab["Rtorque_Body1"], np.cross(Q - P, F1), atol=2 * tol)
        np.testing.assert_allclose(tab["Rtorque_Body1"] @ u, 0, atol=1e-9)


def test_linactuator_exact_solution_and_table_conventions():
    """LinActuator (no deck): the prescribed slide r = v t n satisfies the prismatic joint
    (r stays on the line through the origin along n) and the actuator (r.n = v t); the exact
    loads keep the plate in equilibrium (it does not accelerate): actuator on the plate
    + prismatic on the plate (minus the one on the ground) + weight = 0, the actuator along n
    only, the prismatic normal to n, its moment on the ground about the origin r x F. The
    ADAMS tables agree with it to their 7 printed digits: RforceA is the load on the plate,
    RforceP/RtorqueP that on the ground about the origin (signs verified here, not assumed)."""
    from spatialmbd.validation.chrono_models import LINACT_SETUP, linear_actuator_exact
    from spatialmbd.rotations import A_from_p
    m, g = 1.0, np.array([0, 0, -9.80665])
    for name, setup in LINACT_SETUP.items():
        n = A_from_p(np.array(setup["p"]))[:, 2]
        t = read_table(adams_dir() / f"{name}_ADAMS_Pos.txt")[0]
        ex = linear_actuator_exact(name, t)
        v = setup["speed"]
        np.testing.assert_allclose(ex["Pos"] @ n, v * t, atol=1e-14)
        np.testing.assert_allclose(np.cross(ex["Pos"], n), 0, atol=1e-14)
        np.testing.assert_allclose(np.gradient(ex["Pos"], t, axis=0), ex["Vel"], atol=1e-12)
        np.testing.assert_allclose(ex["RforceA"] - ex["RforceP"] + m * g, m * ex["Acc"],
                                   atol=1e-12)
        np.testing.assert_allclose(np.cross(ex["RforceA"], n), 0, atol=1e-12)
        np.testing.assert_allclose(ex["RforceP"] @ n, 0, atol=1e-12)
        np.testing.assert_allclose(ex["RtorqueP"], np.cross(ex["Pos"], ex["RforceP"]))
        for q, e in ex.items():
            val = read_table(adams_dir() / f"{name}_ADAMS_{q}.txt")[1]
            scale = max(1.0, float(np.abs(e).max()))
            np.testing.assert_allclose(val, e, atol=5e-6 * scale, err_msg=f"{name} {q}")
    # which is which: Case02's prismatic takes the normal part of the weight, which has a
    # downward z component on the ground; the actuator pushes the plate up along n
    _, fp, _ = read_table(adams_dir() / "LinActuator_Case02_ADAMS_RforceP.txt")
    _, fa, _ = read_table(adams_dir() / "LinActuator_Case02_ADAMS_RforceA.txt")
    assert fp[0, 2] < -4.9 and fa[0, 2] > 4.9


def test_statement_parser_handles_continuations_comments_and_degrees():
    (st,) = parse_statements("MARKER/0102, PART = 01 ! comment\n, QP = 1, 2, 3\n"
                             ", REULER = 180D, 45D, 0\n")
    assert (st.name, st.id) == ("MARKER", 102)
    assert st.keys["QP"] == ["1", "2", "3"] and st.keys["REULER"] == ["180D", "45D", "0"]


def test_adams_reaction_convention_by_hand():
    """At release (rest, rod horizontal) I_O theta'' = m g d, so the centre of mass accelerates
    down by d theta'' and the joint holds the body up with m (g - d theta''); ADAMS reports the
    reaction on the ground, i.e. the opposite force."""
    m, g, d, I_O = 1.0, 9.80665, 2.0, 0.1 + 4.0
    on_body_z = m * (g - d * (m * g * d / I_O))
    _, force, _ = read_table(adams_dir() / "Revolute_Case01_ADAMS_Rforce.txt")
    assert force[0, 2] == pytest.approx(-on_body_z, rel=1e-5)
    np.testing.assert_allclose(force[0, :2], 0, atol=1e-9)


# ------------------------------------------------------------------------- the exact solutions
def _euler_rhs(I):
    def f(t, w):
        return [(I[1] - I[2]) * w[1] * w[2] / I[0], (I[2] - I[0]) * w[2] * w[0] / I[1],
                (I[0] - I[1]) * w[0] * w[1] / I[2]]
    return f


def test_jacobi_solution_solves_eulers_equations():
    efb = EulerFreeBody((1.0, 2.0, 3.0), 6.0, 0.3)
    t = np.linspace(0, 5, 201)
    sol = solve_ivp(_euler_rhs((1.0, 2.0, 3.0)), (0, 5), [0, 6.0, 0.3], t_eval=t, rtol=1e-12,
                    atol=1e-12)
    np.testing.assert_allclose(efb.omega_local(t), sol.y.T, atol=1e-8)
    # w2 changes sign at K / lambda, 3 K / lambda, ...
    sn = efb.omega_local([efb.K / efb.lam, 3 * efb.K / efb.lam])[:, 1]
    np.testing.assert_allclose(sn, 0, atol=1e-12)


def test_symmetric_free_body_closed_form_solves_the_kinematics():
    A0 = np.eye(3)
    w0 = np.array([0.3, -0.2, 2.0])

    def rhs(t, y):
        w, A = y[:3], y[3:].reshape(3, 3)
        wd = _euler_rhs((1.0, 1.0, 2.0))(t, w)
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        return np.concatenate([wd, (A @ W).ravel()])

    t = np.linspace(0, 6, 61)
    sol = solve_ivp(rhs, (0, 6), np.concatenate([w0, A0.ravel()]), t_eval=t, rtol=1e-12,
                    atol=1e-12)
    w, A = symmetric_free_body(t, 1.0, 2.0, A0, w0)
    np.testing.assert_allclose(w, sol.y[:3].T, atol=1e-9)
    np.testing.assert_allclose(A, sol.y[3:].T.reshape(-1, 3, 3), atol=1e-9)


def test_physical_pendulum_solves_its_equation_and_period():
    pend = PhysicalPendulum(7.02, (0.5855265, 0.0010530, 0.5855265), (0, 0.5, 0), np.eye(3),
                            (0, 0, 0), (1, 0, 0), (0, 0, -9.81))
    w2 = pend.omega0**2
    t = np.linspace(0, 4, 101)
    sol = solve_ivp(lambda t, y: [y[1], -w2 * np.sin(y[0])], (0, 4), [np.pi / 2, 0],
                    t_eval=t, rtol=1e-12, atol=1e-12)
    th, thd, _ = pend.angle(t)
    np.testing.assert_allclose(th, sol.y[0], atol=1e-9)
    np.testing.assert_allclose(thd, sol.y[1], atol=1e-9)
    assert pend.I_O == pytest.approx(0.5855265 + 7.02 * 0.25)
    # theta returns to pi/2 after one period
    assert pend.angle([pend.period])[0][0] == pytest.approx(np.pi / 2, abs=1e-7)


def test_rotating_pendulum_solution():
    t = np.linspace(0, 3, 121)
    sol = solve_ivp(lambda t, y: [y[1], 34.335 / 3.0 * np.sin(y[0])], (0, 3), [0, -1.0],
                    t_eval=t, rtol=1e-12, atol=1e-12)
    phi, phid = rotating_pendulum(t, 3.0, 34.335, -1.0)
    np.testing.assert_allclose(phi, sol.y[0], atol=1e-8)
    np.testing.assert_allclose(phid, sol.y[1], atol=1e-8)


def test_reference_data_ship_inside_the_package():
    """The references are package data (a regular, non-editable install has them)."""
    import spatialmbd
    pkg = Path(spatialmbd.__file__).resolve().parent
    d = reference_dir().resolve()
    assert pkg in d.parents
    assert (d / "references.json").is_file() and (d / "adams" / "PROVENANCE.md").is_file()
    import tomllib
    root = pkg.parents[1]
    data = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    patterns = data["package-data"]["spatialmbd"]
    for f in d.rglob("*"):
        if f.is_file():
            rel = f.relative_to(pkg).as_posix()
            assert any(Path(rel).match(p) for p in patterns), rel


def _wheel_venv(tmp_path):
    """A fresh virtual environment (reusing the installed dependencies) holding only the wheel
    built from this source tree: what a regular, non-editable `pip install` gives."""
    import subprocess
    import sys
    import spatialmbd
    root = Path(spatialmbd.__file__).resolve().parents[2]
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w",
                    str(tmp_path / "whl"), str(root)], check=True, capture_output=True)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)],
                   check=True)
    py = venv / "bin" / "python"
    wheel = next((tmp_path / "whl").glob("*.whl"))
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
                   check=True, capture_output=True)
    return py


@pytest.mark.slow       # builds a wheel (13 s of CI); pytest -m slow runs it
def test_validation_data_work_from_an_installed_wheel(tmp_path):
    """From a regular install (outside the source tree): the reference data are found and two
    validation cases pass (uncompiled, so the new install does not compile the kernels)."""
    import os
    import subprocess
    py = _wheel_venv(tmp_path)
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    env.pop("PYTHONPATH", None)
    probe = ("import spatialmbd, spatialmbd.validation.core as c, pathlib;"
             "from spatialmbd.validation.adams import read_table;"
             "assert 'site-packages' in spatialmbd.__file__, spatialmbd.__file__;"
             "c.references()['adams'];"
             "t, v, _ = read_table(c.adams_dir() / 'Revolute_Case01_ADAMS_Pos.txt');"
             "assert len(t) == 501; print('ok')")
    out = subprocess.run([str(py), "-c", probe], cwd=tmp_path, env=env, capture_output=True,
                         text=True)
    assert out.returncode == 0 and "ok" in out.stdout, out.stderr[-2000:]
    out = subprocess.run([str(py), "-m", "spatialmbd", "validate", "slider_crank_kinematics",
                          "heavy_top"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    assert "all 2 validation cases passed" in out.stdout


@pytest.mark.slow
def test_validate_passes_from_an_installed_wheel(tmp_path):
    """`spatialmbd validate` (all cases, compiled) in a fresh virtual environment holding only
    the built wheel."""
    import subprocess
    py = _wheel_venv(tmp_path)
    out = subprocess.run([str(py), "-m", "spatialmbd", "validate"], cwd=tmp_path,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    assert f"all {len(CASE_NAMES)} validation cases passed" in out.stdout


def test_bicycle_reference_eigenvalues_at_rest():
    """The benchmark matrices at v = 0: the two pairs of an inverted pendulum, +-3.13164324790656
    and +-5.53094371765393 1/s, the values the benchmark paper lists for standing still."""
    from spatialmbd.validation.exact import bicycle_eigenvalues
    ref = json.loads((reference_dir() / "references.json").read_text())["meijaard_bicycle"]
    ev = bicycle_eigenvalues(0.0, ref["M"], ref["C1"], ref["K0"], ref["K2"], ref["g"])
    assert np.allclose(ev.real, [-5.53094371765393, -3.13164324790656, 3.13164324790656,
                                 5.53094371765393], atol=1e-12)


def test_moore_frames_of_the_straight_run_are_the_models_start():
    """Upright and straight (yaw, roll 0, pitch lam, steer 0), the wheels turning at -v/r
    about Moore's y axis (to the right): validation.bicycle.body_state gives
    models.whipple_bicycle(v)'s own initial state."""
    from spatialmbd import models
    from spatialmbd.validation import bicycle as bk
    v = 4.0
    P = models.MEIJAARD
    model = models.whipple_bicycle(v).compile()
    q, vv, _ = bk.body_state(model, [0, 0, P["lam"], 0, 0, 0],
                             [0, 0, 0, -v / P["rR"], 0, -v / P["rF"]])
    assert np.allclose(q[:, :3], model.q0[:, :3], atol=1e-14)
    assert np.allclose(np.abs(q[:, 3:] @ model.q0[:, 3:].T).diagonal(), 1, atol=1e-14)
    assert np.allclose(vv, model.v0, atol=1e-13)


def test_basu_mandal_values_entered_as_published():
    ref = json.loads((reference_dir() / "references.json").read_text())["basu_mandal_bicycle"]
    assert ref["state"]["psi"] == 0.9501292851472 and ref["state"]["betard"] == 8.912989661489
    assert ref["accelerations"]["psifdd"] == -4.6198904039403
    assert ref["sig_figs"]["phid"] == 12 and ref["sig_figs"]["psidd"] == 14
