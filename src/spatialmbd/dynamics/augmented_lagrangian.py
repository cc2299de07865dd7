"""Augmented Lagrangian formulation, Eqs. (12.16)-(12.18):

    M vdot_0 = g                                                                  (12.16)
    (M + alpha D^T D) vdot_{i+1} = M vdot_i - alpha D^T (-gamma + 2 mu omega Phidot
                                                         + omega^2 Phi)           (12.17)
    until ||vdot_{i+1} - vdot_i|| <= tolerance                                    (12.18, ERRATA)

The tolerance is relative to max(1, |vdot|_inf). The right-hand side of (12.17) subtracts terms
of size alpha |D^T (...)|, so round-off puts a floor of about alpha |D^T c| eps under the
attainable change (1e-9 to 1e-8 relative with alpha = 1e7). The iteration is also taken as
converged when it has reached that floor: the change is below ``floor`` (1e-6 relative) and no
longer contracts (it exceeds half the previous change).

Read with the multiplier update lam_{i+1} = lam_i - alpha (D vdot_{i+1} - gamma + 2 mu omega
Phidot + omega^2 Phi) (Jalon and Bayo 1994), (12.17) is M vdot_{i+1} = g + D^T lam_{i+1}
-- the iteration converges to the standard multipliers, while each solve stays positive
definite (redundant constraints and singular positions are handled). One factorisation of the
leading matrix serves every iteration of an instant.
"""
from __future__ import annotations

import numpy as np

from ..errors import ConvergenceError
from .base import MethodOutput, check_positive, register
from .penalty import _PenaltyBase


@register
class AugmentedLagrangian(_PenaltyBase):
    name = "augmented_lagrangian"

    def __init__(self, alpha: float = 1e7, omega: float = 10.0, mu: float = 1.0,
                 tolerance: float = 1e-8, max_iterations: int = 50, floor: float = 1e-6):
        super().__init__(alpha, omega, mu)
        self.tolerance = check_positive("augmented_lagrangian tolerance", tolerance)
        self.max_iterations = int(check_positive("augmented_lagrangian max_iterations",
                                                 max_iterations))
        self.floor = check_positive("augmented_lagrangian floor", floor)
        self.total_iterations = 0

    def accelerations(self, ev, t):
        solve, c_term = self._factor(ev, t)
        vdot = ev.M.solve(ev.g)                                                  # Eq. (12.16)
        DT_c = ev.cv.D.T @ c_term
        lam = np.zeros(ev.cv.phi.size)
        previous = np.inf
        for it in range(1, self.max_iterations + 1):
            new = solve(ev.M.dot(vdot) - self.alpha * DT_c)                      # Eq. (12.17)
            lam = lam + self._lam(ev, new, c_term)
            change = float(np.linalg.norm(new - vdot))
            vdot = new
            scale = max(1.0, float(np.abs(vdot).max()))
            at_floor = change <= self.floor * scale and change > 0.5 * previous
            if change <= self.tolerance * scale or at_floor:                     # Eq. (12.18)
                self.total_iterations += it
                return MethodOutput(vdot, lam, it)
            previous = change
        err = ConvergenceError(f"t = {t:.6g} s: augmented Lagrangian iterations did not converge "
                               f"in {self.max_iterations} (last change {change:.3g}); raise "
                               "alpha or max_iterations, or loosen the tolerance")
        err.t = t
        raise err

    def parameters(self):
        out = super().parameters()
        out.update(tolerance=self.tolerance, max_iterations=self.max_iterations, floor=self.floor)
        return out
