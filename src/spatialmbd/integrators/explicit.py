"""Compiled arithmetic of explicit Runge-Kutta stages, shared by the integrators and by the
compiled right-hand sides that evaluate whole sets of stages (``ODEProblem.stages``).

A stage s of an explicit method with tableau A (rows a_s, zero above the diagonal) is
    Y_s = y + h sum_(j<s) a_sj K_j,   K_s = f(t + c_s h, Y_s).
"""
from __future__ import annotations

from ..jit import njit


@njit
def rk_combine(y, h, A, K, s, out):
    """out = y + h sum_(j<s) A[s, j] K[j] (the stage vector Y_s)."""
    for i in range(y.size):
        acc = 0.0
        for j in range(s):
            acc += A[s, j] * K[j, i]
        out[i] = y[i] + h * acc


def rk_stages(f, t, y, h, A, C, K, s0, s1, out, t_last):
    """Stages s0 .. s1-1 with the rhs f (Python): K[s] = f(t + C[s] h, Y_s); the stage vectors
    go to ``out`` (the last one stays there); the last stage is evaluated at t_last (the exact
    end of the step)."""
    for s in range(s0, s1):
        rk_combine(y, h, A, K, s, out)
        K[s] = f(t_last if s == s1 - 1 else t + C[s] * h, out)
