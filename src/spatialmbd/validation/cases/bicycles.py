"""The bicycles: Meijaard et al.'s benchmark eigenvalues, the IFToMM uncontrolled bicycle and
Basu-Mandal's steady motions."""
from __future__ import annotations

import numpy as np

from ... import models
from ..core import (CaseResult, bound_basis, compare_history, compare_value, integration_bound,
                    references)
from ..exact import bicycle_eigenvalues
from .common import (_energy_checks, _exudyn_check, _half_digit, _paired_error, _sim,
                     _violation_check)


def _lean_steer_eigenvalues(speed: float) -> np.ndarray:
    """The four lean and steer eigenvalues of models.whipple_bicycle linearized about its
    straight run at ``speed``: the eigenvalues of the linear model's reduced A, from which
    the ignorable position, heading, wheel angles and forward speed are deflated."""
    from ...analyses.linearize import linearize
    lin = linearize(models.whipple_bicycle(speed).compile(), steady=speed > 0)
    return lin.reduced().eigenvalues


def case_meijaard_bicycle(full: bool) -> CaseResult:
    from scipy.optimize import brentq
    from ...analyses.linearize import linearize
    ref = references()["meijaard_bicycle"]
    mats = [ref[k] for k in ("M", "C1", "K0", "K2")]
    case = CaseResult("Whipple bicycle benchmark (Meijaard et al. 2007)", "the nonlinear "
                      "multibody bicycle with knife-edge wheels rolling without slip, "
                      "linearized about its straight run: lean and steer eigenvalues, weave "
                      "and capsize speeds, the torque-to-angle transfer matrix; a nonlinear "
                      "run against the linear model; energy",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    speeds = np.arange(0.0, 10.01, 0.5 if full else 1.0)
    worst, at = 0.0, 0.0
    for v in speeds:
        err = _paired_error(_lean_steer_eigenvalues(v), bicycle_eigenvalues(v, *mats, ref["g"]))
        if err >= worst:
            worst, at = err, v
    case.add(f"lean/steer eigenvalues, v = 0 .. 10 m/s (worst of {4 * speeds.size})", 0.0,
             worst, worst, 1e-8, "the differenced linearization (entries to ~5e-9 of their "
             "size)",
             f"worst at v = {at:g} m/s", "1/s")

    def weave_margin(v):                      # the oscillatory pair's real part
        ev = _lean_steer_eigenvalues(v)
        return float(ev[np.abs(ev.imag) > 1e-6].real.max())
    weave = brentq(weave_margin, 3.5, 5.0, xtol=1e-13)
    compare_value(case, "weave speed (oscillatory pair stable above)", weave,
                  ref["weave_speed_m_s"], 1e-9, "published digits (14) and the eigenvalues' "
                  "accuracy (1e-12 1/s here) over the slope of the real part", "m/s")

    def capsize_eigenvalue(v):                # the real eigenvalue nearest zero
        ev = _lean_steer_eigenvalues(v)
        re = ev[np.abs(ev.imag) <= 1e-9 * np.abs(ev)].real
        return float(re[np.argmin(np.abs(re))])
    # the ignorable modes are deflated, so it crosses zero as a simple eigenvalue
    capsize = brentq(capsize_eigenvalue, 5.8, 6.3, xtol=1e-13)
    compare_value(case, "capsize speed (real eigenvalue stable below)", capsize,
                  ref["capsize_speed_m_s"], 1e-9, "published digits (14) and the eigenvalue's "
                  "accuracy near zero (1e-12 1/s on the reduced system) over its slope 0.04 "
                  "1/s per m/s", "m/s")

    # inputs and outputs: the lean torque (on the rear frame about x) and the steer torque
    # (about the steer axis, between the frames) to the lean and steer angles, against the
    # benchmark's (M s^2 + v C1 s + g K0 + v^2 K2)^-1 at points s away from the eigenvalues
    M_, C1_, K0_, K2_ = (np.asarray(a, dtype=float) for a in mats)
    worst, at = 0.0, ""
    for v in (0.0, 3.0, 5.0, 8.0):
        b = models.whipple_bicycle(v)
        b.add_force("rotational_spring_damper", "steer_torque", joint="steer")
        lin = linearize(b.compile(), steady=v > 0, inputs=["rear_frame.mx", "steer_torque"],
                        outputs=["rear_frame.rx", "steer.angle"])
        for s_ in (0.5j, 1 + 2j, 3.0, -0.7 + 5j, 10j):
            G = lin.C_out @ np.linalg.solve(s_ * np.eye(lin.A.shape[0]) - lin.A, lin.B)
            Gr = np.linalg.inv(M_ * s_ * s_ + v * C1_ * s_ + ref["g"] * K0_ + v * v * K2_)
            err = float(np.abs(G - Gr).max() / np.abs(Gr).max())
            if err >= worst:
                worst, at = err, f"v = {v:g} m/s, s = {s_}"
    case.add("transfer matrix, lean and steer torques to angles (relative, worst of 20)", 0.0,
             worst, worst, 1e-8, "as the eigenvalues: the differenced linearization",
             f"worst at {at}", "")

    # nonlinear: pushed sideways at 1e-4 rad/s at 5 m/s, lean and steer follow the linear model
    v, eps = 5.0, 1e-4
    lin = linearize(models.whipple_bicycle(v).compile(), steady=True,
                    outputs=["rear_frame.rx", "steer.angle"])
    model = models.whipple_bicycle(v, eps).compile()
    b = lin.velocity_basis.T @ (model.v0 - lin.model.v0).reshape(-1)
    x0 = np.concatenate([np.zeros(lin.n), b])
    t_end = 3.0 if full else 1.5
    res = _sim(model, t_end, full, 1e-11, 1e-11, method="projection", output_step=0.05,
               correct_initial=False)
    from scipy.linalg import expm
    step = expm(lin.A * (res.t[1] - res.t[0]))              # the outputs' spacing
    x, lin_out = x0, []
    for _ in res.t:
        lin_out.append(lin.C_out @ x)
        x = step @ x
    lin_out = np.array(lin_out)
    lean, steer = models.bicycle_lean_steer(res)
    amp = float(np.abs(lin_out).max())
    tol = integration_bound(res, amp) + amp * eps      # second order: (amp / eps) eps^2
    basis = bound_basis(res, amp, "rad") + " + eps^2 (second-order terms, eps = 1e-4 rad/s)"
    compare_history(case, "lean angle vs linear model, pushed at 1e-4 rad/s", lean,
                    lin_out[:, 0], tol, basis, "rad", t=res.t)
    compare_history(case, "steer angle vs linear model", steer, lin_out[:, 1], tol, basis,
                    "rad", t=res.t)
    # the IFToMM "uncontrolled bicycle" manoeuvre: 4.6 m/s, pushed at 0.5 rad/s
    res = _sim(models.whipple_bicycle(4.6, 0.5).compile(), 10.0 if full else 3.0, full, 1e-8,
               1e-10, method="projection", output_step=0.01)
    _energy_checks(case, res, "energy change, 4.6 m/s pushed at 0.5 rad/s")
    _violation_check(case, res)
    lean, _ = models.bicycle_lean_steer(res)
    case.notes.append(f"self-stable between {weave:.6f} and {capsize:.6f} m/s; at 4.6 m/s "
                      f"pushed at 0.5 rad/s the lean peaks at {np.degrees(lean.max()):.2f} deg "
                      f"and is {np.degrees(lean[-1]):.3f} deg at {res.t[-1]:g} s")
    return case


def case_iftomm_bicycle(full: bool) -> CaseResult:
    ref = references()["iftomm_bicycle"]
    case = CaseResult("IFToMM uncontrolled bicycle, manoeuvres M1-M3", "the nonlinear "
                      "bicycle pushed sideways below (M1), inside (M2) and above (M3) its "
                      "self-stable speeds, 5 s: centres of mass against an independent code",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    for name, m in ref["manoeuvres"].items():
        res = _exudyn_check(case, models.whipple_bicycle(m["speed"], m["lean_rate"]).compile(),
                            dict(m, t_s=ref["t_s"], steps=ref["steps"]),
                            label=f"{name} ({m['speed']:g} m/s, pushed at {m['lean_rate']:g} "
                                  "rad/s): ", integrator="dop853", rtol=1e-12, atol=1e-14)
        lean, _ = models.bicycle_lean_steer(res)
        case.notes.append(f"{name}: lean at 5 s {np.degrees(lean[-1]):.4f} deg")
    return case


def case_basu_mandal_bicycle(full: bool) -> CaseResult:
    from ...analyses.common import dense
    from ...dynamics.eom import EquationsOfMotion
    from .. import bicycle as bk
    ref = references()["basu_mandal_bicycle"]
    case = CaseResult("Whipple bicycle, nonlinear (Basu-Mandal et al. 2007)", "the "
                      "accelerations of the nonlinear benchmark bicycle (four bodies, two "
                      "wheels rolling without slip) at a general leaning, steering, pitching "
                      "state", f"{ref['source']}; {ref['how']}; {ref['precision']}")
    model = models.whipple_bicycle(0.0).compile()
    eom = EquationsOfMotion(model)

    def evaluate(state):
        q, v, fr = bk.body_state(model, *bk.moore_from_basu(state))
        ev = eom.evaluate(0.0, q, v)
        D, M = dense(ev.cv.D), ev.M.dense()
        m = D.shape[0]
        kkt = np.block([[M, -D.T], [D, np.zeros((m, m))]])        # M vdot = g + D^T lam
        vdot = np.linalg.solve(kkt, np.concatenate([ev.g, ev.cv.gamma]))[:v.size]
        acc = bk.basu_accelerations(model, vdot.reshape(v.shape), fr)
        return (np.array([acc[k] for k in ref["accelerations"]]),
                bk.basu_rear_hub_velocity(model, v), ev, D @ v.reshape(-1))

    state, sig = ref["state"], ref["sig_figs"]
    acc, hub, ev, Dv = evaluate(state)
    # the published state is rounded: its effect on each output, sum_j |d out / d in_j| h_j
    # (h_j half a unit in the last digit of input j; central differences), bounds what two
    # exact computations from the rounded state may differ by
    inputs = ("theta", "psi", "phi", "psif", "betar", "betaf", "thetad", "psid", "phid",
              "psifd", "betard", "betafd")
    spread_acc, spread_hub = np.zeros(acc.size), np.zeros(3)
    for key in inputs:
        h = _half_digit(state[key], sig[key])
        if h == 0.0:
            continue
        up, down = dict(state), dict(state)
        up[key] += 1e-6
        down[key] -= 1e-6
        a_up, v_up, *_ = evaluate(up)
        a_dn, v_dn, *_ = evaluate(down)
        spread_acc += np.abs(a_up - a_dn) / 2e-6 * h
        spread_hub += np.abs(v_up - v_dn) / 2e-6 * h
    basis = ("the published state's rounding through the equations (sum of |d/d input| x half "
             "its last digit) + half the published last digit")
    for k, (key, value) in enumerate(ref["accelerations"].items()):
        unit = "m/s^2" if key in ("xdd", "ydd", "zdd") else "rad/s^2"
        compare_value(case, f"{key} (nonlinear equations of motion)", acc[k], value,
                      spread_acc[k] + _half_digit(value, sig[key]), basis, unit)
    for k, key in enumerate(("xd", "yd", "zd")):
        compare_value(case, f"{key} of the rear wheel centre (from the rolling constraints)",
                      hub[k], state[key], spread_hub[k] + _half_digit(state[key], sig[key]),
                      basis, "m/s")
    scale = 5e-14 * 10
    compare_value(case, "the published state on the constraints: max |Phi|",
                  float(np.abs(ev.cv.phi).max()), 0.0, scale, "its rounding (5e-14) x 10",
                  "m")
    compare_value(case, "the published rates on the constraints: max |D v|",
                  float(np.abs(Dv).max()), 0.0, scale, "its rounding (5e-14) x 10", "m/s")
    case.notes.append("the state is mapped through Moore's frames (validation.bicycle): yaw, "
                      "roll, pitch of the rear frame, steer, wheel angles; the accelerations "
                      "are read back the same way")
    return case
