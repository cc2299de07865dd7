"""Compiled arithmetic of explicit Runge-Kutta stages, shared by the integrators and by the
compiled right-hand sides that evaluate whole sets of stages (``ODEProblem.stages``).

A stage s of an explicit method with nodes c, tableau a (rows a_s, zero above the diagonal) and
slopes k_j (the stage derivatives) is
    Y_s = y + h sum_(j<s) a_sj k_j,   k_s = f(t + c_s h, Y_s).
(The names avoid A and K, the rotation matrix and M + alpha D^T D of the text.)
"""
from __future__ import annotations

from ..jit import njit


@njit
def rk_combine(y, h, tableau, slopes, s, out):
    """out = y + h sum_(j<s) tableau[s, j] slopes[j] (the stage vector Y_s)."""
    for i in range(y.size):
        acc = 0.0
        for j in range(s):
            acc += tableau[s, j] * slopes[j, i]
        out[i] = y[i] + h * acc


def rk_stages(f, t, y, h, tableau, nodes, slopes, s0, s1, out, t_last):
    """Stages s0 .. s1-1 with the rhs f (Python): slopes[s] = f(t + nodes[s] h, Y_s); the stage
    vectors go to ``out`` (the last one stays there); the last stage is evaluated at t_last (the
    exact end of the step)."""
    for s in range(s0, s1):
        rk_combine(y, h, tableau, slopes, s, out)
        slopes[s] = f(t_last if s == s1 - 1 else t + nodes[s] * h, out)
