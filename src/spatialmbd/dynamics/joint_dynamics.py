"""The articulated-body (O(N)) accelerations of the recursive method (:mod:`.recursive`): the body
terms at the bodies' state, the backward recursion of articulated inertias and the forward
recursion of joint accelerations, :func:`rhs_joint`."""
from __future__ import annotations

import math


from ..jit import array_view, njit
from ..rotations import pdot_scalar
from ..state import state_into
from .layout import body_views, force_views
from .joint_tree import (FREE, REVOLUTE, SIZES_Q, SIZES_V, SPHERICAL, TRANSLATIONAL, _unit,
                         joint_kinematics, tree_views)
from .system import _forces, body_terms


# ----------------------------------------------------------------------------- dynamics
@njit(inline="always")
def _bodies_stage(y, F, I, W):
    """The body terms of :func:`.system.stage_state` -- A, J = A J' A^T, g (gravity,
    -omega~ J omega, the compiled force elements) -- without the constraint equations, which
    the joint coordinates satisfy by construction. False if g is not finite."""
    bo, fo = body_views(F, I, W), force_views(F, I, W)
    nb = bo.mass.size
    q = array_view(y, 0, (nb, 7))
    v = array_view(y, 7 * nb, (nb, 6))
    state_into(q, v, False, bo.r, bo.A, bo.rdot, bo.omega, bo.p)
    body_terms(bo.A, bo.omega, bo.Jl, bo.Jl_inv, bo.weight, bo.J, bo.Jinv, bo.g, False)
    _forces(bo, fo)
    for i in range(bo.g.size):
        if not math.isfinite(bo.g[i]):
            return False
    return True


@njit(inline="always")
def _chol(A, n):
    """In-place Cholesky of the leading n x n block of A (lower triangle); False if not
    positive definite."""
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / d
    return True


@njit(inline="always")
def _chol_solve(L, n, x):
    """x <- A^-1 x with the factor of :func:`_chol` (leading n entries of x)."""
    for i in range(n):
        s = x[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(inline="always")
def _articulate(H, K, Ic, pc, hp, u, L, Kt, Ia, row, n):
    """For n rates: D = H^T U (U = I_C H, given in K), hp = H^T p_C, u = D^-1 hp,
    Ia = I_C - U D^-1 U^T and K <- U D^-1. False if D is not positive definite."""
    for i in range(n):
        for j in range(i + 1):
            s = 0.0
            for l in range(6):
                s += H[l, i] * K[l, j]
            L[i, j] = s
        s = 0.0
        for l in range(6):
            s += H[l, i] * pc[l]
        hp[i] = s
        u[i] = s
    if not _chol(L, n):
        return False
    _chol_solve(L, n, u)
    for i in range(6):                           # Kt = U D^-1, row by row
        for j in range(n):
            row[j] = K[i, j]
        _chol_solve(L, n, row)
        for j in range(n):
            Kt[i, j] = row[j]
    for i in range(6):
        for j in range(6):
            s = Ic[i, j]
            for l in range(n):
                s -= Kt[i, l] * K[j, l]
            Ia[i, j] = s
    for i in range(6):
        for j in range(n):
            K[i, j] = Kt[i, j]
    return True


@njit(inline="always")
def _articulate3(H, K, Ic, pc, hp, u, Kt, Ia):
    """:func:`_articulate` for three rates (a spherical joint), with D^-1 from an unrolled
    3 x 3 Cholesky factor (False if D is not positive definite)."""
    d00 = d01 = d02 = d11 = d12 = d22 = 0.0
    h0 = h1 = h2 = 0.0
    for l in range(6):
        d00 += H[l, 0] * K[l, 0]
        d01 += H[l, 0] * K[l, 1]
        d02 += H[l, 0] * K[l, 2]
        d11 += H[l, 1] * K[l, 1]
        d12 += H[l, 1] * K[l, 2]
        d22 += H[l, 2] * K[l, 2]
        h0 += H[l, 0] * pc[l]
        h1 += H[l, 1] * pc[l]
        h2 += H[l, 2] * pc[l]
    # D = L L^T (Cholesky, unrolled)
    if not d00 > 0.0:
        return False
    l00 = math.sqrt(d00)
    l10, l20 = d01 / l00, d02 / l00
    s11 = d11 - l10 * l10
    if not s11 > 0.0:
        return False
    l11 = math.sqrt(s11)
    l21 = (d12 - l20 * l10) / l11
    s22 = d22 - l20 * l20 - l21 * l21
    if not s22 > 0.0:
        return False
    l22 = math.sqrt(s22)
    hp[0], hp[1], hp[2] = h0, h1, h2
    # x = D^-1 b by forward and back substitution with L (as _chol_solve, unrolled)
    y0 = h0 / l00
    y1 = (h1 - l10 * y0) / l11
    y2 = (h2 - l20 * y0 - l21 * y1) / l22
    u[2] = y2 / l22
    u[1] = (y1 - l21 * u[2]) / l11
    u[0] = (y0 - l10 * u[1] - l20 * u[2]) / l00
    for i in range(6):                           # Kt = U D^-1, row by row
        y0 = K[i, 0] / l00
        y1 = (K[i, 1] - l10 * y0) / l11
        y2 = (K[i, 2] - l20 * y0 - l21 * y1) / l22
        x2 = y2 / l22
        x1 = (y1 - l21 * x2) / l11
        Kt[i, 0], Kt[i, 1], Kt[i, 2] = (y0 - l10 * x1 - l20 * x2) / l00, x1, x2
    for i in range(6):                           # Ia = I_C - U D^-1 U^T
        for j in range(6):
            Ia[i, j] = Ic[i, j] - (Kt[i, 0] * K[j, 0] + Kt[i, 1] * K[j, 1]
                                   + Kt[i, 2] * K[j, 2])
    for i in range(6):
        K[i, 0], K[i, 1], K[i, 2] = Kt[i, 0], Kt[i, 1], Kt[i, 2]
    return True


@njit
def rhs_joint(t, x, xd, y, T, F, I, W):
    """xd = [zdot, zddot, power of the non-conservative forces] at x = [z, zdot, W]
    (zdot of Euler parameters: 1/2 G^T omega, 5.12); y: the body-state work row
    (13 nb + 1). Returns False if the accelerations are not finite or an articulated inertia
    is singular."""
    tv = tree_views(T)
    parent, child, kind, qo, vo, axis = tv.parent, tv.child, tv.kind, tv.qo, tv.vo, tv.axis
    s_child = tv.s_child
    TI, Tp, TH, Tc, TK, Tu = tv.TI, tv.Tp, tv.TH, tv.Tc, tv.TK, tv.Tu
    nj = parent.size
    bo = body_views(F, I, W)
    nb = bo.mass.size
    nq = qo[nj - 1] + SIZES_Q[kind[nj - 1]] if nj else 0
    nv = x.size - 1 - nq
    zq, zv = array_view(x, 0, (nq,)), array_view(x, nq, (nv,))
    joint_kinematics(zq, zv, T, nb, y)
    if not _bodies_stage(y, F, I, W):
        return False
    r, om, J, g = bo.r, bo.omega, bo.J, bo.g
    for b in range(nb):                          # I_b = M_b = diag(m I, J) (10.6), p_b = g_b
        Ib = TI[b]
        for i in range(6):
            for j in range(6):
                Ib[i, j] = 0.0
            Tp[b, i] = g[6 * b + i]
        for i in range(3):
            Ib[i, i] = bo.mass[b]
            for j in range(3):
                Ib[3 + i, 3 + j] = J[b, i, j]
    # per joint: motion subspace H (6 x n, world axes) and velocity-product acceleration c
    for k in range(nj):
        P, C = parent[k], child[k]
        H, c = TH[k], Tc[k]
        kd = kind[k]
        if kd == FREE:
            for i in range(6):
                for j in range(6):
                    H[i, j] = 1.0 if i == j else 0.0
                c[i] = 0.0
            continue
        wP0, wP1, wP2 = om[P, 0], om[P, 1], om[P, 2]         # the ground's row is 0
        AP, AC = bo.A[P], bo.A[C]
        j0 = -(AC[0, 0] * s_child[k, 0] + AC[0, 1] * s_child[k, 1] + AC[0, 2] * s_child[k, 2])
        j1 = -(AC[1, 0] * s_child[k, 0] + AC[1, 1] * s_child[k, 1] + AC[1, 2] * s_child[k, 2])
        j2 = -(AC[2, 0] * s_child[k, 0] + AC[2, 1] * s_child[k, 1] + AC[2, 2] * s_child[k, 2])
        if kd == TRANSLATIONAL:
            u0 = AP[0, 0] * axis[k, 0] + AP[0, 1] * axis[k, 1] + AP[0, 2] * axis[k, 2]
            u1 = AP[1, 0] * axis[k, 0] + AP[1, 1] * axis[k, 1] + AP[1, 2] * axis[k, 2]
            u2 = AP[2, 0] * axis[k, 0] + AP[2, 1] * axis[k, 1] + AP[2, 2] * axis[k, 2]
            H[0, 0], H[1, 0], H[2, 0], H[3, 0], H[4, 0], H[5, 0] = u0, u1, u2, 0.0, 0.0, 0.0
            sd = zv[vo[k]]
            x0, x1, x2 = wP1 * u2 - wP2 * u1, wP2 * u0 - wP0 * u2, wP0 * u1 - wP1 * u0
            d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
            b0, b1, b2 = wP1 * d2 - wP2 * d1, wP2 * d0 - wP0 * d2, wP0 * d1 - wP1 * d0
            c[0] = 2.0 * x0 * sd + wP1 * b2 - wP2 * b1
            c[1] = 2.0 * x1 * sd + wP2 * b0 - wP0 * b2
            c[2] = 2.0 * x2 * sd + wP0 * b1 - wP1 * b0
            c[3], c[4], c[5] = 0.0, 0.0, 0.0
            continue
        # revolute and spherical: omega_C = omega_P + (rates in world axes); c_w = omega_P x
        # (those rates), c_r = omega_P x (omega_P x d_PJ) + omega_C x (omega_C x d_JC)
        # + c_w x d_JC (d_PJ = r_J - r_P, d_JC = r_C - r_J)
        if kd == REVOLUTE:
            u0 = AP[0, 0] * axis[k, 0] + AP[0, 1] * axis[k, 1] + AP[0, 2] * axis[k, 2]
            u1 = AP[1, 0] * axis[k, 0] + AP[1, 1] * axis[k, 1] + AP[1, 2] * axis[k, 2]
            u2 = AP[2, 0] * axis[k, 0] + AP[2, 1] * axis[k, 1] + AP[2, 2] * axis[k, 2]
            H[0, 0], H[1, 0], H[2, 0] = u1 * j2 - u2 * j1, u2 * j0 - u0 * j2, u0 * j1 - u1 * j0
            H[3, 0], H[4, 0], H[5, 0] = u0, u1, u2
            th = zv[vo[k]]
            e0, e1, e2 = u0 * th, u1 * th, u2 * th
        else:
            o = vo[k]
            for col in range(3):                 # the parent's axis col, and its moment arm
                a0, a1, a2 = AP[0, col], AP[1, col], AP[2, col]
                H[0, col], H[1, col], H[2, col] = a1 * j2 - a2 * j1, a2 * j0 - a0 * j2, \
                    a0 * j1 - a1 * j0
                H[3, col], H[4, col], H[5, col] = a0, a1, a2
            e0 = AP[0, 0] * zv[o] + AP[0, 1] * zv[o + 1] + AP[0, 2] * zv[o + 2]
            e1 = AP[1, 0] * zv[o] + AP[1, 1] * zv[o + 1] + AP[1, 2] * zv[o + 2]
            e2 = AP[2, 0] * zv[o] + AP[2, 1] * zv[o + 1] + AP[2, 2] * zv[o + 2]
        x0, x1, x2 = wP1 * e2 - wP2 * e1, wP2 * e0 - wP0 * e2, wP0 * e1 - wP1 * e0   # c_w
        a0, a1, a2 = r[C, 0] - j0 - r[P, 0], r[C, 1] - j1 - r[P, 1], r[C, 2] - j2 - r[P, 2]
        wC0, wC1, wC2 = om[C, 0], om[C, 1], om[C, 2]
        b0, b1, b2 = wP1 * a2 - wP2 * a1, wP2 * a0 - wP0 * a2, wP0 * a1 - wP1 * a0
        c0, c1, c2 = wP1 * b2 - wP2 * b1, wP2 * b0 - wP0 * b2, wP0 * b1 - wP1 * b0
        b0, b1, b2 = wC1 * j2 - wC2 * j1, wC2 * j0 - wC0 * j2, wC0 * j1 - wC1 * j0
        c0 += wC1 * b2 - wC2 * b1 + (x1 * j2 - x2 * j1)
        c1 += wC2 * b0 - wC0 * b2 + (x2 * j0 - x0 * j2)
        c2 += wC0 * b1 - wC1 * b0 + (x0 * j1 - x1 * j0)
        c[0], c[1], c[2], c[3], c[4], c[5] = c0, c1, c2, x0, x1, x2
    # backward: leaves first
    Ia, L, Kt = tv.w66[0], tv.w66[1], tv.w66[2]  # work arrays of the tree (no allocation;
    G, S = tv.w33[0], tv.w33[1]                  # joint_kinematics is done with w33)
    wv, hp, row = tv.w6[0], tv.w6[1], tv.w6[2]
    for k in range(nj - 1, -1, -1):
        P, C = parent[k], child[k]
        n = SIZES_V[kind[k]]
        H, c, K, u = TH[k], Tc[k], TK[k], Tu[k]
        Ic, pc = TI[C], Tp[C]
        for i in range(6):                       # U = I_C H (in K)
            for j in range(n):
                s = 0.0
                for l in range(6):
                    s += Ic[i, l] * H[l, j]
                K[i, j] = s
        if n == 1:                               # one rate (revolute, translational)
            dk = tv.armature[k]                  # D = J_a + H^T I_C H (forces.armature)
            hp0 = 0.0
            for l in range(6):
                dk += H[l, 0] * K[l, 0]
                hp0 += H[l, 0] * pc[l]
            if not dk > 0.0:
                return False
            hp[0] = hp0
            u[0] = hp0 / dk
            if P < nb:                           # (a root's Ia and w go nowhere)
                for i in range(6):
                    for j in range(6):
                        Ia[i, j] = Ic[i, j] - K[i, 0] * K[j, 0] / dk
            for i in range(6):
                K[i, 0] /= dk
        elif n == 3:
            if not _articulate3(H, K, Ic, pc, hp, u, Kt, Ia):
                return False
        else:
            if not _articulate(H, K, Ic, pc, hp, u, L, Kt, Ia, row, n):
                return False
        if P >= nb:
            continue
        for i in range(6):                       # w = p~ - Ia c, p~ = p_C - U D^-1 H^T p_C
            s = pc[i]
            for l in range(n):
                s -= K[i, l] * hp[l]
            for l in range(6):
                s -= Ia[i, l] * c[l]
            wv[i] = s
        IP, pP = TI[P], Tp[P]
        d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
        # X = [[I, S], [0, I]], S x = x cross d; X^T Ia X = [[Ar, G], [G^T, S^T G + B^T S + C]]
        # with Ia = [[Ar, B], [B^T, C]], G = Ar S + B; X^T w = [w_r, w_w + d x w_r]
        S[0, 0], S[0, 1], S[0, 2] = 0.0, d2, -d1
        S[1, 0], S[1, 1], S[1, 2] = -d2, 0.0, d0
        S[2, 0], S[2, 1], S[2, 2] = d1, -d0, 0.0
        for i in range(3):
            for j in range(3):
                G[i, j] = (Ia[i, 0] * S[0, j] + Ia[i, 1] * S[1, j] + Ia[i, 2] * S[2, j]
                           + Ia[i, 3 + j])
        for i in range(3):
            for j in range(3):
                IP[i, j] += Ia[i, j]
                IP[i, 3 + j] += G[i, j]
                IP[3 + j, i] += G[i, j]
                IP[3 + i, 3 + j] += (S[0, i] * G[0, j] + S[1, i] * G[1, j] + S[2, i] * G[2, j]
                                     + Ia[0, 3 + i] * S[0, j] + Ia[1, 3 + i] * S[1, j]
                                     + Ia[2, 3 + i] * S[2, j] + Ia[3 + i, 3 + j])
        pP[0] += wv[0]
        pP[1] += wv[1]
        pP[2] += wv[2]
        pP[3] += wv[3] + d1 * wv[2] - d2 * wv[1]
        pP[4] += wv[4] + d2 * wv[0] - d0 * wv[2]
        pP[5] += wv[5] + d0 * wv[1] - d1 * wv[0]
    # forward: roots first; the bodies' vdot into bo.vdot, zddot into xd
    vd = bo.vdot
    for k in range(nj):
        P, C = parent[k], child[k]
        n = SIZES_V[kind[k]]
        H, c, K, u = TH[k], Tc[k], TK[k], Tu[k]
        for i in range(6):
            wv[i] = c[i]
        if P < nb:                               # w = X vdot_P + c
            o = 6 * P
            d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
            wv[0] += vd[o] + vd[o + 4] * d2 - vd[o + 5] * d1
            wv[1] += vd[o + 1] + vd[o + 5] * d0 - vd[o + 3] * d2
            wv[2] += vd[o + 2] + vd[o + 3] * d1 - vd[o + 4] * d0
            wv[3] += vd[o + 3]
            wv[4] += vd[o + 4]
            wv[5] += vd[o + 5]
        for j in range(n):                       # zdd = u - K^T w
            s = u[j]
            for i in range(6):
                s -= K[i, j] * wv[i]
            row[j] = s
            xd[nq + vo[k] + j] = s
        for i in range(6):                       # vdot_C = w + H zdd
            s = wv[i]
            for j in range(n):
                s += H[i, j] * row[j]
            vd[6 * C + i] = s
        # zdot: the rates, or 1/2 G^T omega for Euler parameters (5.12)
        oq, ov = qo[k], vo[k]
        if kind[k] == SPHERICAL:
            pd = pdot_scalar(_unit(zq, oq), (zv[ov], zv[ov + 1], zv[ov + 2]))
            xd[oq], xd[oq + 1], xd[oq + 2], xd[oq + 3] = pd
        elif kind[k] == FREE:
            for i in range(3):
                xd[oq + i] = zv[ov + i]
            pd = pdot_scalar(_unit(zq, oq + 3), (zv[ov + 3], zv[ov + 4], zv[ov + 5]))
            xd[oq + 3], xd[oq + 4], xd[oq + 5], xd[oq + 6] = pd
        else:
            xd[oq] = zv[ov]
    xd[nq + nv] = bo.g_power[0]
    for k in range(nq + nv + 1):
        if not math.isfinite(xd[k]):
            return False
    return True
