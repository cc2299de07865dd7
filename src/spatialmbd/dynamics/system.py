"""The compiled equations of motion of a model: one call per right-hand-side evaluation.

:class:`System` packs everything an evaluation needs into three flat arrays -- ``F`` (model
floats), ``I`` (integers: the header, topology, sparsity patterns) and ``W`` (the work arrays
of one evaluation) -- because a compiled call pays about 0.1 us per array argument; inside
the compiled code :func:`body_views`, :func:`cons_views` and :func:`schur_views` turn them back
into named views (the namedtuples :data:`Body`, :data:`Cons`, :data:`Schur`). Per evaluation,
with no Python loop over bodies or joints:

* :func:`stage_state`: p / |p|, A(p) (4.13), J = A J' A^T and its inverse (10.6), gravity and
  the gyroscopic term -omega~ J omega (10.4), and every compiled constraint group
  (:func:`..constraints.kernels.evaluate_instances`) into Phi, D (m, 12 blocks), nu, gamma;
* the method's linear algebra, all O(N) for tree topologies (a chain):
  :func:`solve_multipliers` -- S = D M^-1 D^T (12.5) assembled body by body into a fixed
  sparse pattern, sparse Cholesky with a fill-reducing ordering (:mod:`.sparse`), then
  vdot = M^-1 (g + D^T lam) (12.4); the penalty solve -- M + alpha D^T D (12.14) and the
  augmented Lagrangian iteration (12.17); the projection -- the corrections of chapter 14
  with D D^T;
* each method's compiled right-hand side fuses it all with qdot = T(q) v (5.12): it lives next
  to the method's class (``standard.rhs_standard`` / ``stages_standard``,
  ``penalty.rhs_penalty`` / ``stages_penalty``, ``projection.project``); this module holds
  what they share (the stage, the structured solves, the packed buffers, :class:`System`).

The compiled functions live in :mod:`.algebra` (re-exported here); this module holds the
packing, :class:`System`.

Force elements and constraint types without a compiled kernel are evaluated in Python between
the two stages (they see the state through :attr:`System.state`).

The matrix D never exists as such: row a of D holds 12 numbers, the columns of its bodies
body_i = row_bi[a] and body_j = row_bj[a] (the ground, index nb, is skipped).
"""
from __future__ import annotations

import copy as copy_module

import numpy as np

from ..constraints.kernels import JointTable
from ..forces.armature import Armature
from ..forces.kernels import STATE_WIDTH, ForceTable
from ..jit import njit
from ..state import BodyState
from . import sparse as spc
from .algebra import (  # noqa: F401 -- re-exported: the methods import them from here
    FIELDS, KFIELDS, body_views, cons_views, field_view, force_views, pack, schur_views, fill,
    copy, finite, _M, _R, _P, congruence, body_terms, stage_state, _force_states_in,
    _force_states_out, _forces, _state, block_apply, minv_all, m_all, mass_apply, row_times,
    add_transpose_times, assemble_schur, schur_factor_solve, finish,
    baumgarte_rhs, solve_multipliers, copy_v, write_ydot, _write_ydot, OK, SINGULAR, NOT_FINITE,
    NOT_CONVERGED, MP_STANDARD, MP_PENALTY, normalize_y, dependent_rows)


# --------------------------------------------------------------------------------- Python side
class System:
    """Packed model, topology, sparsity patterns and work arrays of one model.

    keep: the constraint rows used in the multiplier and projection solves (default all; the
    redundant rows found by the mobility analysis are left out).
    """

    def __init__(self, model, keep=None):
        self.model = model
        nb = self.nb = model.nb
        m = self.m = model.n_eq
        groups, offsets = model.constraint_groups, model.group_offsets
        self.table = table = JointTable(groups, offsets)
        self.python_groups = [(g, off) for g, off in zip(groups, offsets) if not g.compiled]
        row_bi = np.empty(m, dtype=np.int64)
        row_bj = np.empty(m, dtype=np.int64)
        drv = []
        for g, off in zip(groups, offsets):
            row_bi[off:off + g.size] = np.repeat(g.body_i, g.n_eq)
            row_bj[off:off + g.size] = np.repeat(g.body_j, g.n_eq)
            if g.rheonomic:
                drv.extend(range(off, off + g.size))
        self.row_bi, self.row_bj = row_bi, row_bj
        self.driver_rows = np.array(drv, dtype=np.int64)
        keep = np.arange(m, dtype=np.int64) if keep is None else np.asarray(keep, np.int64)
        self.keep = keep
        G = table.G
        self.force_table = ft = ForceTable(model.force_groups)
        self.python_forces = [g for g in model.force_groups if not g.compiled]
        Gf = ft.G
        # the armature rows (forces.armature): rows m .. m + na - 1 of the multiplier solve
        arm_k, arm_J, start = [], [], 0
        for grp in ft.groups:
            if grp.name == Armature.name:
                arm_k += range(start, start + grp.n)
                arm_J += list(grp.inertia)
            start += grp.n
        self.arm_k = arm_k = np.array(arm_k, dtype=np.int64)
        self.n_armature = na = arm_k.size
        self.row_bi_all = np.concatenate([row_bi, Gf.bi[arm_k].astype(np.int64)])
        self.row_bj_all = np.concatenate([row_bj, Gf.bj[arm_k].astype(np.int64)])
        #: the rows of the multiplier solve: the kept constraint rows, then the armature rows
        self.keep_all = keep_all = np.concatenate([keep, np.arange(m, m + na, dtype=np.int64)])
        inc = self._incidence(keep_all)
        red = np.arange(keep.size, keep_all.size)
        arm_diag = self.S.positions(red, red) if na else np.zeros(0, np.int64)
        D_all = np.zeros((m + na, 12))
        arrays = dict(
            fkind=ft.kind, fbi=Gf.bi, fbj=Gf.bj, fs_i=Gf.s_i, fs_j=Gf.s_j, fR_i=Gf.R_i,
            fR_j=Gf.R_j, fparam=Gf.param, fcoord=Gf.coord, flaw=ft.law, fenergy=np.zeros(ft.n),
            fpower=np.zeros(ft.n), fscratch=np.zeros((1, 12)), g_power=np.zeros(1),
            mass=model.mass, Jl=model.inertia, Jl_inv=model.inertia_inverse,
            weight=model.mass[:, None] * model.gravity[None, :],
            s_i=G.s_i, s_j=G.s_j, R_i=G.R_i, R_j=G.R_j, param=G.param,
            kind=table.kind, rows=table.rows, bi=G[0], bj=G[1], coord=G[8],
            row_bi=row_bi, row_bj=row_bj, keep=keep_all, drv=self.driver_rows, **inc,
            D_all=D_all, gamma_all=np.zeros(m + na), lam_all=np.zeros(m + na),
            rg_all=np.zeros(m + na), row_bi_all=self.row_bi_all, row_bj_all=self.row_bj_all,
            arm_k=arm_k, armature=np.array(arm_J, dtype=float), arm_diag=arm_diag,
            S_Cp=self.S.Cp, S_Ci=self.S.Ci, S_Lp=self.S.Lp, S_Li=self.S.Li, S_Rp=self.S.Rp,
            S_Rj=self.S.Rj, S_Rpos=self.S.Rpos, S_perm=self.S.perm,
            r=np.zeros((nb + 1, 3)), A=np.zeros((nb + 1, 3, 3)), rdot=np.zeros((nb + 1, 3)),
            omega=np.zeros((nb + 1, 3)), p=np.zeros((nb + 1, 4)), J=np.zeros((nb, 3, 3)),
            Jinv=np.zeros((nb, 3, 3)), g=np.zeros(6 * nb), phi=np.zeros(m),
            D=np.zeros((m, 12)), nu=np.zeros(m), gamma=np.zeros(m), law=np.zeros((G[0].size, 3)),
            lam=np.zeros(m), vdot=np.zeros(6 * nb), rg=np.zeros(m), t6=np.zeros(6 * nb),
            u6=np.zeros(6 * nb),
            wk=np.zeros((max(1, int(np.diff(inc["inc_ptr"]).max(initial=0))), 12)),
            Cx=np.zeros(self.S.Ci.size), Lx=np.zeros(self.S.nnz_L), xs=np.zeros(keep_all.size),
            ys=np.zeros(keep_all.size), bs=np.zeros(keep_all.size), q=np.zeros((nb, 7)),
            v=np.zeros(6 * nb))
        self.F, self.I, self.W = pack(FIELDS, arrays)
        self._layout = {name: (int(self.I[4 * k]), int(np.asarray(arrays[name]).size),
                               np.asarray(arrays[name]).shape)
                        for k, (name, buf, _) in enumerate(FIELDS) if buf == "W"}
        self._kpack = None
        self._kshared = [None]                # the penalty pack, shared with the clones
        self.fused = not self.python_groups and not self.python_forces
        self._bind()

    def _bind(self):
        """The Python-side views of W (and the drivers' law table into W)."""
        w = lambda name: self.fields(None, name)  # noqa: E731
        self.law = w("law")
        table = copy_module.copy(self.table)
        table.law = self.law                  # drivers write their (f, f', f'') here
        table.G = table.G._replace(law=self.law)
        self.flaw = w("flaw")                 # the force elements' laws, likewise
        if self.force_table.has_laws:
            flaw, forces = self.flaw, self.force_table
            table.also_set = [lambda t: forces.set_time(t, flaw)]
            table.has_drivers = True
        self.table = table
        self.state = BodyState(r=w("r"), A=w("A"), rdot=w("rdot"), omega=w("omega"),
                               p=w("p"))
        self.g = w("g")
        self.phi, self.D, self.nu, self.gamma = w("phi"), w("D"), w("nu"), w("gamma")
        self.lam, self.vdot, self.bs, self.Cx = w("lam"), w("vdot"), w("bs"), w("Cx")

    @classmethod
    def for_model(cls, model, keep=None) -> "System":
        """A System of the model with its own work arrays; the static part (packed model,
        patterns, symbolic factorisations) is built once per model and kept rows."""
        from ..model.data import thread_data
        cache = thread_data(model).systems
        key = None if keep is None else tuple(np.asarray(keep).tolist())
        proto = cache.get(key)
        if proto is None:
            proto = cache[key] = cls(model, keep)
        return proto.clone()

    def clone(self) -> "System":
        """The same static data with fresh work arrays."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.W = self.W.copy()
        if self._kpack is not None:
            new._kpack = (self._kpack[0], self._kpack[1].copy())
        new._bind()
        return new

    # ---------------------------------------------------------------- patterns
    def _incidence(self, keep):
        """Rows incident to each body and the positions of their products in S (keep: the
        rows of the solve, armature rows included)."""
        nb = self.nb
        rk = keep.size
        full_bi, full_bj = self.row_bi_all[keep], self.row_bj_all[keep]
        body = np.concatenate([full_bi, full_bj])
        side = np.concatenate([np.zeros(rk, np.int64), np.ones(rk, np.int64)])
        red = np.concatenate([np.arange(rk), np.arange(rk)])
        real = body < nb
        body, side, red = body[real], side[real], red[real]
        order = np.lexsort((red, body))
        body, side, red = body[order], side[order], red[order]
        inc_ptr = np.zeros(nb + 1, dtype=np.int64)
        np.cumsum(np.bincount(body, minlength=nb), out=inc_ptr[1:])
        # every pair (ta <= tc) of rows incident to a body
        counts = np.diff(inc_ptr)
        npair = counts * (counts + 1) // 2
        pair_ptr = np.zeros(nb + 1, dtype=np.int64)
        np.cumsum(npair, out=pair_ptr[1:])
        pa, pc = _pairs(inc_ptr, red, int(pair_ptr[-1]))
        self.S = spc.symbolic(rk, pa, pc)
        pair_pos = self.S.positions(pa, pc) if pa.size else np.zeros(0, np.int64)
        return dict(inc_ptr=inc_ptr, inc_row=red.astype(np.int64),
                    inc_side=side.astype(np.int64), pair_ptr=pair_ptr, pair_pos=pair_pos)

    def penalty_pack(self):
        """(KI, KW) of K = M + alpha D^T D (built on first use, static part shared by the
        clones of a System)."""
        if self._kpack is None:
            if self._kshared[0] is None:
                self._kshared[0] = self._build_penalty()
            KI, KW = self._kshared[0]
            self._kpack = (KI, KW.copy())
        return self._kpack

    def drop_penalty_rows(self, rows) -> None:
        """Leave the constraint rows ``rows`` (redundant ones) out of M + alpha D^T D and of
        the penalty term (their multipliers are 0), as the standard method leaves them out of
        its multiplier solve. None or empty: use every row."""
        KI, KW = self.penalty_pack()
        off, nr, nc = int(KI[4]), int(KI[5]), int(KI[6])        # KFIELDS[1] = rowblk
        rowblk = KI[off:off + nr * nc].reshape(nr, nc)
        bi, bj = self.row_bi_all, self.row_bj_all
        rowblk[:, 3] = (bi > bj).astype(np.int64)
        if rows is not None and len(rows):
            rowblk[np.asarray(rows, dtype=np.int64), 3] = -1

    def _build_penalty(self):
        nb, m = self.nb, self.m + self.n_armature      # the armature rows join J B^T B
        bi, bj = self.row_bi_all, self.row_bj_all
        both = (bi < nb) & (bj < nb)
        lo, hi = np.minimum(bi[both], bj[both]), np.maximum(bi[both], bj[both])
        pairs = np.unique(lo * (nb + 1) + hi)
        blk_b1 = np.concatenate([np.arange(nb), pairs // (nb + 1)])
        blk_b2 = np.concatenate([np.arange(nb), pairs % (nb + 1)])
        nblk = blk_b1.size
        a6 = np.arange(6)
        R = (6 * blk_b1[:, None, None] + a6[None, :, None]) * np.ones((1, 1, 6), np.int64)
        C = (6 * blk_b2[:, None, None] + a6[None, None, :]) * np.ones((1, 6, 1), np.int64)
        K = spc.symbolic(6 * nb, R.ravel(), C.ravel())
        blkpos = K.positions(R.ravel(), C.ravel()).reshape(nblk, 6, 6)
        diag = np.arange(nblk) < nb
        lower = K.pinv[R] > K.pinv[C]               # the duplicate of an upper entry
        blkpos[diag[:, None, None] & lower] = -1
        rowblk = np.full((m, 4), -1, dtype=np.int64)
        rowblk[bi < nb, 0] = bi[bi < nb]
        rowblk[bj < nb, 1] = bj[bj < nb]
        key = np.minimum(bi, bj) * (nb + 1) + np.maximum(bi, bj)
        rowblk[both, 2] = nb + np.searchsorted(pairs, key[both])
        rowblk[:, 3] = (bi > bj).astype(np.int64)
        arrays = dict(blkpos=blkpos, rowblk=rowblk, K_Cp=K.Cp, K_Ci=K.Ci, K_Lp=K.Lp,
                      K_Li=K.Li, K_Rp=K.Rp, K_Rj=K.Rj, K_Rpos=K.Rpos, K_perm=K.perm,
                      Kx=np.zeros(K.Ci.size), KLx=np.zeros(K.nnz_L), xk=np.zeros(6 * nb),
                      yk=np.zeros(6 * nb), ck=np.zeros(m), dtc=np.zeros(6 * nb),
                      old=np.zeros(6 * nb), rotor=self.field_values("armature").copy())
        _, KI, KW = pack(KFIELDS, arrays)
        self.K = K
        return KI, KW

    # ---------------------------------------------------------------- evaluation
    def python_stage(self, t: float, W=None):
        """Constraint groups without a compiled kernel and the force elements, in Python."""
        state = self.state if W is None else self.state_of(W)
        state.t = t
        if self.python_groups:
            phi, D, nu, gamma = (self.fields(W, n) for n in ("phi", "D", "nu", "gamma"))
            for g, off in self.python_groups:
                e = g.evaluate(state, t)
                sl = slice(off, off + g.size)
                phi[sl], nu[sl], gamma[sl] = e.phi.ravel(), e.nu.ravel(), e.gamma.ravel()
                D[sl] = e.D.reshape(-1, 12)
        if self.python_forces:
            gen = np.zeros((self.nb + 1, 6))
            for group in self.python_forces:
                group.evaluate(state, t, gen)
            g = self.g if W is None else self.fields(W, "g")
            g += gen[:self.nb].ravel()
            if not np.all(np.isfinite(g)):
                return False
        return True

    def dependent_rows(self, q, t: float, tol: float = 1e-13) -> np.ndarray:
        """Constraint rows of D(q, t) that depend on others: the Cholesky factorisation of
        D D^T leaves out every row whose pivot is <= tol times its diagonal entry (an exactly
        redundant row gives a pivot at round-off level, about 1e-16; a merely ill-conditioned
        one stays far above: 1e-11 for the 10 000-link revolute chain). Sorted row indices
        (among the kept rows) -- empty when the rows are independent."""
        y = np.concatenate([np.asarray(q, dtype=float).ravel(), np.zeros(6 * self.nb)])
        self.evaluate(t, y, False)
        dropped = np.zeros(self.keep_all.size, dtype=np.int64)   # armature rows: never
        if dependent_rows(self.F, self.I, self.W, tol, dropped) == 0:
            return np.zeros(0, dtype=np.int64)
        return np.sort(self.keep[self.S.perm[dropped == 1]])

    def fields(self, W, name):
        """A view of field ``name`` of the work array W (default the system's own)."""
        if W is None:
            W = self.W
        o, size, shape = self._layout[name]
        if len(shape) == 1:
            return W[o:o + size]
        return W[o:o + size].reshape(shape)

    def field_values(self, name):
        """A field of the model buffers F or I (read only: e.g. ``armature``)."""
        return field_view(FIELDS, self.F, self.I, self.W, name)

    def set_force_states(self, z, W=None) -> None:
        """The force elements' internal states (``force_table.n_states``, in the order of y)
        for evaluations at a given q, v (whose y does not carry them)."""
        flaw = self.fields(self.W if W is None else W, "flaw")
        coord = self.force_table.G.coord
        for k in np.flatnonzero(coord >= 0):
            flaw[k, 3:3 + STATE_WIDTH] = z[coord[k]:coord[k] + STATE_WIDTH]

    def state_of(self, W) -> BodyState:
        f = lambda name: self.fields(W, name)  # noqa: E731
        return BodyState(r=f("r"), A=f("A"), rdot=f("rdot"), omega=f("omega"), p=f("p"))

    def evaluate(self, t: float, y: np.ndarray, normalize: bool, W=None) -> bool:
        """Both stages at (t, y) into W (default the system's own); False if g is not finite."""
        own = W is None or W is self.W
        if self.table.has_drivers:
            self.table.set_time(t)
            if not own:
                self.fields(W, "law")[:] = self.law
                self.fields(W, "flaw")[:] = self.flaw
        ok = stage_state(t, y, 1.0 if normalize else 0.0, self.F, self.I, self.W if own else W)
        if self.python_groups or self.python_forces:
            ok = self.python_stage(t, None if own else W) and ok
        return ok


@njit
def _pairs(inc_ptr, red, total):
    pa = np.empty(total, dtype=np.int64)
    pc = np.empty(total, dtype=np.int64)
    q = 0
    for b in range(inc_ptr.size - 1):
        for ta in range(inc_ptr[b], inc_ptr[b + 1]):
            for tc in range(ta, inc_ptr[b + 1]):
                pa[q] = red[ta]
                pc[q] = red[tc]
                q += 1
    return pa, pc
