"""The singular-position guard of the methods that follow their constraint drift (standard,
Baumgarte, penalty, augmented Lagrangian without its projection): where the run comes so close to a singular position
that its drift decides the branch, it stops with a diagnosis instead of going on, perhaps on
the other branch, and reporting success.

Why these methods cannot pass a singular position by design (docs/choosing.md). They keep the
state on a drifted manifold Phi(q) = eps (eps: the constraint violation the integration has
accumulated, or the penalty's compliance), not on Phi = 0. At a bifurcation point of Phi = 0 --
the N-four-bar's flat positions, where the parallelogram and the crossed branch meet -- the
drifted manifold is split: like x y = eps near the crossing axes x y = 0, its pieces turn from
one branch onto the other at a distance of order sqrt(|eps| L) from the singular position, with
a curvature the integrator resolves exactly. A run of these methods therefore passes straight
only when a step happens to jump the gap, and otherwise follows the turn onto the other branch
with the constraints satisfied (the projection method returns to Phi = 0 after every step, so
its steps cross the singular position straight; it is not guarded).

The guard measures, after every accepted step, how close the state is to a singular position:
r = sigma_min / sigma_max of the kept rows of D with the rotation columns divided by L and
every row then scaled to unit length, so r is a geometric quantity, independent of masses and
of the rows' units (0.19 for the 2-loop N-four-bar at its start,
0 at a singular position; it shrinks with the size of a closed-loop mechanism: 1e-3 for 40
loops); L is the model's length scale (:func:`..guards.guard_length`: its
extent, or its longest lever arm if larger). With eps = max_a |Phi_a| / |row a| (the drift as
a distance, in m) it stops where

    r < GUARD_FACTOR * sqrt(eps / L)   on the approach (r < APPROACH * its largest value
                                       so far),

the region where the drifted manifold's split is within a few times its distance to the
singular position (at the turn of the 2-loop N-four-bar under the standard method at rk45 rtol
1e-6, r fell to 7.5e-5 with sqrt(eps / L) = 1.5e-3: 0.05 of the band). A turn has a curvature
radius of order sqrt(eps L), so the integrator resolves it with steps that land inside that region
on the approach. Only an approach counts: a run that starts at a singular position (rows
dependent there, independent along the initial velocity: the regression models rand2000 and
rand2007 of tests/dynamics/data) has had its branch chosen by that velocity and moves away from
it, r growing from 0. (The penalty methods' compliance keeps rand2007 inside the band all along
-- r a fraction of sqrt(eps / L) -- so they stop there once r heads back towards the
singular position, near t = 0.075 and 0.1 s.)

sigma_min comes from a compiled inverse iteration on the sparse Cholesky factor of D~ D~^T
(no BLAS: the same decision on every processor), an upper bound of it; sigma_max is taken as
its lower bound 1 (the rows have unit length, and the largest eigenvalue of D~ D~^T is at least
its largest diagonal entry). So the estimated r is never below the true one: the guard never
stops a run earlier than the rule says. It costs one evaluation of the constraints, one
factorisation and GUARD_ITERATIONS triangular solve pairs per accepted step.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import njit
from . import sparse as spc
from .algebra import _P, _R, _state, assemble_schur
from .layout import body_views, cons_views, schur_views

#: the guard stops where r < GUARD_FACTOR sqrt(eps / L) (module docstring)
GUARD_FACTOR = 1.0
#: a run approaches a singular position once r has fallen below this fraction of its largest
#: value so far
APPROACH = 0.5
#: iterations of the inverse iteration (sigma_min)
GUARD_ITERATIONS = 8


@njit
def _start_vector(n, x):
    """A fixed vector with no symmetry (a symmetric mechanism's singular mode may be
    orthogonal to the vector of ones), unit length."""
    s = 0.0
    for k in range(n):
        x[k] = 1.0 + 0.5 * math.sin(1.2345 * k + 0.321)
        s += x[k] * x[k]
    s = math.sqrt(s)
    for k in range(n):
        x[k] /= s


@njit
def singular_ratio(t, y, F, I, W, length):
    """(sigma_min / sigma_max of the kept rows of D at the state y, each row scaled to unit
    length after the rotation columns are divided by ``length``; the largest constraint
    violation as a distance, max_a |Phi_a| / |row a|, m): r = 0 where D~ D~^T has no positive
    pivot (a singular position, a vanishing row, a NaN), 1 without constraint rows."""
    bo, co, sc = body_views(F, I, W), cons_views(F, I, W), schur_views(F, I, W)
    _state(t, y, 0.0, bo, co)                       # the constraints at y (no forces)
    P = _P(sc)
    n = P[0].size
    D, row_bi, row_bj = _R(co)
    m_con = co.phi.size
    nb = bo.mass.size
    Ds = np.zeros(D.shape)
    eps = 0.0
    for k in range(n):
        a = P[0][k]
        if a >= m_con:                          # an armature row (left out: rows_only)
            continue
        norm = 0.0
        for c in range(12):                     # the ground's side does not count
            side = row_bi[a] if c < 6 else row_bj[a]
            x = 0.0 if side >= nb else (D[a, c] / length if (c % 6) >= 3 else D[a, c])
            Ds[a, c] = x
            norm += x * x
        norm = math.sqrt(norm)
        if not (norm > 0.0 and math.isfinite(norm)):
            return 0.0, math.inf
        for c in range(12):
            Ds[a, c] /= norm
        eps = max(eps, abs(co.phi[a]) / norm)
    if n == 0:
        return 1.0, eps
    mass = np.ones(nb)
    unit = np.zeros((nb, 3, 3))
    for b in range(nb):
        for c in range(3):
            unit[b, c, c] = 1.0
    assemble_schur((mass, unit, unit), (Ds, row_bi, row_bj), P, True, True)
    sym, Cx, Lx, xs, ys = P[11], P[7], P[8], P[9], P[10]
    x = np.empty(n)
    if spc.numeric_ratio(sym, Cx, Lx, xs) <= 0.0:
        return 0.0, eps
    _start_vector(n, x)                              # sigma_min^2: inverse iteration
    inv = 0.0
    for _ in range(GUARD_ITERATIONS):
        spc.solve(sym, Lx, x, ys)
        inv = math.sqrt(np.sum(x * x))
        if not (inv > 0.0 and math.isfinite(inv)):
            return 0.0, eps
        for k in range(n):
            x[k] /= inv
    return math.sqrt(max(1.0 / inv, 0.0)), eps     # / sigma_max, taken as its lower bound 1


@njit
def passes_guard(t, y, F, I, W, gp):
    """False where the run is to stop (gp = [on, factor, length, the largest r of the run so
    far (0 at the start; updated here)]: the rule of this module, on approach); True with the
    guard off."""
    if gp[0] == 0.0:
        return True
    r, eps = singular_ratio(t, y, F, I, W, gp[2])
    approaching = r < APPROACH * gp[3]
    gp[3] = max(gp[3], r)
    return not (approaching and r < gp[1] * math.sqrt(eps / gp[2]))
