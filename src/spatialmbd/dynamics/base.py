"""Methods to solve the equations of motion (text ch. 12): the strategy contract.

A method turns an :class:`~spatialmbd.dynamics.eom.Evaluation` (M, g, Phi, D, nu, gamma at one
instant) into accelerations vdot and multipliers lam (convention of eom.py: D^T lam are the
reaction forces on the bodies). It never knows which integrator drives it. A method may also
offer ``project(eom, t, q, v)``, applied by the integrator after every accepted step.

Adding a method: subclass :class:`Method`, set ``name``, implement ``accelerations`` and
register it with :func:`register`. (The built-in methods also provide a compiled right-hand
side, :meth:`Method.kernels`, which ``simulate`` uses; a method without one runs through
``accelerations`` with the arrays of an :class:`~.eom.Evaluation`.)
"""
from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import ClassVar, Optional

import numpy as np

from ..errors import ModelError


@dataclass
class MethodOutput:
    vdot: np.ndarray            # (6 nb,)
    lam: np.ndarray             # (m,)
    iterations: int = 0         # inner iterations (augmented Lagrangian)


class Method(abc.ABC):
    name: ClassVar[str] = ""
    #: whether the method projects the state onto the constraint manifold after each step
    projects: ClassVar[bool] = False
    #: whether the method keeps the state on a drifted manifold Phi = eps (standard,
    #: Baumgarte, penalty, augmented Lagrangian), so that its ``singular`` option decides
    #: what happens near a singular position (:mod:`.singular_guard`)
    follows_drift: ClassVar[bool] = False
    #: "stop" (default of the methods that follow their drift): stop with the diagnosis where
    #: the drift decides the branch (:mod:`.singular_guard`); "continue": go on regardless
    singular: str = "continue"

    def setup(self, eom, redundant_rows: Optional[np.ndarray] = None) -> None:
        """Called once per simulation before the first evaluation."""
        self.redundant_rows = redundant_rows

    @abc.abstractmethod
    def accelerations(self, ev, t: float) -> MethodOutput:
        """vdot and lam at the evaluated instant."""

    #: the method keeps a count of inner iterations (``total_iterations``)
    iterate: ClassVar[bool] = False

    def kernels(self, system, W=None):
        """The compiled right-hand side, if the method has one (built-in methods,
        :mod:`.system`): ``(full, after_state, args)`` with ``full(t, y, ydot, *args)`` (the
        whole evaluation) and ``after_state(y, ydot, *args)`` (after :func:`stage_state` and
        the Python stage), both returning a status (>= 0 success, the inner iterations for
        iterative methods; < 0 see :meth:`status`). W: the work array (default the system's).
        """
        return None

    def stages(self, system):
        """Optional compiled ``ODEProblem.stages`` hook (built-in methods); None here."""
        return None

    def status(self, code: int, system, t: float, y, ydot, W=None) -> int:
        """Handle a negative status of the compiled solve: fall back, or raise."""
        return code

    def parameters(self) -> dict:
        return {}


METHODS: dict[str, type[Method]] = {}


def register(cls):
    METHODS[cls.name] = cls
    return cls


ALIASES = {"lagrange": "standard", "al": "augmented_lagrangian", "augmented": "augmented_lagrangian",
           "augmented-lagrangian": "augmented_lagrangian"}


def get_method(spec, **options) -> Method:
    """A method from a name (with options) or a Method instance."""
    if isinstance(spec, Method):
        if options:
            raise ValueError("options can only be given with a method name")
        return spec
    if isinstance(spec, str):
        key = ALIASES.get(spec.lower(), spec.lower())
        if key not in METHODS:
            raise ValueError(f"unknown method {spec!r}; valid names: " + ", ".join(sorted(METHODS)))
        return METHODS[key](**options)
    raise TypeError(f"method must be a name or a Method, not {type(spec).__name__}")


#: the values of the ``singular`` option
SINGULAR_CHOICES = ("stop", "continue")


def check_singular(name: str, value) -> str:
    """The ``singular`` option of method ``name``; ModelError naming the choices otherwise."""
    if value not in SINGULAR_CHOICES:
        raise ModelError(f"{name} singular: expected one of {', '.join(SINGULAR_CHOICES)}, got "
                         f"{value!r} (\"stop\": stop with the diagnosis where the drift decides "
                         "the branch at a singular position; \"continue\": go on regardless)")
    return value


def check_positive(name: str, value, allow_zero: bool = False) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{name}: expected a number, got {value!r}") from None
    ok = value >= 0 if allow_zero else value > 0
    if not (np.isfinite(value) and ok):
        raise ModelError(f"{name}: must be {'>= 0' if allow_zero else '> 0'}, got {value}")
    return value
