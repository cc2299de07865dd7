"""Motion laws f(t) for drivers (rheonomic constraints), each with analytic f', f''.

Drivers prescribe a joint coordinate or a body coordinate as f(t); the constraint is
Phi = coordinate(q) - f(t), so nu = f'(t) (7.4) and gamma gains f''(t). No finite differences
are used in the engine: every law supplies its derivatives in closed form.

Laws of one class are evaluated for all driver instances at once (:class:`MotionLawSet`).
"""
from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Callable, ClassVar, Optional, Sequence

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

    @classmethod
    def evaluate_times(cls, laws: Sequence["MotionLaw"], times: np.ndarray):
        """(f, f', f'') for each law at every time: three arrays (nt, n). This default calls
        :meth:`evaluate_many` once per time (a user's functions are called as in a run); the
        built-in laws override it with one array expression over all times (the same
        arithmetic per element, so the same values)."""
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.empty((3, times.size, len(laws)))
        for k, t in enumerate(times):
            out[0, k], out[1, k], out[2, k] = cls.evaluate_many(laws, float(t))
        return out[0], out[1], out[2]

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

    @classmethod
    def evaluate_times(cls, laws, times):
        shape = (np.size(times), len(laws))
        f = np.broadcast_to(cls.evaluate_many(laws, 0.0)[0], shape)
        return f, np.zeros(shape), np.zeros(shape)


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

    @classmethod
    def evaluate_times(cls, laws, times):
        f, fd, fdd = cls.evaluate_many(laws, np.asarray(times, dtype=float).reshape(-1, 1))
        return f, np.broadcast_to(fd, f.shape), np.zeros(f.shape)


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

    @classmethod
    def evaluate_times(cls, laws, times):
        return cls.evaluate_many(laws, np.asarray(times, dtype=float).reshape(-1, 1))


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

    @classmethod
    def evaluate_times(cls, laws, times):
        return cls.evaluate_many(laws, np.asarray(times, dtype=float).reshape(-1, 1))


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

    @classmethod
    def evaluate_times(cls, laws, times):
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.empty((3, times.size, len(laws)))
        for k, law in enumerate(laws):                 # Horner's rule over all times at once
            c = np.polynomial.Polynomial(law.coefficients)
            out[0, :, k], out[1, :, k], out[2, :, k] = c(times), c.deriv(1)(times), \
                c.deriv(2)(times)
        return out[0], out[1], out[2]


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


@dataclass
class TimeSeries(MotionLaw):
    """f(t) from samples (t_k, f_k): linear interpolation (f' the slope of the segment holding
    t, f'' = 0) or a zero-order hold (``interpolation="zoh"``: f = f_k on [t_k, t_(k+1)),
    f' = 0); f_0 before t_0, the last value after the last time. Give ``times`` and ``values``
    or a CSV ``file`` with columns t, value (a header line is allowed). The times must be
    strictly increasing and every number finite. The integrator of a simulation steps onto the
    sample times (the jumps of f or f' are not integrated across)."""

    file: Optional[str] = None
    times: Optional[list] = None
    values: Optional[list] = None
    interpolation: str = "linear"
    kind: ClassVar[str] = "time_series"

    def __post_init__(self):
        what = f"time series {self.file!r}" if self.file is not None else "time series"
        if self.interpolation not in ("linear", "zoh"):
            raise ModelError(f"{what}: interpolation must be 'linear' or 'zoh' (zero-order "
                             f"hold), got {self.interpolation!r}")
        if self.file is not None:
            if self.times is not None or self.values is not None:
                raise ModelError(f"{what}: give a file or times and values, not both")
            t, f = read_series(self.file)
        else:
            if self.times is None or self.values is None:
                raise ModelError("time series: give a CSV file (columns t, value) or times "
                                 "and values")
            try:
                t = np.asarray(self.times, dtype=float).reshape(-1)
                f = np.asarray(self.values, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                raise ModelError(f"{what}: times and values must be numbers") from None
        _check_series(what, t, f)
        self._t, self._f = t, f

    @property
    def breakpoints(self) -> np.ndarray:
        """The sample times, where f (zoh) or f' (linear) jumps."""
        return self._t

    def sample(self, t: float):
        tk, fk = self._t, self._f
        k = int(np.searchsorted(tk, t, side="right")) - 1
        if k < 0:
            return float(fk[0]), 0.0
        if k >= tk.size - 1:
            return float(fk[-1]), 0.0
        if self.interpolation == "zoh":
            return float(fk[k]), 0.0
        slope = (fk[k + 1] - fk[k]) / (tk[k + 1] - tk[k])
        return float(fk[k] + slope * (t - tk[k])), float(slope)

    def sample_times(self, times: np.ndarray):
        """(f, f') at every time (nt,): :meth:`sample` over an array."""
        tk, fk = self._t, self._f
        k = np.searchsorted(tk, times, side="right") - 1
        before, after = k < 0, k >= tk.size - 1
        inner = np.clip(k, 0, max(tk.size - 2, 0))
        f = np.where(before, fk[0], fk[-1])
        fd = np.zeros(times.size)
        inside = ~before & ~after
        if self.interpolation == "zoh":
            f = np.where(inside, fk[inner], f)
        elif tk.size > 1:
            slope = (fk[inner + 1] - fk[inner]) / (tk[inner + 1] - tk[inner])
            f = np.where(inside, fk[inner] + slope * (times - tk[inner]), f)
            fd = np.where(inside, slope, 0.0)
        return f, fd

    @classmethod
    def evaluate_many(cls, laws, t):
        f = np.empty(len(laws))
        fd = np.empty(len(laws))
        for k, law in enumerate(laws):
            f[k], fd[k] = law.sample(t)
        return f, fd, np.zeros(len(laws))

    @classmethod
    def evaluate_times(cls, laws, times):
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.zeros((3, times.size, len(laws)))
        for k, law in enumerate(laws):
            out[0, :, k], out[1, :, k] = law.sample_times(times)
        return out[0], out[1], out[2]

    def to_dict(self) -> dict:
        out = {"type": self.kind}
        if self.file is not None:
            out["file"] = self.file
        else:
            out["times"], out["values"] = self._t.tolist(), self._f.tolist()
        out["interpolation"] = self.interpolation
        return out


def read_series(file) -> tuple:
    """(t (n,), value (n,)) of a CSV file with columns t, value (one optional header line)."""
    import os
    if not os.path.isfile(str(file)):
        raise ModelError(f"time series file {file!r} not found (looked for "
                         f"{os.path.abspath(str(file))}); give a path relative to the model "
                         "file or an absolute one")
    rows = []
    with open(file, encoding="utf-8") as fh:
        for n, line in enumerate(fh, start=1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            parts = [p.strip() for p in text.split(",")]
            try:
                numbers = [float(p) for p in parts]
            except ValueError:
                if not rows and n == _first_line(file):
                    continue                               # the header
                raise ModelError(f"time series file {file!r}, line {n}: expected two numbers "
                                 f"t, value; got {text!r}") from None
            if len(numbers) != 2:
                raise ModelError(f"time series file {file!r}, line {n}: expected two columns "
                                 f"t, value; got {len(numbers)}")
            rows.append(numbers)
    if not rows:
        raise ModelError(f"time series file {file!r}: no samples (expected lines t, value)")
    data = np.array(rows)
    return data[:, 0], data[:, 1]


def _first_line(file) -> int:
    with open(file, encoding="utf-8") as fh:
        for n, line in enumerate(fh, start=1):
            if line.strip() and not line.strip().startswith("#"):
                return n
    return 0


def _check_series(what, t, f) -> None:
    if t.size != f.size or t.size == 0:
        raise ModelError(f"{what}: {t.size} times and {f.size} values; give one value per "
                         "time (at least one)")
    bad = np.flatnonzero(~np.isfinite(t) | ~np.isfinite(f))
    if bad.size:
        raise ModelError(f"{what}: sample {bad[0]} is not finite (t = {t[bad[0]]}, value = "
                         f"{f[bad[0]]}); every time and value must be a finite number")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        k = back[0]
        raise ModelError(f"{what}: the times must increase strictly; t[{k + 1}] = {t[k + 1]} "
                         f"follows t[{k}] = {t[k]}")


LAWS: dict[str, type[MotionLaw]] = {cls.kind: cls for cls in
                                    (Constant, ConstantVelocity, Harmonic, SmoothStep, Polynomial,
                                     TimeSeries, UserFunction)}


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

    def over(self, times) -> np.ndarray:
        """(nt, n, 3): f, f', f'' of every law at every time (one array call per law class
        and all times for the built-in laws)."""
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.empty((times.size, self.n, 3))
        for cls, idx, laws in self._groups:
            f, fd, fdd = cls.evaluate_times(laws, times)
            out[:, idx, 0], out[:, idx, 1], out[:, idx, 2] = f, fd, fdd
        return out
