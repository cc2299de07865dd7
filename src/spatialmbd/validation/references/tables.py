"""The reference data of the validation cases: the ADAMS and Chrono cases, the constructed
models, and the exact solutions and table accuracies derived from them."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...rotations import A_from_p
from ..adams import Deck, read_table
from ..exact import (AxialMotion, DistancePendulum, PhysicalPendulum, align_quaternion_sign,
                     quat_from_matrix)


ALL_QUANTITIES = ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce", "Rtorque")

ADAMS_CASES = {
    "Revolute_Case01": ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce", "Rtorque"),
    "Revolute_Case02": ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce", "Rtorque"),
    "Spherical_Case01": ("Pos", "Quat", "Rforce"),
    "Spherical_Case02": ("Pos", "Quat", "Rforce"),
    "Universal_Case01": ("Pos", "Quat", "Rforce", "Rtorque"),
    "Universal_Case02": ("Pos", "Quat", "Rforce", "Rtorque"),
    "Universal_Case03": ALL_QUANTITIES,
    "Prismatic_Case01": ALL_QUANTITIES,
    "Prismatic_Case02": ALL_QUANTITIES,
    "Prismatic_Case03": ALL_QUANTITIES,
    "Cylindrical_Case01": ALL_QUANTITIES,
    "Cylindrical_Case02": ALL_QUANTITIES,
    "Cylindrical_Case03": ALL_QUANTITIES,
    "Distance_Case01": ALL_QUANTITIES,
    "Distance_Case02": ALL_QUANTITIES,
    "Distance_Case03": ALL_QUANTITIES,
    # force elements (the quantities Chrono's unit tests check: no Rtorque for the spring)
    "TranSpring_Case02": ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce"),
    "RotSpring_Case01": ALL_QUANTITIES,
    "RotSpring_Case02": ALL_QUANTITIES,
}

#: The force-element tests: the deck the model is read from (its name differs from the tables'
#: for TranSpring) and the SFORCE coefficients of Chrono's unit test, with which the tables
#: were computed. The decks in adams_models/ carry other coefficients (TransSpring_Case01:
#: c = 1 N s/m; RotSpring_Case01: k = 1 N m/deg = 57.3 N m/rad, c = 0.05 N m s/deg); a
#: least-squares fit of the tables' own force and motion (:func:`spring_table_fit`, stored in
#: references.json) gives Chrono's values to 6 digits, so these replace the deck's.
#: RotSpring_Case02 has no deck of its own: Chrono's test is Case01's pendulum with the
#: stiffness modulated as 50 + 10 |theta| N m/rad (ChFunction "CustomSpring", damping 10),
#: which the fit of its tables confirms.
SPRING_CASES = {
    "TranSpring_Case02": dict(deck="TransSpring_Case01", test="utest_JOINT_transpring.cpp",
                              coefficients={"sforce1": dict(stiffness=100.0, damping=5.0)}),
    "RotSpring_Case01": dict(deck="RotSpring_Case01", test="utest_JOINT_rotspring.cpp",
                             coefficients={"sforce1": dict(stiffness=200.0, damping=10.0)}),
    "RotSpring_Case02": dict(deck="RotSpring_Case01", test="utest_JOINT_rotspring.cpp",
                             coefficients={"sforce1": dict(stiffness=50.0, damping=10.0,
                                                           nonlinear_stiffness=[10.0])}),
}


def adams_deck(adams_dir: Path, case: str) -> Deck:
    """The deck of an ADAMS case (for the force-element tests: the deck named in SPRING_CASES
    with the SFORCE coefficients of Chrono's unit test)."""
    spec = SPRING_CASES.get(case)
    deck = Deck.read(Path(adams_dir) / f"test_{spec['deck'] if spec else case}.adm")
    if spec:
        for f in deck.forces:
            f.update(spec["coefficients"][f["name"]])
        deck.name = case
    return deck


def spring_table_fit(adams_dir: Path, case: str) -> dict:
    """Stiffness and damping of the one SFORCE of a force-element case fitted (least squares
    over the 501 rows) to the tables alone: TRANSLATIONAL, the force on the ground along the
    unit vector u from the I marker (ground) to the centre of mass against (l - L0, ldot) from
    Pos and Vel; ROTATIONAL, the torque on the ground about the joint axis n (the joint
    reaction has none) against (theta, theta') with theta the angle of the centre of mass
    about n from its start and theta' = Avel . n. A case with a nonlinear stiffness
    k + k1 |x| fits the column |x| x as well (stiffness_k1_fit)."""
    deck = adams_deck(adams_dir, case)
    nonlinear = "nonlinear_stiffness" in SPRING_CASES[case]["coefficients"][deck.forces[0]["name"]]
    (f,) = deck.forces
    mi = deck.markers[f["I"]]
    if not deck.parts[mi.part]["ground"]:
        raise ValueError(f"{case}: the fit expects the SFORCE's I marker on the ground")
    t, pos, _ = read_table(adams_dir / f"{case}_ADAMS_Pos.txt")
    if f["type"] == "TRANSLATIONAL":
        _, vel, _ = read_table(adams_dir / f"{case}_ADAMS_Vel.txt")
        _, force, _ = read_table(adams_dir / f"{case}_ADAMS_Rforce.txt")
        d = pos - mi.origin
        ell = np.linalg.norm(d, axis=1)
        u = d / ell[:, None]
        A = np.c_[ell - f["length"], np.einsum("ti,ti->t", vel, u)]
        y = np.einsum("ti,ti->t", force, u)
    else:
        _, avel, _ = read_table(adams_dir / f"{case}_ADAMS_Avel.txt")
        _, torque, _ = read_table(adams_dir / f"{case}_ADAMS_Rtorque.txt")
        n = mi.A[:, 2]
        d = pos - mi.origin
        theta = np.arctan2(np.cross(d[0], d) @ n, d @ d[0])
        A = np.c_[theta, avel @ n]
        y = torque @ n
    if nonlinear:
        A = np.c_[A[:, 0], np.abs(A[:, 0]) * A[:, 0], A[:, 1]]
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    out = {"stiffness_fit": float(f"{coef[0]:.7g}"), "damping_fit": float(f"{coef[-1]:.7g}"),
           "residual_max": round_up(float(np.abs(A @ coef - y).max()))}
    if nonlinear:
        out["stiffness_k1_fit"] = float(f"{coef[1]:.7g}")
    return out

#: The cases without a closed form: ours against ADAMS within the RMS tolerance (per column,
#: over the 501 rows) that Project Chrono's own unit test accepts for its solution against the
#: same tables (src/tests/unit_tests/joints/, commit 7689fbc02d12c5419fa6acad8791100fd89979dd;
#: ChValidation::Test with NormType::RMS).
CHRONO_RMS_TOLERANCES = {
    "Distance_Case02": ("utest_JOINT_distance.cpp", dict(
        Pos=1e-3, Vel=2e-3, Acc=2e0, Quat=4e-3, Avel=2e-2, Aacc=2e1, Rforce=1e-1,
        Rtorque=1e-10)),
    "Distance_Case03": ("utest_JOINT_distance.cpp", dict(
        Pos=1e-3, Vel=1e-4, Acc=2e-2, Quat=1e-3, Avel=1e-2, Aacc=1e-1, Rforce=2e-2,
        Rtorque=1e-10)),
    # Chrono's Case03 checks are commented out in that file ("////"); these are the values
    # written there
    "TranSpring_Case02": ("utest_JOINT_transpring.cpp", dict(
        Pos=1e-3, Vel=3e-4, Acc=2e-2, Quat=1e-10, Avel=1e-10, Aacc=1e-10, Rforce=5e-3)),
    "RotSpring_Case01": ("utest_JOINT_rotspring.cpp", dict(
        Pos=1e-3, Vel=5e-4, Acc=2e-2, Quat=1e-3, Avel=1e-3, Aacc=5e-3, Rforce=5e-3,
        Rtorque=1e-2)),
    "RotSpring_Case02": ("utest_JOINT_rotspring.cpp", dict(
        Pos=1e-3, Vel=5e-4, Acc=2e-2, Quat=1e-3, Avel=1e-3, Aacc=5e-3, Rforce=5e-3,
        Rtorque=1e-2)),
    "Universal_Case03": ("utest_JOINT_universal.cpp (checks commented out)", dict(
        Pos=2e-3, Vel=2e-3, Acc=2e-2, Quat=1e-3, Avel=2e-2, Aacc=2e-2, Rforce=2e-2,
        Rtorque=5e-4)),
}

#: Chrono joint tests without an ADAMS deck: the model is rebuilt in code from the unit test's
#: C++ source (validation.chrono_models.MODELS), compared with the tables listed (all of them)
#: within the RMS tolerance per column the unit test states (same commit, ChValidation::Test
#: with NormType::RMS).
REVSPH_TABLES = ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce_Body1", "Rtorque_Body1",
                 "Rforce_Body2", "Rtorque_Body2")
LINACT_TABLES = ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "RforceP", "RtorqueP", "RforceA",
                 "RtorqueA")
SPRING_TABLES = ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce")
MODEL_CASES = {
    "RevSpherical_Case01": ("utest_JOINT_revsph.cpp", REVSPH_TABLES, dict(
        Pos=1e-4, Vel=1e-4, Acc=1e-1, Quat=1e-5, Avel=1e-4, Aacc=5e-1, Rforce_Body1=5e-1,
        Rtorque_Body1=5e-1, Rforce_Body2=5e-1, Rtorque_Body2=5e-1)),
    "RevSpherical_Case02": ("utest_JOINT_revsph.cpp", REVSPH_TABLES, dict(
        Pos=1e-4, Vel=1e-4, Acc=1e-1, Quat=1e-5, Avel=1e-3, Aacc=5e-1, Rforce_Body1=5e-1,
        Rtorque_Body1=5e-1, Rforce_Body2=5e-1, Rtorque_Body2=5e-1)),
    # an exact solution (the motion is prescribed): ours against it and against ADAMS within
    # ADAMS's own error against it (no Chrono tolerance used)
    "LinActuator_Case01": ("utest_JOINT_linactuator.cpp", LINACT_TABLES, None),
    "LinActuator_Case02": ("utest_JOINT_linactuator.cpp", LINACT_TABLES, None),
    # a damped oscillator along z: exact, compared as the LinActuator cases
    "TranSpring_Case01": ("utest_JOINT_transpring.cpp", SPRING_TABLES, None),
    # ChLinkTSDA with force functors (Case03/04 a nonlinear spring; Case01 exact as above)
    "TranSpringCB_Case01": ("utest_JOINT_tsda.cpp", SPRING_TABLES, None),
    "TranSpringCB_Case02": ("utest_JOINT_tsda.cpp", SPRING_TABLES, dict(
        Pos=1e-4, Vel=5e-5, Acc=5e-4, Quat=1e-10, Avel=1e-10, Aacc=1e-10, Rforce=5e-4)),
    **{f"TranSpringCB_Case0{k}": ("utest_JOINT_tsda.cpp", SPRING_TABLES, dict(
        Pos=1e-4, Vel=5e-4, Acc=1e-3, Quat=5e-5, Avel=5e-3, Aacc=5e-2, Rforce=5e-3))
       for k in (3, 4)},
}

#: Torque-free bodies and other constructed cases (data used by validation.cases).
FREE_SYMMETRIC = dict(mass=1.0, inertia=(3.0, 3.0, 5.0), omega_local=(1.0, 0.5, 4.0),
                      euler_zxz=(0.3, 0.4, 0.5))
FREE_ASYMMETRIC = dict(mass=1.0, inertia=(1.0, 2.0, 3.0), omega_local=(0.0, 6.0, 0.3))


def round_up(x: float, digits: int = 2) -> float:
    """x rounded up to ``digits`` significant digits (for stated error bounds)."""
    if x <= 0:
        return 0.0
    e = math.floor(math.log10(x)) - digits + 1
    return float(f"{math.ceil(x / 10**e) * 10**e:.{digits}g}")


def adams_pendulum(deck: Deck) -> PhysicalPendulum:
    """The exact solution of a single-joint ADAMS pendulum deck: a physical pendulum about the
    revolute axis, or (spherical, Hooke) about the normal of the plane of the initial
    joint-to-centre line and gravity, in which these pendulums stay by symmetry (released at
    rest, principal axes along the rod)."""
    b = deck.builder()
    (name, body), = b.bodies.items()
    joint = deck.joints[0]
    mi = deck.markers[joint["I"]]
    if joint["type"] == "REVOLUTE":
        axis = mi.A[:, 2]
    else:
        axis = np.cross(body.r - mi.origin, deck.gravity)
    return PhysicalPendulum(body.mass, body.inertia, body.r, A_from_p(body.p), mi.origin, axis,
                            deck.gravity)


def _parallel(a, b, tol=1e-9) -> bool:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return bool(np.linalg.norm(np.cross(a, b)) <= tol * np.linalg.norm(a) * np.linalg.norm(b))


def adams_exact(deck: Deck):
    """The exact solution of a single-joint ADAMS deck, or None where there is none:
    revolute, spherical and Hooke pendulums (:func:`adams_pendulum`; a Hooke joint only when the
    swing axis (r - P) x g is one of its cross axes, else the joint's kinematics turn the body
    about its rod and the motion leaves the plane), translational and cylindrical joints
    (:class:`AxialMotion`), the distance constraint (GCON DM(a, b) - L) when its point on the
    body is the centre of mass (:class:`DistancePendulum`; else a double pendulum: none)."""
    if deck.forces:
        return None
    b = deck.builder()
    (name, body), = b.bodies.items()
    joint = deck.joints[0]
    mi, mj = deck.markers[joint["I"]], deck.markers[joint["J"]]
    kind = joint["type"]
    if kind == "HOOKE" and not any(_parallel(np.cross(body.r - mi.origin, deck.gravity), u)
                                   for u in (mi.A[:, 0], mj.A[:, 1])):
        return None
    if kind in ("REVOLUTE", "SPHERICAL", "HOOKE"):
        return adams_pendulum(deck)
    A0 = A_from_p(body.p)
    if kind in ("TRANSLATIONAL", "CYLINDRICAL"):
        return AxialMotion(body.mass, body.inertia, body.r, A0, mi.origin, mi.A[:, 2],
                           deck.gravity, rotates=kind == "CYLINDRICAL")
    if kind == "DISTANCE":
        if np.linalg.norm(mj.origin - body.r) > 1e-12 * joint["length"]:
            return None
        return DistancePendulum(body.mass, body.inertia, body.r, A0, mi.origin, deck.gravity)
    raise ValueError(f"{deck.name}: no exact solution for a {kind} joint")


def exact_adams_quantities(pend, t) -> dict:
    """The exact counterpart of every ADAMS output table (reaction ON THE GROUND); ``pend``
    a PhysicalPendulum, AxialMotion or DistancePendulum."""
    ex = pend.motion(t)
    return dict(Pos=ex.r, Vel=ex.rdot, Acc=ex.rddot, Quat=quat_from_matrix(ex.A), Avel=ex.omega,
                Aacc=ex.omegadot, Rforce=-ex.force_on_body, Rtorque=-ex.moment_on_body)


def adams_accuracy(adams_dir: Path) -> dict:
    out = {}
    for case, quantities in ADAMS_CASES.items():
        deck = adams_deck(adams_dir, case)
        exact = adams_exact(deck)
        entry = _exact_entry(deck, exact)
        if case in SPRING_CASES:
            spec = SPRING_CASES[case]
            entry["deck"] = f"test_{spec['deck']}.adm"
            entry["coefficients"] = {
                "used": spec["coefficients"], "source": f"{spec['test']} (Chrono)",
                "deck": {f["name"]: {k: Deck.read(adams_dir / entry["deck"]).forces[n][k]
                                     for k in ("stiffness", "damping")}
                         for n, f in enumerate(deck.forces)},
                "table_fit": spring_table_fit(adams_dir, case)}
        entry["quantities"] = {}
        if exact is None:
            test, tols = CHRONO_RMS_TOLERANCES[case]
            entry["chrono_test"] = (f"src/tests/unit_tests/joints/{test} of Project Chrono, "
                                    "commit 7689fbc02d12c5419fa6acad8791100fd89979dd")
        ex = None
        for q in quantities:
            t, val, cols = read_table(adams_dir / f"{case}_ADAMS_{q}.txt")
            qe = entry["quantities"][q] = {"columns": cols, "rows": int(len(t)),
                                           "max_abs": round_up(float(np.abs(val).max()), 7)}
            if exact is None:
                qe["chrono_rms_tolerance"] = tols[q]
                continue
            if ex is None:
                ex = exact_adams_quantities(exact, t)
            e = ex[q]
            if q == "Quat":
                e = align_quaternion_sign(e, val)
            err = np.abs(e - val)
            qe["adams_error_vs_exact_max"] = round_up(float(err.max()))
            qe["adams_error_vs_exact_rms"] = round_up(float(np.sqrt(np.mean(err**2))))
        out[case] = entry
    return out


def model_case_entries(adams_dir: Path) -> dict:
    """The entries of the MODEL_CASES (no deck, no closed form): the tables' shape and size
    and Chrono's RMS tolerance for each."""
    from ..chrono_models import EXACT, MODELS, NO_CLOSED_FORM
    out = {}
    for case, (test, tables, tols) in MODEL_CASES.items():
        entry = {"model": (f"rebuilt in code from {test} (spatialmbd.validation.chrono_models."
                           f"{MODELS[case].__name__}): no ADAMS deck is published"),
                 "chrono_test": (f"src/tests/unit_tests/joints/{test} of Project Chrono, "
                                 "commit 7689fbc02d12c5419fa6acad8791100fd89979dd")}
        if case in EXACT and case.startswith(("TranSpring_", "TranSpringCB_")):
            entry["exact"] = ("the damped oscillator m z'' + c z' + k z = -m g from rest at "
                              "the anchor, the body not turning; the force on the ground "
                              "k z + c z' along z (validation.chrono_models."
                              f"{EXACT[case][0].__name__})")
        elif case in EXACT:
            entry["exact"] = ("prescribed slide r = v t n along the prismatic axis, constant "
                              "orientation; the actuator carries -m (g.n) n, the prismatic "
                              "joint the normal part of the weight (validation.chrono_models."
                              f"{EXACT[case][0].__name__})")
        else:
            entry.update(exact=None, why=(
                f"no closed form: {NO_CLOSED_FORM[case]}; ours against ADAMS within the RMS "
                "tolerance Project Chrono's unit test states for it"))
        entry["quantities"] = {}
        for q in tables:
            t, val, cols = read_table(adams_dir / f"{case}_ADAMS_{q}.txt")
            qe = entry["quantities"][q] = {"columns": cols, "rows": int(len(t)),
                                           "max_abs": round_up(float(np.abs(val).max()), 7)}
            if case not in EXACT:
                qe["chrono_rms_tolerance"] = tols[q]
                continue
            e = EXACT[case][0](case, t)[q]
            if q == "Quat":
                e = align_quaternion_sign(e, val)
            err = np.abs(e - val)
            qe["adams_error_vs_exact_max"] = round_up(float(err.max()))
            qe["adams_error_vs_exact_rms"] = round_up(float(np.sqrt(np.mean(err**2))))
        out[case] = entry
    return out


def _exact_entry(deck: Deck, exact) -> dict:
    """What the exact solution of a deck is (the revolute/spherical/Hooke pendulums keep their
    original two keys)."""
    if isinstance(exact, PhysicalPendulum):
        return {"period_exact_s": exact.period, "I_O": exact.I_O}
    if isinstance(exact, AxialMotion):
        out = {"exact": ("translation along the joint axis s = (g . n) t^2 / 2"
                         + (" and the physical pendulum about it" if exact.pendulum is not None
                            else ", no rotation") + " (validation.exact.AxialMotion)"),
               "axial_acceleration": exact.g_axial}
        if exact.pendulum is not None:
            out.update(period_exact_s=exact.pendulum.period, I_O=exact.pendulum.I_O)
        return out
    if isinstance(exact, DistancePendulum):
        return {"exact": ("point-mass pendulum of the link length, orientation constant "
                          "(validation.exact.DistancePendulum)"),
                "length": exact.L, "period_exact_s": exact.period}
    if deck.forces:
        why = ("a body on a spring-damper of natural length 2 m from a fixed point (an elastic "
               "pendulum)" if not deck.joints else "a pendulum on a revolute joint with a "
               "torsional spring-damper (gravity torque m g d cos theta)")
        return {"exact": None,
                "why": (f"no closed form: {why}; ours against ADAMS within the RMS tolerance "
                        "Project Chrono's unit test states for it")}
    return {"exact": None,
            "why": ("no closed form: " + ("the distance constraint holds a point away from "
                                          "the centre of mass (a double pendulum)"
                                          if deck.joints[0]["type"] == "DISTANCE" else
                                          "the swing axis is not a cross axis of the Hooke "
                                          "joint, so the body turns about its rod and leaves "
                                          "the vertical plane")
                    + "; ours against ADAMS within the RMS tolerance Project Chrono's unit "
                    "test states for it")}
