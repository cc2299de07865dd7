"""Constraint types: the contract every joint and driver module implements.

A constraint type evaluates all of its instances in one call. The joint geometry is reduced, at
model compile time, to local quantities on each of the two bodies i and j:

    s_i, s_j  (n, 3)     joint point in body-i / body-j axes (the text's s'^P)
    R_i, R_j  (n, 3, 3)  orthonormal joint triads in body axes, columns [u, a, b]: u is the joint
                         axis (or the first vector of a basic constraint), a and b span the plane
                         normal to it, b = u x a (Fig. 9.2)
    length    (n,)       link length of composite joints (spherical-spherical, ...)

``evaluate(state, t)`` returns a :class:`ConstraintEval` with, for the n instances and m equations
per instance,

    phi   (n, m)       Phi(q, t), Eq. (7.2)
    D     (n, m, 12)   dPhidot/dv with v = [rdot_i, omega_i, rdot_j, omega_j], Eq. (7.3)
    nu    (n, m)       -dPhi/dt, Eq. (7.4) (ERRATA: the printed right-hand side "v" is nu)
    gamma (n, m)       D vdot = gamma, Eq. (7.6), including the time terms of drivers.

The equations of a type are written once, as a compiled kernel for one instance k,
``kernel(S, G, k, row, out)`` built from the primitives of :mod:`.primitives` (see there for
S, G and out); :mod:`.kernels` runs it for every instance of every group -- per group for
``evaluate``, for the whole model at once in the assembly.

Adding a joint type: subclass :class:`ConstraintType`, set ``name``, ``n_eq`` and ``eq_labels``,
decorate it with :func:`register`, and either write its compiled ``kernel`` (and list it in
:data:`.kernels.KINDS`) or override ``evaluate`` with a vectorized NumPy version (then it runs
in Python, outside the compiled hot path).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np

from ..state import BodyState


@dataclass
class ConstraintEval:
    phi: np.ndarray
    D: np.ndarray
    nu: np.ndarray
    gamma: np.ndarray


@dataclass(frozen=True)
class JointGeometry:
    """Local joint geometry of n instances (see the module docstring)."""

    s_i: np.ndarray
    s_j: np.ndarray
    R_i: np.ndarray
    R_j: np.ndarray
    length: np.ndarray

    @classmethod
    def stack(cls, items: Sequence["JointGeometry"]) -> "JointGeometry":
        return cls(*(np.concatenate([getattr(g, f) for g in items], axis=0)
                     for f in ("s_i", "s_j", "R_i", "R_j", "length")))


class ConstraintType:
    """A group of constraint instances of one type, evaluated together."""

    name: ClassVar[str] = ""
    n_eq: ClassVar[int] = 0
    eq_labels: ClassVar[tuple[str, ...]] = ()
    #: which driver kinds may act on a joint of this type ("angle", "translation")
    driver_kinds: ClassVar[tuple[str, ...]] = ()
    #: whether the constraint depends explicitly on time
    rheonomic: ClassVar[bool] = False

    def __init__(self, names: Sequence[str], body_i: np.ndarray, body_j: np.ndarray,
                 geometry: JointGeometry):
        self.names = tuple(names)
        self.body_i = np.asarray(body_i, dtype=np.intp)
        self.body_j = np.asarray(body_j, dtype=np.intp)
        self.geometry = geometry
        self.n = len(self.names)

    @property
    def size(self) -> int:
        return self.n * self.n_eq

    @property
    def compiled(self) -> bool:
        """True when the group runs through the compiled kernels (evaluate not overridden)."""
        from .kernels import KIND_ID
        return self.name in KIND_ID and type(self).evaluate is ConstraintType.evaluate

    def law_values(self, t: float) -> np.ndarray | None:
        """(n, 3) f, f', f'' of the drivers' motion laws at t (None: not a driver)."""
        return None

    def evaluate(self, state: BodyState, t: float) -> ConstraintEval:
        """Phi, D, nu, gamma of every instance at the given state and time."""
        from .kernels import evaluate_group
        return evaluate_group(self, state, t)

    @staticmethod
    def _scleronomic(phi, D, gamma) -> ConstraintEval:
        """A time-independent evaluation (nu = 0); scalar parts get their equation axis."""
        if phi.ndim == 1:
            phi, D, gamma = phi[:, None], D[:, None, :], gamma[:, None]
        return ConstraintEval(phi, D, np.zeros_like(phi), gamma)


CONSTRAINT_TYPES: dict[str, type[ConstraintType]] = {}


def register(cls: type[ConstraintType]) -> type[ConstraintType]:
    CONSTRAINT_TYPES[cls.name] = cls
    return cls
