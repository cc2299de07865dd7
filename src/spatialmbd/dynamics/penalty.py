"""Penalty method, Eqs. (12.9)-(12.15):

    (M + alpha D^T D) vdot = g - alpha D^T (-gamma + 2 mu omega Phidot + omega^2 Phi)   (12.14)

The constraint forces are D^T lam with lam = -alpha (D vdot - gamma + 2 mu omega Phidot +
omega^2 Phi) (the convention of eom.py). Redundant constraints need no special treatment: the
leading matrix stays positive definite. Defaults alpha = 1e7, omega = 10, mu = 1 (text).

M + alpha D^T D has the block pattern of the bodies connected by joints; it is assembled into
that fixed pattern and factorised by a sparse Cholesky (compiled: :func:`.system.solve_penalty`).
"""
from __future__ import annotations

import numpy as np

from ..errors import SingularMatrixError
from . import system as cs
from .base import Method, MethodOutput, check_positive, register
from .standard import _y_of


class _PenaltyBase(Method):
    #: augmented Lagrangian iterations (12.17) instead of one penalty solve (False here)
    iterate = False

    def __init__(self, alpha: float = 1e7, omega: float = 10.0, mu: float = 1.0):
        self.alpha = check_positive(f"{self.name} alpha", alpha)
        self.omega = check_positive(f"{self.name} omega", omega, allow_zero=True)
        self.mu = check_positive(f"{self.name} mu", mu, allow_zero=True)

    def _singular(self, t):
        err = SingularMatrixError(f"t = {t:.6g} s: M + alpha D^T D is not positive definite "
                                  "(a body has a singular mass matrix?)")
        err.t = t
        return err

    def params(self) -> np.ndarray:
        """mp of the compiled solve (:data:`.system.MP_PENALTY`)."""
        return np.array([1.0, self.alpha, self.omega, self.mu, float(self.iterate),
                         getattr(self, "tolerance", 0.0), getattr(self, "max_iterations", 1),
                         getattr(self, "floor", 0.0)])

    def kernels(self, system, W=None):
        KI, KW = system.penalty_pack()
        self._mp = self.params()
        return (cs.rhs_penalty, cs.after_state_penalty,
                (system.F, system.I, system.W if W is None else W, KI, KW, self._mp))

    def stages(self, system):
        """The compiled ``ODEProblem.stages`` hook (see Standard.stages)."""
        if not system.fused or system.table.has_drivers:
            return None
        KI, KW = system.penalty_pack()
        F, I, W, mp = system.F, system.I, system.W, self._mp
        kernel = cs.stages_penalty
        count = np.zeros(1, dtype=np.int64)
        method = self

        def stages(t, y, h, A, C, K, s0, s1, out, t_last):
            done = kernel(t, y, h, A, C, K, s0, s1, out, t_last, F, I, W, KI, KW, mp, count)
            if method.iterate:
                method.total_iterations += int(count[0])
                count[0] = 0
            return done
        return stages

    def status(self, code, system, t, y, ydot, W=None):
        if code == cs.SINGULAR:
            raise self._singular(t)
        if code == cs.NOT_CONVERGED:
            raise self._not_converged(t)
        return code

    def accelerations(self, ev, t):
        sys_ = ev.system
        mp = self.__dict__.get("_mp")
        if mp is None:
            mp = self._mp = self.params()
        KI, KW = sys_.penalty_pack()
        y = _y_of(ev)
        code = cs.after_state_penalty(y, np.empty(y.size), sys_.F, sys_.I, ev.W, KI, KW, mp)
        if code < 0:
            self.status(code, sys_, t, y, None, ev.W)
        it = max(code, 0)
        if self.iterate:
            self.total_iterations += it
        return MethodOutput(sys_.fields(ev.W, "vdot").copy(), sys_.fields(ev.W, "lam").copy(),
                            it)

    def parameters(self):
        return {"alpha": self.alpha, "omega": self.omega, "mu": self.mu}


@register
class Penalty(_PenaltyBase):
    name = "penalty"
