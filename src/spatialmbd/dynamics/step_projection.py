"""The projection after every accepted step onto Phi = 0 and D v = nu (Eqs. 14.12, 14.19), in
the metric of the mass matrix or the text's Euclidean one: the step of the projection method
(:mod:`.projection`) and of the penalty methods with option ``project`` (:mod:`.penalty`).
Compiled (:func:`.projection_kernels.project`), with least squares (:mod:`.correction`) where
D D^T is singular at an instant."""
from __future__ import annotations

import abc
from typing import Optional

import numpy as np

from ..errors import ConvergenceError
from .correction import _correct_positions_lstsq, _correct_velocities_lstsq
from .projection_kernels import project


class ProjectsState:
    """The projection after every accepted step (the run calls :meth:`project_y`), shared by
    the projection method and by the penalty methods with option ``project`` (their
    formulation with projections). A class using it gives :meth:`_projection_settings` and
    ``metric``."""
    metric = "auto"

    @abc.abstractmethod
    def _projection_settings(self):
        """(tolerance on max |Phi| in m, Newton iterations) of the projection."""

    def _projection_advice(self, iterations, tol) -> str:
        """What to do when the projection does not converge (the end of the error message)."""
        return ("raise method option max_iterations or tolerance "
                f"(now {iterations}, {tol:.3g})")

    def tolerance_for(self, integrator, q, fraction: float = 1.0) -> float:
        """The tolerance on max |Phi| of a run with ``integrator``: the method's, but never
        coarser than ``fraction`` of the integrator's absolute tolerance (a multistep
        integrator's history asks for 1e-3 of it; down to a round-off floor of the
        positions' size, 64 eps max(1, |r|)). The projection must not leave more error than the
        step control allows: near a singular position a residual eps of Phi hides a position
        error of eps / sigma along the near-dependent direction (sigma the small singular value
        of D), which the accelerations then amplify -- a loose projection at a tight rtol made
        the steps crawl there (docs/choosing.md)."""
        tolerance = self._projection_settings()[0]
        atol = getattr(integrator, "atol", None)
        if atol is None:
            return tolerance
        q = np.asarray(q, dtype=float).reshape(-1, 7)
        floor = 64.0 * np.finfo(float).eps * max(1.0, float(np.abs(q[:, :3]).max(initial=0.0)))
        return min(tolerance, max(fraction * float(np.min(atol)), floor))

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
        tol0, iterations = self._projection_settings()
        tol = tol0 if tolerance is None else float(tolerance)
        if system.table.has_drivers:
            system.table.set_time(t)
        it = -1
        if not system.python_groups:
            it = project(t, y, system.F, system.I, system.W, tol, iterations,
                         np.zeros(6 * system.nb), self.mass_metric(multistep))
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
                    f"{iterations} iterations (max |Phi| = {np.abs(phi).max():.3g}), "
                    f"nor by least squares; {self._projection_advice(iterations, tol)}")
                err.t = t
                raise err from None
            y[:7 * nb], y[7 * nb:13 * nb] = q.ravel(), v
        return y

    def _project_lstsq(self, model, t, q, v, tol=None):
        tol0, iterations = self._projection_settings()
        q = np.asarray(q, dtype=float).reshape(model.nb, 7)
        q, _, _, _ = _correct_positions_lstsq(model, q, t, tol0 if tol is None else tol,
                                              iterations, None, None)
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
