"""Coordinate projection (beyond the text, as its own remarks call for): the standard method
for the accelerations, and after every accepted step the positions and velocities are projected
back onto Phi = 0 and D v = nu with the corrections of chapter 14 (14.12, 14.19), by default in
the metric of the mass matrix (dx = -M^-1 D^T (D M^-1 D^T)^-1 Phi; metric="euclidean" for the
text's -D^T (D D^T)^-1 Phi): the corrections then return exactly the constraint impulse a
regularised solve withheld at a singular position (docs/choosing.md). No gains to choose --
the text notes there is no reliable rule for Baumgarte's.

The projection runs compiled (:func:`project`) on the same sparse Cholesky machinery as
the multipliers; if that matrix is singular at some instant the least-squares (Euclidean)
corrections of :mod:`.correction` are used for that instant.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import ConvergenceError
from . import sparse as spc
from .base import check_positive, register
from .correction import _correct_positions_lstsq, _correct_velocities_lstsq
from .projection_kernels import project
from .standard import Standard


#: the metrics of the corrections: "mass" (dx = -M^-1 D^T (D M^-1 D^T)^-1 Phi), "euclidean" (the
#: text's dx = -D^T (D D^T)^-1 Phi, 14.12 and 14.19) or "auto" (the default): the mass metric
#: under the one-step integrators, the Euclidean one under the multistep ones (bdf4, abm4), whose
#: histories carried a larger error with the mass metric (Andrews squeezer, rtol 1e-8: bdf4
#: 5.0e-6 against 2.0e-6 rad, abm4 2.2e-6 against 1.0e-7 rad; docs/choosing.md)
METRICS = ("auto", "mass", "euclidean")


@register
class Projection(Standard):
    name = "projection"
    projects = True
    follows_drift = False         # it returns to Phi = 0 after every step

    #: the wide window (docs/choosing.md): the projection returns the withheld impulse
    regularisation = (spc.SINGULAR_PIVOT, spc.TIKHONOV_SHIFT)

    def __init__(self, tolerance: float = 1e-10, max_iterations: int = 10, solver: str = "schur",
                 metric: str = "auto"):
        super().__init__(solver)
        if metric not in METRICS:
            raise ValueError(f"projection method: unknown metric {metric!r}; valid: {METRICS}")
        self.metric = metric
        self.tolerance = check_positive("projection tolerance", tolerance)
        self.max_iterations = int(check_positive("projection max_iterations", max_iterations))

    def tolerance_for(self, integrator, q, fraction: float = 1.0) -> float:
        """The tolerance on max |Phi| of a run with ``integrator``: the method's, but never
        coarser than ``fraction`` of the integrator's absolute tolerance (a multistep
        integrator's history asks for 1e-3 of it; down to a round-off floor of the
        positions' size, 64 eps max(1, |r|)). The projection must not leave more error than the
        step control allows: near a singular position a residual eps of Phi hides a position
        error of eps / sigma along the near-dependent direction (sigma the small singular value
        of D), which the accelerations then amplify -- a loose projection at a tight rtol made
        the steps crawl there (docs/choosing.md)."""
        atol = getattr(integrator, "atol", None)
        if atol is None:
            return self.tolerance
        q = np.asarray(q, dtype=float).reshape(-1, 7)
        floor = 64.0 * np.finfo(float).eps * max(1.0, float(np.abs(q[:, :3]).max(initial=0.0)))
        return min(self.tolerance, max(fraction * float(np.min(atol)), floor))

    def mass_metric(self, multistep: bool = False) -> bool:
        """Whether the corrections are in the mass metric (for a multistep integrator's run
        when ``multistep``)."""
        return self.metric == "mass" or (self.metric == "auto" and not multistep)

    def project_y(self, system, t, y, tolerance: Optional[float] = None,
                  multistep: bool = False) -> np.ndarray:
        """y (a copy) with q and v projected; raises ConvergenceError if Newton fails.
        tolerance: on max |Phi| (m), this call only (default: the method's); multistep: the
        run's integrator is a multistep one (the metric "auto" is then Euclidean)."""
        y = y.copy()
        tol = self.tolerance if tolerance is None else float(tolerance)
        if system.table.has_drivers:
            system.table.set_time(t)
        it = -1
        if not system.python_groups:
            it = project(t, y, system.F, system.I, system.W, tol,
                         self.max_iterations, np.zeros(6 * system.nb),
                         self.mass_metric(multistep))
        if it == -1 or it == -2:
            # D D^T singular here, or Newton on it stalled (D nearly rank deficient: a singular
            # position, where the iteration converges only linearly): least squares (SVD),
            # which ignores the dependent directions
            nb = system.nb
            try:
                q, v = self._project_lstsq(system.model, t, y[:7 * nb], y[7 * nb:13 * nb],
                                           tol)
            except ConvergenceError:
                q = y[:7 * nb].reshape(nb, 7)
                phi = system.model.assembler.evaluate(q, None, t).phi
                err = ConvergenceError(
                    f"t = {t:.6g} s: projection onto the constraints did not converge in "
                    f"{self.max_iterations} iterations (max |Phi| = {np.abs(phi).max():.3g}), "
                    "nor by least squares; raise method option max_iterations or tolerance "
                    f"(now {self.max_iterations}, {tol:.3g})")
                err.t = t
                raise err from None
            y[:7 * nb], y[7 * nb:13 * nb] = q.ravel(), v
        return y

    def _project_lstsq(self, model, t, q, v, tol=None):
        q = np.asarray(q, dtype=float).reshape(model.nb, 7)
        q, _, _, _ = _correct_positions_lstsq(model, q, t,
                                              self.tolerance if tol is None else tol,
                                              self.max_iterations, None, None)
        v, _, _ = _correct_velocities_lstsq(model, q, np.asarray(v, dtype=float), t, None,
                                            None)
        return q, v

    def project(self, eom, t, q, v):
        """(q, v) projected onto the position and velocity constraint manifolds."""
        nb = eom.nb
        y = np.concatenate([np.asarray(q, dtype=float).ravel(),
                            np.asarray(v, dtype=float).ravel()])
        y = self.project_y(eom.system, t, y)
        return y[:7 * nb].reshape(nb, 7), y[7 * nb:13 * nb]

    def parameters(self):
        return {"tolerance": self.tolerance, "max_iterations": self.max_iterations,
                "solver": self.solver, "metric": self.metric}
