"""Joint friction proportional to the joint's reaction: the algebraic loop, closed exactly in
every evaluation of the body-coordinate methods.

A ``joint_friction`` element with ``mu`` has the friction level mu N, where the load N (N on a
translation, N m on an angle or rotation) is read from the joint's reaction force on body i,
f_i = sum_r D_r,i^T lam_r over the joint's constraint rows r (Eq. 10.10), with the joint axis
u = A_i u'_i: N = |f_i - (f_i . u) u| on a translational joint (the normal reaction across the
slide), r |f_i - (f_i . u) u| + r_a |f_i . u| on a revolute joint (pin radius r, thrust-collar
radius r_a), r |f_i| on a spherical joint (ball radius r). The multipliers depend on the
friction (it enters g), so N = N(lam(N)): a fixed point, iterated around the method's own solve
(:func:`.standard.after_state_standard`, :func:`.penalty.after_state_penalty`), compiled:

1. solve with the loads of the previous evaluation (a warm start; 0 at the first) -> lam;
2. the loads N' from lam; if max |N' - N| <= 1e-12 max N (or, at the round-off floor of the
   solve, <= 1e-8 max N and no longer shrinking), the evaluation is done: the friction applied
   is that of the loads the last solve used, within that tolerance of the reactions it gave;
3. otherwise each changed instance is evaluated again at the same state with N' (its old
   generalized force, power and LuGre rate replaced in g, the power total and its state rate),
   and the solve is repeated.

The iteration contracts when mu r |dN/dT| < 1, T = mu N the friction force or moment: N changes
by T / l when the friction acts on a lever arm l of the joint's reaction (a pendulum of length l
whose pivot moment changes its tangential, not its radial, reaction has |dN/dT| <= 1/l), so
mu r / l < 1 -- true for every bearing with a pin smaller than its link. (For a translational
joint mu |dN/dF| < 1: a slider whose friction force tilts the link that loads it.) A wheel on
its axle, a block on a slide: N does not depend on T and the loop ends after its second solve.
Not converging within :data:`MAX_ITERATIONS` solves stops the run with an error naming the
elements. At a singular position (the minimum-norm multipliers of the fallback) the loads are
those of the last iteration.

:func:`install` fits a method for a model with such elements; the recursive method (joint
reactions from the articulated-body recursion, not multipliers) and solver="kkt" are refused.
The whole-run compiled drivers and the Runge-Kutta stage hooks are not used (each right-hand
side is one compiled call of the loop).
"""
from __future__ import annotations

import copy as copy_module
import math

import numpy as np

from ..constraints.kernels import JointRows
from ..errors import ModelError, SimulationError
from ..forces.contact import laws as L
from ..forces.joint_friction import (C_AXIAL, C_MODE, C_RADIUS, C_REACTION, REACTION, TOTAL,
                                     JointFriction, evaluate_friction)
from ..forces.kernel_tools import ROTATION, add_coordinate_force, add_wrench
from ..jit import njit
from .base import MethodOutput
from .penalty import after_state_penalty
from .standard import after_state_standard
from .system import body_views, cons_views, force_views, stage_state

#: solves per evaluation before the loop gives up
MAX_ITERATIONS = 200
#: converged: max |N' - N| <= RTOL max N; at the solve's round-off floor: FLOOR max N
RTOL, FLOOR = 1e-12, 1e-8
#: status of a loop that did not converge (the methods' codes are 0 .. -3)
NOT_CONVERGED = -7


# ------------------------------------------------------------------------------ compiled
@njit
def _table(fo):
    return JointRows(fo.fbi, fo.fbj, fo.fs_i, fo.fs_j, fo.fR_i, fo.fR_j, fo.fparam, fo.flaw,
                     fo.fcoord)


@njit
def new_loads(F, I, W, RI, out):
    """out[a] = the load N' of reaction instance a from the multipliers in W; returns
    (max |N' - N|, max N')."""
    bo, co, fo = body_views(F, I, W), cons_views(F, I, W), force_views(F, I, W)
    change, big = 0.0, 0.0
    for a in range(RI.shape[0]):
        k, r0, ne = RI[a, 0], RI[a, 1], RI[a, 2]
        f0 = f1 = f2 = 0.0
        for r in range(r0, r0 + ne):                      # f_i = D_i^T lam (10.10)
            lam = co.lam[r]
            f0 += co.D[r, 0] * lam
            f1 += co.D[r, 1] * lam
            f2 += co.D[r, 2] * lam
        p = fo.fparam
        if int(p[k, C_REACTION]) == TOTAL:
            load = p[k, C_RADIUS] * math.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
        else:
            i = fo.fbi[k]
            A, R = bo.A, fo.fR_i
            u0 = A[i, 0, 0] * R[k, 0, 0] + A[i, 0, 1] * R[k, 1, 0] + A[i, 0, 2] * R[k, 2, 0]
            u1 = A[i, 1, 0] * R[k, 0, 0] + A[i, 1, 1] * R[k, 1, 0] + A[i, 1, 2] * R[k, 2, 0]
            u2 = A[i, 2, 0] * R[k, 0, 0] + A[i, 2, 1] * R[k, 1, 0] + A[i, 2, 2] * R[k, 2, 0]
            ax = f0 * u0 + f1 * u1 + f2 * u2
            e0, e1, e2 = f0 - ax * u0, f1 - ax * u1, f2 - ax * u2
            load = p[k, C_RADIUS] * math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) \
                + p[k, C_AXIAL] * abs(ax)
        out[a] = load
        change = max(change, abs(load - fo.flaw[k, 0]))
        big = max(big, load)
    return change, big


@njit
def apply_loads(F, I, W, RI, loads):
    """Each reaction instance evaluated again at its new load: its generalized force, power
    (and LuGre rate) replaced in g, the power total and the law columns."""
    bo, fo = body_views(F, I, W), force_views(F, I, W)
    S = (bo.r, bo.A, bo.rdot, bo.omega, bo.p)
    G = _table(fo)
    D = fo.fscratch
    for a in range(RI.shape[0]):
        k = RI[a, 0]
        lugre = fo.fparam[k, L.C_FRICTION] == L.LUGRE
        if lugre:
            G.law[k, 3] = G.law[k, 1]             # the deflection z, kept by the kernel
        _, Q0, _, _, pw0 = evaluate_friction(S, G, k, D)
        G.law[k, 0] = loads[a]
        if lugre:
            G.law[k, 3] = G.law[k, 1]
        _, Q1, _, _, pw1 = evaluate_friction(S, G, k, D)
        if int(fo.fparam[k, 0]) == ROTATION:
            d0, d1, d2 = Q1[0] - Q0[0], Q1[1] - Q0[1], Q1[2] - Q0[2]
            add_wrench(bo.g, G.bj[k], 0.0, 0.0, 0.0, d0, d1, d2)
            add_wrench(bo.g, G.bi[k], 0.0, 0.0, 0.0, -d0, -d1, -d2)
        else:
            add_coordinate_force(bo.g, G, k, D, Q1[0] - Q0[0])
        fo.fpower[k] = pw1
        bo.g_power[0] += pw1 - pw0


@njit(inline="always")
def _done(change, big, previous, it):
    if change <= RTOL * big:
        return True
    return it > 2 and change <= FLOOR * big and change > 0.5 * previous


@njit
def after_standard(y, ydot, F, I, W, mp, RI):
    """:func:`.standard.after_state_standard` iterated to the fixed point of the loads."""
    loads = np.empty(RI.shape[0])
    previous = np.inf
    for it in range(MAX_ITERATIONS):
        code = after_state_standard(y, ydot, F, I, W, mp)
        if code < 0:
            return code
        change, big = new_loads(F, I, W, RI, loads)
        if _done(change, big, previous, it):
            return code
        apply_loads(F, I, W, RI, loads)
        previous = change
    return NOT_CONVERGED


@njit
def rhs_standard(t, y, ydot, F, I, W, mp, RI):
    stage_state(t, y, mp[0], F, I, W)
    return after_standard(y, ydot, F, I, W, mp, RI)


@njit
def after_penalty(y, ydot, F, I, W, KI, KW, mp, RI):
    """:func:`.penalty.after_state_penalty` iterated likewise (returns the inner iterations
    of all its solves)."""
    loads = np.empty(RI.shape[0])
    previous = np.inf
    total = 0
    for it in range(MAX_ITERATIONS):
        code = after_state_penalty(y, ydot, F, I, W, KI, KW, mp)
        if code < 0:
            return code
        total += code
        change, big = new_loads(F, I, W, RI, loads)
        if _done(change, big, previous, it):
            return total
        apply_loads(F, I, W, RI, loads)
        previous = change
    return NOT_CONVERGED


@njit
def rhs_penalty(t, y, ydot, F, I, W, KI, KW, mp, RI):
    stage_state(t, y, mp[0], F, I, W)
    return after_penalty(y, ydot, F, I, W, KI, KW, mp, RI)


LOOPS = {after_state_standard: (rhs_standard, after_standard),
         after_state_penalty: (rhs_penalty, after_penalty)}


# ------------------------------------------------------------------------------ Python side
def reaction_rows(model):
    """(RI (n, 3): force-table index, first constraint row and row count of the joint of each
    reaction-proportional friction instance; their names), or None without any."""
    rows, names, start = [], [], 0
    where = {}
    for g, off in zip(model.constraint_groups, model.group_offsets):
        for n, name in enumerate(g.names):
            where[name] = (off + n * g.n_eq, g.n_eq)
    for g in model.force_groups:
        if not g.compiled:
            continue
        if isinstance(g, JointFriction) and g.reaction_dependent:
            for k in np.flatnonzero(g.param[:, C_MODE] == REACTION):
                rows.append((start + k, *where[g.joints[k]]))
                names.append(g.names[k])
        start += g.n
    if not rows:
        return None
    return np.array(rows, dtype=np.int64).reshape(-1, 3), names


def refuse(model, analysis: str) -> None:
    """ModelError naming the reaction-proportional friction elements of ``model``, which
    ``analysis`` (one that does not close their loop) would leave out."""
    found = reaction_rows(model)
    if found is not None:
        raise ModelError(f"{analysis} does not close the loop of joint friction proportional "
                         f"to the joint reaction ({', '.join(repr(n) for n in found[1])}); "
                         "run simulate(), or give the friction a constant 'frictionloss'")


def install(meth, eom):
    """``meth`` itself for a model without reaction-proportional joint friction, else a copy
    whose compiled right-hand side and accelerations close the loop (no stage hook)."""
    found = reaction_rows(eom.model)
    if found is None:
        return meth
    RI, names = found
    listed = ", ".join(repr(n) for n in names)
    if getattr(meth, "joint_coordinates", False):
        raise ModelError(f"joint friction proportional to the reaction ({listed}): method "
                         f"{meth.name!r} has no multipliers to read the reactions from; use "
                         "method 'standard', 'baumgarte', 'projection', 'augmented_lagrangian' "
                         "or 'penalty'")
    new = copy_module.copy(meth)
    kernels_of, status_of = meth.kernels, meth.status

    def kernels(system, W=None):
        found = kernels_of(system, W)
        if found is None or found[1] not in LOOPS:
            raise ModelError(f"joint friction proportional to the reaction ({listed}) runs in "
                             "the compiled solves of the built-in methods; method "
                             f"{meth.name!r} with {meth.parameters()} has none (use "
                             "solver='schur')")
        full, after = LOOPS[found[1]]
        return full, after, tuple(found[2]) + (RI,)

    def status(code, system, t, y, ydot, W=None):
        if code == NOT_CONVERGED:
            err = SimulationError(
                f"t = {t:.6g} s: the friction proportional to the joint reaction ({listed}) "
                f"did not converge in {MAX_ITERATIONS} solves: the loop contracts when mu x "
                "radius is smaller than the lever arm of the joint's reaction (see "
                "docs/joint-limits-friction.md); lower mu or the radius")
            err.t = t
            raise err
        return status_of(code, system, t, y, ydot, W)

    def accelerations(ev, t):
        system = ev.system
        _, after, args = kernels(system, ev.W)
        y = ev.y
        ydot = np.empty(y.size)
        code = after(y, ydot, *args)
        if code < 0:
            status(code, system, t, y, ydot, ev.W)
        return MethodOutput(system.fields(ev.W, "vdot").copy(),
                            system.fields(ev.W, "lam").copy())

    new.kernels, new.status, new.accelerations = kernels, status, accelerations
    new.stages = lambda system: None
    new.reaction_friction = names
    return new
