"""Coordinate projection (beyond the text, as its own remarks call for): the standard method
for the accelerations, and after every accepted step the positions and velocities are projected
back onto Phi = 0 and D v = nu with the corrections of chapter 14 (14.12, 14.19), by default in
the metric of the mass matrix (dx = -M^-1 D^T (D M^-1 D^T)^-1 Phi; metric="euclidean" for the
text's -D^T (D D^T)^-1 Phi): the corrections then return exactly the constraint impulse a
regularised solve withheld at a singular position (docs/choosing.md). No gains to choose --
the text notes there is no reliable rule for Baumgarte's.

The projection runs compiled (:mod:`.step_projection`) on the same sparse Cholesky machinery as
the multipliers; if that matrix is singular at some instant the least-squares (Euclidean)
corrections of :mod:`.correction` are used for that instant.
"""
from __future__ import annotations

from . import sparse as spc
from .base import check_positive, register
from .standard import Standard
from .step_projection import ProjectsState


#: the metrics of the corrections: "mass" (dx = -M^-1 D^T (D M^-1 D^T)^-1 Phi), "euclidean" (the
#: text's dx = -D^T (D D^T)^-1 Phi, 14.12 and 14.19) or "auto" (the default): the mass metric
#: under the one-step integrators, the Euclidean one under the multistep ones (bdf4, abm4), whose
#: histories carried a larger error with the mass metric (Andrews squeezer, rtol 1e-8: bdf4
#: 5.0e-6 against 2.0e-6 rad, abm4 2.2e-6 against 1.0e-7 rad; docs/choosing.md)
METRICS = ("auto", "mass", "euclidean")


@register
class Projection(ProjectsState, Standard):
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

    def _projection_settings(self):
        return self.tolerance, self.max_iterations

    def parameters(self):
        return {"tolerance": self.tolerance, "max_iterations": self.max_iterations,
                "solver": self.solver, "metric": self.metric}
