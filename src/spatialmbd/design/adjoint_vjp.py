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
perturbed at once in one of its state components -- 12: with normalised Euler parameters the
rows read p only through p / |p|, so its 3 tangent directions do --, and the change of the
rows each body reaches is its own. Likewise the packed model floats: a float of a joint moves
the rows of its bodies and constraints; of a force element, the rows of its bodies; floats
whose rows are disjoint share an evaluation. The body floats (mass, J', J'^-1, weight) need
none: r_v is linear in m, m g and J', its derivative is written out (:func:`_body_floats`).
Per RK4 stage: one evaluation at
the stage, K solves, 2 (12 n_colours + n_float_colours) evaluations of the residuals (no
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


@njit(inline="always")
def _index(b, comp, npc, nb):
    """The state index of component comp of body b: r (3), the npc = 4 Euler parameters
    (none when npc = 3: the tangent directions are handled apart), v (6)."""
    if comp < 3 + npc:
        return 7 * b + comp
    return 7 * nb + 6 * b + comp - 3 - npc


@njit
def _body_floats(bfl, A, omega, vdot, muv, Fbar):
    """Fbar += (d r_v / d F)^T mu_v for the body floats, analytically: bfl (4, nf) holds per
    float its index in ``active``, kind (0 mass, 1 J', 2 J'^-1, 3 weight: the order of
    ``adjoint._BODY_FLOATS``), body and component. r_v of body b = [weight + (D^T lam)_r -
    m vdot_r; -w x (A J' A^T w) + (D^T lam)_w - A J' A^T wdot]: d/d weight_c = mu_r,c;
    d/dm = -mu_r . vdot_r; d/dJ'_cd = a_c e_d - u_c z_d with a = A^T (w x mu_w),
    e = A^T w, u = A^T mu_w, z = A^T wdot; J'^-1 is read only by the solve, not by the
    residual (its derivative along dF/dp comes with J''s)."""
    K = muv.shape[1]
    for e in range(bfl.shape[1]):
        j, kind, b, c = bfl[0, e], bfl[1, e], bfl[2, e], bfl[3, e]
        o = 6 * b
        for k in range(K):
            if kind == 0:
                acc = 0.0
                for i in range(3):
                    acc -= muv[o + i, k] * vdot[o + i]
            elif kind == 3:
                acc = muv[o + c, k]
            elif kind == 1:
                r, s = c // 3, c % 3
                w0, w1, w2 = omega[b, 0], omega[b, 1], omega[b, 2]
                m0, m1, m2 = muv[o + 3, k], muv[o + 4, k], muv[o + 5, k]
                x0, x1, x2 = w1 * m2 - w2 * m1, w2 * m0 - w0 * m2, w0 * m1 - w1 * m0
                a_r = A[b, 0, r] * x0 + A[b, 1, r] * x1 + A[b, 2, r] * x2
                e_s = A[b, 0, s] * w0 + A[b, 1, s] * w1 + A[b, 2, s] * w2
                u_r = A[b, 0, r] * m0 + A[b, 1, r] * m1 + A[b, 2, r] * m2
                z_s = (A[b, 0, s] * vdot[o + 3] + A[b, 1, s] * vdot[o + 4]
                       + A[b, 2, s] * vdot[o + 5])
                acc = a_r * e_s - u_r * z_s
            else:
                acc = 0.0
            Fbar[j, k] += acc


@njit
def vjp_structured(t, Y, kbar, ybar, Fbar, F, I, W, mp, active, eps, S):
    """ybar += f_y(t, Y)^T kbar, Fbar += f_F(t, Y)[:, active]^T kbar (kbar (n, K), its last
    (work) row ignored) through the residuals; S: the colouring (:func:`.adjoint.structure`).
    Returns the status (0 = OK)."""
    (cls_ptr, cls_body, nbr_ptr, nbr_body, crw_ptr, crw_row,
     fcl_ptr, fcl_idx, fb_ptr, fb_body, fc_ptr, fc_row, bfl) = S
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
    _body_floats(bfl, bo.A, bo.omega, vdot, muv, Fbar)
    rv1, rv2 = np.empty(6 * nb), np.empty(6 * nb)
    rc1, rc2 = np.empty(m), np.empty(m)
    qd1, qd2 = np.empty(7 * nb), np.empty(7 * nb)
    tmp6 = np.empty(6 * nb)
    bsum = np.empty((nb, K))
    csum = np.empty((m, K))
    ncls = cls_ptr.size - 1
    step = np.empty(nb)
    Ysave = Y.copy()
    # with normalised Euler parameters (mp[0] = 1) every residual reads p through p / |p|:
    # its gradient in p lies in the tangent space, spanned by the rows of E(p^) (orthonormal,
    # normal to p^), so 3 directions per body do instead of 4
    npc = 3 if mp[0] != 0.0 else 4
    Tb = np.zeros((nb, 3, 4))
    if npc == 3:
        for b in range(nb):
            o = 7 * b + 3
            nrm = np.sqrt(Y[o] ** 2 + Y[o + 1] ** 2 + Y[o + 2] ** 2 + Y[o + 3] ** 2)
            e0, e1, e2, e3 = Y[o] / nrm, Y[o + 1] / nrm, Y[o + 2] / nrm, Y[o + 3] / nrm
            Tb[b, 0, 0], Tb[b, 0, 1], Tb[b, 0, 2], Tb[b, 0, 3] = -e1, e0, -e3, e2
            Tb[b, 1, 0], Tb[b, 1, 1], Tb[b, 1, 2], Tb[b, 1, 3] = -e2, e3, e0, -e1
            Tb[b, 2, 0], Tb[b, 2, 1], Tb[b, 2, 2], Tb[b, 2, 3] = -e3, -e2, e1, e0
    for cl in range(ncls):                          # the states, one colour class at a time
        for comp in range(9 + npc):
            tangent = npc == 3 and 3 <= comp < 6
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                if tangent:
                    step[b] = eps
                    for i in range(4):
                        Y[7 * b + 3 + i] += eps * Tb[b, comp - 3, i]
                else:
                    idx = _index(b, comp, npc, nb)
                    step[b] = eps * max(1.0, abs(Y[idx]))
                    Y[idx] += step[b]
            _local(t, Y, F, I, W, mp, vdot, lam, rv1, rc1, qd1, tmp6, ydot)
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                if tangent:
                    for i in range(4):
                        Y[7 * b + 3 + i] = Ysave[7 * b + 3 + i] - eps * Tb[b, comp - 3, i]
                else:
                    idx = _index(b, comp, npc, nb)
                    Y[idx] -= 2.0 * step[b]
            _local(t, Y, F, I, W, mp, vdot, lam, rv2, rc2, qd2, tmp6, ydot)
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                if tangent:
                    for i in range(4):
                        Y[7 * b + 3 + i] = Ysave[7 * b + 3 + i]
                else:
                    idx = _index(b, comp, npc, nb)
                    Y[idx] = Ysave[idx]
            _sums(kq, muv, muc, rv1, rc1, qd1, rv2, rc2, qd2, bsum, csum)
            for e in range(cls_ptr[cl], cls_ptr[cl + 1]):
                b = cls_body[e]
                for k in range(K):
                    acc = 0.0
                    for u in range(nbr_ptr[b], nbr_ptr[b + 1]):
                        acc += bsum[nbr_body[u], k]
                    for u in range(crw_ptr[b], crw_ptr[b + 1]):
                        acc += csum[crw_row[u], k]
                    acc /= 2.0 * step[b]
                    if tangent:
                        for i in range(4):
                            ybar[7 * b + 3 + i, k] += acc * Tb[b, comp - 3, i]
                    else:
                        ybar[_index(b, comp, npc, nb), k] += acc
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
