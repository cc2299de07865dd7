"""Constraint types: the contract every joint and driver module implements.

A constraint type evaluates all of its instances in one vectorized call. The joint geometry is
reduced, at compile time, to local quantities on each of the two bodies i and j:

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

Adding a joint type: subclass :class:`ConstraintType`, set ``name``, ``n_eq`` and ``eq_labels``,
implement ``evaluate``, and decorate it with :func:`register`.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np

from ..state import BodyState
from . import primitives as prim


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


class ConstraintType(abc.ABC):
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

    @abc.abstractmethod
    def evaluate(self, state: BodyState, t: float) -> ConstraintEval:
        """Phi, D, nu, gamma of every instance at the given state and time."""

    # ------------------------------------------------------------------ helpers for subclasses
    def _kins(self, state: BodyState):
        """Points and triad vectors of both bodies: (P_i, P_j, (u_i, a_i, b_i), (u_j, a_j, b_j))."""
        g = self.geometry
        P_i = prim.body_point(state, self.body_i, g.s_i, 0)
        P_j = prim.body_point(state, self.body_j, g.s_j, 1)
        tri_i = tuple(prim.body_vector(state, self.body_i, g.R_i[:, :, k], 0) for k in range(3))
        tri_j = tuple(prim.body_vector(state, self.body_j, g.R_j[:, :, k], 1) for k in range(3))
        return P_i, P_j, tri_i, tri_j

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
