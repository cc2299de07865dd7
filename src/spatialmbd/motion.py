"""Motion laws f(t) for drivers (rheonomic constraints), each with analytic f', f''.

Drivers prescribe a joint coordinate or a body coordinate as f(t); the constraint is
Phi = coordinate(q) - f(t), so nu = f'(t) (7.4) and gamma gains f''(t). No finite differences
are used in the engine: every law supplies its derivatives in closed form.

Laws of one class are evaluated for all driver instances at once (:class:`MotionLawSet`).
"""
from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Callable, ClassVar, Sequence

import numpy as np

from .errors import ModelError


class MotionLaw(abc.ABC):
    """Base class. Subclasses are dataclasses whose numeric fields are the law's parameters."""

    kind: ClassVar[str] = ""

    def __call__(self, t: float) -> tuple[float, float, float]:
        f, fd, fdd = type(self).evaluate_many([self], float(t))
        return float(f[0]), float(fd[0]), float(fdd[0])

    @classmethod
    @abc.abstractmethod
    def evaluate_many(cls, laws: Sequence["MotionLaw"], t: float):
        """(f, f', f'') for each law of this class at time t: three arrays (n,)."""

    def to_dict(self) -> dict:
        out = {"type": self.kind}
        out.update({k: v for k, v in self.__dict__.items()})
        return out


@dataclass
class Constant(MotionLaw):
    """f(t) = value."""

    value: float = 0.0
    kind: ClassVar[str] = "constant"

    @classmethod
    def evaluate_many(cls, laws, t):
        f = np.array([law.value for law in laws], dtype=float)
        return f, np.zeros_like(f), np.zeros_like(f)


@dataclass
class ConstantVelocity(MotionLaw):
    """f(t) = initial + rate * t (rad or m; rate in rad/s or m/s)."""

    rate: float = 0.0
    initial: float = 0.0
    kind: ClassVar[str] = "constant_velocity"

    @classmethod
    def evaluate_many(cls, laws, t):
        rate = np.array([law.rate for law in laws], dtype=float)
        f0 = np.array([law.initial for law in laws], dtype=float)
        return f0 + rate * t, rate, np.zeros_like(rate)


@dataclass
class Harmonic(MotionLaw):
    """f(t) = offset + amplitude * sin(frequency * t + phase); frequency in rad/s."""

    amplitude: float = 1.0
    frequency: float = 1.0
    phase: float = 0.0
    offset: float = 0.0
    kind: ClassVar[str] = "harmonic"

    @classmethod
    def evaluate_many(cls, laws, t):
        a = np.array([law.amplitude for law in laws], dtype=float)
        w = np.array([law.frequency for law in laws], dtype=float)
        ph = np.array([law.phase for law in laws], dtype=float)
        c = np.array([law.offset for law in laws], dtype=float)
        arg = w * t + ph
        s, co = np.sin(arg), np.cos(arg)
        return c + a * s, a * w * co, -a * w * w * s


@dataclass
class SmoothStep(MotionLaw):
    """Quintic step from f0 (t <= t0) to f1 (t >= t1) with zero slope and curvature at both ends."""

    t0: float = 0.0
    t1: float = 1.0
    f0: float = 0.0
    f1: float = 1.0
    kind: ClassVar[str] = "smooth_step"

    def __post_init__(self):
        if not self.t1 > self.t0:
            raise ModelError(f"smooth_step: t1 ({self.t1}) must be greater than t0 ({self.t0})")

    @classmethod
    def evaluate_many(cls, laws, t):
        t0 = np.array([law.t0 for law in laws], dtype=float)
        t1 = np.array([law.t1 for law in laws], dtype=float)
        f0 = np.array([law.f0 for law in laws], dtype=float)
        f1 = np.array([law.f1 for law in laws], dtype=float)
        T = t1 - t0
        x = np.clip((t - t0) / T, 0.0, 1.0)
        inside = (t > t0) & (t < t1)
        h = x**3 * (10 - 15 * x + 6 * x * x)
        hd = np.where(inside, 30 * x * x * (1 - x) ** 2 / T, 0.0)
        hdd = np.where(inside, 60 * x * (1 - x) * (1 - 2 * x) / T**2, 0.0)
        df = f1 - f0
        return f0 + df * h, df * hd, df * hdd


@dataclass
class Polynomial(MotionLaw):
    """f(t) = sum_k coefficients[k] * t**k."""

    coefficients: list = field(default_factory=lambda: [0.0])
    kind: ClassVar[str] = "polynomial"

    @classmethod
    def evaluate_many(cls, laws, t):
        f = np.empty(len(laws))
        fd = np.empty(len(laws))
        fdd = np.empty(len(laws))
        for k, law in enumerate(laws):
            c = np.polynomial.Polynomial(law.coefficients)
            f[k], fd[k], fdd[k] = c(t), c.deriv(1)(t), c.deriv(2)(t)
        return f, fd, fdd


@dataclass
class UserFunction(MotionLaw):
    """f, f', f'' given as three callables of t (derivatives are required, not differenced)."""

    f: Callable[[float], float] = None
    fdot: Callable[[float], float] = None
    fddot: Callable[[float], float] = None
    kind: ClassVar[str] = "user"

    def __post_init__(self):
        for name in ("f", "fdot", "fddot"):
            if not callable(getattr(self, name)):
                raise ModelError(f"user motion law: {name} must be a callable of t; the engine "
                                 "needs analytic first and second derivatives (f, fdot, fddot)")

    @classmethod
    def evaluate_many(cls, laws, t):
        return (np.array([law.f(t) for law in laws], dtype=float),
                np.array([law.fdot(t) for law in laws], dtype=float),
                np.array([law.fddot(t) for law in laws], dtype=float))

    def to_dict(self) -> dict:
        raise ModelError("a user-function motion law cannot be written to a model file")


LAWS: dict[str, type[MotionLaw]] = {cls.kind: cls for cls in
                                    (Constant, ConstantVelocity, Harmonic, SmoothStep, Polynomial,
                                     UserFunction)}


def make_law(spec) -> MotionLaw:
    """A MotionLaw from an instance, a number (constant), or a dict {"type": ..., params}."""
    if isinstance(spec, MotionLaw):
        return spec
    if isinstance(spec, (int, float)):
        return Constant(float(spec))
    if isinstance(spec, dict):
        params = dict(spec)
        kind = params.pop("type", None)
        if kind not in LAWS or kind == "user":
            raise ModelError(f"unknown motion law type {kind!r}; valid: "
                             + ", ".join(k for k in LAWS if k != "user"))
        try:
            return LAWS[kind](**params)
        except TypeError as exc:
            raise ModelError(f"motion law {kind!r}: {exc}") from None
    raise ModelError(f"a motion law must be a MotionLaw, a number or a dict, not {spec!r}")


class MotionLawSet:
    """Evaluates a list of laws, one vectorized call per law class."""

    def __init__(self, laws: Sequence[MotionLaw]):
        self.n = len(laws)
        groups: dict[type, list[int]] = {}
        for k, law in enumerate(laws):
            groups.setdefault(type(law), []).append(k)
        self._groups = [(cls, np.array(idx), [laws[i] for i in idx]) for cls, idx in groups.items()]

    def __call__(self, t: float):
        f = np.empty(self.n)
        fd = np.empty(self.n)
        fdd = np.empty(self.n)
        for cls, idx, laws in self._groups:
            f[idx], fd[idx], fdd[idx] = cls.evaluate_many(laws, t)
        return f, fd, fdd
