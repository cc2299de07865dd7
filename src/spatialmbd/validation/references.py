"""Derivation of the reference values stored in spatialmbd/validation/data/references.json.

``python -m spatialmbd.validation.references --write`` recomputes every derived value (closed
forms, the accuracy of the ADAMS tables against the exact solution) and writes the JSON file
with each value's provenance: source, how it was obtained, precision. The validation suite
reads the file; the tests check that the stored values still agree with the derivation.
Published values (the slider-crank energy, the Bricard mobility) are entered as published.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
from scipy.special import ellipk

from .. import models
from ..rotations import A_from_p
from .adams import Deck, read_table
from .exact import (AxialMotion, DistancePendulum, EulerFreeBody, PhysicalPendulum,
                    align_quaternion_sign, heavy_top_steady_precession, quat_from_matrix)

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
    from .chrono_models import EXACT, MODELS, NO_CLOSED_FORM
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


def derive(adams_dir: Path) -> dict:
    """Every reference value with its provenance."""
    g = models.G_TEXT
    refs = {"_about": (
        "Reference values of the spatialmbd validation suite, with provenance (source, how "
        "obtained, precision). Derived values are recomputed by `python -m "
        "spatialmbd.validation.references --write`; the tests check they still agree.")}

    refs["adams"] = {
        "source": ("MSC ADAMS results for single-joint spatial pendulums published by Project "
                   "Chrono (BSD-3 licence) in data/testing/joints/ of "
                   "github.com/projectchrono/chrono, commit "
                   "7689fbc02d12c5419fa6acad8791100fd89979dd; copied unchanged into "
                   "spatialmbd/validation/data/adams/ (see PROVENANCE.md there)"),
        "how": ("ADAMS/Solver runs of the decks test_<case>.adm (1 kg, 4 m pendulum, centre "
                "of mass 2 m from the joint, gravity 9.80665 m/s^2 along -z, released at rest "
                "horizontally; Prismatic/Cylindrical: the same body on a translational/"
                "cylindrical joint; Distance: held by a distance constraint GCON DM(a, b) - 2 "
                "at its centre of mass (Case01) or at a point 2 m from it (Case02/03); "
                "TranSpring_Case02: the body free on a translational spring-damper SFORCE from "
                "the origin, natural length 2 m; RotSpring_Case01: the Revolute_Case01 pendulum "
                "with a torsional spring-damper SFORCE about the joint axis (Case02: its "
                "stiffness 50 + 10 |theta| N m/rad, no deck of its own); RevSpherical: no "
                "deck, the model of Chrono's unit test rebuilt in code, the 1 kg pendulum on a "
                "revolute-spherical link 2 m long; LinActuator: no deck either, a 1 kg plate "
                "driven at constant speed along a prismatic joint by a linear actuator); "
                "REQUEST "
                "output every 0.01 s for 0..5 s. Reactions (Rforce, Rtorque) act on the ground "
                "part (I marker) about the I marker, in global axes (with a spring-damper: "
                "its load on the ground, added to the joint's; RevSpherical: Rforce/Rtorque_Body1 "
                "on the ground about the revolute point, _Body2 on the pendulum about the "
                "spherical point; LinActuator: RforceP/RtorqueP the prismatic joint's on the ground "
                "about the origin, RforceA/RtorqueA the actuator's on the plate)."),
        "precision": ("7 significant digits as printed; the ADAMS integration error against "
                      "the exact elliptic solution is listed per quantity "
                      "(adams_error_vs_exact_*, max/RMS over the 501 rows, rounded up to 2 "
                      "digits; computed here with validation.exact.PhysicalPendulum, "
                      "AxialMotion and DistancePendulum); for the cases without a closed form "
                      "(exact: null) the RMS tolerance per column that Project Chrono's unit "
                      "test accepts against the same tables (chrono_rms_tolerance, "
                      "chrono_test)"),
        "cases": {**adams_accuracy(adams_dir), **model_case_entries(adams_dir)},
    }

    a01 = models.simple_pendulum_a01()
    body = a01.bodies["mass"]
    pend = PhysicalPendulum(body.mass, body.inertia, body.r, np.eye(3), (0, 0, 0), (0, 0, 1),
                            a01.gravity)
    T_point = 4 * math.sqrt(1.0 / g) * float(ellipk(0.5))
    refs["iftomm_a01"] = {
        "source": "IFToMM benchmark A01 (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006): 1 kg, 1 m, from "
                  "the horizontal at x = +1 m, gravity 9.81 m/s^2 along -y",
        "how": ("exact large-amplitude pendulum, T = 4 sqrt(I_O / (m g d)) K(1/2) with "
                "I_O = m L^2 + I_c; the model's point mass has I_c = 1e-6 kg m^2"),
        "precision": "closed form, evaluated in double precision",
        "period_s": pend.period, "period_point_mass_s": T_point, "I_O": pend.I_O,
    }

    top = models.HEAVY_TOP
    omega_p = heavy_top_steady_precession(top["mass"], top["l"], top["I1"], top["I3"], g,
                                          top["theta"], top["spin"])
    refs["heavy_top"] = {
        "source": "constructed (models.heavy_top / models.HEAVY_TOP data)",
        "how": ("steady precession of a heavy symmetric top: slow root of "
                "A Omega^2 cos(theta) - C w3 Omega + m g l = 0 (A = I1 + m l^2, C = I3)"),
        "precision": "closed form, evaluated in double precision",
        "theta_rad": top["theta"], "spin_w3": top["spin"], "precession_rate": omega_p,
    }

    from .exact import NutatingTop
    nut = NutatingTop(top["mass"], top["l"], top["I1"], top["I3"], 9.81, math.pi / 3, 20.0,
                      0.0)
    refs["heavy_top_nutation"] = {
        "source": ("constructed (models.heavy_top / models.HEAVY_TOP data): the heavy "
                   "symmetric top released with its axis 60 deg from the vertical, spinning at "
                   "20 rad/s about it, not precessing (H. Goldstein, Classical Mechanics, sec. "
                   "5.7: the cusped nutation)"),
        "how": ("u = cos(theta) oscillates between the first two roots of the cubic u'^2 = "
                "(1 - u^2)(alpha - beta u) - (b - a u)^2: u(t) = u1 + (u2 - u1) sn^2(lam t + "
                "K | m) (validation.exact.NutatingTop); the spin w3 and the angular momentum "
                "about the vertical p_phi = A b are conserved"),
        "precision": "closed form (cubic roots, Jacobi elliptic functions), double precision",
        "theta0_rad": math.pi / 3, "spin_w3": 20.0, "precession0": 0.0,
        "u1": nut.u1, "u2": nut.u2, "nutation_period_s": nut.period, "p_phi": nut.p_phi(),
    }

    fs = FREE_SYMMETRIC
    I1, I3 = fs["inertia"][0], fs["inertia"][2]
    refs["free_symmetric"] = {
        "source": "constructed (validation.references.FREE_SYMMETRIC)",
        "how": ("Euler's equations, I1 = I2: body-axis angular velocity precesses at "
                "lambda = (I3 - I1)/I1 w3; A(t) = R_h(|H|/I1 t) A0 R_3(-lambda t)"),
        "precision": "closed form",
        "data": fs, "lambda": (I3 - I1) / I1 * fs["omega_local"][2],
    }
    fa = FREE_ASYMMETRIC
    efb = EulerFreeBody(fa["inertia"], fa["omega_local"][1], fa["omega_local"][2])
    refs["free_asymmetric"] = {
        "source": "constructed (validation.references.FREE_ASYMMETRIC)",
        "how": ("Jacobi's solution of Euler's equations (validation.exact.EulerFreeBody): "
                "w2 = a2 sn(lambda t + K(m) | m) changes sign every 2 K(m) / lambda"),
        "precision": "closed form",
        "data": fa, "flip_time_s": efb.flip_time, "elliptic_parameter_m": efb.m,
        "lambda": efb.lam,
    }

    nfb = models.n_four_bar(2)
    Ic = float(nfb.bodies["crank0"].inertia[2, 2])
    N, m, L = 2, 1.0, 1.0
    refs["iftomm_a02"] = {
        "source": "IFToMM benchmark A02, N = 2 (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006)",
        "how": ("parallelogram branch: I phi'' = K sin phi, I = (N+1)(I_c + m L^2/4) + N m L^2 "
                "with the model's bar inertia I_c (the published slender-bar I_c = m L^2/12 gives "
                "m L^2 ((N+1)/3 + N)), K = m g L ((N+1)/2 + N); from phi = 0, phi' = -1 rad/s "
                "over the top: validation.exact.rotating_pendulum"),
        "precision": "closed form",
        "I": (N + 1) * (Ic + m * L * L / 4) + N * m * L * L,
        "I_published_thin_bar": m * L * L * ((N + 1) / 3 + N),
        "K": m * g * L * ((N + 1) / 2 + N),
    }

    refs["iftomm_a03"] = {
        "source": ("IFToMM benchmark A03, Andrews' squeezer mechanism (IFToMM benchmark library; "
                   "Hairer & Wanner, Solving Ordinary Differential Equations II, sec. VII.7, after "
                   "Schiehlen, Multibody Systems Handbook, 1990): reference solution at t = 0.03 s "
                   "of the Test Set for IVP Solvers (F. Mazzia, C. Magherini, problem 'andrews', "
                   "revision 1.2, 2006)"),
        "how": ("published: PSIDE with rtol = atol = 1e-14 on a Cray C90, the seven relative "
                "angles (beta, Theta, gamma, Phi, delta, Omega, epsilon), their rates and "
                "second derivatives"),
        "precision": ("16 digits printed; about 10 correct: two independent converged "
                      "solutions (spatialmbd's body coordinates with dop853 at rtol 1e-13, and "
                      "the test set's own relative-coordinate equations reduced to index 1 and "
                      "integrated by SciPy's DOP853 at rtol 1e-13) agree with each other to "
                      "3e-11 rad and both differ from it by up to 1.43e-9 rad, 5.4e-7 rad/s "
                      "and 0.058 rad/s^2"),
        "t_s": 0.03,
        "angles_rad": [15.81077119629904, -15.75637105984298, 0.04082224013073101,
                       -0.5347301163226948, 0.5244099658805304, 0.5347301163226948,
                       1.048080741042263],
        "rates_rad_s": [1139.920302151208, -1424.379294994111, 11.03291221937134,
                        19.29337464421385, 0.5735699284790808, -19.29337464421385,
                        0.3231791658026955],
        "accelerations_rad_s2": [-24631.76316945196, 51850.37701610329, 324102.5686413781,
                                 566749.3645176213, 16743.62929479361, -566749.3645176222,
                                 9826.520791458422],
        "uncertainty": {"angles_rad": 2e-9, "rates_rad_s": 1e-6,
                        "accelerations_rad_s2": 0.1},
    }

    refs["iftomm_a04"] = {
        "source": "IFToMM benchmark A04 Bricard mechanism (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006)",
        "how": "published: Gruebler-Kutzbach 0 DoF, actual mobility 1 (one redundant equation)",
        "precision": "exact integers",
        "grubler": 0, "dof": 1, "redundant_equations": 1,
        "exudyn": dict(how=EXUDYN_HOW,
                       t_s=10.0, steps=[0.0002, 0.0001], com=[
                           [0.499999981905, 0.0, -0.000134516955],
                           [0.999865483041, -0.499999981915, -0.000268997729],
                           [0.999865483041, -1.00013448078, 0.499731002271],
                           [0.499999981905, -1.00013448078, 0.999731002271],
                           [0.0, -0.499999981915, 0.999865519225]],
                       step_difference=6.34e-09),
    }

    refs["iftomm_a05"] = {
        "source": "IFToMM benchmark A05 flyball governor (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006)",
        "how": ("no torque about the shaft axis: angular momentum about z conserved; "
                "mechanical energy + elastic energy - damper work conserved"),
        "precision": "invariants (exact)",
        "exudyn": dict(how=EXUDYN_HOW,
                       t_s=2.0, steps=[5e-05, 2.5e-05], com=[
                           [0.0, 0.0, 0.5],
                           [0.0, -0.0, 0.505909295927],
                           [0.158175457669, -0.880773929158, 0.519998471181],
                           [-0.158175457669, 0.880773929158, 0.519998471181]],
                       step_difference=5.05e-08),
    }

    sc = models.slider_crank_iftomm()
    V = sum(bd.mass * g * bd.r[2] for bd in sc.bodies.values())
    refs["spatial_slider_crank"] = {
        "source": ("IFToMM spatial rigid slider-crank (pre-revision data), "
                   "IFToMM benchmark library (after Gonzalez et al., Multibody Syst. Dyn. 16, 2006): "
                   "'one published implementation finds "
                   "0.76643568 J' (datum z = 0, initial velocities consistent with the joints)"),
        "how": "published value",
        "precision": "8 decimals (+-5e-9 J)",
        "energy_J": 0.76643568,
        "potential_J": V,
        "kinetic_J": 0.76643568 - V,
        "note": ("reproduced with the universal joint's cross axes x (slider) and "
                 "(0, -2, 1)/sqrt 5 (rod) and the crank speed held at 6 rad/s in the "
                 "velocity correction (models.slider_crank_iftomm); models.slider_crank's "
                 "axes give 0.76662000 J"),
        "exudyn": dict(how=EXUDYN_HOW + "; from the velocities of the initial "
                       "correction with the crank's 6 rad/s held",
                       t_s=2.0, steps=[0.0001, 5e-05], com=[
                           [0.0, 0.068214654268, 0.095716429491],
                           [0.144542599376, 0.018214654268, 0.035716429491],
                           [0.289085198752, 0.0, 0.0]],
                       step_difference=3.38e-07),
    }

    refs["slider_crank_kinematics"] = {
        "source": "models.slider_crank_exact (closed form x = sqrt(L^2 - |B_yz|^2))",
        "how": "closed-form slider position, velocity, acceleration at constant crank speed",
        "precision": "closed form",
    }
    refs["hertz_impact"] = {
        "source": ("Hertz contact theory: K = 4/3 E* sqrt(R), E* = E / (1 - nu^2) for a sphere on "
                   "a rigid flat; impact of elastic bodies (K. L. Johnson, Contact Mechanics, "
                   "Cambridge 1985, ch. 11)"),
        "how": ("energy balance m v0^2 / 2 = 2/5 K d_max^(5/2) gives d_max and the peak force "
                "K d_max^(3/2); the duration T = 2 (d_max / v0) int_0^1 dx / sqrt(1 - x^(5/2)) "
                "= 2.94 d_max / v0 (quadrature); elastic: rebound at v0"),
        "precision": "closed form, evaluated in double precision",
        "radius_m": 0.1, "mass_kg": 1.0, "young_Pa": 2.0e11, "poisson": 0.3, "v0_m_s": 1.0,
    }
    refs["cam_follower"] = {
        "source": "constructed (models.cam_follower, models.cam_profile)",
        "how": ("the follower's height is the profile r(pi/2 - w t), r SciPy's periodic cubic "
                "spline through the same radii (an independent implementation); Newton's law "
                "for the follower along its guide, m y'' = F_spring + N n_y, gives the normal "
                "force N, n the outward profile normal turned by the cam angle"),
        "precision": "closed form, evaluated in double precision",
    }
    refs["meijaard_bicycle"] = {
        "source": ("J. P. Meijaard, J. M. Papadopoulos, A. Ruina, A. L. Schwab, Linearized "
                   "dynamics equations for the balance and steer of a bicycle: a benchmark and "
                   "review, Proc. R. Soc. A 463 (2007) 1955-1982: the benchmark bicycle's "
                   "parameters (models.MEIJAARD), the coefficient matrices of its lean and "
                   "steer equations M q'' + v C1 q' + (g K0 + v^2 K2) q = 0, q = (lean, "
                   "steer), printed to 14 digits, and its weave and capsize speeds"),
        "how": ("published (the authors derived the equations by hand and checked them with "
                "independent multibody codes); the eigenvalues at each speed are those of "
                "these matrices (exact.bicycle_eigenvalues)"),
        "precision": "14 significant digits",
        "g": 9.81,
        "M": [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]],
        "C1": [[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]],
        "K0": [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]],
        "K2": [[0.0, 76.59734589573222], [0.0, 2.65431523794604]],
        "weave_speed_m_s": 4.29238253634111,
        "capsize_speed_m_s": 6.02426201538837,
    }
    refs["double_pendulum"] = {
        "source": "constructed (models.double_pendulum): two rods on revolute joints, chaotic",
        "how": ("invariants (energy, constraints) over the run, and the first 2 s against an "
                "independent code"),
        "precision": "invariants exact; the independent code to its step error",
        "exudyn": dict(how=EXUDYN_HOW,
                       t_s=2.0, steps=[5e-05, 2.5e-05], com=[
                           [-0.0, 0.440721093114, -0.23614596775],
                           [0.490314623349, 0.927696834538, -0.38596651839]],
                       step_difference=3.7e-08),
    }
    refs["iftomm_bicycle"] = {
        "source": ("IFToMM benchmark library, uncontrolled bicycle: the Meijaard et al. (2007) "
                   "bicycle (models.whipple_bicycle) started upright and straight, pushed "
                   "sideways: M1 4.0 m/s at 0.05 rad/s, M2 4.6 m/s at 0.5 rad/s, M3 8.0 m/s at "
                   "0.05 rad/s; the library's own reference solutions are not reachable here"),
        "how": ("an independent code instead: Exudyn 1.13.6 (Euler-parameter rigid bodies, its "
                "revolute joints and exact ObjectJointRollingDisc, generalized-alpha rho_inf "
                "0.9, modified Newton at its default tolerances) on the same data, at the "
                "fixed steps 1.25e-4 s and 6.25e-5 s; the centres of mass of the four bodies "
                "(rear frame, rear wheel, front frame, front wheel) at t = 5 s at the finer "
                "step (bench/exudyn_references.py)"),
        "precision": ("second order in the step: the finer step's error is about a third of "
                      "the two steps' difference (step_difference); plus Exudyn's Newton "
                      "tolerance (relative 1e-8 of the positions)"),
        "t_s": 5.0,
        "steps": [1.25e-4, 6.25e-5],
        "manoeuvres": {
            "M1": dict(speed=4.0, lean_rate=0.05, com=[
                      [20.292743251956, -0.312856580591, 0.899987752423],
                      [19.995957823359, -0.268934994681, 0.299996666103],
                      [20.885068528335, -0.40837278796, 0.699982863612],
                      [21.003297746395, -0.428952544363, 0.349985255587]],
                       step_difference=7.44e-08),
            "M2": dict(speed=4.6, lean_rate=0.5, com=[
                      [22.875584316537, -4.901594292056, 0.899949739991],
                      [22.583886640438, -4.831213023375, 0.299983955319],
                      [23.462027663681, -5.028420718453, 0.699953705213],
                      [23.580000227414, -5.05065998195, 0.349971006547]],
                       step_difference=3.03e-07),
            "M3": dict(speed=8.0, lean_rate=0.05, com=[
                      [40.292636910491, -0.739458109184, 0.899982442772],
                      [39.992925888549, -0.725768470791, 0.299994195282],
                      [40.892346524022, -0.758159271463, 0.699985859557],
                      [41.012352292675, -0.759972881513, 0.349992536323]],
                       step_difference=9.42e-08),
        },
    }
    refs["basu_mandal_bicycle"] = {
        "source": ("P. Basu-Mandal, A. Chatterjee, J. M. Papadopoulos, Hands-free circular "
                   "motions of a benchmark bicycle, Proc. R. Soc. A 463 (2007) 1983-2003, "
                   "Table 1: a general state of the Meijaard et al. (2007) benchmark bicycle "
                   "(leaning 35.6 deg, steered, pitched, turning) and the accelerations of the "
                   "nonlinear equations of motion there, as transcribed with their significant "
                   "digits in the DynamicistToolKit (dtk.bicycle.basu_table_one_input, "
                   "basu_table_one_output, basu_sig_figs)"),
        "how": ("published: two independent derivations of the nonlinear equations of motion "
                "agreeing to the digits printed; Basu-Mandal's coordinates: rear wheel centre "
                "(x, y, z), yaw theta, "
                "lean psi, pitch phi, steer psif, wheel angles betar, betaf "
                "(validation.bicycle)"),
        "precision": "12 to 14 significant digits (sig_figs; 0: an exact zero)",
        "state": {"x": 0.0, "y": 0.0, "z": 0.2440472102925, "theta": 0.0,
                  "psi": 0.9501292851472, "phi": 3.1257073014894, "psif": 0.2311385135743,
                  "betar": 0.0, "betaf": 0.0, "xd": -2.8069345714545,
                  "yd": -0.1480982396001, "zd": 0.1058778746261, "thetad": 0.7830033527065,
                  "psid": 0.6068425835418, "phid": -0.0119185528069,
                  "psifd": 0.4859824687093, "betard": 8.9129896614890,
                  "betafd": 8.0133620584155},
        "accelerations": {"xdd": -0.5041626315047, "ydd": -0.3449706619454,
                          "zdd": -1.4604528332980, "thetadd": 0.8353281706379,
                          "psidd": -7.8555281128244, "phidd": 0.1205543897884,
                          "psifdd": -4.6198904039403, "betardd": 1.8472554144217,
                          "betafdd": 2.4548072904550},
        "sig_figs": {"x": 0, "y": 0, "z": 13, "theta": 0, "psi": 13, "phi": 14, "psif": 13,
                     "betar": 0, "betaf": 0, "xd": 14, "yd": 13, "zd": 13, "thetad": 13,
                     "psid": 13, "phid": 12, "psifd": 13, "betard": 13, "betafd": 14,
                     "xdd": 13, "ydd": 13, "zdd": 13, "thetadd": 13, "psidd": 14,
                     "phidd": 13, "psifdd": 14, "betardd": 14, "betafdd": 13},
    }
    return refs


#: provenance of the references computed with Exudyn (validation cases iftomm_a04, iftomm_a05)
EXUDYN_HOW = ("Exudyn 1.13.6, an independent code (Euler-parameter rigid bodies, its own "
              "joints and spring-dampers, generalized-alpha rho_inf 0.9, modified Newton at "
              "its default tolerances), on the same model data at two fixed steps; the "
              "centres of mass of every body at the end at the finer step "
              "(bench/exudyn_references.py)")


def main(argv=None) -> int:
    from .core import adams_dir, reference_dir
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--write", action="store_true", help="write references.json")
    args = parser.parse_args(argv)
    refs = derive(adams_dir())
    text = json.dumps(refs, indent=1, sort_keys=False)
    if args.write:
        path = reference_dir() / "references.json"
        path.write_text(text + "\n")
        print(f"wrote {path}")
    else:
        print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
