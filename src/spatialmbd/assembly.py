"""Assembly: stack the constraint groups into Phi, D, nu, gamma of the whole system.

The sparsity pattern of D (m x 6 nb) is computed once per model: each instance of a group fills
a (n_eq x 12) block in the columns of its two bodies (ground columns dropped). Every evaluation
then only computes the blocks (one vectorized call per constraint type) and scatters them with
precomputed indices, into a dense array for small systems or the data vector of a fixed CSR
matrix for large ones.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Union

import numpy as np
import scipy.sparse as sp

from .state import BodyState

#: systems with more velocity coordinates than this use sparse D by default
SPARSE_THRESHOLD = 600


@dataclass
class ConstraintValues:
    """Phi (m,), D (m, 6 nb) dense ndarray or CSR matrix, nu (m,), gamma (m,)."""

    phi: np.ndarray
    D: Union[np.ndarray, sp.csr_matrix]
    nu: np.ndarray
    gamma: np.ndarray


class Assembler:
    def __init__(self, model, sparse: bool | None = None):
        self.model = model
        self.nb = model.nb
        self.m = model.n_eq
        self.n = 6 * model.nb
        self.sparse = (self.n > SPARSE_THRESHOLD) if sparse is None else bool(sparse)
        rows, cols, keep = [], [], []
        offsets = model.group_offsets
        for g, off in zip(model.constraint_groups, offsets):
            r = off + np.arange(g.size).reshape(g.n, g.n_eq)
            c = np.concatenate([6 * g.body_i[:, None] + np.arange(6),
                                6 * g.body_j[:, None] + np.arange(6)], axis=1)
            k = np.concatenate([np.repeat((g.body_i != self.nb)[:, None], 6, axis=1),
                                np.repeat((g.body_j != self.nb)[:, None], 6, axis=1)], axis=1)
            rows.append(np.broadcast_to(r[:, :, None], (g.n, g.n_eq, 12)).ravel())
            cols.append(np.broadcast_to(c[:, None, :], (g.n, g.n_eq, 12)).ravel())
            keep.append(np.broadcast_to(k[:, None, :], (g.n, g.n_eq, 12)).ravel())
        if rows:
            keep = np.concatenate(keep)
            self._keep = np.nonzero(keep)[0]
            self.rows = np.concatenate(rows)[self._keep]
            self.cols = np.concatenate(cols)[self._keep]
        else:
            self._keep = np.zeros(0, dtype=np.intp)
            self.rows = self.cols = np.zeros(0, dtype=np.intp)
        if self.sparse:
            pattern = sp.csr_matrix((np.arange(1, self.rows.size + 1, dtype=float),
                                     (self.rows, self.cols)), shape=(self.m, self.n))
            pattern.sort_indices()
            self._csr_order = pattern.data.astype(np.intp) - 1
            self._csr_indices = pattern.indices.copy()
            self._csr_indptr = pattern.indptr.copy()

    # ---------------------------------------------------------------------------------------
    def blocks(self, state: BodyState, t: float):
        """Evaluate every group: lists of ConstraintEval in group order."""
        return [g.evaluate(state, t) for g in self.model.constraint_groups]

    def evaluate(self, q: np.ndarray, v: np.ndarray | None, t: float,
                 state: BodyState | None = None) -> ConstraintValues:
        """Phi, D, nu, gamma at (q, v, t). q: (nb, 7) or flat; v: (nb, 6), flat or None."""
        if state is None:
            state = BodyState.from_qv(q, v, t)
        evals = self.blocks(state, t)
        if not evals:
            z = np.zeros(0)
            return ConstraintValues(z, self.assemble_D(z), z, z)
        phi = np.concatenate([e.phi.ravel() for e in evals])
        nu = np.concatenate([e.nu.ravel() for e in evals])
        gamma = np.concatenate([e.gamma.ravel() for e in evals])
        data = np.concatenate([e.D.ravel() for e in evals])
        return ConstraintValues(phi, self.assemble_D(data), nu, gamma)

    def assemble_D(self, data: np.ndarray):
        """Scatter the concatenated (n, n_eq, 12) blocks into D (dense or CSR)."""
        data = data[self._keep] if data.size else data
        if self.sparse:
            return sp.csr_matrix((data[self._csr_order] if data.size else data,
                                  self._csr_indices, self._csr_indptr), shape=(self.m, self.n))
        D = np.zeros((self.m, self.n))
        D[self.rows, self.cols] = data
        return D

    def phi(self, q: np.ndarray, t: float) -> np.ndarray:
        """Phi(q, t) only (m,)."""
        state = BodyState.from_qv(q, None, t)
        evals = self.blocks(state, t)
        return np.concatenate([e.phi.ravel() for e in evals]) if evals else np.zeros(0)
