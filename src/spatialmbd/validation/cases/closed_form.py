"""Mechanisms against closed-form results: slider-crank kinematics, a Hertz impact, a cam and
its follower."""
from __future__ import annotations

import math

import numpy as np

from ... import models
from ...kinematics import kinematic_analysis
from ...model import ModelBuilder
from ...simulate import simulate
from ..core import (CaseResult, bound_basis, compare_history, compare_value, integration_bound,
                    references)
from .common import _sim


def case_slider_crank_kinematics(full: bool) -> CaseResult:
    ref = references()["slider_crank_kinematics"]
    case = CaseResult("Slider-crank kinematics", "models.slider_crank driven at 6 rad/s over "
                      "one crank revolution: slider position, velocity, acceleration",
                      f"{ref['source']}; {ref['how']}; {ref['precision']}")
    model = models.slider_crank(driven=True).compile()
    t = np.linspace(0, 2 * np.pi / 6.0, 181 if full else 61)
    tol_newton = 1e-10
    kin = kinematic_analysis(model, t, tol=tol_newton)
    s = kin.body("slider")
    x, xd, xdd = models.slider_crank_exact(6.0 * t)
    conds = []
    for k in range(0, len(t), max(1, len(t) // 12)):
        D = model.assembler.evaluate(kin.q[k], None, t[k]).D
        D = D.toarray() if hasattr(D, "toarray") else D
        conds.append(np.linalg.cond(D))
    kappa = float(max(conds))
    L = 0.3
    tol_x = kappa * tol_newton
    vmax, amax = float(np.abs(xd).max()), float(np.abs(xdd).max())
    eps = np.finfo(float).eps
    basis = f"cond(D) = {kappa:.3g} x Newton tolerance {tol_newton:g}"
    compare_history(case, "slider x", s["r"][:, 0], x, tol_x, basis, "m", t=t)
    compare_history(case, "slider xdot", s["rdot"][:, 0], xd,
                    kappa * (tol_x / L + 1e3 * eps) * vmax, basis + " (relative, x |v|max / L)",
                    "m/s", t=t)
    compare_history(case, "slider xddot", s["rddot"][:, 0], xdd,
                    kappa * (tol_x / L + 1e3 * eps) * amax, basis + " (relative, x |a|max / L)",
                    "m/s^2", t=t)
    compare_history(case, "slider y, z (on the guide)", s["r"][:, 1:], np.zeros((len(t), 2)),
                    tol_x, basis, "m", t=t)
    return case


# ------------------------------------------------------------------------------ IFToMM
def case_hertz_impact(full: bool) -> CaseResult:
    """A sphere on a rigid flat at v0, no gravity, the Hertz law from the materials: the
    indentation where the sphere stops, the force there, the contact duration and the
    rebound speed against Hertz's impact theory."""
    from scipy.integrate import quad
    ref = references()["hertz_impact"]
    case = CaseResult("Hertz impact of a sphere on a rigid flat", "steel sphere at 1 m/s, "
                      "Hertz law from E and nu: indentation, peak force, contact duration, "
                      "rebound", f"{ref['source']}; {ref['how']}; {ref['precision']}")
    R, m, E, nu, v0 = (ref[k] for k in ("radius_m", "mass_kg", "young_Pa", "poisson", "v0_m_s"))
    K = 4.0 / 3.0 * E / (1 - nu ** 2) * math.sqrt(R)                      # Hertz stiffness
    dmax = (5.0 * m * v0 ** 2 / (4.0 * K)) ** 0.4
    T = 2.0 * dmax / v0 * quad(lambda x: 1.0 / math.sqrt(1.0 - x ** 2.5), 0, 1)[0]
    gap0 = 1e-4
    b = ModelBuilder("hertz_impact", gravity=(0, 0, 0))
    J = 0.4 * m * R ** 2
    b.add_body("ball", m, (J, J, J), r=(0, 0, R + gap0), rdot=(0, 0, -v0))
    b.add_force("contact", "floor", body_i="ground", body_j="ball",
                shape_i={"type": "plane", "normal": (0, 0, 1.0)},
                shape_j={"type": "sphere", "radius": R}, law="hertz", young_j=E, poisson_j=nu)
    model = b.compile()

    def turn(t, s):                     # the sphere stops: vertical velocity crosses zero
        return s.rdot[0, 2]
    turn.direction, turn.name = 1.0, "turn"

    def separation(t, s):
        return s.r[0, 2] - R
    separation.direction, separation.name = 1.0, "separation"
    t_touch = gap0 / v0
    rtol = 1e-11 if full else 1e-9
    res = simulate(model, t_touch + 1.5 * T, method="projection", rtol=rtol, atol=rtol * 1e-4,
                   output_step=T / 50, events=[turn, separation], event_tol=1e-15)
    if not res.success:
        raise RuntimeError(f"simulation failed: {res.message}")
    ev = {e["name"]: e for e in res.events}
    t_sep = ev["separation"]["t"]
    names = [e["name"] for e in res.events]
    z_turn = res.event_states[names.index("turn")][0][0, 2]     # located, not sampled
    tol = integration_bound(res, 1.0)               # relative: N (rtol + atol / scale)
    basis = bound_basis(res, 1.0, "(relative)")
    compare_value(case, "maximum indentation d_max", R - z_turn, dmax, tol * dmax, basis, "m")
    compare_value(case, "peak force K d_max^(3/2)", K * (R - z_turn) ** 1.5, K * dmax ** 1.5,
                  1.5 * tol * K * dmax ** 1.5, basis + " (x 3/2: F ~ d^(3/2))", "N")
    compare_value(case, "contact duration", t_sep - t_touch, T, tol * T + 2e-15, basis, "s")
    compare_value(case, "rebound speed (elastic: v0)", res.v[-1, 0, 2], v0, tol * v0, basis,
                  "m/s")
    case.notes.append(f"K = {K:.6g} N/m^1.5, {res.counters['steps']} steps")
    return case


def case_cam_follower(full: bool) -> CaseResult:
    """A disc cam turning at 20 rad/s with a spring-loaded translating follower (the
    point_on_cam sliding joint): the follower height against the profile, and the normal force
    on the follower against Newton's law for it."""
    from scipy.interpolate import CubicSpline
    from ...constraints.point_curve import normal_force
    ref = references()["cam_follower"]
    case = CaseResult("Cam and translating follower", "point_on_cam joint, 20 rad/s: follower "
                      "height and normal force", f"{ref['source']}; {ref['how']}; "
                      f"{ref['precision']}")
    w, m, k, preload = 20.0, 0.5, 500.0, 10.0
    model = models.cam_follower(speed=w, preload=preload, stiffness=k,
                                follower_mass=m).compile()
    res = _sim(model, 2 * np.pi / w if full else np.pi / w, full, 1e-8, 1e-10,
               method="projection", output_step=np.pi / w / 60)
    radii = models.cam_profile()
    theta = 2 * np.pi * np.arange(len(radii) + 1) / len(radii)
    r = CubicSpline(theta, radii + radii[:1], bc_type="periodic")
    th = (np.pi / 2 - w * res.t) % (2 * np.pi)
    tol = integration_bound(res, 0.07)
    compare_history(case, "follower height y = r(pi/2 - w t)", res.q[:, 1, 1], r(th), tol,
                    bound_basis(res, 0.07, "m"), "m", t=res.t)
    R, R1, R2 = r(th), r(th, 1), r(th, 2)
    spring = k * (0.2 - R - (0.2 - r(np.pi / 2) + preload / k))
    tx, ty = R1 * np.cos(th) - R * np.sin(th), R1 * np.sin(th) + R * np.cos(th)
    nx, ny = ty, -tx
    phi = w * res.t
    n_y = (np.sin(phi) * nx + np.cos(phi) * ny) / np.hypot(nx, ny)
    N_ref = (m * w * w * R2 - spring) / n_y
    scale = float(np.abs(N_ref).max())
    compare_history(case, "normal force (m y'' - F_spring) / n_y", normal_force(res, "contact"),
                    N_ref, integration_bound(res, scale) * w * w,
                    bound_basis(res, scale, "N") + " x w^2 (an acceleration)", "N", t=res.t)
    return case
