"""What the validation cases share: the run (with the method chosen for the whole suite), the
energy, momentum and constraint checks, the tolerance scales of the comparisons."""
from __future__ import annotations

import math
import warnings

import numpy as np

from ...rotations import A_from_p
from ...simulate import RedundantConstraintsWarning, simulate
from ..core import bound_basis, compare_history, integration_bound
from ..exact import PhysicalPendulum
from ..exact import AxialMotion, DistancePendulum


#: run_validation(method=...): the method every case runs with where the model and the case's
#: integrator allow it (else the case's own); the methods that ran, per case
METHOD = None
METHODS_USED: list = []


def _sim(model, t_end, full, rtol_short, rtol_full, **kw):
    rtol = rtol_full if full else rtol_short
    kw.setdefault("atol", rtol * 1e-2)
    if METHOD is not None and _applies(METHOD, model, kw):
        kw["method"] = METHOD
        kw.pop("method_options", None)
    res = simulate(model, t_end, rtol=rtol, **kw)
    METHODS_USED.append(res.settings["method"])
    if not res.success:
        raise RuntimeError(f"simulation failed: {res.message}")
    return res


def _applies(method, model, kw) -> bool:
    """Whether ``method`` can run this case: "recursive" needs a tree it can write in joint
    coordinates and the rk45 integrator; the body-coordinate methods run every model."""
    if method != "recursive":
        return True
    from ...dynamics.recursive import JointTree
    from ...errors import ModelError
    if kw.get("integrator", "rk45") != "rk45" or kw.get("events"):
        return False
    try:
        JointTree(model, model.q0, model.v0)
    except ModelError:
        return False
    return True


def _angular_momentum(res, point=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Total angular momentum about a fixed point, global axes, (nt, 3)."""
    model = res.model
    A = A_from_p(res.q[:, :, 3:])
    J = A @ model.inertia[None] @ np.swapaxes(A, 2, 3)
    w = res.v[:, :, 3:]
    r = res.q[:, :, :3] - np.asarray(point)
    H = np.einsum("tnij,tnj->tni", J, w) + model.mass[None, :, None] * np.cross(r, res.v[:, :, :3])
    return H.sum(axis=1)


def _energy_checks(case, res, what="energy balance (T + V - W_nc)(t) - (T + V)(0)"):
    """Energy balance within the integration bound. Its scale s is the first-order size of the
    energy error a relative state error rtol causes: T and the elastic energy are quadratic in
    the state (dT = 2 T dv/v), the gravitational energy and the work integral linear, so
    s = 2 max T + max |V_g| + 2 max V_e + max |W_nc|."""
    en = res.energy()
    scale = float(2 * np.abs(en["kinetic"]).max() + np.abs(en["gravitational"]).max()
                  + 2 * np.abs(en["elastic"]).max() + np.abs(en["work_nonconservative"]).max())
    return compare_history(case, what, en["error"], np.zeros_like(en["error"]),
                           integration_bound(res, scale), bound_basis(res, scale, "J"), "J",
                           t=res.t)


def _violation_check(case, res, scale=1.0):
    viol = res.constraint_violation()["position"]
    return compare_history(case, "constraint violation |Phi|", viol, np.zeros_like(viol),
                           integration_bound(res, scale), bound_basis(res, scale, "m"), "m",
                           t=res.t)


# ------------------------------------------------------------------------------ ADAMS
#: Natural size of each ADAMS quantity (for the integration bound of the exact comparison).
def _adams_scales(pend: PhysicalPendulum) -> dict:
    w0, d, m, g = pend.omega0, pend.d, pend.m, np.linalg.norm(pend.g)
    wmax = 2 * w0 * np.sin(pend.theta0 / 2)
    return dict(Pos=d, Vel=wmax * d, Acc=(w0**2 + wmax**2) * d, Quat=1.0, Avel=wmax,
                Aacc=w0**2, Rforce=m * (g + (w0**2 + wmax**2) * d), Rtorque=m * g * d)


def _axial_scales(ax: AxialMotion, t) -> dict:
    """Natural sizes for a body guided along a line: the largest distance from the joint point
    l, speed, acceleration and rotation rates of the exact motion, with the pendulum rate
    w0 = sqrt(|g| / d0) (d0 = |r0 - P|) as the floor of the rates where the body does not
    turn; forces m (|g| + |a|max), moments l times that."""
    ex = ax.motion(t)
    g = float(np.linalg.norm(ax.g))
    d0 = float(np.linalg.norm(ax.r0 - ax.P))
    w0 = np.sqrt(g / d0)
    ell = max(d0, float(np.linalg.norm(ex.r - ax.P, axis=1).max()))
    amax = float(np.linalg.norm(ex.rddot, axis=1).max())
    force = ax.m * (g + amax)
    return dict(Pos=ell, Vel=max(float(np.linalg.norm(ex.rdot, axis=1).max()), w0 * d0),
                Acc=g + amax, Quat=1.0,
                Avel=max(float(np.linalg.norm(ex.omega, axis=1).max()), w0),
                Aacc=max(float(np.linalg.norm(ex.omegadot, axis=1).max()), w0 ** 2),
                Rforce=force, Rtorque=ell * force)


def _exact_scales(exact, t) -> dict:
    if isinstance(exact, AxialMotion):
        return _axial_scales(exact, t)
    if isinstance(exact, DistancePendulum):
        return _adams_scales(exact.pendulum)
    return _adams_scales(exact)


def _compare_rms(case, quantity, ours, ref, tolerance, basis, unit, cols, t):
    """Chrono's metric (ChValidation::Test, NormType::RMS): the RMS over all rows of each
    column of ours - reference; the check reports the worst column."""
    diff = np.asarray(ours, float) - np.asarray(ref, float)
    rms = np.sqrt(np.mean(diff ** 2, axis=0)) if np.all(np.isfinite(diff)) else np.full(
        diff.shape[1], np.inf)
    k = int(np.argmax(rms))
    row = int(np.argmax(np.abs(diff[:, k]))) if np.isfinite(rms[k]) else 0
    return case.add(quantity, float(ref[row, k]), float(ours[row, k]), float(rms[k]),
                    float(tolerance), basis,
                    f"RMS over {len(diff)} instants of the worst column {cols[k]}; its largest "
                    f"difference {abs(diff[row, k]):.2g} at t = {t[row]:.3g} s", unit)


def _rate(t, w_local) -> float:
    """Mean rotation rate of the (w1, w2) component of the body angular velocity."""
    ang = np.unwrap(np.arctan2(w_local[:, 1], w_local[:, 0]))
    return float((ang[-1] - ang[0]) / (t[-1] - t[0]))


def _exudyn_check(case, model, exu, label="", **settings):
    """The centres of mass at exu["t_s"] against Exudyn's (references.EXUDYN_HOW): within our
    integration bound + Exudyn's step error (a third of its two steps' difference) + its
    Newton tolerance (1e-8 of the positions' size). Returns our run."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        res = _sim(model, exu["t_s"], False, settings.pop("rtol"), 0.0, method="projection",
                   output_step=exu["t_s"], **settings)
    com = np.asarray(exu["com"])
    scale = max(float(np.abs(com).max()), 1.0)
    diff = np.abs(res.q[-1, :, :3] - com)
    k = np.unravel_index(int(np.argmax(diff)), diff.shape)
    case.add(f"{label}centres of mass at {exu['t_s']:g} s against Exudyn (an independent code)",
             float(com[k]), float(res.q[-1, :, :3][k]), float(diff.max()),
             integration_bound(res, scale) + exu["step_difference"] / 3 + 1e-8 * scale,
             bound_basis(res, scale, "m") + " + Exudyn's step error (step_difference / 3, "
             f"steps {exu['steps'][0]:g} and {exu['steps'][1]:g} s) + its Newton tolerance",
             f"worst of the bodies' coordinates: {model.body_names[k[0]]} {'xyz'[k[1]]}", "m")
    return res


def _paired_error(ours, ref) -> float:
    """Largest distance between each reference eigenvalue and the nearest of ours (each of
    ours used once)."""
    left, worst = list(ours), 0.0
    for r in ref:
        k = int(np.argmin([abs(o - r) for o in left]))
        worst = max(worst, abs(left.pop(k) - r))
    return worst


def _half_digit(value: float, sig: int) -> float:
    """Half a unit in the last of ``sig`` significant digits of ``value`` (0: exact)."""
    if sig == 0 or value == 0:
        return 0.0
    return 0.5 * 10.0 ** (math.floor(math.log10(abs(value))) - sig + 1)
