"""Assembly: stack the constraint groups into Phi, D, nu, gamma of the whole system.

Each equation row of D (m x 6 nb) has at most 12 non-zeros, the columns of the two bodies of
its joint (ground columns dropped), so the kernels produce D as ``blocks`` (m, 12). The sparsity
pattern of D is computed once per model; every evaluation runs all compiled groups in one call
(:func:`.constraints.kernels.evaluate_instances`), groups without a compiled kernel in Python,
and D itself -- a dense array for small systems or a CSR matrix with the fixed pattern for
large ones -- is only scattered from the blocks when someone asks for ``ConstraintValues.D``.
(The dynamics never do: :mod:`.dynamics.system` works on the blocks.)
"""
from __future__ import annotations

from typing import Union

import numpy as np
import scipy.sparse as sp

from .constraints.kernels import JointTable, evaluate_instances
from .state import BodyState

#: systems with more velocity coordinates than this use sparse D by default
SPARSE_THRESHOLD = 600


class ConstraintValues:
    """Phi (m,), D (m, 6 nb) dense ndarray or CSR matrix, nu (m,), gamma (m,).

    ``blocks`` (m, 12): the non-zeros of each row of D over [v_i, v_j] of its two bodies.
    """

    def __init__(self, phi, D=None, nu=None, gamma=None, *, blocks=None, assembler=None):
        self.phi = phi
        self.nu = nu
        self.gamma = gamma
        self.blocks = blocks
        self._D = D
        self._assembler = assembler

    @property
    def D(self) -> Union[np.ndarray, sp.csr_matrix]:
        if self._D is None:
            self._D = self._assembler.assemble_D(self.blocks.ravel())
        return self._D

    def __repr__(self) -> str:
        return f"ConstraintValues(m={np.size(self.phi)})"


def coupler_slices(groups) -> list:
    """(group, instance slice of the joint table) of the coupler groups (constraints.couplers),
    whose law columns hold their angle references."""
    out, start = [], 0
    for g in groups:
        if g.coupler:
            out.append((g, slice(start, start + g.n)))
        start += g.n
    return out


def reset_couplers(couplers, law) -> None:
    """Angle references of the couplers back to the assembled zero (start of an analysis)."""
    for _, sl in couplers:
        law[sl, :2] = 0.0


def advance_couplers(couplers, law, q, nb) -> None:
    """Advance the couplers' angle references to their unwrapped angles at q (nb, 7)."""
    if couplers:
        from .constraints.couplers import advance
        advance(couplers, law, BodyState.from_qv(np.asarray(q).reshape(nb, 7), None, 0.0))


class Assembler:
    def __init__(self, model, sparse: bool | None = None):
        self.model = model
        self.nb = model.nb
        self.m = model.n_eq
        self.n = 6 * model.nb
        self.sparse = (self.n > SPARSE_THRESHOLD) if sparse is None else bool(sparse)
        groups, offsets = model.constraint_groups, model.group_offsets
        self.table = JointTable(groups, offsets)
        self.couplers = coupler_slices(groups)
        self._python = [(g, off) for g, off in zip(groups, offsets) if not g.compiled]
        rows, cols, keep = [], [], []
        for g, off in zip(groups, offsets):
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

    def reset_couplers(self) -> None:
        reset_couplers(self.couplers, self.table.law)

    def advance_couplers(self, q) -> None:
        advance_couplers(self.couplers, self.table.law, q, self.nb)

    def coupler_references(self) -> list:
        """The couplers' angle references now (copies; [] without couplers)."""
        return [self.table.law[sl, :2].copy() for _, sl in self.couplers]

    def set_coupler_references(self, refs) -> None:
        """Set the references (from :meth:`coupler_references`; None: the assembled zero)."""
        if refs is None:
            self.reset_couplers()
            return
        for (_, sl), ref in zip(self.couplers, refs):
            self.table.law[sl, :2] = ref

    # ---------------------------------------------------------------------------------------
    def blocks(self, state: BodyState, t: float):
        """Evaluate every group: lists of ConstraintEval in group order."""
        return [g.evaluate(state, t) for g in self.model.constraint_groups]

    def evaluate(self, q: np.ndarray, v: np.ndarray | None, t: float,
                 state: BodyState | None = None) -> ConstraintValues:
        """Phi, D, nu, gamma at (q, v, t). q: (nb, 7) or flat; v: (nb, 6), flat or None."""
        if state is None:
            state = BodyState.from_qv(q, v, t)
        m = self.m
        phi, nu, gamma = np.empty(m), np.empty(m), np.empty(m)
        D = np.empty((m, 12))
        if self.table.has_drivers:
            self.table.set_time(t)
        if self.table.kind.size:
            evaluate_instances(self.table.kind, state.arrays(), self.table.G, self.table.rows,
                               (phi, D, nu, gamma))
        for g, off in self._python:
            e = g.evaluate(state, t)
            sl = slice(off, off + g.size)
            phi[sl], nu[sl], gamma[sl] = e.phi.ravel(), e.nu.ravel(), e.gamma.ravel()
            D[sl] = e.D.reshape(-1, 12)
        return ConstraintValues(phi, None, nu, gamma, blocks=D, assembler=self)

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
        return self.evaluate(q, None, t).phi
