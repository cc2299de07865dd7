"""Time integrators of text ch. 13 behind one contract (see :mod:`.base`).

Registered names: ``euler``, ``heun``, ``rk4`` (fixed step), ``abm4`` (Adams-Bashforth-Moulton
PECE), ``bdf4`` (Gear), ``rk45`` (Dormand-Prince 5(4)), ``dop853`` (Dormand-Prince 8(5,3))
and the SciPy methods ``scipy-rk45``,
``scipy-dop853``, ``scipy-radau``, ``scipy-bdf``, ``scipy-lsoda``. Get one with
``get_integrator(name, **options)``.

Structure: every integrator is a stepper (its stepping formula, :class:`.driver.Stepper`) and an
injected step-size controller (:mod:`.controllers`) run by the one loop :func:`.driver.run`,
which owns output sampling, projection, counters, progress, events and partial results.
except ``rk45`` and ``dop853``: every run of theirs goes through the one compiled adaptive
driver :func:`.adaptive_driver.rk_steps` (whole runs from compiled code, :mod:`..dynamics.fused`
and :mod:`..dynamics.recursive`; any other problem, events and breakpoints from Python,
:mod:`.adaptive_run`).
"""
from .base import (INTEGRATORS, Counters, IntegrationResult, Integrator, ODEProblem,
                   check_finite, get_integrator, register)
from .controllers import FixedStepController, IController, PIController
from .driver import Event, EventRecord, Step, Stepper
from .fixed_step import FixedStepIntegrator, ForwardEuler, Heun, RungeKutta4
from .adams import AdamsBashforthMoulton4
from .gear import GearBDF4
from .dormand_prince import DormandPrince45, DormandPrince853
from .scipy_ivp import (ScipyBDF, ScipyDOP853, ScipyIntegrator, ScipyLSODA, ScipyRadau,
                        ScipyRK45)

__all__ = [
    "INTEGRATORS", "Counters", "IntegrationResult", "Integrator", "ODEProblem", "check_finite",
    "get_integrator", "register", "IController", "PIController",
    "FixedStepController", "Event", "EventRecord", "Step", "Stepper", "FixedStepIntegrator",
    "ForwardEuler",
    "Heun", "RungeKutta4", "AdamsBashforthMoulton4", "GearBDF4", "DormandPrince45",
    "DormandPrince853",
    "ScipyIntegrator", "ScipyRK45", "ScipyDOP853", "ScipyRadau", "ScipyBDF", "ScipyLSODA",
]
