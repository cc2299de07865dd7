"""The IFToMM benchmark problems A01-A05, the spatial slider-crank, the double pendulum and the
robot arm."""
from __future__ import annotations

import warnings

import numpy as np

from ... import models
from ...kinematics import mobility
from ...rotations import A_from_p
from ...simulate import RedundantConstraintsWarning, simulate
from ..core import (CaseResult, bound_basis, compare_history, compare_value, hermite_crossings,
                    integration_bound, references)
from ..exact import PhysicalPendulum, rotating_pendulum
from .common import _angular_momentum, _energy_checks, _exudyn_check, _sim, _violation_check


def case_a01(full: bool) -> CaseResult:
    ref = references()["iftomm_a01"]
    case = CaseResult("IFToMM A01 simple pendulum", "point mass on a 1 m link, released "
                      "horizontally: position against the exact elliptic solution",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    b = models.simple_pendulum_a01()
    body = b.bodies["mass"]
    pend = PhysicalPendulum(body.mass, body.inertia, body.r, np.eye(3), (0, 0, 0), (0, 0, 1),
                            b.gravity)
    res = _sim(b.compile(), 10.0 if full else 5.0, full, 1e-8, 1e-11, method="projection",
               output_step=0.01)
    ex = pend.motion(res.t)
    tol = integration_bound(res, 1.0)
    compare_history(case, "position of the mass (x, y)", res.q[:, 0, :2], ex.r[:, :2], tol,
                    bound_basis(res, 1.0, "m"), "m", t=res.t)
    theta = pend.angle_of(A_from_p(res.q[:, 0, 3:]))
    tc = hermite_crossings(res.t, theta, res.v[:, 0, 3:] @ pend.w)
    wmax = 2 * pend.omega0 * np.sin(pend.theta0 / 2)
    if len(tc) >= 2:
        period = 2 * (tc[-1] - tc[0]) / (len(tc) - 1)
        compare_value(case, "period", period, ref["period_s"], 4 * tol / wmax / (len(tc) - 1),
                      "2 x crossing-time bound tol / theta'max over the crossings", "s",
                      note=f"from {len(tc)} zero crossings; point-mass period "
                           f"{ref['period_point_mass_s']:.9f} s (I_c = 1e-6 adds "
                           f"{ref['period_s'] - ref['period_point_mass_s']:.2g} s)")
    _energy_checks(case, res, "energy change")
    # the 2006 specification: 2000 s (845 periods), dop853 at rtol 1e-12
    long = _sim(b.compile(), 2000.0, full, 1e-12, 1e-12, output_step=1.0,
                integrator="dop853", atol=1e-14)
    en = _energy_checks(case, long, "energy change over 2000 s (2006 specification)")
    # an energy error dE shifts the period by dT/dE dE: over t the motion lags by
    # (t / T) dT/dE dE, at most v_max times that in position (dT/dE from T(theta0))
    from scipy.special import ellipk
    h = 1e-6
    T_of = [4 * ellipk(np.sin((pend.theta0 + s_) / 2) ** 2) / pend.omega0 for s_ in (h, -h)]
    dT_dE = (T_of[0] - T_of[1]) / (2 * h) / (pend.m * pend.gn * pend.d * np.sin(pend.theta0))
    lag = long.t[-1] / ref["period_s"] * abs(dT_dE) * en.error
    vmax = wmax * pend.d
    exl = pend.motion(long.t)
    compare_history(case, "position over 2000 s (2006 specification)", long.q[:, 0, :2],
                    exl.r[:, :2], integration_bound(long, 1.0) + vmax * lag,
                    bound_basis(long, 1.0, "m") + " + v_max (t/T) |dT/dE| dE, the lag the "
                    f"measured energy error dE explains ({vmax * lag:.2g} m)", "m", t=long.t)
    return case


def case_a02(full: bool) -> CaseResult:
    ref = references()["iftomm_a02"]
    case = CaseResult("IFToMM A02 N-four-bar (N = 2)", "parallelogram of spatial revolute joints "
                      "(redundant), through the singular configurations: crank angles against "
                      "I phi'' = K sin phi", f"{ref['source']}; {ref['how']}; {ref['precision']}")
    model = models.n_four_bar(2).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        # the singular configurations are hard on every method (see the note); projection
        # with rtol 1e-7 passes all of them (3 in the short run, 10 in the full one)
        res = _sim(model, 10.0 if full else 3.0, full, 1e-7, 1e-7, method="projection",
                   output_step=0.01)
    phi_ex, phid_ex = rotating_pendulum(res.t, ref["I"], ref["K"], -1.0)
    wmax = float(max(1.0, np.abs(phid_ex).max()))
    tol = 2 * integration_bound(res, wmax)
    for k in range(3):
        A = A_from_p(res.q[:, model.body_index(f"crank{k}"), 3:])
        phi = np.unwrap(np.arctan2(A[:, 1, 0], A[:, 0, 0]))
        compare_history(case, f"crank {k} angle", phi, phi_ex, tol,
                        "2 x " + bound_basis(res, wmax, "(|omega|max)"), "rad", t=res.t)
    for k in range(2):
        A = A_from_p(res.q[:, model.body_index(f"coupler{k}"), 3:])
        ang = np.arctan2(A[:, 1, 0], A[:, 0, 0])
        compare_history(case, f"coupler {k} rotation (translates)", ang, np.zeros_like(ang),
                        tol, "as the crank angles", "rad", t=res.t)
    _energy_checks(case, res, "energy change")
    case.notes.append(f"method {res.settings['method']}; passes "
                      f"{int(np.sum(np.abs(np.diff(np.floor(phi_ex / np.pi - 0.5)))))} "
                      "singular configurations (cranks horizontal). Fragile by design of the "
                      "benchmark (a step landing on a singular configuration breaks the "
                      "solve): with rk45 the standard method and Baumgarte (rtol 1e-8) fail at "
                      "the 2nd one, projection at rtol 1e-9 at the 1st, the augmented "
                      "Lagrangian at rtol 1e-7 at the 3rd, penalty jumps to another branch")
    return case


ANDREWS_SYMBOLS = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")


def case_a03(full: bool) -> CaseResult:
    ref = references()["iftomm_a03"]
    case = CaseResult("IFToMM A03 Andrews' squeezer", "seven bodies, three closed loops of "
                      "spatial revolute joints (9 redundant equations), spring and drive "
                      "torque: the test set's angles, rates and accelerations at t = 0.03 s",
                      f"{ref['source']}; {ref['how']}; precision {ref['precision']}")
    model = models.andrews_squeezer().compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        # dop853 at tight tolerances: the crank turns 2.5 times in 0.03 s at up to 1400 rad/s
        res = _sim(model, ref["t_s"], full, 1e-11, 1e-13, method="projection",
                   integrator="dop853", output_step=2.5e-4)
    A = A_from_p(res.q[:, :, 3:])
    theta = np.unwrap(np.arctan2(A[:, :, 1, 0], A[:, :, 0, 0]), axis=0)   # rotation about z
    ours = {"angles_rad": models.andrews_coordinates(theta[-1]),
            "rates_rad_s": models.andrews_coordinates(res.v[-1, :, 5]),
            "accelerations_rad_s2": models.andrews_coordinates(res.vdot[-1, :, 5])}
    units = {"angles_rad": "rad", "rates_rad_s": "rad/s", "accelerations_rad_s2": "rad/s^2"}
    for key, value in ours.items():
        target = np.asarray(ref[key])
        err = np.abs(value - target)
        k = int(np.argmax(err))
        scale = float(np.abs(target).max())
        unc = ref["uncertainty"][key]
        case.add(f"{key.split('_')[0]} at t = {ref['t_s']} s (worst of 7)", float(target[k]),
                 float(value[k]), float(err[k]), integration_bound(res, scale) + unc,
                 bound_basis(res, scale, units[key]) + f", + the reference's {unc:g}",
                 f"worst: {ANDREWS_SYMBOLS[k]}; all 7: max {err.max():.2g}, RMS "
                 f"{np.sqrt(np.mean(err ** 2)):.2g}", units[key])
    _energy_checks(case, res, "energy balance (T + V_spring - W_torque)(t) - (T + V)(0)")
    _violation_check(case, res, scale=0.1)
    case.notes.append(f"method {res.settings['method']}, {res.settings['integrator']}; the "
                      f"crank turns {theta[-1, 0] - theta[0, 0]:.3f} rad; the 9 redundant "
                      "equations of the planar loops are left out of the solve")
    return case


def case_a04(full: bool) -> CaseResult:
    ref = references()["iftomm_a04"]
    case = CaseResult("IFToMM A04 Bricard mechanism", "redundant constraints: mobility, "
                      "energy conservation, motion", f"{ref['source']}; {ref['how']}; "
                      f"{ref['precision']}")
    model = models.bricard().compile()
    mob = mobility(model)
    compare_value(case, "Gruebler count", mob.grubler, ref["grubler"], 0, "exact", "DoF")
    compare_value(case, "mobility (rank of D)", mob.dof, ref["dof"], 0, "exact", "DoF")
    compare_value(case, "redundant equations", mob.n_redundant, ref["redundant_equations"], 0,
                  "exact", "", note=", ".join(f"{r[1]}.{r[3]}" for r in mob.redundant))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        res = _sim(model, 10.0 if full else 2.0, full, 1e-8, 1e-10, method="standard",
                   output_step=0.01)
    _energy_checks(case, res, "energy change")
    _violation_check(case, res)
    P3 = res.point("bar3.end")["r"] if "bar3.end" in model.points else res.q[:, 2, :3]
    travel = float(np.linalg.norm(P3 - P3[0], axis=1).max())
    case.add("P3 travel (must exceed 0.5 m: it moves)", 0.5, travel, max(0.0, 0.5 - travel), 0.0,
             "motion check", note="position of joint P3 (end of bar 3)", unit="m")
    case.notes.append("standard method: the redundant equation is left out of the multiplier "
                      "solve, so the reactions of its joint are not unique")
    _exudyn_check(case, model, ref["exudyn"], integrator="dop853", rtol=1e-11, atol=1e-13)
    return case


def case_a05(full: bool) -> CaseResult:
    ref = references()["iftomm_a05"]
    case = CaseResult("IFToMM A05 flyball governor (stiff)", "stiff spring-dampers, implicit "
                      "integrator (Gear BDF4): angular momentum about z, energy balance with "
                      "the damper work", f"{ref['source']}; {ref['how']}; {ref['precision']}")
    model = models.flyball_governor().compile()
    res = _sim(model, 10.0 if full else 0.2, full, 1e-5, 1e-6, method="standard",
               integrator="bdf4", output_step=0.01)
    H = _angular_momentum(res)
    Hs = float(abs(H[0, 2]))
    compare_history(case, "angular momentum about z", H[:, 2], np.full(len(H), H[0, 2]),
                    integration_bound(res, Hs), bound_basis(res, Hs), "kg m^2/s", t=res.t)
    _energy_checks(case, res)
    z = res.body("slider")["r"][:, 2]
    case.notes.append(f"slider height {z[0]:.4f} -> {z[-1]:.4f} m (max {z.max():.4f}); damper "
                      f"work {res.work[-1]:.4g} J; {res.counters['nfev']} evaluations, "
                      f"{res.counters['njev']} Jacobians")
    _exudyn_check(case, model, ref["exudyn"], integrator="bdf4", rtol=1e-9, atol=1e-11)
    return case


def case_spatial_slider_crank(full: bool) -> CaseResult:
    ref = references()["spatial_slider_crank"]
    case = CaseResult("IFToMM spatial slider-crank", "energy after the initial-velocity "
                      "correction (crank speed held at 6 rad/s) and its constancy",
                      f"{ref['source']}; {ref['how']}; precision {ref['precision']}")
    model = models.slider_crank_iftomm().compile()
    res = _sim(model, 2.0 if full else 0.5, full, 1e-8, 1e-10, method="projection",
               output_step=0.01, hold={"crank": ["rx"]})
    en = res.energy()
    compare_value(case, "total energy after the correction", en["total"][0], ref["energy_J"],
                  5e-9 + 1e-12, "published rounding (8 decimals)", "J")
    _energy_checks(case, res, "energy change")
    _violation_check(case, res)
    other = simulate(models.slider_crank(driven=False).compile(), 0.01, output_step=0.01,
                     hold={"crank": ["rx"]}).energy()["total"][0]
    _exudyn_check(case, model, ref["exudyn"], integrator="dop853", rtol=1e-12, atol=1e-14,
                  hold={"crank": ["rx"]})
    case.notes.append(f"models.slider_crank (universal axes (1,2,0)/sqrt5 on the rod, z on the "
                      f"slider) gives {other:.8f} J for the same initial state; without holding "
                      "the crank speed the minimum-norm correction slows the crank")
    return case


def case_double_pendulum(full: bool) -> CaseResult:
    case = CaseResult("Spatial double pendulum", "models.double_pendulum: energy conservation "
                      "and constraints (chaotic: no closed form); the first 2 s against an "
                      "independent code",
                      "constructed model; invariant: total energy (conservative system); "
                      + references()["double_pendulum"]["exudyn"]["how"])
    model = models.double_pendulum().compile()
    res = _sim(model, 10.0 if full else 2.0, full, 1e-8, 1e-10, method="standard",
               output_step=0.01)
    _energy_checks(case, res, "energy change")
    _violation_check(case, res)
    _exudyn_check(case, model, references()["double_pendulum"]["exudyn"], integrator="dop853",
                  rtol=1e-12, atol=1e-14)
    return case


def case_robot_arm(full: bool) -> CaseResult:
    case = CaseResult("6-DoF robot arm with compliant joints", "models.robot_arm: energy "
                      "balance with the joint damper work, constraints",
                      "constructed model; invariant: T + V_g + V_e - W_damping")
    res = _sim(models.robot_arm().compile(), 5.0 if full else 0.5, full, 1e-7, 1e-9,
               method="standard", output_step=0.01)
    _energy_checks(case, res)
    _violation_check(case, res)
    case.notes.append(f"damper work {res.work[-1]:.4g} J over {res.t[-1]:g} s")
    return case
