"""Cases against Adams and Chrono result tables: the Adams revolute and spherical joint decks
and the models of Chrono's validation suite."""
from __future__ import annotations

import numpy as np

from ...rotations import A_from_p
from ..adams import read_table
from ..core import (CaseResult, adams_dir, bound_basis, compare_history, integration_bound,
                    references)
from ..exact import align_quaternion_sign
from ..references import ADAMS_CASES, MODEL_CASES, adams_deck, adams_exact, exact_adams_quantities
from .common import _compare_rms, _energy_checks, _exact_scales, _sim, _violation_check


def _ground_load(res, deck):
    """(force, moment) (nt, 3) that the joints and force elements of the deck apply to the
    ground, the moment about the I marker of the first joint (else of the first force), in
    global axes: the ADAMS tables' Rforce/Rtorque. Joint reactions from Results.reactions
    (force_i/moment_i about the joint point of body i, force_j/moment_j of body j), force
    elements from their own force law (spatialmbd.outputs.force_outputs)."""
    from ...outputs import force_outputs
    nt = len(res.t)
    force, moment = np.zeros((nt, 3)), np.zeros((nt, 3))
    O = deck.markers[(deck.joints or deck.forces)[0]["I"]].origin
    on_ground = lambda m: deck.parts[deck.markers[m].part]["ground"]      # noqa: E731
    reactions = res.reactions() if deck.joints else {}
    for j in deck.joints:
        r = reactions[j["name"]]
        if on_ground(j["I"]) == on_ground(j["J"]):
            raise ValueError(f"{deck.name} {j['name']}: not a joint to the ground")
        if on_ground(j["I"]):
            f, m, P = r.force_i, r.moment_i, deck.markers[j["I"]].origin
        else:
            f, m, P = r.force_j, r.moment_j, deck.markers[j["J"]].origin
        force += f
        moment += m + np.cross(P - O, f)
    for fe in deck.forces:
        out = force_outputs(res, fe["name"])
        mi, mj = deck.markers[fe["I"]], deck.markers[fe["J"]]
        if fe["type"] == "TRANSLATIONAL":
            if on_ground(fe["I"]) == on_ground(fe["J"]):
                raise ValueError(f"{deck.name} {fe['name']}: not a force to the ground")
            ground, other = (mi, mj) if on_ground(fe["I"]) else (mj, mi)
            b = res.body(deck.part_name(other.part))
            A0 = A_from_p(b["p"][0])
            P = b["r"] + np.einsum("tij,j->ti", A_from_p(b["p"]),
                                   A0.T @ (other.origin - b["r"][0]))
            d = P - ground.origin                 # from the ground point to the body's
            f = out["force"][:, None] * d / np.linalg.norm(d, axis=1)[:, None]   # tension
            force += f
            moment += np.cross(ground.origin - O, f)
        else:
            if not on_ground(fe["I"]):
                raise ValueError(f"{deck.name} {fe['name']}: a ROTATIONAL SFORCE is read here "
                                 "with its I marker on the ground")
            joint = deck.sforce_joint(fe)
            if not on_ground(joint["I"]):
                raise ValueError(f"{deck.name} {fe['name']}: its joint's I marker must be on "
                                 "the ground")
            n = deck.markers[joint["I"]].A[:, 2]   # the joint axis u_i, fixed with the ground
            moment += -out["torque"][:, None] * n  # tau u on body j, -tau u on body i
    return force, moment


UNITS = dict(Pos="m", Vel="m/s", Acc="m/s^2", Quat="", Avel="rad/s", Aacc="rad/s^2",
             Rforce="N", Rtorque="N m")


def _compare_tables(case, res, t, tables, ours, exact, scales, entry, rms_basis):
    """Every ADAMS table against ours. With an exact solution (``exact``, ``scales``: its
    quantities and natural sizes): within ADAMS's own error against it + our integration
    bound, and ours against it within that bound. Without one (exact None): by Project
    Chrono's RMS metric and tolerance (``rms_basis`` names its source)."""
    for q, (tq, val, cols) in tables.items():
        if not np.allclose(tq, t):
            raise ValueError(f"{case.name}: {q} has different output times")
        o = align_quaternion_sign(ours[q], val) if q == "Quat" else ours[q]
        unit = _unit(q)
        if exact is None:
            _compare_rms(case, f"{q} vs ADAMS (RMS)", o, val,
                         entry["quantities"][q]["chrono_rms_tolerance"],
                         f"Project Chrono's RMS tolerance for its own solution ({rms_basis})",
                         unit, cols, t)
            continue
        e = align_quaternion_sign(exact[q], val) if q == "Quat" else exact[q]
        ours_bound = integration_bound(res, scales[q])
        adams_err = entry["quantities"][q]["adams_error_vs_exact_max"]
        compare_history(case, f"{q} vs ADAMS", o, val, adams_err + ours_bound,
                        f"ADAMS error vs exact {adams_err:.2g} + ours "
                        f"{ours_bound:.2g} [{bound_basis(res, scales[q])}]", unit, t=t)
        compare_history(case, f"{q} vs exact", o, e, ours_bound,
                        bound_basis(res, scales[q]), unit, t=t)


def _unit(table: str) -> str:
    """The unit of a table: Rforce_Body1, RforceP, RforceA... are forces (Rforce)."""
    for q, unit in UNITS.items():
        if table == q or table.startswith(q + "_") or table[:-1] == q:
            return unit
    raise KeyError(table)


def adams_case(name: str, full: bool) -> CaseResult:
    """One ADAMS joint test: the deck read into a model, simulated over the 501 output times
    of the tables. With an exact solution (references.adams_exact): every table compared with
    ours (tolerance: the ADAMS run's own error against the exact solution + our integration
    bound) and ours with the exact solution. Without one: every table compared with ours by
    Project Chrono's metric and tolerance for its own solution (RMS per column), and the
    energy balance and the constraint violation within our integration bound."""
    info = references()["adams"]
    entry = info["cases"][name]
    case = CaseResult(f"ADAMS {name}", f"MSC ADAMS joint test {name} (Project Chrono data)",
                      f"{info['source']}. {info['how']} Precision: {info['precision']}.")
    d = adams_dir()
    deck = adams_deck(d, name)
    model = deck.builder().compile()
    body = model.body_names[0]
    exact_solution = adams_exact(deck)
    tables = {q: read_table(d / f"{name}_ADAMS_{q}.txt") for q in ADAMS_CASES[name]}
    t = next(iter(tables.values()))[0]
    res = _sim(model, float(t[-1]), full, 1e-7, 1e-10, method="standard", t_eval=t)
    b = res.body(body)
    joint = (deck.joints or deck.forces)[0]
    force_ground, moment_ground = _ground_load(res, deck)
    ours = dict(Pos=b["r"], Vel=b["rdot"], Acc=b["rddot"], Quat=b["p"], Avel=b["omega"],
                Aacc=b["omegadot"], Rforce=force_ground, Rtorque=moment_ground)
    exact = scales = None
    if exact_solution is not None:
        exact = exact_adams_quantities(exact_solution, t)
        scales = _exact_scales(exact_solution, t)
    _compare_tables(case, res, t, tables, ours, exact, scales, entry,
                    entry.get("chrono_test", "").split(" of ")[0].split("/")[-1])
    reaction = (f"reaction = force_i/moment_i (on the ground, body i of the "
                f"{joint['type'].lower()} {'constraint' if joint['type'] == 'DISTANCE' else 'joint'}"
                ", about the fixed I marker) as ADAMS reports it")
    if deck.forces:
        spec = entry["coefficients"]
        fit = spec["table_fit"]
        reaction = (("Rforce = the spring-damper's force on the ground (FX(I, J) of the SFORCE: "
                     "tension f times the unit vector from the ground point to the body)"
                     if not deck.joints else
                     "Rforce/Rtorque = the load on the ground from the joint (force_i/moment_i "
                     "about the I marker) plus the torsional spring-damper's torque on it "
                     "(-tau n), as Chrono's test adds them")
                    + f"; SFORCE coefficients {spec['used']} from {spec['source']}, not the "
                    f"deck's {spec['deck']}: the tables fit k = {fit['stiffness_fit']:g}, "
                    f"c = {fit['damping_fit']:g}")
    if exact_solution is None:
        _energy_checks(case, res, "energy balance (T + V - W_damper)(t) - (T + V)(0)"
                       if deck.forces else "energy change")
        size = float(np.linalg.norm(b["r"], axis=1).max())
        if deck.joints and joint["type"] == "DISTANCE":
            # Phi = d.d - L^2: a position error dr changes it by 2 L dr
            viol = res.constraint_violation()["position"]
            scale = 2 * joint["length"] * size
            compare_history(case, "constraint violation |d.d - L^2|", viol,
                            np.zeros_like(viol), integration_bound(res, scale),
                            bound_basis(res, scale, "(2 L |r|max: dPhi = 2 L dr)"), "m^2",
                            t=res.t)
        elif deck.joints:                                 # (a free body has no constraint)
            _violation_check(case, res, scale=size)
        case.notes.append(f"no closed form ({entry['why'].split(';')[0][len('no closed form: '):]}"
                          f"); Chrono's tolerances from {entry['chrono_test']}; {reaction}")
    else:
        period = entry.get("period_exact_s")
        case.notes.append((f"exact period {period:.9f} s; " if period else "")
                          + (f"{entry['exact']}; " if "exact" in entry else "") + reaction)
    return case


def chrono_model_case(name: str, full: bool) -> CaseResult:
    """A Chrono joint test without an ADAMS deck (references.MODEL_CASES): the model rebuilt
    in code from the unit test's source (validation.chrono_models), simulated over the 501
    output times, plus the energy balance (with the driver's work where there is a driver)
    and the constraint violation within our integration bound. With an exact solution
    (chrono_models.EXACT): every table compared with ours within ADAMS's own error against
    it + our integration bound, and ours with it. Without one: every table compared with ours
    by Project Chrono's metric and tolerance (RMS per column). The short run uses rtol 1e-9,
    not the 1e-7 of the deck cases: at 1e-7 our own integration error in RevSpherical_Case02's
    Vel (RMS 1.0e-4 m/s) reaches Chrono's tolerance 1e-4."""
    from ..chrono_models import CONVENTIONS, EXACT, MODELS, link_length
    info = references()["adams"]
    entry = info["cases"][name]
    test, tables_used, _ = MODEL_CASES[name]
    case = CaseResult(f"ADAMS {name}", f"MSC ADAMS joint test {name} (Project Chrono data, "
                      f"model from {test})",
                      f"{info['source']}. {info['how']} Precision: {info['precision']}.")
    d = adams_dir()
    builder, outputs = MODELS[name](name)
    model = builder.compile()
    tables = {q: read_table(d / f"{name}_ADAMS_{q}.txt") for q in tables_used}
    t = next(iter(tables.values()))[0]
    res = _sim(model, float(t[-1]), full, 1e-9, 1e-11, method="standard", t_eval=t)
    exact = scales = None
    if name in EXACT:
        exact_of, scales_of = EXACT[name]
        exact, scales = exact_of(name, t), scales_of(name, t)
    _compare_tables(case, res, t, tables, outputs(res), exact, scales, entry, test)
    size = max(1.0, float(np.linalg.norm(res.q[:, :, :3], axis=2).max()))
    if name in EXACT:
        _energy_checks(case, res, "energy balance (T + V - W_nc)(t) - (T + V)(0)")
        _violation_check(case, res, scale=size)
        case.notes.append(f"exact: {entry['exact']}; {entry['model']}; {CONVENTIONS[name]}; "
                          f"work of the driver or damper {res.work[-1]:.6g} J")
        return case
    if model.n_eq == 0:
        _energy_checks(case, res, "energy balance (T + V - W_damper)(t) - (T + V)(0)")
    else:
        _energy_checks(case, res, "energy change")
        # Phi = (u.d, d.d - L^2): a position error dr changes them by at most 2 L dr
        scale = 2 * link_length(name) * size
        viol = res.constraint_violation()["position"]
        compare_history(case, "constraint violation |(u.d, d.d - L^2)|", viol,
                        np.zeros_like(viol), integration_bound(res, scale),
                        bound_basis(res, scale, "(2 L |r|max: dPhi <= 2 L dr)"), "m^2",
                        t=res.t)
    case.notes.append(f"no closed form ({entry['why'].split(';')[0][len('no closed form: '):]}"
                      f"); {entry['model']}; Chrono's tolerances from {entry['chrono_test']}; "
                      f"{CONVENTIONS[name]}")
    return case
