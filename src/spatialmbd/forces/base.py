"""Force elements (text ch. 11): the contract every force module implements.

A force group evaluates all of its instances at once and returns their contribution to the
generalized force vector g (10.6) of every body: (nb+1, 6) rows [f (3), n (3)] in global axes,
n about the centre of mass, the ground row last (discarded). Sign convention: the returned
forces act ON the bodies.

For the energy balance each group also reports its potential energy (conservative parts) and
the power of its non-conservative parts (damping, actuators, external loads).
"""
from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np

from ..errors import ModelError
from ..state import BodyState


#: the kinds a force parameter may have in a model file (how the reader checks it)
PARAM_KINDS = ("body", "joint", "point", "vector", "matrix", "string", "number", "law", "any")


class Dispatch:
    """The compiled dispatch of the package, installed by :mod:`.kernels` once it has been
    generated (this module sits below it and never imports it): ``kind_id`` (type name ->
    kind number) and ``evaluate_group(group, state, t, states)``."""

    def __init__(self):
        self.kind_id: dict = {}
        self.evaluate_group = None


DISPATCH = Dispatch()


class ForceType(abc.ABC):
    """A force-element type. Declares in its class body: ``name``; ``parameters``, a dict
    keyword -> kind (one of :data:`PARAM_KINDS`: how the model file writes it); ``required``,
    the keywords without a default; ``in_files`` False if it cannot be written in a model file
    (Python callables). The registry (:func:`register`) generates from these the builder's
    keyword checks, the model-file schema and the docs table."""

    name: ClassVar[str] = ""
    parameters: ClassVar[dict] = {}
    required: ClassVar[tuple] = ()
    in_files: ClassVar[bool] = True
    #: how the viewer draws an instance between its two attachment points (``bi``/``s_i``,
    #: ``bj``/``s_j``): "spring" (a coil), or "" (not drawn: contacts draw their shapes,
    #: joint-coordinate elements sit on their joint)
    drawn_as: ClassVar[str] = ""
    #: the compiled kernel of one instance (see :mod:`.kernels`); None: evaluate in Python
    kernel: ClassVar = None
    #: number of numeric parameters the kernel reads from the table's param columns
    n_param: ClassVar[int] = 0

    @property
    def compiled(self) -> bool:
        """True when the group runs in the fused compiled dispatch."""
        return type(self).kernel is not None and self.name in DISPATCH.kind_id

    def columns(self) -> dict:
        """The force-table columns of the instances (compiled types): bi, bj (n,), s_i, s_j
        (n, 3) in body axes, R_i, R_j (n, 3, 3), param (n, n_param); absent ones are zero."""
        raise ModelError(f"force type {self.name!r} declares a kernel but no columns()")

    #: the motion laws of the instances (MotionLawSet), or None
    laws = None

    def state_rows(self) -> np.ndarray:
        """(n,) bool: the instances that carry internal states (integrated with the bodies;
        see :mod:`.kernels`). None by default."""
        return np.zeros(self.n, dtype=bool)

    @property
    def time_dependent(self) -> bool:
        """True if a law of an instance changes with time (then it is set at every time)."""
        from ..motion import Constant
        return self.laws is not None and any(
            cls is not Constant for cls, _, _ in self.laws._groups)

    def law_values(self, t: float) -> np.ndarray:
        """(n, 3): f, f', f'' of each instance's law at t (zeros without laws)."""
        out = np.zeros((self.n, 3))
        if self.laws is not None:
            out[:, 0], out[:, 1], out[:, 2] = self.laws(t)
        return out

    def _run(self, state, t, states=None):
        return DISPATCH.evaluate_group(self, state, t, states)

    @classmethod
    def allowed(cls) -> tuple:
        return tuple(cls.parameters)

    @classmethod
    def doc(cls) -> str:
        import sys
        text = cls.__doc__ or sys.modules[cls.__module__].__doc__ or ""
        import re
        first = " ".join(text.strip().split("\n\n")[0].split())
        end = re.search(r"(?<!Eq)(?<!Eqs)(?<!sec)\.\s+(?=[A-Z])", first)
        return first if end is None else first[:end.start() + 1]

    def __init__(self, names):
        self.names = tuple(names)
        self.n = len(self.names)

    @classmethod
    @abc.abstractmethod
    def validate(cls, spec, builder) -> None:
        """Check a ForceSpec against the builder; raise ModelError naming the problem."""

    @classmethod
    @abc.abstractmethod
    def build(cls, specs, context) -> "ForceType":
        """The group of all specs of this type (context: body index, joint geometry)."""

    def evaluate(self, state: BodyState, t: float, g: np.ndarray) -> None:
        """Add the generalized forces of every instance to g (nb+1, 6) (compiled types: through
        the kernel; others override this)."""
        g += self._run(state, t)[0]

    def potential_energy(self, state: BodyState, t: float, states=None) -> float:
        """Potential energy stored in the elements (J); states: (n, 3) internal states of the
        instances (LuGre bristles; default zero)."""
        if type(self).kernel is None:
            return 0.0
        return float(np.sum(self._run(state, t, states)[1]))

    def kinetic_energy(self, state: BodyState, t: float = 0.0) -> float:
        """Kinetic energy the elements add to the bodies' (J): rotor inertias (armature)."""
        return 0.0

    def nonconservative_power(self, state: BodyState, t: float) -> float:
        """Power delivered to the bodies by non-conservative parts (W)."""
        if type(self).kernel is None:
            return 0.0
        return float(np.sum(self._run(state, t)[2]))


def add_to_bodies(g: np.ndarray, body: np.ndarray, f: np.ndarray, n: np.ndarray) -> None:
    """g[body] += [f, n] with repeated bodies accumulated (np.add.at)."""
    np.add.at(g, (body, slice(0, 3)), f)
    np.add.at(g, (body, slice(3, 6)), n)


def check_body(spec, builder, key="body", ground_ok=False) -> str:
    body = spec.params.get(key)
    if body == "ground" and ground_ok:
        return body
    if body not in builder.bodies:
        raise ModelError(f"forces[{spec.name!r}].{key}: unknown body {body!r} (bodies: "
                         f"{', '.join(builder.bodies)})")
    return body


def local_point(spec, builder, body, key, default=(0.0, 0.0, 0.0)) -> np.ndarray:
    """A point on ``body`` in body axes, from a name, a local vector or None (default)."""
    value = spec.params.get(key, default)
    if body == "ground":
        pts = {}
    else:
        pts = builder.bodies[body].points
    if isinstance(value, str):
        if value not in pts:
            raise ModelError(f"forces[{spec.name!r}].{key}: body {body!r} has no point named "
                             f"{value!r}")
        return np.array(pts[value], dtype=float)
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise ModelError(f"forces[{spec.name!r}].{key}: expected 3 numbers or a point name, "
                         f"got {value!r}")
    return arr


def check_unknown(spec, allowed) -> None:
    allowed = allowed() if callable(allowed) else allowed
    extra = set(spec.params) - set(allowed)
    if extra:
        raise ModelError(f"forces[{spec.name!r}]: unknown parameter(s) {sorted(extra)} for a "
                         f"{spec.type}; allowed: {sorted(allowed)}")


def nonlinear_stiffness(spec, units: str) -> np.ndarray:
    """The ``nonlinear_stiffness`` [k1, k2, k3] of a spring element (1 to 3 finite numbers,
    missing ones 0; default none): the stiffness k + k1 |d| + k2 d^2 + k3 |d|^3 of the
    deflection d. The total stiffness must not be negative where the element starts: a
    softening spring (negative coefficients) is the user's to keep within its range."""
    value = spec.params.get("nonlinear_stiffness")
    out = np.zeros(3)
    if value is None:
        return out
    coefs = np.atleast_1d(np.asarray(value, dtype=object))
    try:
        numbers = np.array([float(c) for c in coefs.reshape(-1)], dtype=float)
    except (TypeError, ValueError):
        numbers = np.array([np.nan])
    if coefs.ndim != 1 or not 1 <= numbers.size <= 3 or not np.all(np.isfinite(numbers)):
        raise ModelError(f"forces[{spec.name!r}].nonlinear_stiffness: give 1 to 3 finite "
                         f"numbers [k1, k2, k3]{' (' + units + ')' if units else ''}, the "
                         "coefficients of |d|, d^2, |d|^3 in the stiffness k + k1 |d| + "
                         f"k2 d^2 + k3 |d|^3; got {value!r}")
    out[:numbers.size] = numbers
    return out


def spring_law(k: float, nonlinear, d: float):
    """(k(d) d, potential) of a spring of stiffness k + k1 |d| + k2 d^2 + k3 |d|^3 at
    deflection d (nonlinear = [k1, k2, k3]) -- the compiled kernels' arithmetic, for outputs
    evaluated in Python."""
    k1, k2, k3 = (float(c) for c in nonlinear)
    a = abs(d)
    return ((k + a * (k1 + a * (k2 + a * k3))) * d,
            d * d * (0.5 * k + a * (k1 / 3.0 + a * (0.25 * k2 + a * 0.2 * k3))))


#: the live registry of force-element types: name -> class
FORCE_TYPES: dict = {}


def register(cls):
    """Class decorator: add a force-element type to the live registry (usable from user code);
    checks the declaration at once."""
    if not cls.name or not isinstance(cls.name, str):
        raise ModelError(f"force type {cls.__name__}: set a non-empty string ``name``")
    bad = {k: v for k, v in cls.parameters.items() if v not in PARAM_KINDS}
    if bad:
        raise ModelError(f"force type {cls.name!r}: unknown parameter kinds {bad}; use "
                         f"{', '.join(PARAM_KINDS)}")
    missing = set(cls.required) - set(cls.parameters)
    if missing:
        raise ModelError(f"force type {cls.name!r}: required {sorted(missing)} are not among "
                         "its parameters")
    if cls.kernel is not None and cls.columns is ForceType.columns:
        raise ModelError(f"force type {cls.name!r}: a type with a kernel must define columns() "
                         "(its force-table columns)")
    other = FORCE_TYPES.get(cls.name)
    if other is not None and other.__qualname__ != cls.__qualname__:
        raise ModelError(f"force type {cls.__name__}: the name {cls.name!r} is taken by "
                         f"{other.__name__}")
    FORCE_TYPES[cls.name] = cls
    return cls
