"""Forward dynamics driver: initial-condition correction, the time loop, saving and counters.

One module per job: ``setup`` (output times, method and integrator, mobility at the start,
checks), ``rhs`` (the right-hand side), ``run`` (:func:`simulate`), ``compiled`` (runs in
compiled code from start to end, in slices), ``assembly`` (results at the output times,
counters, events) and ``progress``.

Data flows one way (STYLE.md): model -> state (t, q, v) -> assembly -> method (vdot, lam) ->
integrator -> results. The integrator advances y = [q (7 nb), v (6 nb), z, W] with
    qdot = T(q) v (rdot as is, pdot = 1/2 G^T omega, Eq. 5.12),  vdot from the method,
    zdot = the rates of the force elements' internal states (LuGre bristles; usually none),
    Wdot = power of non-conservative forces and drivers (for the energy balance; last).
Euler parameters: the right-hand side uses p / |p| (so A(p) is always a rotation) and every
accepted step renormalises p; since p^T pdot = 0 exactly, this only removes integration error
(a projection onto the unit sphere, which does not lower the integrator's order).

The right-hand side of the built-in methods is compiled (:mod:`.dynamics.system`): one call per
evaluation when the model has no force elements and only compiled joint types, otherwise two
compiled stages around the Python force elements. Methods without a compiled path run through
``Method.accelerations``. Large models skip the dense rank analysis of D when a sparse Cholesky
factorisation of D D^T shows that its rows are independent.
"""
from __future__ import annotations

from .run import simulate
from .rhs import right_hand_side
from .setup import RedundantConstraintsWarning, output_times

__all__ = ["simulate", "right_hand_side", "output_times", "RedundantConstraintsWarning"]
