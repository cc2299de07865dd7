"""Constraint types: the contract every joint and driver module implements.

A constraint type evaluates all of its instances in one call. The joint geometry is reduced, at
model compile time, to local quantities on each of the two bodies i and j:

    s_i, s_j  (n, 3)     joint point in body-i / body-j axes (the text's s'^P)
    R_i, R_j  (n, 3, 3)  orthonormal joint triads in body axes, columns [u, a, b]: u is the joint
                         axis (or the first vector of a basic constraint), a and b span the plane
                         normal to it, b = u x a (Fig. 9.2)
    param     (n, P)     the type's own parameters (link length, pitch, ...), in the order of
                         its ``parameters`` declaration

``evaluate(state, t)`` returns a :class:`ConstraintEval` with, for the n instances and m equations
per instance,

    phi   (n, m)       Phi(q, t), Eq. (7.2)
    D     (n, m, 12)   dPhidot/dv with v = [rdot_i, omega_i, rdot_j, omega_j], Eq. (7.3)
    nu    (n, m)       -dPhi/dt, Eq. (7.4) (ERRATA: the printed right-hand side "v" is nu)
    gamma (n, m)       D vdot = gamma, Eq. (7.6), including the time terms of drivers.

A type declares everything about itself in its class body (the registry generates the rest:
the compiled dispatch, the builder's keyword checks, the model-file schema and the docs table):

    name, aliases      its name in files and the API, and accepted other spellings
    n_eq, eq_labels    number of equations per instance and a label for each
    inputs             the geometric inputs it needs: point, axis (on i), point2, axis2 (on j)
    parameters         a tuple of :class:`Param` (name, unit, default, checks, doc)
    driver_kinds       the driver kinds that may act on it ("angle", "translation")
    angle_based        its equations use the relative joint angle (defined while a_j is not
                       along the axis u_i)
    kernel             the compiled kernel for one instance k, ``kernel(S, G, k, row, out)``,
                       built from the primitives of :mod:`.primitives` (S: body state arrays,
                       G: the :class:`~.kernels.JointRows` table, out = (phi, D, nu, gamma))

Adding a joint type is one module in this package (it is discovered, registered and compiled
into the dispatch automatically) plus its test file; see docs/architecture.md. A type
registered from user code after the package was imported runs its kernel through its own
compiled loop, called per group between the compiled stages (correct, somewhat slower).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, ClassVar, Optional, Sequence

import numpy as np

from ..errors import ModelError
from ..state import BodyState


@dataclass
class ConstraintEval:
    phi: np.ndarray
    D: np.ndarray
    nu: np.ndarray
    gamma: np.ndarray


@dataclass(frozen=True)
class Param:
    """One parameter of an element type: a number per instance, or with ``size`` > 1 a list of
    1 to ``size`` numbers (stored as its length followed by the values: ``size + 1`` columns).

    name: keyword in the API and the model file; unit: SI unit ("m", "m/rad", "-", ...);
    default: None = required (unless the type computes it from the assembled configuration);
    positive / nonzero: checks applied by the builder and the file reader (to every value of a
    list); doc: one line.
    """

    name: str
    unit: str
    doc: str
    default: Optional[float] = None
    positive: bool = False
    nonzero: bool = False
    size: int = 1

    @property
    def width(self) -> int:
        """Columns of the parameter block: 1, or the length and ``size`` values of a list."""
        return 1 if self.size == 1 else self.size + 1

    def check(self, value, what: str):
        """The validated value (a finite float; a float array for a list), or ModelError naming
        the element and value."""
        if self.size > 1:
            if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
                raise ModelError(f"{what}.{self.name}: expected a list of 1 to {self.size} "
                                 f"numbers ({self.unit}), got {value!r}")
            if not 1 <= len(value) <= self.size:
                raise ModelError(f"{what}.{self.name}: expected 1 to {self.size} numbers "
                                 f"({self.unit}), got {len(value)}")
            out = np.empty(len(value))
            for k, x in enumerate(value):       # each value checked as a scalar parameter
                item = Param(f"{self.name}[{k}]", self.unit, self.doc, None, self.positive,
                             self.nonzero)
                out[k] = item.check(x, what)
            return out
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise ModelError(f"{what}.{self.name}: expected a number ({self.unit}), got "
                             f"{value!r}") from None
        if not math.isfinite(x):
            raise ModelError(f"{what}.{self.name}: must be finite, got {value!r}")
        if self.positive and not x > 0:
            raise ModelError(f"{what}.{self.name}: must be positive, got {x} ({self.unit})")
        if self.nonzero and x == 0:
            raise ModelError(f"{what}.{self.name}: must not be zero ({self.unit})")
        return x


#: the link length of the composite joints; default: the distance of the points as assembled
LINK_LENGTH = Param("length", "m", "link length; default: the distance of the two points as "
                    "assembled", positive=True)


@dataclass(frozen=True)
class JointGeometry:
    """Local joint geometry of n instances (see the module docstring)."""

    s_i: np.ndarray
    s_j: np.ndarray
    R_i: np.ndarray
    R_j: np.ndarray
    param: np.ndarray

    @classmethod
    def stack(cls, items: Sequence["JointGeometry"]) -> "JointGeometry":
        return cls(*(np.concatenate([getattr(g, f) for g in items], axis=0)
                     for f in ("s_i", "s_j", "R_i", "R_j", "param")))


class ConstraintType:
    """A group of constraint instances of one type, evaluated together."""

    name: ClassVar[str] = ""
    aliases: ClassVar[tuple[str, ...]] = ()
    n_eq: ClassVar[int] = 0
    eq_labels: ClassVar[tuple[str, ...]] = ()
    #: geometric inputs: "point", "axis" (on body i), "point2", "axis2" (on body j)
    inputs: ClassVar[frozenset] = frozenset()
    #: the type's parameters, stored per instance in the param column (n, P) of the table
    parameters: ClassVar[tuple[Param, ...]] = ()
    #: which driver kinds may act on a joint of this type ("angle", "translation")
    driver_kinds: ClassVar[tuple[str, ...]] = ()
    #: whether the constraint depends explicitly on time
    rheonomic: ClassVar[bool] = False
    #: the equations use the relative joint angle (see primitives.angle_row)
    angle_based: ClassVar[bool] = False
    #: an equation between two joints' coordinates (constraints.couplers), not a joint
    coupler: ClassVar[bool] = False
    #: equations (indices) that constrain velocities only -- nonholonomic rows such as rolling
    #: without slip (constraints.rolling): their kernel writes phi = nu = 0, so position solves
    #: carry them with zero residual and the velocity and acceleration levels use them in full
    velocity_rows: ClassVar[tuple[int, ...]] = ()
    #: how the viewer draws an instance: "link" (a rod between the joint points on body i and
    #: body j: a distance constraint), or "" (a joint marker)
    drawn_as: ClassVar[str] = ""
    #: the compiled kernel of one instance, kernel(S, G, k, row, out) (None: override evaluate)
    kernel: ClassVar[Optional[Callable]] = None

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
        """True when the group runs in the fused compiled dispatch (its kernel is part of it and
        evaluate is not overridden)."""
        return (DISPATCH.kind_id.get(self.name, -1) >= 0 and type(self).kernel is not None
                and type(self).evaluate is ConstraintType.evaluate)

    @classmethod
    def doc(cls) -> str:
        """The first sentence of the type's docstring (or of its module's)."""
        import sys
        text = cls.__doc__ or sys.modules[cls.__module__].__doc__ or ""
        import re
        first = " ".join(text.strip().split("\n\n")[0].split())
        end = re.search(r"(?<!Eq)(?<!Eqs)(?<!sec)\.\s+(?=[A-Z])", first)
        return first if end is None else first[:end.start() + 1]

    @classmethod
    def resolve_parameters(cls, given: dict, P_i: np.ndarray, P_j: np.ndarray,
                           what: str) -> np.ndarray:
        """(P,) parameter values of one instance from the user's keywords ``given``.

        P_i, P_j: the global joint points as assembled (for defaults derived from them).
        Missing parameters take their default; LINK_LENGTH defaults to |P_j - P_i|."""
        out = np.zeros(cls.param_columns())
        col = 0
        for par in cls.parameters:
            a, col = col, col + par.width
            value = given.get(par.name)
            if value is None and par is LINK_LENGTH:
                value = float(np.linalg.norm(P_j - P_i))
                if not value > 0:
                    raise ModelError(f"{what}: the two points coincide, so the link length is "
                                     "0; give distinct points or length > 0")
            if value is None:
                value = par.default
            if value is None:
                raise ModelError(f"{what}: a {cls.name} joint needs {par.name} ({par.unit}): "
                                 f"{par.doc}")
            value = par.check(value, what)
            if par.size == 1:
                out[a] = value
            else:                        # a list: its length, then its values
                out[a] = value.size
                out[a + 1:a + 1 + value.size] = value
        return out

    @classmethod
    def param_columns(cls) -> int:
        """Columns of the type's parameter block: the widths of its parameters (a type that
        stores derived values after them, e.g. spline coefficients, returns more)."""
        return sum(par.width for par in cls.parameters)

    @classmethod
    def check_assembled(cls, what: str, axis_i: np.ndarray, axis_j: np.ndarray) -> None:
        """Checks of the assembled geometry (global unit axes u_i, u_j); ModelError if wrong."""

    def law_values(self, t: float) -> np.ndarray | None:
        """(n, 3) f, f', f'' of the drivers' motion laws at t (None: not a driver)."""
        return None

    def law_history(self, times: np.ndarray) -> np.ndarray | None:
        """(nt, n, 3): :meth:`law_values` at every time of ``times`` (nt,) at once."""
        return None

    def evaluate(self, state: BodyState, t: float) -> ConstraintEval:
        """Phi, D, nu, gamma of every instance at the given state and time."""
        return DISPATCH.evaluate_group(self, state, t)

    @staticmethod
    def _scleronomic(phi, D, gamma) -> ConstraintEval:
        """A time-independent evaluation (nu = 0); scalar parts get their equation axis."""
        if phi.ndim == 1:
            phi, D, gamma = phi[:, None], D[:, None, :], gamma[:, None]
        return ConstraintEval(phi, D, np.zeros_like(phi), gamma)


#: the live registry: name -> type (every registered joint, basic constraint and driver)
CONSTRAINT_TYPES: dict[str, type[ConstraintType]] = {}
#: other accepted spellings -> name
ALIASES: dict[str, str] = {}


class Dispatch:
    """The compiled dispatch of the package, installed by :mod:`.kernels` once it has been
    generated (the registry sits below it and never imports it): ``kind_id`` (type name ->
    kind number in the fused dispatch), ``evaluate_group(group, state, t)`` and
    ``register_late(cls)`` (a compiled loop of its own for a type registered afterwards; None
    until the dispatch is built)."""

    def __init__(self):
        self.kind_id: dict = {}
        self.evaluate_group: Optional[Callable] = None
        self.register_late: Optional[Callable] = None


DISPATCH = Dispatch()


def register(cls: type[ConstraintType]) -> type[ConstraintType]:
    """Class decorator: add a constraint type to the live registry (usable from user code).

    Checks the declaration (name, n_eq, labels, inputs, parameters) at once, so a wrong type
    fails where it is defined, naming the problem."""
    where = f"constraint type {cls.__name__}"
    if not cls.name or not isinstance(cls.name, str):
        raise ModelError(f"{where}: set a non-empty string ``name``")
    if not isinstance(cls.n_eq, int) or cls.n_eq < 1 or len(cls.eq_labels) != cls.n_eq:
        raise ModelError(f"{where} ({cls.name!r}): n_eq = {cls.n_eq!r} needs as many "
                         f"eq_labels, got {cls.eq_labels!r}")
    unknown = set(cls.inputs) - {"point", "axis", "point2", "axis2"}
    if unknown:
        raise ModelError(f"{where} ({cls.name!r}): unknown inputs {sorted(unknown)}; use "
                         "point, axis, point2, axis2")
    if any(not isinstance(r, int) or not 0 <= r < cls.n_eq for r in cls.velocity_rows):
        raise ModelError(f"{where} ({cls.name!r}): velocity_rows {cls.velocity_rows!r} must be "
                         f"equation indices below n_eq = {cls.n_eq}")
    names = [p.name for p in cls.parameters]
    if len(set(names)) != len(names):
        raise ModelError(f"{where} ({cls.name!r}): duplicate parameter names {names}")
    for key in (cls.name,) + tuple(cls.aliases):
        owner = ALIASES.get(key, key if key in CONSTRAINT_TYPES else None)
        if owner is not None and CONSTRAINT_TYPES[owner].__qualname__ != cls.__qualname__:
            raise ModelError(f"{where}: the name {key!r} is taken by "
                             f"{CONSTRAINT_TYPES[owner].__name__}")
    CONSTRAINT_TYPES[cls.name] = cls
    for alias in cls.aliases:
        ALIASES[alias] = cls.name
    if DISPATCH.register_late is not None:      # registered after the dispatch was made
        DISPATCH.register_late(cls)
    return cls


def canonical_name(name) -> str:
    """The registered name for ``name`` or one of its aliases (unchanged if unknown)."""
    return ALIASES.get(name, name) if isinstance(name, str) else name
