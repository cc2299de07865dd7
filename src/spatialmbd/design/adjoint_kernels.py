"""Compiled forward and backward passes of the discrete adjoint (:mod:`.adjoint`).

The scheme differentiated is the one :func:`spatialmbd.sweep.forward_sensitivities`
integrates: classic RK4 (Eqs. 13.14, 13.19) on y = [q, v, w] with the right-hand side of the
standard / Baumgarte method (:func:`spatialmbd.dynamics.standard.rhs_standard`, the index-1
ODE of Eq. 12.3), each step followed by the renormalisation of every body's Euler parameters,
p -> p / |p| (Eq. 4.30). One step is the map

    k1 = f(t, y)            Y2 = y + h/2 k1      k2 = f(t + h/2, Y2)
    Y3 = y + h/2 k2         k3 = f(t + h/2, Y3)  Y4 = y + h k3       k4 = f(t + h, Y4)
    y+ = P(y + h/6 (k1 + 2 k2 + 2 k3 + k4))

and its adjoint, for a cotangent ybar+ (n, K) of y+ (K cotangents at once):

    yhat_bar = P'^T ybar+     (P' = (I - p^ p^T) / |p| per body, symmetric)
    kbar_i = h b_i yhat_bar   (b = 1/6, 1/3, 1/3, 1/6)
    stage 4: Ybar4 = f_y(Y4)^T kbar4, Fbar += f_F(Y4)^T kbar4, kbar3 += h Ybar4
    stage 3: Ybar3 = f_y(Y3)^T kbar3, ...,                    kbar2 += h/2 Ybar3
    stage 2: Ybar2 = f_y(Y2)^T kbar2, ...,                    kbar1 += h/2 Ybar2
    ybar = yhat_bar + Ybar4 + Ybar3 + Ybar2 + f_y(y)^T kbar1

f_y^T kbar and f_F^T kbar are vector-Jacobian products whose Jacobian columns are central
differences of the compiled right-hand side, (f(y + e_c) - f(y - e_c)) / (2 e), e = eps
max(1, |y_c|) (eps = 1e-6: truncation ~ eps^2, rounding ~ 1e-16 / eps, both below 1e-9
relative), over every state c and every packed model float a in ``active`` (those the
parameters move); all inside one compiled loop, no Python per step.

Checkpointing: the forward pass stores the state at every ``every``-th step; the backward
pass recomputes the states of one segment (at most ``every`` steps) from its checkpoint before
it walks the segment backwards, so memory is (n_steps / every + every) states.
"""
from __future__ import annotations

import numpy as np

from ..dynamics.standard import rhs_standard
from ..jit import njit
from .adjoint_vjp import vjp_structured

B_RK4 = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)


@njit
def _project(y, nb):
    """Renormalise the Euler parameters of every body in place (Eq. 4.30)."""
    for b in range(nb):
        o = 7 * b + 3
        s = 0.0
        for i in range(4):
            s += y[o + i] * y[o + i]
        norm = np.sqrt(s)
        for i in range(4):
            y[o + i] /= norm


@njit
def _step(t, h, y, k1, k2, k3, k4, tmp, F, I, W, mp, nb):
    """One RK4 step of y in place; returns the right-hand side status (0 = OK)."""
    n = y.size
    st = rhs_standard(t, y, k1, F, I, W, mp)
    if st != 0:
        return st
    for i in range(n):
        tmp[i] = y[i] + 0.5 * h * k1[i]
    st = rhs_standard(t + 0.5 * h, tmp, k2, F, I, W, mp)
    if st != 0:
        return st
    for i in range(n):
        tmp[i] = y[i] + 0.5 * h * k2[i]
    st = rhs_standard(t + 0.5 * h, tmp, k3, F, I, W, mp)
    if st != 0:
        return st
    for i in range(n):
        tmp[i] = y[i] + h * k3[i]
    st = rhs_standard(t + h, tmp, k4, F, I, W, mp)
    if st != 0:
        return st
    for i in range(n):                                          # Eq. (13.14)
        y[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
    _project(y, nb)
    return 0


@njit
def forward_pass(step_t, step_h, out_after, y0, Y_out, checkpoints, every, F, I, W, mp, nb):
    """Integrate from y0 along the steps (step_t, step_h) (n_steps,); after step i the state
    goes into Y_out[out_after[i]] when out_after[i] >= 0, and before step i into
    checkpoints[i // every] when i % every == 0. Returns (status, failed step index)."""
    n = y0.size
    y = y0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    for i in range(step_t.size):
        if i % every == 0:
            checkpoints[i // every, :] = y
        st = _step(step_t[i], step_h[i], y, k1, k2, k3, k4, tmp, F, I, W, mp, nb)
        if st != 0:
            return st, i
        if out_after[i] >= 0:
            Y_out[out_after[i], :] = y
    return 0, -1


@njit
def _vjp(t, Y, kbar, ybar, Fbar, F, I, W, mp, active, fp, fm, eps):
    """ybar += f_y(t, Y)^T kbar and Fbar += f_F(t, Y)[:, active]^T kbar (central differences
    of the compiled right-hand side; kbar (n, K)). Returns the status (0 = OK)."""
    n, K = kbar.shape
    for c in range(n):
        yc = Y[c]
        e = eps * max(1.0, abs(yc))
        Y[c] = yc + e
        s1 = rhs_standard(t, Y, fp, F, I, W, mp)
        Y[c] = yc - e
        s2 = rhs_standard(t, Y, fm, F, I, W, mp)
        Y[c] = yc
        if s1 != 0 or s2 != 0:
            return 1
        for k in range(K):
            acc = 0.0
            for r in range(n):
                acc += (fp[r] - fm[r]) * kbar[r, k]
            ybar[c, k] += acc / (2.0 * e)
    for j in range(active.size):
        a = active[j]
        fa = F[a]
        e = eps * max(abs(fa), 1e-3)
        F[a] = fa + e
        s1 = rhs_standard(t, Y, fp, F, I, W, mp)
        F[a] = fa - e
        s2 = rhs_standard(t, Y, fm, F, I, W, mp)
        F[a] = fa
        if s1 != 0 or s2 != 0:
            return 1
        for k in range(K):
            acc = 0.0
            for r in range(n):
                acc += (fp[r] - fm[r]) * kbar[r, k]
            Fbar[j, k] += acc / (2.0 * e)
    return 0


@njit
def _pvjp(t, Y, kbar, ybar, Fbar, F, I, W, mp, active, fp, fm, eps, S, structured):
    """The stage's vector-Jacobian product by the structured or the dense path."""
    if structured:
        return vjp_structured(t, Y, kbar, ybar, Fbar, F, I, W, mp, active, eps, S)
    return _vjp(t, Y, kbar, ybar, Fbar, F, I, W, mp, active, fp, fm, eps)


@njit
def _step_adjoint(t, h, y, ybar, Fbar, F, I, W, mp, nb, active, eps, work, S, structured):
    """ybar (n, K): the cotangent of y+ on entry, of y on return (Fbar accumulated)."""
    n, K = ybar.shape
    k1, k2, k3, k4, Y2, Y3, Y4, yh, fp, fm = work
    rhs_standard(t, y, k1, F, I, W, mp)
    for i in range(n):
        Y2[i] = y[i] + 0.5 * h * k1[i]
    rhs_standard(t + 0.5 * h, Y2, k2, F, I, W, mp)
    for i in range(n):
        Y3[i] = y[i] + 0.5 * h * k2[i]
    rhs_standard(t + 0.5 * h, Y3, k3, F, I, W, mp)
    for i in range(n):
        Y4[i] = y[i] + h * k3[i]
    rhs_standard(t + h, Y4, k4, F, I, W, mp)
    for i in range(n):
        yh[i] = y[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
    for b in range(nb):                             # P'^T ybar, P' = (I - p^ p^T) / |p|
        o = 7 * b + 3
        norm = np.sqrt(yh[o] ** 2 + yh[o + 1] ** 2 + yh[o + 2] ** 2 + yh[o + 3] ** 2)
        for k in range(K):
            dot = 0.0
            for i in range(4):
                dot += yh[o + i] / norm * ybar[o + i, k]
            for i in range(4):
                ybar[o + i, k] = (ybar[o + i, k] - yh[o + i] / norm * dot) / norm
    kb = np.empty((4, n, K))
    for s in range(4):
        w = h * (1.0 / 6.0 if s == 0 or s == 3 else 1.0 / 3.0)
        for i in range(n):
            for k in range(K):
                kb[s, i, k] = w * ybar[i, k]
    Yb = np.zeros((n, K))
    if _pvjp(t + h, Y4, kb[3], Yb, Fbar, F, I, W, mp, active, fp, fm, eps, S, structured):
        return 1
    for i in range(n):
        for k in range(K):
            ybar[i, k] += Yb[i, k]
            kb[2, i, k] += h * Yb[i, k]
            Yb[i, k] = 0.0
    if _pvjp(t + 0.5 * h, Y3, kb[2], Yb, Fbar, F, I, W, mp, active, fp, fm, eps, S,
                 structured):
        return 1
    for i in range(n):
        for k in range(K):
            ybar[i, k] += Yb[i, k]
            kb[1, i, k] += 0.5 * h * Yb[i, k]
            Yb[i, k] = 0.0
    if _pvjp(t + 0.5 * h, Y2, kb[1], Yb, Fbar, F, I, W, mp, active, fp, fm, eps, S,
                 structured):
        return 1
    for i in range(n):
        for k in range(K):
            ybar[i, k] += Yb[i, k]
            kb[0, i, k] += 0.5 * h * Yb[i, k]
    y1 = y.copy()
    if _pvjp(t, y1, kb[0], ybar, Fbar, F, I, W, mp, active, fp, fm, eps, S, structured):
        return 1
    return 0


@njit
def backward_pass(step_t, step_h, out_after, out0, checkpoints, every, K, ptr, rows, cols,
                  vals, F, I, W, mp, nb, active, eps, S, structured):
    """The adjoint sweep: returns (status, ybar0 (n, K), Fbar (n_active, K)) for K costs
    whose derivatives with respect to the state at output time o are the entries
    ptr[o] .. ptr[o + 1] - 1 of (rows: state index, cols: cost index, vals: d cost / d y)."""
    n = checkpoints.shape[1]
    ybar = np.zeros((n, K))
    Fbar = np.zeros((active.size, K))
    work = (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
            np.empty(n), np.empty(n), np.empty(n), np.empty(n))
    ns = step_t.size
    seg = np.empty((every + 1, n))
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    n_seg = (ns + every - 1) // every
    for s in range(n_seg - 1, -1, -1):
        i0 = s * every
        i1 = min(ns, i0 + every)
        seg[0, :] = checkpoints[s]
        y = checkpoints[s].copy()
        for i in range(i0, i1 - 1):                     # recompute the segment's states
            _step(step_t[i], step_h[i], y, k1, k2, k3, k4, tmp, F, I, W, mp, nb)
            seg[i - i0 + 1, :] = y
        for i in range(i1 - 1, i0 - 1, -1):
            if out_after[i] >= 0:
                o = out_after[i]
                for e in range(ptr[o], ptr[o + 1]):
                    ybar[rows[e], cols[e]] += vals[e]
            y = seg[i - i0].copy()
            if _step_adjoint(step_t[i], step_h[i], y, ybar, Fbar, F, I, W, mp, nb, active,
                             eps, work, S, structured):
                return 1, ybar, Fbar
    if out0 >= 0:
        for e in range(ptr[out0], ptr[out0 + 1]):
            ybar[rows[e], cols[e]] += vals[e]
    return 0, ybar, Fbar


@njit
def vjp_at(t, Y, kbar, F, I, W, mp, active, eps, S, structured):
    """(f_y^T kbar, f_F[:, active]^T kbar) at one state (the set-up's check of the structured
    path against the dense one)."""
    n, K = kbar.shape
    ybar = np.zeros((n, K))
    Fbar = np.zeros((active.size, K))
    st = _pvjp(t, Y.copy(), kbar, ybar, Fbar, F, I, W, mp, active, np.empty(n), np.empty(n),
               eps, S, structured)
    return st, ybar, Fbar
