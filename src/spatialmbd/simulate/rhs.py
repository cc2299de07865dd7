"""The right-hand side of a run, y' = f(t, y) for y = [q, v, z, W]: compiled (one or two
compiled stages) or through ``Method.accelerations`` in Python."""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..dynamics import EquationsOfMotion, get_method
from ..dynamics import reaction_friction
from ..dynamics import system as cs
from ..integrators.base import check_finite
from ..state import normalize_q, qdot_from_v
from .setup import _start_mobility


def right_hand_side(model, method="standard", method_options: Optional[dict] = None):
    """The y' = f(t, y) that :func:`simulate` integrates, and its initial state y0.

    y = [q (7 nb), v (6 nb), z, W] (see the module docstring; z: the internal states of force
    elements such as LuGre friction, usually none). For benchmarks and for driving the
    equations of motion with an integrator of one's own (W is a quadrature: the rhs does not
    depend on it; declare it with ``ODEProblem(rhs, n_quadrature=1)`` for the implicit ones). No initial-condition correction. Redundant constraint
    equations (found at the model's initial state, as :func:`simulate` finds them) are left
    out of the multiplier solve, as in :func:`simulate`: with them every evaluation would take
    the least-squares fallback, tens of times slower.
    """
    meth = get_method(method, **(method_options or {}))
    eom = EquationsOfMotion(model)
    mob = _start_mobility(model, eom, normalize_q(np.asarray(model.q0, dtype=float)),
                          np.asarray(model.v0, dtype=float), 0.0)
    meth.setup(eom, np.array([r[0] for r in mob.redundant], dtype=int) if mob else None)
    meth = reaction_friction.install(meth, eom)
    driver_rows = _driver_rows(model)
    track_work = bool(model.force_groups) or driver_rows.size > 0
    rhs = _compiled_rhs(model, eom, meth, track_work)
    if rhs is None:
        rhs = _python_rhs(model, eom, meth, track_work, driver_rows)
    y0 = np.concatenate([normalize_q(np.asarray(model.q0, dtype=float)).reshape(-1),
                         np.asarray(model.v0, dtype=float).reshape(-1),
                         np.zeros(eom.system.force_table.n_states), [0.0]])
    return rhs, y0


def _compiled_rhs(model, eom, meth, track_work):
    """y' = f(t, y) through the method's compiled kernels (None if it has none)."""
    system = eom.system
    kernels = meth.kernels(system)
    if kernels is None:
        return None
    full, after, args = kernels
    table = system.table
    drivers = table.has_drivers
    iterate = meth.iterate
    status = meth.status

    def finish(t, y, ydot, code):
        if code < 0 and model.force_groups and not np.all(np.isfinite(system.g)):
            eom._raise_non_finite(system.state, t)     # names the force element
        if code < 0:
            code = status(code, system, t, y, ydot)
        if code < 0:
            check_finite(t, ydot, "accelerations")
        elif iterate:
            meth.total_iterations += code

    if system.fused:
        def rhs(t, y):
            if not y.flags.c_contiguous:          # e.g. a column of SciPy's Jacobian
                y = np.ascontiguousarray(y)
            if drivers:
                table.set_time(t)
            ydot = np.empty_like(y)
            code = full(t, y, ydot, *args)
            if code:
                finish(t, y, ydot, code)
            return ydot
        return rhs

    F, I, W = system.F, system.I, system.W
    forces = system.python_forces            # the compiled ones are inside the kernels
    state = system.state

    def rhs(t, y):
        if not y.flags.c_contiguous:
            y = np.ascontiguousarray(y)
        if drivers:
            table.set_time(t)
        cs.stage_state(t, y, 1.0, F, I, W)
        if not system.python_stage(t):
            eom._raise_non_finite(state, t)
        ydot = np.empty_like(y)
        code = after(y, ydot, *args)
        if code:                                  # (a method may redo the solve here)
            finish(t, y, ydot, code)
        if forces and track_work:
            ydot[-1] += sum(g.nonconservative_power(state, t) for g in forces)
        return ydot
    return rhs


def _python_rhs(model, eom, meth, track_work, driver_rows):
    """y' = f(t, y) through Method.accelerations (methods without a compiled path)."""
    nb = model.nb
    n_q, n_v = 7 * nb, 6 * nb

    def rhs(t, y):
        qq = normalize_q(y[:n_q]).reshape(nb, 7)
        vv = y[n_q:n_q + n_v]
        ev = eom.evaluate(t, qq, vv)
        out = meth.accelerations(ev, t)
        ydot = np.empty_like(y)
        ydot[:n_q] = qdot_from_v(qq, vv.reshape(nb, 6)).reshape(-1)
        ydot[n_q:n_q + n_v] = out.vdot
        if track_work:
            ydot[-1] = _nonconservative_power(model, ev, out.lam, driver_rows, t)
        else:
            ydot[-1] = 0.0
        check_finite(t, ydot, "accelerations")
        return ydot
    return rhs


def _driver_rows(model) -> np.ndarray:
    rows = []
    for g, off in zip(model.constraint_groups, model.group_offsets):
        if g.rheonomic:
            rows.extend(range(off, off + g.size))
    return np.array(rows, dtype=int)


def _nonconservative_power(model, ev, lam, driver_rows, t) -> float:
    """Power of the non-conservative force elements and of the drivers' reactions (lam^T nu)."""
    p = sum(g.nonconservative_power(ev.state, t) for g in model.force_groups)
    if driver_rows.size:
        p += float(lam[driver_rows] @ ev.cv.nu[driver_rows])
    return p
