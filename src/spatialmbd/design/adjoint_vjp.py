"""Vector-Jacobian products of the standard / Baumgarte right-hand side that use the
structure of the equations of motion (the fast path of :mod:`.adjoint_kernels`).

f(y) = [qdot(q, v); vdot; w'] with vdot from K [vdot; lam] = [g; rg], K = [M, -D^T; D, 0]
(Eqs. 12.3-12.4; M = diag(m I, J), J = A J' A^T). For a cotangent kbar = [kbar_q; kbar_v]
(the work entry w' carries none: no cost reads w), differentiating K x = b at fixed x* =
[vdot*, lam*] gives

    kbar_v^T d vdot = mu_v^T dr_v + mu_c^T dr_c,    K^T mu = [kbar_v; 0],
    r_v = g + D^T lam* - M vdot*,   r_c = rg - D vdot*       (the residual of K x* = b)

so one extra solve (mu, by the compiled Schur solve: K^T = [M, D^T; -D, 0] is K with
lam -> -lam) turns the product into the derivative of residuals that are *local*: the rows of
body b (r_v and qdot) depend on b and the bodies joined to it by a joint or a force element,
the rows of a constraint on its two bodies. So directions are combined: every body of one
colour class (bodies at distance >= 3 in that graph: no row depends on two of them) is
perturbed at once in one of its 13 state components, and the change of the rows each body
reaches is its own. Likewise the packed model floats: a float of body b moves the rows of b;
of a joint, the rows of its bodies and constraints; of a force element, the rows of its
bodies; floats whose rows are disjoint share an evaluation. Per RK4 stage: one evaluation at
the stage, K solves, 2 (13 n_colours + n_float_colours) evaluations of the residuals (no
solve) -- instead of 2 (n + n_active) right-hand sides, n = 13 nb + 1.

The residual derivatives are central differences like those of the dense path; the
:class:`.adjoint.Adjoint` set-up checks this path against the dense one at the start state.
"""
from __future__ import annotations

import numpy as np

from ..dynamics.standard import rhs_standard
from ..dynamics.system import (_M, _P, _R, _write_ydot, baumgarte_rhs, body_views,
                               cons_views, copy_v, force_views, schur_views, solve_multipliers,
                               stage_state)
from ..dynamics.algebra import add_transpose_times, m_all, row_times
from ..jit import njit


@njit
def _local(t, Y, F, I, W, mp, vdot, lam, rv, rc, qd, tmp6, ydot):
    """The local rows at Y: rv = g + D^T lam - M vdot (6 nb), rc = rg - D vdot (m),
    qd = qdot (7 nb), at fixed vdot, lam."""
    stage_state(t, Y, mp[0], F, I, W)
    bo, co, fo = body_views(F, I, W), cons_views(F, I, W), force_views(F, I, W)
    copy_v(Y, bo.v)
    R = _R(co)
    baumgarte_rhs(R, co.gamma, co.phi, co.nu, bo.v, int(mp[1]), mp[2], mp[3], co.rg)
    for i in range(rv.size):
        rv[i] = bo.g[i]
    add_transpose_times(R, lam, rv)
    m_all(_M(bo), vdot, tmp6)
    for i in range(rv.size):
        rv[i] -= tmp6[i]
    for a in range(rc.size):
        rc[a] = co.rg[a] - row_times(R, a, vdot)
    _write_ydot(bo, co, fo, ydot)
    for i in range(qd.size):
        qd[i] = ydot[i]


@njit
def _sums(kq, muv, muc, rv1, rc1, qd1, rv2, rc2, qd2, bsum, csum):
    """bsum[b, k] = mu_v . (rv1 - rv2) + kbar_q . (qd1 - qd2) over the rows of body b,
    csum[a, k] = mu_c[a] (rc1 - rc2)[a]."""
    nb, K = bsum.shape
    for b in range(nb):
        for k in range(K):
            acc = 0.0
            for i in range(6):
                acc += muv[6 * b + i, k] * (rv1[6 * b + i] - rv2[6 * b + i])
            for i in range(7):
                acc += kq[7 * b + i, k] * (qd1[7 * b + i] - qd2[7 * b + i])
            bsum[b, k] = acc
    for a in range(csum.shape[0]):
        for k in range(K):
            csum[a, k] = muc[a, k] * (rc1[a] - rc2[a])


@njit
def vjp_structured(t, Y, kbar, ybar, Fbar, F, I, W, mp, active, eps, S):
    """ybar += f_y(t, Y)^T kbar, Fbar += f_F(t, Y)[:, active]^T kbar (kbar (n, K), its last
    (work) row ignored) through the residuals; S: the colouring (:func:`.adjoint.structure`).
    Returns the status (0 = OK)."""
    (cls_ptr, cls_body, nbr_ptr, nbr_body, crw_ptr, crw_row,
     fcl_ptr, fcl_idx, fb_ptr, fb_body, fc_ptr, fc_row) = S
    n, K = kbar.shape
    ydot = np.empty(n)
    if rhs_standard(t, Y, ydot, F, I, W, mp) < 0:
        return 1
    bo, co, sc = body_views(F, I, W), cons_views(F, I, W), schur_views(F, I, W)
    nb = bo.mass.size
    m = co.lam.size
    vdot = bo.vdot.copy()
    lam = co.lam.copy()
    muv = np.zeros((6 * nb, K))
    muc = np.zeros((m, K))
    g = np.empty(6 * nb)
    rg = np.zeros(m)
    lk = np.empty(m)
    a6 = np.empty(6 * nb)
    kq = np.ascontiguousarray(kbar[:7 * nb, :])
    for k in range(K):                              # K^T mu = [kbar_v; 0]
        for i in range(6 * nb):
            g[i] = kbar[7 * nb + i, k]
        for a in range(m):
            rg[a] = 0.0
        if not solve_multipliers(_M(bo), _R(co), _P(sc), g, rg, lk, sc.bs, bo.t6, bo.u6, a6):
            return 1
        for i in range(6 * nb):
            muv[i, k] = a6[i]
        for a in range(m):
            muc[a, k] = -lk[a]
    rv1, rv2 = np.empty(6 * nb), np.empty(6 * nb)
    rc1, rc2 = np.empty(m), np.empty(m)
    qd1, qd2 = np.empty(7 * nb), np.empty(7 * nb)
    tmp6 = np.empty(6 * nb)
    bsum = np.empty((nb, K))
    csum = np.empty((m, K))
    ncls = cls_ptr.size - 1
    step = np.empty(nb)
    Ysave = Y.copy()
    for cl in range(ncls):                          # the states, one colour class at a time
        for comp in range(13):
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                idx = 7 * b + comp if comp < 7 else 7 * nb + 6 * b + comp - 7
                step[b] = eps * max(1.0, abs(Y[idx]))
                Y[idx] += step[b]
            _local(t, Y, F, I, W, mp, vdot, lam, rv1, rc1, qd1, tmp6, ydot)
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                idx = 7 * b + comp if comp < 7 else 7 * nb + 6 * b + comp - 7
                Y[idx] -= 2.0 * step[b]
            _local(t, Y, F, I, W, mp, vdot, lam, rv2, rc2, qd2, tmp6, ydot)
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                idx = 7 * b + comp if comp < 7 else 7 * nb + 6 * b + comp - 7
                Y[idx] = Ysave[idx]
            _sums(kq, muv, muc, rv1, rc1, qd1, rv2, rc2, qd2, bsum, csum)
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                idx = 7 * b + comp if comp < 7 else 7 * nb + 6 * b + comp - 7
                for k in range(K):
                    acc = 0.0
                    for u in range(nbr_ptr[b], nbr_ptr[b + 1]):
                        acc += bsum[nbr_body[u], k]
                    for u in range(crw_ptr[b], crw_ptr[b + 1]):
                        acc += csum[crw_row[u], k]
                    ybar[idx, k] += acc / (2.0 * step[b])
    fstep = np.empty(active.size)
    Fsave = np.empty(active.size)
    for j in range(active.size):
        Fsave[j] = F[active[j]]
    for cl in range(fcl_ptr.size - 1):              # the packed floats, likewise
        for e in range(fcl_ptr[cl], fcl_ptr[cl + 1]):
            j = fcl_idx[e]
            fstep[j] = eps * max(abs(F[active[j]]), 1e-3)
            F[active[j]] += fstep[j]
        _local(t, Y, F, I, W, mp, vdot, lam, rv1, rc1, qd1, tmp6, ydot)
        for e in range(fcl_ptr[cl], fcl_ptr[cl + 1]):
            j = fcl_idx[e]
            F[active[j]] -= 2.0 * fstep[j]
        _local(t, Y, F, I, W, mp, vdot, lam, rv2, rc2, qd2, tmp6, ydot)
        for e in range(fcl_ptr[cl], fcl_ptr[cl + 1]):
            j = fcl_idx[e]
            F[active[j]] = Fsave[j]
        _sums(kq, muv, muc, rv1, rc1, qd1, rv2, rc2, qd2, bsum, csum)
        for e in range(fcl_ptr[cl], fcl_ptr[cl + 1]):
            j = fcl_idx[e]
            for k in range(K):
                acc = 0.0
                for u in range(fb_ptr[j], fb_ptr[j + 1]):
                    acc += bsum[fb_body[u], k]
                for u in range(fc_ptr[j], fc_ptr[j + 1]):
                    acc += csum[fc_row[u], k]
                Fbar[j, k] += acc / (2.0 * fstep[j])
    return 0
