"""SciPy's ``solve_ivp`` methods behind the integrator interface (text ch. 13 for comparison).

[scipy-rk45] RK45, [scipy-dop853] DOP853, [scipy-radau] Radau, [scipy-bdf] BDF, [scipy-lsoda] LSODA.

The solver classes that ``scipy.integrate.solve_ivp`` drives are stepped here directly (same
algorithms, same options rtol / atol / max_step / first_step), which gives per-step progress
reports, partial outputs up to a failure and the failure time. Outputs at ``t_eval`` come from
each method's own dense output (or are the step end points).

Counters: nfev counts every call of ``problem.rhs`` (including those SciPy makes for
finite-difference Jacobians, which SciPy's own ``nfev`` omits); steps counts accepted steps;
njev and nlu are SciPy's counts; ``rejected`` is not reported by SciPy and stays 0.

Projection: SciPy owns its internal state, so ``problem.project`` can only be applied to the
outputs, not to the accepted steps; the drift off the manifold is therefore not corrected during
the integration (use a spatialmbd integrator when projection matters).

Failures: a non-finite derivative raises SimulationError at once (SciPy's implicit methods would
raise ValueError from their LU). A SciPy step failure (e.g. "Required step size is less than
spacing between numbers.") becomes a SimulationError with ``.t`` = the time reached, so the
result has status "failed" and the message from SciPy.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
import scipy.integrate

from ..errors import SimulationError, SpatialMBDError
from .base import Integrator, register
from .controller import (atol_vector, default_max_step, non_negative, positive,
                         raise_if_nonfinite, validate_tolerances)


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

    def _integrate(self, problem, t0, y0, t_eval, counters, outputs, progress) -> None:
        rhs = problem.rhs
        project = problem.project
        touts = t_eval.tolist()
        n_out = len(touts)
        t_end = touts[-1]
        k_out = 0
        if touts[0] == t0:
            outputs.append(y0)
            k_out = 1
        if k_out == n_out:
            return

        def fun(t, y):
            counters.nfev += 1
            dy = rhs(t, y)
            raise_if_nonfinite(t, dy, "derivative")    # SciPy's LU would raise ValueError
            return dy

        kwargs = dict(rtol=self.rtol, atol=atol_vector(self.atol, y0.size),
                      max_step=self.max_step, first_step=self.first_step)
        if self.implicit and problem.jac is not None:
            kwargs["jac"] = problem.jac
        if self.method == "LSODA":
            kwargs["min_step"] = self.min_step
        t = t0
        solver = None
        try:
            solver = getattr(scipy.integrate, self.method)(fun, t0, y0, t_end, **kwargs)
            while solver.status == "running":
                message = solver.step()
                if solver.status == "failed":
                    t = solver.t
                    err = SimulationError(f"t = {t:.6g} s: SciPy {self.method} failed: "
                                          f"{message}")
                    err.t = t
                    raise err
                t = solver.t
                y = solver.y
                raise_if_nonfinite(t, y)
                counters.steps += 1
                if k_out < n_out and touts[k_out] <= t:
                    dense = None
                    while k_out < n_out and touts[k_out] <= t:
                        to = touts[k_out]
                        if to == t:
                            yo = y.copy()
                        else:
                            if dense is None:
                                dense = solver.dense_output()
                            yo = dense(to)
                        outputs.append(yo if project is None else project(to, yo))
                        k_out += 1
                if progress is not None:
                    progress(t)
        except (SpatialMBDError, np.linalg.LinAlgError, FloatingPointError) as exc:
            if getattr(exc, "t", None) is None:
                exc.t = t
            raise
        finally:
            if solver is not None:
                counters.njev = int(solver.njev or 0)
                counters.nlu = int(solver.nlu or 0)


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
