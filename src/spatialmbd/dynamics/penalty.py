"""Penalty method, Eqs. (12.9)-(12.15):

    (M + alpha D^T D) vdot = g - alpha D^T (-gamma + 2 mu omega Phidot + omega^2 Phi)   (12.14)

The constraint forces are D^T lam with lam = -alpha (D vdot - gamma + 2 mu omega Phidot +
omega^2 Phi) (the convention of eom.py). Redundant constraints need no special treatment: the
leading matrix stays positive definite. Defaults alpha = 1e7, omega = 10, mu = 1 (text).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SingularMatrixError
from .base import Method, MethodOutput, check_positive, register


class _PenaltyBase(Method):
    def __init__(self, alpha: float = 1e7, omega: float = 10.0, mu: float = 1.0):
        self.alpha = check_positive(f"{self.name} alpha", alpha)
        self.omega = check_positive(f"{self.name} omega", omega, allow_zero=True)
        self.mu = check_positive(f"{self.name} mu", mu, allow_zero=True)

    def _factor(self, ev, t):
        """A solver for (M + alpha D^T D) x = b, and the penalty right-hand side."""
        D = ev.cv.D
        if sp.issparse(D):
            A = (ev.M.sparse() + self.alpha * (D.T @ D)).tocsc()
            try:
                lu = spla.splu(A)
            except RuntimeError:
                raise self._singular(t) from None
            solve = lu.solve
        else:
            A = ev.M.dense() + self.alpha * (D.T @ D)
            try:
                c = la.cho_factor(A, check_finite=False)
            except la.LinAlgError:
                raise self._singular(t) from None
            solve = lambda b: la.cho_solve(c, b, check_finite=False)  # noqa: E731
        # constraint dynamics term of (12.14): -gamma + 2 mu omega Phidot + omega^2 Phi
        c_term = -ev.cv.gamma + 2 * self.mu * self.omega * ev.phidot + self.omega**2 * ev.cv.phi
        return solve, c_term

    def _singular(self, t):
        err = SingularMatrixError(f"t = {t:.6g} s: M + alpha D^T D is not positive definite "
                                  "(a body has a singular mass matrix?)")
        err.t = t
        return err

    def _lam(self, ev, vdot, c_term):
        return -self.alpha * (ev.cv.D @ vdot + c_term)

    def parameters(self):
        return {"alpha": self.alpha, "omega": self.omega, "mu": self.mu}


@register
class Penalty(_PenaltyBase):
    name = "penalty"

    def accelerations(self, ev, t):
        solve, c_term = self._factor(ev, t)
        vdot = solve(ev.g - self.alpha * (ev.cv.D.T @ c_term))                 # Eq. (12.14)
        return MethodOutput(vdot, self._lam(ev, vdot, c_term))
