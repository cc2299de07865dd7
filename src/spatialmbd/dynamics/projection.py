"""Coordinate projection (beyond the text, as its own remarks call for): the standard method
for the accelerations, and after every accepted step the positions and velocities are projected
back onto Phi = 0 and D v = nu with the corrections of chapter 14 (14.12, 14.19). No gains to
choose -- the text notes there is no reliable rule for Baumgarte's.
"""
from __future__ import annotations

import numpy as np

from .base import check_positive, register
from .correction import correct_positions, correct_velocities
from .standard import Standard


@register
class Projection(Standard):
    name = "projection"
    projects = True

    def __init__(self, tolerance: float = 1e-10, max_iterations: int = 10, solver: str = "schur"):
        super().__init__(solver)
        self.tolerance = check_positive("projection tolerance", tolerance)
        self.max_iterations = int(check_positive("projection max_iterations", max_iterations))

    def project(self, eom, t, q, v):
        """(q, v) projected onto the position and velocity constraint manifolds."""
        q, _, _, _ = correct_positions(eom.model, q, t, self.tolerance, self.max_iterations,
                                       assembler=eom.assembler)
        v, _, _ = correct_velocities(eom.model, q, v, t, assembler=eom.assembler)
        return q, v

    def parameters(self):
        return {"tolerance": self.tolerance, "max_iterations": self.max_iterations,
                "solver": self.solver}
