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
leading matrix serves every iteration of an instant (compiled: :func:`.system.solve_penalty`).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..errors import ConvergenceError
from . import system as cs
from .penalty import after_state_penalty
from .base import check_positive, register
from .penalty import _PenaltyBase

#: adaptation when (12.17) does not converge at an instant: (alpha factor, iterations factor),
#: tried in turn from the current values. A larger alpha contracts the iteration faster along
#: directions where D is nearly singular (near a singular position, redundant rows); a smaller
#: one lowers the round-off floor alpha |D^T c| eps when M + alpha D^T D is badly conditioned
#: (bodies with large mass ratios), where a larger alpha never converges.
ESCALATION = ((10.0, 4), (0.01, 4), (1e-4, 16))
#: rows whose relative distance to the span of the rows before them is below this count as
#: nearly dependent at an instant
NEAR_DEPENDENT = 1e-3
ALPHA_RANGE = (1e2, 1e11)


@register
class AugmentedLagrangian(_PenaltyBase):
    name = "augmented_lagrangian"
    iterate = True

    def __init__(self, alpha: float = 1e7, omega: Optional[float] = None,
                 mu: Optional[float] = None,
                 tolerance: float = 1e-8, max_iterations: int = 50, floor: float = 1e-6,
                 singular: str = "stop", project: bool = True):
        super().__init__(alpha, omega, mu, singular, project)
        self.tolerance = check_positive("augmented_lagrangian tolerance", tolerance)
        self.max_iterations = int(check_positive("augmented_lagrangian max_iterations",
                                                 max_iterations))
        self.floor = check_positive("augmented_lagrangian floor", floor)
        self.total_iterations = 0
        self.adaptations = []
        self.singular_instants = 0
        self._alpha0, self._iterations0 = self.alpha, self.max_iterations
        self._drop = None

    def setup(self, eom, redundant_rows=None) -> None:
        """Leave the redundant rows (found by the mobility analysis) out of M + alpha D^T D, as
        the standard method leaves them out of its multiplier solve: along a redundant
        direction D has a tiny but non-zero singular value (round-off, or a mechanism near a
        special position), so M + alpha D^T D barely contracts there and the iteration (12.17)
        stalls (the Bricard mechanism). Their multipliers are 0.

        Every run starts from the configured settings and counters: an adaptation of alpha
        or max_iterations in one run (see :meth:`status`) does not carry into the next."""
        super().setup(eom, redundant_rows)
        self.alpha, self.max_iterations = self._alpha0, self._iterations0
        self.total_iterations = 0
        self.adaptations = []
        self.singular_instants = 0
        self._drop = None if redundant_rows is None or not len(redundant_rows) else \
            [int(r) for r in redundant_rows]
        eom.system.drop_penalty_rows(self._drop)

    def kernels(self, system, W=None):
        system.drop_penalty_rows(getattr(self, "_drop", None))
        return super().kernels(system, W)

    def status(self, code, system, t, y, ydot, W=None):
        """On non-convergence, adapt before failing.

        1. Near a singular position D has rows that are nearly dependent *here* (relative
           distance to the rows before them below :data:`NEAR_DEPENDENT`): (12.17) barely
           contracts along them. The instant is redone with those rows left out as well (for this instant
           only; the reactions are then carried by the others).
        2. Otherwise the settings of :data:`ESCALATION` (relative to the method's own) are
           tried in turn; the first that converges is kept for the rest of the run
           (``alpha`` and ``max_iterations`` change; ``adaptations`` lists (t, alpha,
           max_iterations)).
        The successful attempt rewrites all of ydot."""
        if code != cs.NOT_CONVERGED:
            return super().status(code, system, t, y, ydot, W)
        KI, KW = system.penalty_pack()
        W = system.W if W is None else W
        out = np.empty(y.size) if ydot is None else ydot
        tried = []
        near = self._nearly_dependent_rows(system, t, y)
        if near:
            system.drop_penalty_rows(sorted(set(near) | set(self._drop or ())))
            try:
                code = after_state_penalty(y, out, system.F, system.I, W, KI, KW,
                                              self.params())
            finally:
                system.drop_penalty_rows(self._drop)
            if code >= 0:
                self.singular_instants += 1
                return code
            tried.append(f"{len(near)} nearly dependent row(s) left out")
        base = self.params()
        for fa, fi in ESCALATION:
            mp = base.copy()
            mp[1] = min(max(self._alpha0 * fa, ALPHA_RANGE[0]), ALPHA_RANGE[1])
            mp[6] = max(int(self._iterations0 * fi), int(base[6]))
            tried.append(f"alpha {mp[1]:.3g} with {int(mp[6])} iterations")
            code = after_state_penalty(y, out, system.F, system.I, W, KI, KW, mp)
            if code >= 0:
                self.alpha, self.max_iterations = float(mp[1]), int(mp[6])
                live = self.__dict__.get("_mp")
                if live is not None:                   # the compiled kernels' parameters
                    live[1], live[6] = mp[1], mp[6]
                self.adaptations.append((float(t), self.alpha, self.max_iterations))
                return code
        raise self._not_converged(t, tried)

    def _nearly_dependent_rows(self, system, t, y):
        """Rows of D(q) (q from y) (nearly) dependent on the rows before them here (relative
        distance to their span below :data:`NEAR_DEPENDENT`, the project's one rank decision
        :func:`spatialmbd.rank.row_rank`, in the model's row order -- the same rows on every
        machine), besides the redundant ones: [] when none."""
        from ..kinematics import _dense
        from ..rank import row_rank
        from ..state import normalize_q
        model = system.model
        nb = model.nb
        q = normalize_q(np.asarray(y[:7 * nb], dtype=float)).reshape(nb, 7)
        D = _dense(model.assembler.evaluate(q, None, t).D)
        keep = np.setdiff1d(np.arange(D.shape[0]), np.asarray(self._drop or [], dtype=int))
        if keep.size == 0:
            return []
        return [int(keep[p]) for p in row_rank(D[keep], NEAR_DEPENDENT).dependent]

    def _not_converged(self, t, tried=()):
        extra = f" (nor with {', '.join(tried)})" if tried else ""
        err = ConvergenceError(
            f"t = {t:.6g} s: augmented Lagrangian iterations did not converge in "
            f"{self.max_iterations}{extra}; change method option alpha (now {self.alpha:.3g}) "
            f"or max_iterations (now {self.max_iterations}), loosen tolerance (now "
            f"{self.tolerance:.3g}), or, if the mechanism is at a singular position, use method "
            "'penalty'")
        err.t = t
        return err

    def parameters(self):
        out = super().parameters()
        out.update(tolerance=self.tolerance, max_iterations=self.max_iterations, floor=self.floor)
        return out
