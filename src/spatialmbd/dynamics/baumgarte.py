"""Baumgarte stabilisation, Eqs. (12.7)-(12.8): the acceleration constraints are replaced by
Phi'' + 2 alpha Phi' + beta^2 Phi = 0, i.e. gamma -> gamma - 2 alpha Phidot - beta^2 Phi,
with Phidot = D v - nu. (alpha here is not the penalty factor of (12.14); ERRATA.) The formula
is evaluated in the compiled solve (:func:`.system.baumgarte_rhs`).
"""
from __future__ import annotations

from .base import check_positive, register
from .standard import Standard


@register
class Baumgarte(Standard):
    name = "baumgarte"

    def __init__(self, alpha: float = 5.0, beta: float = 5.0, solver: str = "schur",
                 singular: str = "stop"):
        super().__init__(solver, singular)
        self.alpha = check_positive("baumgarte alpha", alpha, allow_zero=True)
        self.beta = check_positive("baumgarte beta", beta, allow_zero=True)

    mode = 1          # the compiled right-hand side uses gamma - 2 alpha Phidot - beta^2 Phi

    def gains(self):
        return self.alpha, self.beta

    def parameters(self):
        return {"alpha": self.alpha, "beta": self.beta, "solver": self.solver,
                "singular": self.singular}
