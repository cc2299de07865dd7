"""The finite-difference Jacobian df/dy of the implicit integrators (bdf4 and, when the problem
has no ``jac``, SciPy's Radau, BDF and LSODA), with increments sized to the right-hand side's
round-off.

Forward differences (f(y + d_j e_j) - f(y)) / d_j have the error |f''| d_j / 2 + eps_f |f| / d_j,
eps_f the relative round-off of f; d_j = sqrt(eps_f) s_j balances the two (s_j = max(|y_j|,
atol_j / rtol), the size below which a component counts as small). eps_f is the machine epsilon
for a right-hand side computed to round-off, but not for the equations of motion at a nearly
singular position: the multiplier solve amplifies round-off by the inverse of the small
singular value (or of the regularising shift), and on the random closed loop rand2007 of
tests/dynamics/data f changes by 1e-5 of itself for state perturbations of 1e-15 for the first
0.5 ms. sqrt(eps) increments then give columns that are noise (central differences at 1e-8 and
1e-6 differed by 58 times the Jacobian's norm); Newton diverged with a fresh Jacobian at step
sizes far below those the error test allowed (bdf4: 2,662 Newton failures in 3,280 steps).
So eps_f is measured at every Jacobian, by one more evaluation at a perturbation of a few ulps
(:func:`rhs_noise`).

SciPy's own ``num_jac`` starts from sqrt(eps) max(|y_j|, atol): 1.5e-17 for a component at 0
with atol = 1e-9, round-off of the right-hand side; on the four-bar with a 1e8 N/m spring its
columns made Radau's Newton diverge with a fresh Jacobian (contraction rate ~1) at every step.
"""
from __future__ import annotations

import math

import numpy as np

EPS = float(np.finfo(float).eps)
#: the perturbation (in units of eps s_j) of the round-off measurement
NOISE_PROBE = 64.0
#: the largest relative round-off assumed (increments up to sqrt of it, 1 % of s_j)
MAX_NOISE = 1e-4


def rhs_noise(rhs, t: float, y: np.ndarray, fy: np.ndarray, scale: np.ndarray,
              nd: int) -> float:
    """The relative round-off of ``rhs`` at (t, y): max |f(y + u) - f(y)| / max |f(y)| for
    u_j = +-NOISE_PROBE eps scale_j (alternating signs, the first nd components), at least eps,
    at most MAX_NOISE. The linear part J u is included: it is of the same size as round-off
    for a right-hand side without amplification. One evaluation."""
    u = np.zeros_like(y)
    u[:nd] = NOISE_PROBE * EPS * scale[:nd]
    u[1:nd:2] *= -1.0
    df = rhs(t, y + u) - fy
    size = float(np.max(np.abs(fy))) if fy.size else 0.0
    if not size > 0.0:
        return EPS
    noise = float(np.max(np.abs(df))) / size
    if not math.isfinite(noise):
        return MAX_NOISE
    return min(MAX_NOISE, max(EPS, noise))


def fd_jacobian(rhs, t: float, y: np.ndarray, fy: np.ndarray, typical: np.ndarray, nd: int,
                J: np.ndarray) -> int:
    """J[:, :nd] = forward differences of ``rhs`` at (t, y), fy = rhs(t, y); returns the number
    of evaluations (nd + 1) for the caller to count.

    The increment of component j is sqrt(eps_f) max(|y_j|, typical_j) (rounded to a
    representable one), typical = atol / rtol, eps_f = :func:`rhs_noise`. The columns from nd
    on (the quadratures, which rhs does not read) are left as they are (zero).
    """
    s = np.maximum(np.abs(y), typical)
    rel = math.sqrt(rhs_noise(rhs, t, y, fy, s, nd))
    for j in range(nd):
        yj = y.copy()
        yj[j] += rel * s[j]
        d = yj[j] - y[j]                 # the exactly representable increment
        J[:, j] = (rhs(t, yj) - fy) / d
    return nd + 1
