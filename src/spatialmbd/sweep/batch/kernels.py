"""The compiled part of a batch: one loop over the members, each integrated by the one compiled
adaptive driver (:mod:`...integrators.adaptive_driver`) on the body coordinates
(:func:`...dynamics.fused.dopri_run`, or the RK4 driver there) or on the joint coordinates
(:func:`...dynamics.recursive.dopri_joint`)."""
from __future__ import annotations

import numpy as np

from ...dynamics import recursive as rc
from ...dynamics.fused import OK, TOO_MANY_STEPS, dopri_run, rk4_outputs
from ...dynamics.layout import bare
from ...jit import array_view, njit


# ------------------------------------------------------------------------------ compiled part
@njit(inline="always")
def _rows(A):
    """A (B, k) C-contiguous as one flat uncounted view (rows at b k)."""
    return bare(A.reshape(-1))


@njit(nogil=True)
def integrate_batch(b0, b1, Y0, F, I, W, mp, pp, t_out, adaptive, pair, rtol, atol, max_step,
                    step, max_steps, nb, lam_off, Y, Yd, Lam, status, t_fail, counters):
    """Members b0 <= b < b1: integrate Y0[b] with F[b], W[b] (the shared I) into Y[b] (nt, n)
    and, when Yd and Lam have rows (nt each, else none), vdot into Yd[b] (nt, 6 nb) and
    lambda into Lam[b] (nt, m). status[b]: 0 or a failure code (t_fail[b] the time);
    counters[b] = (nfev, steps, rejected). adaptive: the Dormand-Prince pair ``pair``
    (:mod:`..integrators.pairs`), else RK4 with ``step``. Without the GIL: ranges of members
    run in threads at once (each member has its own F, W, state and outputs; I is read
    only). The arrays are read as uncounted views, as in :func:`integrate_batch_joint`."""
    I, mp, pp, t_out = bare(I), bare(mp), bare(pp), bare(t_out)
    nF, nW, nt, n = F.shape[1], W.shape[1], Y.shape[1], Y.shape[2]
    F, W = _rows(F), _rows(W)
    rows, nd, nl = Yd.shape[1], Yd.shape[2], Lam.shape[2]
    Yf, Ydf, Lamf, cf = _rows(Y), _rows(Yd), _rows(Lam), _rows(counters)
    for b in range(b0, b1):
        Fb, Wb = array_view(F, b * nF, (nF,)), array_view(W, b * nW, (nW,))
        Yb = array_view(Yf, b * nt * n, (nt, n))
        Ydb = array_view(Ydf, b * rows * nd, (rows, nd))
        Lamb = array_view(Lamf, b * rows * nl, (rows, nl))
        cb = array_view(cf, 3 * b, (3,))
        ppb = pp.copy()                   # the singular-position guard's state: per member
        if adaptive:
            code, tf = dopri_run(Y0[b], Fb, I, Wb, mp, ppb, pair, 0.0, t_out, rtol, atol,
                                 max_step, max_steps, nb, Yb, Ydb, Lamb, lam_off, cb)
        else:
            code, tf = rk4_outputs(0.0, Y0[b].copy(), Fb, I, Wb, mp, ppb, t_out, 0,
                                   t_out.size, 0, step, nb, Yb, Ydb, Lamb, lam_off, cb)
        status[b] = code
        t_fail[b] = tf


@njit(nogil=True)
def integrate_batch_joint(b0, b1, X0, Ti, Tf, F, I, W, t_out, pair, rtol, atol, max_step,
                          max_steps, nb, nq, mp, lam_off, X, Y, Yd, Lam, status, t_fail,
                          counters):
    """The recursive method's members b0 <= b < b1: the joint state X0[b] (tree packs Ti,
    shared, and Tf[b], the member's geometry and work) integrated by
    :func:`..dynamics.recursive.dopri_joint` (the pair ``pair``) into X[b] (nt, nx); the
    bodies' [q, v, work] at the outputs into Y[b] and, when Yd and Lam have rows, vdot and
    lambda (standard method, params mp) into Yd[b], Lam[b]. status, t_fail, counters as
    :func:`integrate_batch`."""
    n = X0.shape[1]
    nt = t_out.size
    # shared arrays and rows as uncounted views: every call of the driver and of the
    # right-hand side would otherwise update the reference counts of the arrays all threads
    # share (one cache line ping-ponged between the cores: 1.2x instead of 2x on two threads)
    Ti, I, t_out, mp = bare(Ti), bare(I), bare(t_out), bare(mp)
    nT, nF, nW = Tf.shape[1], F.shape[1], W.shape[1]
    Tf, F, W = _rows(Tf), _rows(F), _rows(W)
    nx, ny, nd, nl = X.shape[2], Y.shape[2], Yd.shape[2], Lam.shape[2]
    Xf, Yf = bare(X.reshape(-1)), bare(Y.reshape(-1))
    Ydf, Lamf, cf = bare(Yd.reshape(-1)), bare(Lam.reshape(-1)), bare(counters.reshape(-1))
    rows = Yd.shape[1]
    for b in range(b0, b1):
        x = X0[b].copy()
        K0 = np.empty(n)
        T = (Ti, array_view(Tf, b * nT, (nT,)))
        Fb, Wb = array_view(F, b * nF, (nF,)), array_view(W, b * nW, (nW,))
        Xb = array_view(Xf, b * nt * nx, (nt, nx))
        code, t, h, err, done = rc.dopri_joint(0.0, x, K0, 0.0, 1e-4, T, Fb, I, Wb, pair,
                                               0.0, t_out, 0, rtol, atol, max_step,
                                               max_steps, Xb, array_view(cf, 3 * b, (3,)))
        if code == OK and done < nt:
            code = TOO_MANY_STEPS
        status[b] = code
        t_fail[b] = t
        Yb = array_view(Yf, b * nt * ny, (done, ny))
        rc.body_rows(array_view(Xf, b * nt * nx, (done, nx)), T, nb, nq, Yb)
        if rows:
            rc.output_accelerations(t_out[:done], Yb, Fb, I, Wb, mp, lam_off,
                                    array_view(Ydf, b * rows * nd, (done, nd)),
                                    array_view(Lamf, b * rows * nl, (done, nl)))
        for k in range(b * nt * ny + done * ny, (b + 1) * nt * ny):   # past a failure: NaN
            Yf[k] = np.nan
        for k in range(b * rows * nd + done * nd, (b + 1) * rows * nd):
            Ydf[k] = np.nan
        for k in range(b * rows * nl + done * nl, (b + 1) * rows * nl):
            Lamf[k] = np.nan


def _run_members(args, B: int, threads: bool, kernel=None) -> None:
    """kernel (default integrate_batch) over all B members: in one call, or (threads) in
    ranges of members handed to one thread per core as each finishes its previous range."""
    import os
    kernel = integrate_batch if kernel is None else kernel
    cores = os.cpu_count() or 1
    if not threads or cores < 2 or B < 2:
        kernel(0, B, *args)
        return
    from concurrent.futures import ThreadPoolExecutor
    size = max(1, B // (8 * cores))                  # small ranges: members differ in cost
    with ThreadPoolExecutor(max_workers=min(cores, B)) as pool:
        futures = [pool.submit(kernel, b0, min(B, b0 + size), *args)
                   for b0 in range(0, B, size)]
        for f in futures:
            f.result()
