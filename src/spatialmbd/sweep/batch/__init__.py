"""Batches of one topology: many members integrated together in one compiled call.

Members that differ only in parameter values (masses, inertias, joint geometry, gravity) and
initial states share the model's structure: the integer pack ``I`` of
:class:`..dynamics.system.System` (topology, sparsity patterns, symbolic factorisation) is the
same, only the float pack ``F`` and the initial state differ. :func:`simulate_batch` stacks
them -- F (B, nF), work arrays W (B, nW), states (B, n) -- and runs one compiled loop over the
members that integrates each with the compiled drivers of :mod:`..dynamics.fused` (those
:func:`simulate` uses for a fully compiled model):

* ``rk45``: Dormand-Prince 5(4) with per-member step control -- the same arithmetic as
  :class:`..integrators.runge_kutta_adaptive.DormandPrince45` (Hairer's starting step, the PI
  controller with beta = 0.04, FSAL, Shampine's dense output, p renormalised -- and with the
  projection method q and v projected, the FSAL derivative re-evaluated -- after every accepted
  step and at every output), so a member's result equals its separate run to round-off;
* ``dop853``: Dormand-Prince 8(5,3) with per-member step control, the arithmetic of
  :class:`..integrators.dop853.DormandPrince853` (for tight tolerances: about a third of
  rk45's evaluations at rtol 1e-8);
* ``rk4``: classic RK4 with a common fixed step, landing on every output time as
  :class:`..integrators.fixed_step.RungeKutta4` does.

With the recursive method (what "auto" gives a tree of joints with rk45 or dop853, as in
simulate())
each member's joint coordinates and joint tree (:class:`..dynamics.recursive.JointTree`)
come from its corrected initial state and the members are integrated by
:func:`..dynamics.recursive.dopri_joint` in one compiled call
(:func:`integrate_batch_joint`), the bodies' coordinates evaluated at the outputs.

vdot and lambda at the output times are evaluated in the same call. A member whose right-hand
side fails (singular S, non-finite values) or whose step size underflows stops with a status
code and is reported as failed; the others continue.

In a sweep (:func:`run_members_batched`), members whose parameters each set one entry of the
model's masses, inertias, gravity or initial state (probed, :func:`_direct_entries`) are not
built: their values are written into copies of one built model's arrays and packs.

Scope (checked, with a ModelError naming what is not supported): dynamic analyses with the
"standard", "baumgarte", "projection" or "recursive" method (where simulate() would fall back to
least squares for a singular D D^T, a batch member fails instead); models whose right-hand side is
fully compiled (every joint type and force element compiled), without drivers or
time-dependent force laws (set from Python at every evaluation), contact elements (their
impact memory is kept by events) or force-element states; no redundant constraints. Models
outside it run through :func:`simulate` one by one
(``engine="simulate"``).

One module per job: ``kernels`` (the compiled loop over the members), ``setup`` (the stacked
packs and states, the scope checks), ``run`` (:func:`simulate_batch`), ``members`` (a sweep's
members in batches), ``reduce`` (their outputs from the arrays) and ``direct`` (members
written into one built model's arrays).
"""
from __future__ import annotations

from ...dynamics.fused import STATUS_TEXT
from .kernels import integrate_batch, integrate_batch_joint
from .members import run_members_batched
from .run import as_results, simulate_batch
from .setup import BatchMember, BatchSetup

__all__ = ["simulate_batch", "BatchSetup", "run_members_batched", "STATUS_TEXT"]
