"""Correction of positions and velocities onto the constraint manifold (text ch. 14).

Positions (14.3)-(14.12): Newton-Raphson with the Moore-Penrose inverse,
    dx = -D^T (D D^T)^-1 Phi(q)                                                 (14.12)
where dx = [dr, dpi] lives in the 6-per-body velocity space (ERRATA for (14.6)); the rotation
part is applied exactly to the Euler parameters (p <- quat(dpi) (x) p), keeping them unit length.
Velocities (14.13)-(14.19): v_c = v_0 - D^T (D D^T)^-1 (D v_0 - nu)              (14.19)
(ERRATA: (14.16) has the sign of delta Phidot wrong; (14.18) is right.)

Coordinates listed in ``hold`` (a boolean mask over the 6 nb velocity-space coordinates) are not
changed; the correction is then the minimum-norm one over the free coordinates.
Rank-deficient D (redundant constraints) is handled by the least-squares pseudo-inverse.
At a start where D has dependent rows the velocities are also made consistent at second order
(:mod:`.flex_correction`: a first-order flex that no motion has is removed, in the metric of
the mass matrix), so that every method starts from the same state.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..errors import ConvergenceError
from ..kinematics import describe_residual, minimum_norm_solve, newton_positions
from .flex_correction import remove_flex
from .projection_kernels import project_positions, project_velocities


@dataclass
class CorrectionReport:
    """What the correction changed: per body the position shift (m), rotation (rad), and the
    velocity change; residuals before and after."""

    dr: np.ndarray           # (nb, 3)
    dtheta: np.ndarray       # (nb, 3) accumulated small rotations (global rotation vector)
    dv: np.ndarray           # (nb, 6)
    phi_before: float
    phi_after: float
    phidot_before: float
    phidot_after: float
    iterations: int
    #: max |w^T gamma| over the self-stresses w before and after the second-order correction
    #: (:mod:`.flex_correction`; 0 when D has no dependent rows at the start)
    flex_before: float = 0.0
    flex_after: float = 0.0

    @property
    def max_position_change(self) -> float:
        return float(np.abs(self.dr).max()) if self.dr.size else 0.0

    @property
    def max_rotation_change(self) -> float:
        return float(np.linalg.norm(self.dtheta, axis=1).max()) if self.dtheta.size else 0.0

    @property
    def max_velocity_change(self) -> float:
        return float(np.abs(self.dv).max()) if self.dv.size else 0.0

    def summary(self) -> str:
        return (f"initial conditions corrected in {self.iterations} Newton iteration(s): "
                f"max |Phi| {self.phi_before:.3g} -> {self.phi_after:.3g}, max |D v - nu| "
                f"{self.phidot_before:.3g} -> {self.phidot_after:.3g}; largest changes: "
                f"position {self.max_position_change:.3g} m, rotation "
                f"{self.max_rotation_change:.3g} rad, velocity {self.max_velocity_change:.3g}"
                + (f"; a first-order flex of the singular start removed (max |w^T gamma| "
                   f"{self.flex_before:.3g} -> {self.flex_after:.3g})"
                   if self.flex_before > 0.0 else ""))


def _system(model, system):
    if system is None:
        from .system import System
        system = System.for_model(model)
    return system


def _free(hold) -> bool:
    return hold is None or not np.any(hold)


def correct_positions(model, q, t=0.0, tol=1e-12, max_iter=30, hold=None, assembler=None,
                      system=None):
    """Positions satisfying Phi(q, t) = 0 by (14.12); returns (q, dx_total, iterations, phi0).

    Without ``hold`` the compiled Newton iteration of :func:`.projection_kernels.project_positions` runs
    (on ``system``, default a new one for the model); with held coordinates, or when D D^T is
    singular (redundant constraints), the iteration below with the least-squares
    pseudo-inverse."""
    q = np.array(q, dtype=float).reshape(model.nb, 7)
    sys_ = _system(model, system) if _free(hold) and model.n_eq else None
    if sys_ is not None and not sys_.python_groups:
        if sys_.table.has_drivers:
            sys_.table.set_time(t)
        y = np.concatenate([q.ravel(), np.zeros(6 * model.nb)])
        total = np.zeros(6 * model.nb)
        # every argument typed as the projection method's call types it (one compiled
        # specialization: a default left out is a type of its own)
        it, phi0, err = project_positions(float(t), y, sys_.F, sys_.I, sys_.W, float(tol),
                                          int(max_iter), total, False)
        if it >= 0:
            return y[:7 * model.nb].reshape(model.nb, 7), total, it, phi0
        if it == -2:
            qf = y[:7 * model.nb].reshape(model.nb, 7)
            raise _not_converged(model, qf, t, max_iter, err,
                                 (assembler or model.assembler).evaluate(qf, None, t).phi)
    return _correct_positions_lstsq(model, q, t, tol, max_iter, hold, assembler)


def _not_converged(model, q, t, max_iter, err, phi):
    return ConvergenceError(
        f"t = {t:.6g} s: position correction did not converge in {max_iter} iterations "
        f"(max |Phi| = {err:.3g}); largest residuals: {describe_residual(model, phi)}. The "
        "initial positions are too far from an assembled configuration, or the joints are "
        "inconsistent.")


def _correct_positions_lstsq(model, q, t, tol, max_iter, hold, assembler=None):
    """The minimum-norm Newton iteration (14.12) of :func:`..kinematics.newton_positions`."""
    q, total, info = newton_positions(model, q, t, tol, max_iter, solve=minimum_norm_solve,
                                      hold=hold, what="position correction")
    return q, total, info.iterations, info.residuals[0]


def correct_velocities(model, q, v, t=0.0, hold=None, assembler=None, system=None):
    """Velocities satisfying D v = nu by (14.19); returns (v, phidot_before, phidot_after).

    Compiled (:func:`.projection_kernels.project_velocities`) without ``hold``; least squares otherwise
    or when D D^T is singular."""
    v = np.array(v, dtype=float).reshape(-1)
    sys_ = _system(model, system) if _free(hold) and model.n_eq else None
    if sys_ is not None and not sys_.python_groups:
        if sys_.table.has_drivers:
            sys_.table.set_time(t)
        y = np.concatenate([np.asarray(q, dtype=float).ravel(), v])
        ok, before, after = project_velocities(float(t), y, sys_.F, sys_.I, sys_.W, False)
        if ok:
            return y[7 * model.nb:].copy(), before, after
    return _correct_velocities_lstsq(model, q, v, t, hold, assembler)


def _correct_velocities_lstsq(model, q, v, t, hold, assembler):
    asm = assembler or model.assembler
    cv = asm.evaluate(q, v, t)
    resid = cv.D @ v - cv.nu
    before = float(np.abs(resid).max()) if resid.size else 0.0
    v = v - minimum_norm_solve(cv.D, resid, hold)                                 # Eq. (14.19)
    resid = cv.D @ v - cv.nu
    after = float(np.abs(resid).max()) if resid.size else 0.0
    return v, before, after


def correct_initial_conditions(model, q, v, t=0.0, hold=None, tol=1e-12, max_iter=30,
                               system=None):
    """Both corrections of chapter 14; returns (q, v, CorrectionReport)."""
    nb = model.nb
    v0 = np.array(v, dtype=float).reshape(-1)
    qc, dx, iters, phi0 = correct_positions(model, q, t, tol, max_iter, hold, system=system)
    vc, pd0, pd1 = correct_velocities(model, qc, v0, t, hold, system=system)
    vc, flex0, flex1 = remove_flex(model, qc, vc, t, hold)
    if flex0 > 0.0:
        resid = model.assembler.evaluate(qc, vc, t)
        pd1 = float(np.abs(resid.D @ vc - resid.nu).max())
    phi1 = model.assembler.phi(qc, t)
    report = CorrectionReport(dr=dx.reshape(nb, 6)[:, :3], dtheta=dx.reshape(nb, 6)[:, 3:],
                              dv=(vc - v0).reshape(nb, 6), phi_before=phi0,
                              phi_after=float(np.abs(phi1).max()) if phi1.size else 0.0,
                              phidot_before=pd0, phidot_after=pd1, iterations=iters,
                              flex_before=flex0, flex_after=flex1)
    return qc, vc.reshape(nb, 6), report


HOLD_NAMES = ("x", "y", "z", "rx", "ry", "rz")


def hold_mask(model, hold) -> Optional[np.ndarray]:
    """A boolean mask (6 nb,) from {"body": ["x", "rz", ...]} or a list of "body.coord"."""
    if hold is None:
        return None
    from ..errors import ModelError
    mask = np.zeros(6 * model.nb, dtype=bool)
    items = hold.items() if isinstance(hold, dict) else []
    pairs = []
    for body, coords in items:
        pairs.extend((body, c) for c in ([coords] if isinstance(coords, str) else coords))
    if not isinstance(hold, dict):
        for entry in hold:
            body, _, coord = str(entry).rpartition(".")
            pairs.append((body, coord))
    for body, coord in pairs:
        k = model.body_index(body)
        if k == model.nb:
            raise ModelError("hold: the ground cannot be held (it never moves)")
        if coord not in HOLD_NAMES:
            raise ModelError(f"hold: coordinate {coord!r} of body {body!r} is not one of "
                             f"{HOLD_NAMES} (translations x, y, z; small rotations rx, ry, rz)")
        mask[6 * k + HOLD_NAMES.index(coord)] = True
    return mask
