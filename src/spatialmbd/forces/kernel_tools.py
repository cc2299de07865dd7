"""Compiled helpers shared by the force-element kernels."""
from __future__ import annotations

from ..jit import njit


@njit(inline="always")
def add_wrench(g, b, f0, f1, f2, n0, n1, n2):
    """g[6 b : 6 b + 6] += [f, n] unless b is the ground (index nb, beyond g)."""
    o = 6 * b
    if o + 5 < g.size:
        g[o] += f0
        g[o + 1] += f1
        g[o + 2] += f2
        g[o + 3] += n0
        g[o + 4] += n1
        g[o + 5] += n2
