"""SciPy's ``solve_ivp`` methods behind the integrator interface (text ch. 13 for comparison).

[scipy-rk45] RK45, [scipy-dop853] DOP853, [scipy-radau] Radau, [scipy-bdf] BDF, [scipy-lsoda] LSODA.

The solver classes that ``scipy.integrate.solve_ivp`` drives are stepped here directly (same
algorithms, same options rtol / atol / max_step / first_step), which gives per-step progress
reports, partial outputs up to a failure and the failure time. Outputs at ``t_eval`` come from
each method's own dense output (or are the step end points).

Jacobian (implicit methods): ``problem.jac`` when given, else forward differences of
``problem.rhs`` by the scheme bdf4 uses (:class:`_FDJacobian`, :mod:`.jacobian`), not
SciPy's ``num_jac``, whose increments are round-off for state components at 0.

Counters: nfev counts every call of ``problem.rhs`` (including those for the finite-difference
Jacobians, which SciPy's own ``nfev`` omits); steps counts accepted steps;
njev and nlu are SciPy's counts; ``rejected`` is not reported by SciPy and stays 0.

Projection: SciPy owns its internal state, so ``problem.project`` can only be applied to the
outputs (and located events), not to the accepted steps; the drift off the manifold is
therefore not corrected during the integration (use a spatialmbd integrator when projection
matters).

Structure: :class:`ScipyStepper` is a self-controlled :class:`.driver.Stepper` (each ``step``
is one solver step; SciPy chooses h), so outputs, events, counters and partial results come
from the common driver.

Failures: a non-finite derivative raises SimulationError at once (SciPy's implicit methods would
raise ValueError from their LU). A SciPy step failure (e.g. "Required step size is less than
spacing between numbers.") becomes a SimulationError with ``.t`` = the time reached, so the
result has status "failed" and the message from SciPy.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
import scipy.integrate

from ..errors import SimulationError
from .base import Integrator, register
from .controller import (atol_vector, default_max_step, non_negative, positive,
                         raise_if_nonfinite, validate_tolerances)
from .driver import Step, Stepper
from .jacobian import fd_jacobian


class ScipyIntegrator(Integrator):
    """A SciPy OdeSolver class stepped under the spatialmbd contract.

    Options: rtol (1e-6), atol (1e-9, scalar or (n,)), max_step (s, default inf), first_step
    (s, default: SciPy's choice), min_step (s, LSODA only).
    """

    method = ""
    implicit = False
    adaptive = True

    def __init__(self, rtol: float = 1e-6, atol=1e-9, max_step: Optional[float] = None,
                 first_step: Optional[float] = None, min_step: float = 0.0):
        self.rtol, self.atol = validate_tolerances(rtol, atol)
        self.max_step = default_max_step(max_step)
        self.first_step = None if first_step is None else positive(first_step, "first_step")
        self.min_step = non_negative(min_step, "min_step")
        if self.min_step and self.method != "LSODA":
            raise ValueError(f"option min_step={min_step!r} is only supported by scipy-lsoda")

    def __repr__(self) -> str:
        return f"{type(self).__name__}(rtol={self.rtol!r}, atol={self.atol!r})"

    def make_stepper(self):
        return ScipyStepper(self)

    def make_controller(self):
        return None


class ScipyStepper(Stepper):
    """A SciPy OdeSolver as a self-controlled stepper: each ``step`` is one solver step."""

    self_controlled = True
    projects_state = False

    def __init__(self, integ):
        self.integ = integ
        self.name = integ.name

    def start(self, problem, t0, y0, t_end, counters):
        integ = self.integ
        rhs = problem.rhs
        self.counters = counters

        last = [None, None, None]                      # t, y, rhs(t, y) of the last call

        def fun(t, y):
            counters.nfev += 1
            dy = rhs(t, y)
            raise_if_nonfinite(t, dy, "derivative")    # SciPy's LU would raise ValueError
            last[:] = t, y.copy(), dy
            return dy

        atol = atol_vector(integ.atol, y0.size)
        kwargs = dict(rtol=integ.rtol, atol=atol, max_step=integ.max_step,
                      first_step=integ.first_step)
        if integ.implicit:
            kwargs["jac"] = problem.jac if problem.jac is not None else _FDJacobian(
                rhs, fun, last, atol / integ.rtol, y0.size - int(problem.n_quadrature or 0),
                counters)
        if integ.method == "LSODA":
            kwargs["min_step"] = integ.min_step
        self.solver = getattr(scipy.integrate, integ.method)(fun, t0, y0, t_end, **kwargs)
        return None

    def step(self, t, y, t_new):
        solver = self.solver
        try:
            message = solver.step()
        finally:
            self.counters.njev = int(solver.njev or 0)
            self.counters.nlu = int(solver.nlu or 0)
        if solver.status == "failed":
            t = solver.t
            err = SimulationError(f"t = {t:.6g} s: SciPy {self.integ.method} failed: {message}")
            err.t = t
            raise err
        y_new = solver.y.copy()
        cache = []

        def dense(s):
            if not cache:
                cache.append(solver.dense_output())
            return cache[0](s)
        return Step(solver.t, y_new, 0.0, 1, dense)


class _FDJacobian:
    """J = df/dy for SciPy's implicit methods when the problem has no ``jac``: forward
    differences of ``rhs`` by :func:`.jacobian.fd_jacobian`, the scheme of bdf4 (increments
    sqrt(eps) max(|y_j|, atol_j / rtol); the quadrature columns left at zero), instead of
    SciPy's ``num_jac`` (increments from max(|y_j|, atol), round-off for components at 0).
    SciPy keeps J across steps and asks for a new one when Newton fails or converges slowly.
    Reuses rhs(t, y) when SciPy has just evaluated it at the same point (it does so before
    every Jacobian after an accepted step). Evaluations are counted in nfev.
    """

    def __init__(self, rhs, fun, last, typical, nd, counters):
        self.rhs, self.fun, self.last = rhs, fun, last
        self.typical, self.nd, self.counters = typical, nd, counters

    def __call__(self, t, y):
        t_last, y_last, fy = self.last
        if t_last != t or y_last is None or not np.array_equal(y_last, y):
            fy = self.fun(t, y)
        n = y.size
        J = np.zeros((n, n))
        self.counters.nfev += fd_jacobian(self.rhs, t, y, fy, self.typical, self.nd, J)
        raise_if_nonfinite(t, J.ravel(), "Jacobian")
        return J


@register
class ScipyRK45(ScipyIntegrator):
    """SciPy RK45: explicit Dormand-Prince 5(4)."""

    name = "scipy-rk45"
    method = "RK45"
    order = 5


@register
class ScipyDOP853(ScipyIntegrator):
    """SciPy DOP853: explicit Dormand-Prince 8(5,3)."""

    name = "scipy-dop853"
    method = "DOP853"
    order = 8


@register
class ScipyRadau(ScipyIntegrator):
    """SciPy Radau: implicit Radau IIA of order 5 (stiff problems)."""

    name = "scipy-radau"
    method = "Radau"
    order = 5
    implicit = True


@register
class ScipyBDF(ScipyIntegrator):
    """SciPy BDF: variable-order (1-5) numerical differentiation formulas (stiff problems)."""

    name = "scipy-bdf"
    method = "BDF"
    order = 5
    implicit = True


@register
class ScipyLSODA(ScipyIntegrator):
    """SciPy LSODA: ODEPACK's automatic Adams / BDF switching."""

    name = "scipy-lsoda"
    method = "LSODA"
    order = 12
    implicit = True
