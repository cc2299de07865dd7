"""Torque-free bodies and heavy tops against their closed-form solutions."""
from __future__ import annotations

import numpy as np

from ... import models
from ...model import ModelBuilder
from ...rotations import A_from_p
from ..core import (CaseResult, bound_basis, compare_history, compare_value, hermite_crossings,
                    integration_bound, references)
from ..exact import EulerFreeBody, symmetric_free_body
from ..references import FREE_ASYMMETRIC, FREE_SYMMETRIC
from .common import _angular_momentum, _energy_checks, _rate, _sim


def case_free_symmetric(full: bool) -> CaseResult:
    ref = references()["free_symmetric"]
    data = FREE_SYMMETRIC
    case = CaseResult("Torque-free symmetric body",
                      "axisymmetric body, no gravity, no joints: body-axis angular velocity and "
                      "orientation against the closed form",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    I1, I3 = data["inertia"][0], data["inertia"][2]
    b = ModelBuilder("free_symmetric", gravity=(0, 0, 0))
    b.add_body("body", data["mass"], data["inertia"], euler_zxz=data["euler_zxz"],
               omega_local=data["omega_local"])
    A0 = A_from_p(b.bodies["body"].p)
    res = _sim(b.compile(), 10.0 if full else 4.0, full, 1e-8, 1e-11, output_step=0.01)
    w_ex, A_ex = symmetric_free_body(res.t, I1, I3, A0, data["omega_local"])
    A = A_from_p(res.q[:, 0, 3:])
    w_local = np.einsum("nji,nj->ni", A, res.v[:, 0, 3:])
    wscale = float(np.linalg.norm(data["omega_local"]))
    compare_history(case, "omega_local (body axes)", w_local, w_ex,
                    integration_bound(res, wscale), bound_basis(res, wscale), "rad/s", t=res.t)
    # orientation: the 3x3 entries; an Euler-parameter error e changes A by at most 4 e
    compare_history(case, "rotation matrix A(t)", A, A_ex, 4 * integration_bound(res, 1.0),
                    "4 x " + bound_basis(res, 1.0, "(|dA| <= 4 |dp|)"), "", t=res.t)
    H = _angular_momentum(res)
    Hs = float(np.linalg.norm(H[0]))
    compare_history(case, "angular momentum H (global)", H, np.repeat(H[:1], len(H), 0),
                    integration_bound(res, Hs * 2), bound_basis(res, Hs * 2), "kg m^2/s",
                    t=res.t)
    compare_value(case, "precession rate lambda of omega_local", _rate(res.t, w_local),
                  ref["lambda"], 2 * integration_bound(res, wscale) / (res.t[-1] * wscale),
                  "angle of (w1, w2): 2 x bound(w) / (|w_perp| t_end)", "rad/s")
    return case


def case_free_asymmetric(full: bool) -> CaseResult:
    ref = references()["free_asymmetric"]
    data = FREE_ASYMMETRIC
    case = CaseResult("Torque-free asymmetric body",
                      "I = (1, 2, 3) started near the intermediate axis: Jacobi's elliptic "
                      "solution, flips of the intermediate axis, invariants",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    b = ModelBuilder("free_asymmetric", gravity=(0, 0, 0))
    b.add_body("body", data["mass"], data["inertia"], omega_local=data["omega_local"])
    res = _sim(b.compile(), 10.0 if full else 5.0, full, 1e-8, 1e-11, output_step=0.01)
    efb = EulerFreeBody(data["inertia"], data["omega_local"][1], data["omega_local"][2])
    A = A_from_p(res.q[:, 0, 3:])
    w_local = np.einsum("nji,nj->ni", A, res.v[:, 0, 3:])
    wdot_local = np.einsum("nji,nj->ni", A, res.vdot[:, 0, 3:])
    wscale = float(np.abs(efb.omega_local(res.t)).max())
    # near the separatrix (m = 0.9926) perturbations grow strongly: the bound is multiplied by
    # the growth factor G of the closed form (EulerFreeBody.amplification)
    growth = efb.amplification(res.t[-1])
    tol_w = integration_bound(res, wscale) * growth
    compare_history(case, "omega_local vs Jacobi solution", w_local, efb.omega_local(res.t),
                    tol_w, bound_basis(res, wscale, f"x perturbation growth G = {growth:.3g}"),
                    "rad/s", t=res.t)
    tc = hermite_crossings(res.t, w_local[:, 1], wdot_local[:, 1])
    flips = (2 * np.arange(len(tc)) + 1) * efb.K / efb.lam
    tol_tc = tol_w / float(np.abs(wdot_local[:, 1]).max() / 2)
    if len(tc) == 0:
        case.add("flips of the intermediate axis", 1, 0, np.inf, 0, "at least one flip")
    else:
        compare_history(case, "times of the flips (w2 = 0)", tc, flips, tol_tc,
                        "G bound(w) / (|w2'|max / 2) at the crossing", "s")
        compare_value(case, "flip half-period 2 K(m) / lambda",
                      float(np.mean(np.diff(tc))) if len(tc) > 1 else 2 * tc[0],
                      ref["flip_time_s"], 2 * tol_tc, "from the flip times", "s",
                      note=f"{len(tc)} flips")
    H = _angular_momentum(res)
    Hs = float(np.linalg.norm(H[0]))
    compare_history(case, "angular momentum H (global)", H, np.repeat(H[:1], len(H), 0),
                    integration_bound(res, 2 * Hs), bound_basis(res, 2 * Hs), "kg m^2/s",
                    t=res.t)
    _energy_checks(case, res, "kinetic energy change")
    return case


# ------------------------------------------------------------------------------ heavy top
def case_heavy_top(full: bool) -> CaseResult:
    ref = references()["heavy_top"]
    case = CaseResult("Heavy symmetric top", "spherical joint at the tip, steady precession: "
                      "nutation angle, precession rate, centre of mass; invariants",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    b = models.heavy_top()
    p = models.HEAVY_TOP
    res = _sim(b.compile(), 5.0 if full else 1.5, full, 1e-8, 1e-10, method="standard",
               output_step=0.01)
    A = A_from_p(res.q[:, 0, 3:])
    e3 = A[:, :, 2]
    theta = np.arccos(np.clip(e3[:, 2], -1, 1))
    tol1 = integration_bound(res, 1.0)
    compare_history(case, "nutation angle theta(t)", theta, np.full_like(theta, p["theta"]),
                    2 * tol1, "2 x " + bound_basis(res, 1.0, "(angle <= 2 |dp|)"), "rad",
                    t=res.t)
    Om = ref["precession_rate"]
    az = np.unwrap(np.arctan2(e3[:, 1], e3[:, 0]))
    tol_az = 2 * tol1 / np.sin(p["theta"])
    compare_history(case, "precession angle vs Omega t", az, Om * res.t, tol_az,
                    "2 bound(p) / sin(theta)", "rad", t=res.t)
    compare_value(case, "precession rate Omega", (az[-1] - az[0]) / (res.t[-1] - res.t[0]), Om,
                  2 * tol_az / res.t[-1], "2 tol(angle) / t_end", "rad/s")
    l = p["l"]
    r_ex = l * np.column_stack([np.sin(p["theta"]) * np.cos(Om * res.t),
                                np.sin(p["theta"]) * np.sin(Om * res.t),
                                np.full_like(res.t, np.cos(p["theta"]))])
    compare_history(case, "centre of mass on its circle", res.q[:, 0, :3], r_ex,
                    l * tol_az + integration_bound(res, l), "l tol(angle) + bound(l)", "m",
                    t=res.t)
    H = _angular_momentum(res)
    Hs = float(np.linalg.norm(H[0]))
    compare_history(case, "angular momentum about the vertical H_z", H[:, 2],
                    np.full(len(H), H[0, 2]), integration_bound(res, Hs),
                    bound_basis(res, Hs), "kg m^2/s", t=res.t)
    w3 = np.einsum("ni,ni->n", res.v[:, 0, 3:], e3)
    compare_history(case, "spin w3 = H_3 / C (axial)", w3, np.full(len(w3), p["spin"]),
                    integration_bound(res, p["spin"]), bound_basis(res, p["spin"]), "rad/s",
                    t=res.t)
    _energy_checks(case, res, "energy change")
    return case


def case_heavy_top_nutation(full: bool) -> CaseResult:
    from ..exact import NutatingTop
    ref = references()["heavy_top_nutation"]
    p = models.HEAVY_TOP
    case = CaseResult("Heavy symmetric top, nutation", "spherical joint at the tip, released "
                      "at 60 deg spinning: cos(theta) against the elliptic closed form; "
                      "conserved spin and angular momentum about the vertical",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    top = NutatingTop(p["mass"], p["l"], p["I1"], p["I3"], 9.81, ref["theta0_rad"],
                      ref["spin_w3"], ref["precession0"])
    b = models.heavy_top(theta=ref["theta0_rad"], spin=ref["spin_w3"],
                         precession=ref["precession0"])
    res = _sim(b.compile(), 5.0 if full else 2.0, full, 1e-10, 1e-11, method="projection",
               output_step=0.005)
    A = A_from_p(res.q[:, 0, 3:])
    e3 = A[:, :, 2]
    compare_history(case, "cos(theta(t)) (theta from the vertical)", e3[:, 2],
                    top.u(res.t), integration_bound(res, 1.0), bound_basis(res, 1.0),
                    "", t=res.t)
    sampling = float(top.u(res.t).min()) - ref["u1"]     # the outputs miss the turning point
    compare_value(case, "lowest cos(theta) reached (root u1)", float(e3[:, 2].min()),
                  ref["u1"], integration_bound(res, 1.0) + sampling,
                  f"bound + the closed form's own miss at the output times ({sampling:.2g})",
                  "")
    H = _angular_momentum(res)
    compare_history(case, "angular momentum about the vertical p_phi", H[:, 2],
                    np.full(len(H), ref["p_phi"]),
                    integration_bound(res, float(np.linalg.norm(H[0]))),
                    bound_basis(res, float(np.linalg.norm(H[0]))), "kg m^2/s", t=res.t)
    w3 = np.einsum("ni,ni->n", res.v[:, 0, 3:], e3)
    compare_history(case, "spin w3 (axial)", w3, np.full(len(w3), ref["spin_w3"]),
                    integration_bound(res, ref["spin_w3"]), bound_basis(res, ref["spin_w3"]),
                    "rad/s", t=res.t)
    _energy_checks(case, res, "energy change")
    periods = res.t[-1] / ref["nutation_period_s"]
    case.notes.append(f"nutation between theta = {np.degrees(np.arccos(ref['u2'])):.2f} and "
                      f"{np.degrees(np.arccos(ref['u1'])):.2f} deg, period "
                      f"{ref['nutation_period_s']:.6f} s ({periods:.1f} periods run)")
    return case
