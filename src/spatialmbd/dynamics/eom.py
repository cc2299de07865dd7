"""Newton-Euler equations of motion of the constrained system (text ch. 10).

    M vdot = g + D^T lam                                           (10.9)-(10.11)

Sign convention (ERRATA for (12.1) vs (12.3)): lam is defined so that D^T lam are the constraint
reaction forces acting on the bodies, (10.10). The augmented system then reads
[M, -D^T; D, 0] [vdot; lam] = [g; gamma]; with the text's (12.3) the multipliers would be -lam.

M is block diagonal, blocks diag(m I, J) with the global inertia J = A J' A^T (10.6); it is
never formed or inverted as a dense matrix: M^-1 b = [b_r / m, A J'^-1 A^T b_w] per body.
g holds gravity, the force elements and the gyroscopic term -omega~ J omega (10.4).

The evaluation itself is compiled (:mod:`.system`); :class:`Evaluation` wraps its arrays for
methods written in Python, and carries the compiled system so the built-in methods solve on it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..assembly import ConstraintValues
from .system import System, mass_apply


@dataclass
class MassMatrix:
    """Block-diagonal M: mass (nb,), J (nb, 3, 3) global, J_inv (nb, 3, 3) global."""

    mass: np.ndarray
    J: np.ndarray
    J_inv: np.ndarray

    def _apply(self, b: np.ndarray, inverse: bool) -> np.ndarray:
        x = np.ascontiguousarray(b, dtype=float)
        cols = x.reshape(x.shape[0], -1)
        out = np.empty_like(cols)
        mass_apply(np.ascontiguousarray(self.mass, dtype=float),
                   np.ascontiguousarray(self.J_inv if inverse else self.J), cols, out, inverse)
        return out.reshape(x.shape)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """M^-1 b for b (6 nb,) or (6 nb, k)."""
        return self._apply(b, True)

    def dot(self, x: np.ndarray) -> np.ndarray:
        """M x for x (6 nb,) or (6 nb, k)."""
        return self._apply(x, False)

    def blocks(self) -> np.ndarray:
        nb = self.mass.size
        blocks = np.zeros((nb, 6, 6))
        blocks[:, 0, 0] = blocks[:, 1, 1] = blocks[:, 2, 2] = self.mass
        blocks[:, 3:, 3:] = self.J
        return blocks

    def sparse(self) -> sp.csr_matrix:
        """M as a sparse block-diagonal matrix."""
        return sp.block_diag(list(self.blocks()), format="csr")

    def dense(self) -> np.ndarray:
        return self.sparse().toarray()


class Evaluation:
    """Everything a method needs at one (t, q, v): state, M, g, cv (Phi, D, nu, gamma), v.

    system / W: the compiled system and the work array holding this evaluation (the built-in
    methods solve on them directly); y = [q, v] the evaluated state vector. The other fields
    are views into W, made on first use.
    """

    def __init__(self, t, y, system, W, assembler):
        self.t = t
        self.y = y
        self.system = system
        self.W = W
        self._assembler = assembler

    def __getattr__(self, name):             # the lazy fields (first access only)
        if name == "v":
            value = self.y[7 * self.system.nb:13 * self.system.nb]
        elif name == "state":
            value = self.system.state_of(self.W)
            value.t = self.t
        elif name == "M":
            value = MassMatrix(self.system.model.mass, self._field("J"), self._field("Jinv"))
        elif name == "g":
            value = self._field("g")
        elif name == "cv":
            value = ConstraintValues(self._field("phi"), None, self._field("nu"),
                                     self._field("gamma"), blocks=self._field("D"),
                                     assembler=self._assembler)
        else:
            raise AttributeError(name)
        self.__dict__[name] = value
        return value

    def _field(self, name):
        return self.system.fields(self.W, name)

    @property
    def phidot(self) -> np.ndarray:
        """dPhi/dt = D v - nu (7.3)-(7.4)."""
        return self.cv.D @ self.v - self.cv.nu


class EquationsOfMotion:
    """Evaluates M, g and the constraints of a model at (t, q, v).

    ``system`` is the compiled :class:`~.system.System` (built on first use; methods choose
    the constraint rows their solves keep with :meth:`set_keep`).
    """

    def __init__(self, model, sparse: bool | None = None):
        self.model = model
        self.nb = model.nb
        if sparse is None:
            self.assembler = model.assembler
        else:
            from ..assembly import Assembler
            self.assembler = Assembler(model, sparse=sparse)
        self.sparse = self.assembler.sparse
        self._keep = None
        self._system = None

    @property
    def system(self) -> System:
        if self._system is None:
            self._system = System.for_model(self.model, self._keep)
        return self._system

    def set_keep(self, keep) -> None:
        """Rows of the multiplier and projection solves (None: all)."""
        keep = None if keep is None else np.asarray(keep, dtype=np.int64)
        same = (keep is None and self._keep is None) or (
            keep is not None and self._keep is not None and np.array_equal(keep, self._keep))
        if not same:
            self._keep = keep
            self._system = None

    def evaluate(self, t: float, q: np.ndarray, v: np.ndarray) -> Evaluation:
        sys_ = self._system if self._system is not None else self.system
        nb = self.nb
        y = np.concatenate((np.asarray(q, dtype=float).reshape(-1),
                            np.asarray(v, dtype=float).reshape(-1)))
        if y.size != 13 * nb:
            raise ValueError(f"q and v must hold {7 * nb} and {6 * nb} numbers")
        W = sys_.W.copy()
        ev = Evaluation(t, y, sys_, W, self.assembler)
        if not sys_.evaluate(t, y, False, W):
            self._raise_non_finite(ev.state, t)
        return ev

    def _raise_non_finite(self, state, t):
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
