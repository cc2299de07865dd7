"""Newton-Euler equations of motion of the constrained system (text ch. 10).

    M vdot = g + D^T lam                                           (10.9)-(10.11)

Sign convention (ERRATA for (12.1) vs (12.3)): lam is defined so that D^T lam are the constraint
reaction forces acting on the bodies, (10.10). The augmented system then reads
[M, -D^T; D, 0] [vdot; lam] = [g; gamma]; with the text's (12.3) the multipliers would be -lam.

M is block diagonal, blocks diag(m I, J) with the global inertia J = A J' A^T (10.6); it is
never formed or inverted as a dense matrix: M^-1 b = [b_r / m, A J'^-1 A^T b_w] per body.
g holds gravity, the force elements and the gyroscopic term -omega~ J omega (10.4).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..assembly import ConstraintValues
from ..state import BodyState
from ..rotations import cross


@dataclass
class MassMatrix:
    """Block-diagonal M: mass (nb,), J (nb, 3, 3) global, J_inv (nb, 3, 3) global."""

    mass: np.ndarray
    J: np.ndarray
    J_inv: np.ndarray

    def solve(self, b: np.ndarray) -> np.ndarray:
        """M^-1 b for b (6 nb,) or (6 nb, k)."""
        nb = self.mass.size
        if b.ndim == 1:
            b = b.reshape(nb, 6)
            out = np.empty_like(b)
            out[:, :3] = b[:, :3] / self.mass[:, None]
            out[:, 3:] = np.einsum("nij,nj->ni", self.J_inv, b[:, 3:])
            return out.reshape(-1)
        k = b.shape[1]
        b = b.reshape(nb, 6, k)
        out = np.empty_like(b)
        out[:, :3] = b[:, :3] / self.mass[:, None, None]
        out[:, 3:] = np.einsum("nij,njk->nik", self.J_inv, b[:, 3:])
        return out.reshape(6 * nb, k)

    def dot(self, x: np.ndarray) -> np.ndarray:
        """M x for x (6 nb,)."""
        nb = self.mass.size
        x = x.reshape(nb, 6)
        out = np.empty_like(x)
        out[:, :3] = x[:, :3] * self.mass[:, None]
        out[:, 3:] = np.einsum("nij,nj->ni", self.J, x[:, 3:])
        return out.reshape(-1)

    def sparse(self) -> sp.csr_matrix:
        """M as a sparse block-diagonal matrix (for the penalty methods)."""
        nb = self.mass.size
        blocks = np.zeros((nb, 6, 6))
        blocks[:, 0, 0] = blocks[:, 1, 1] = blocks[:, 2, 2] = self.mass
        blocks[:, 3:, 3:] = self.J
        return sp.block_diag(list(blocks), format="csr")

    def dense(self) -> np.ndarray:
        nb = self.mass.size
        M = np.zeros((6 * nb, 6 * nb))
        idx = np.arange(nb) * 6
        for k in range(3):
            M[idx + k, idx + k] = self.mass
        for a in range(3):
            for c in range(3):
                M[idx + 3 + a, idx + 3 + c] = self.J[:, a, c]
        return M


@dataclass
class Evaluation:
    """Everything a method needs at one (t, q, v)."""

    state: BodyState
    M: MassMatrix
    g: np.ndarray              # (6 nb,)
    cv: ConstraintValues       # Phi, D, nu, gamma
    v: np.ndarray              # (6 nb,)

    @property
    def phidot(self) -> np.ndarray:
        """dPhi/dt = D v - nu (7.3)-(7.4)."""
        return self.cv.D @ self.v - self.cv.nu


class EquationsOfMotion:
    """Evaluates M, g and the constraints of a model at (t, q, v)."""

    def __init__(self, model, sparse: bool | None = None):
        self.model = model
        self.nb = model.nb
        if sparse is None:
            self.assembler = model.assembler
        else:
            from ..assembly import Assembler
            self.assembler = Assembler(model, sparse=sparse)
        self.sparse = self.assembler.sparse
        self._weight = model.mass[:, None] * model.gravity[None, :]      # (11.1)
        self._J_local = model.inertia
        self._J_local_inv = model.inertia_inverse

    def mass_matrix(self, state: BodyState) -> MassMatrix:
        A = state.A[:self.nb]
        At = np.swapaxes(A, 1, 2)
        J = A @ self._J_local @ At                                         # J = A J' A^T
        J_inv = A @ self._J_local_inv @ At
        return MassMatrix(self.model.mass, J, J_inv)

    def forces(self, state: BodyState, t: float, M: MassMatrix) -> np.ndarray:
        """g (6 nb,): gravity, force elements and the gyroscopic term -omega~ J omega (10.6)."""
        nb = self.nb
        g = np.zeros((nb + 1, 6))
        g[:nb, :3] = self._weight
        w = state.omega[:nb]
        g[:nb, 3:] = -cross(w, np.einsum("nij,nj->ni", M.J, w))         # Eq. (10.4)
        for group in self.model.force_groups:
            group.evaluate(state, t, g)
        if not np.all(np.isfinite(g[:nb])):
            self._raise_non_finite(state, t, M)
        return g[:nb].reshape(-1)

    def _raise_non_finite(self, state, t, M):
        """Name the force element (or the state) that made g non-finite."""
        from ..errors import SimulationError
        culprit = "the state itself (positions or velocities are not finite)"
        for group in self.model.force_groups:
            g = np.zeros((self.nb + 1, 6))
            group.evaluate(state, t, g)
            if not np.all(np.isfinite(g)):
                culprit = f"force element(s) of type {group.name}: {', '.join(group.names)}"
                break
        err = SimulationError(f"t = {t:.6g} s: non-finite (NaN or inf) applied forces from "
                              f"{culprit}")
        err.t = t
        raise err

    def evaluate(self, t: float, q: np.ndarray, v: np.ndarray) -> Evaluation:
        state = BodyState.from_qv(q, v, t)
        M = self.mass_matrix(state)
        g = self.forces(state, t, M)
        cv = self.assembler.evaluate(q, v, t, state=state)
        return Evaluation(state=state, M=M, g=g, cv=cv, v=np.asarray(v, dtype=float).reshape(-1))
