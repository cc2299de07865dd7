"""What a sweep keeps of each member's results: scalar reductions of result columns, or whole
time series.

An output is written ``reduction(column)`` or just ``column`` (the whole time series):

    max(pendulum.z)       min(...)   final(...)   mean(...)   rms(...)   absmax(...)
                          (of the samples; rms = sqrt(mean(x^2)), e.g. a motor's torque)
    peak(pendulum.z)      trough(...)   the largest / smallest value between the samples: the
                          extreme sample refined by the cubic through the four samples
                          around it (for smooth columns; at a jump or kink use max / min)
    period(pendulum.wx)   the mean time between upward zero crossings (s), each crossing
                          located by the cubic through the four samples around it
    pendulum.z            the time series (a "time" dimension in the result)

or a callable ``f(results) -> float`` (its ``__name__`` names it), or a dict
``{name: spec}`` to choose the names.

Columns are those of :meth:`spatialmbd.results.Results.to_dataframe`, computed only when asked:
``<body>.x|y|z|e0..e3|vx|vy|vz|wx|wy|wz|ax|ay|az|alphax|alphay|alphaz`` (global axes, SI),
``<body>.<point>.x|y|z|vx|vy|vz`` (named points), ``<joint>.<body>.fx..mz`` (reactions, N and
N m), ``violation.position|velocity``, ``energy.kinetic|gravitational|elastic|total|error|
work_nonconservative`` (J). Kinematic results offer the columns of their own table.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ..errors import ModelError
from ..jit import njit
from ..outputs.vocabulary import (BODY_ACCELERATION, BODY_POSITION, BODY_VELOCITY, ENERGY,
                                 REACTION, VIOLATION)

__all__ = ["Output", "parse_outputs", "REDUCTIONS", "period", "peak", "trough", "Columns"]

_POINT = {"x": ("r", 0), "y": ("r", 1), "z": ("r", 2), "vx": ("rdot", 0), "vy": ("rdot", 1),
          "vz": ("rdot", 2)}
_SPEC = re.compile(r"^\s*([A-Za-z_]+)\s*\(\s*([^()]+?)\s*\)\s*$")


def period(t: np.ndarray, x: np.ndarray) -> float:
    """Mean time (s) between upward zero crossings of x(t); NaN with fewer than two crossings.

    Each crossing is bracketed by two samples and located as the root of the cubic through the
    four samples around it, so the error is O(dt^4) for smooth x.
    """
    times = crossing_times(t, x)
    if len(times) < 2:
        return math.nan
    return (times[-1] - times[0]) / (len(times) - 1)


def crossing_times(t: np.ndarray, x: np.ndarray) -> list:
    """Times (s) of the upward zero crossings of x(t) (x[k] < 0 <= x[k+1]), each the root in
    [t_k, t_k+1] of the cubic through the four samples around it (Newton's method on the
    cubic, safeguarded by bisection of the bracket; compiled: a sweep locates thousands)."""
    t = np.ascontiguousarray(t, dtype=float)
    x = np.ascontiguousarray(x, dtype=float)
    return _crossings(t, x).tolist()


@njit
def _crossings(t, x):
    idx = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
    out = np.empty(idx.size)
    for j in range(idx.size):
        out[j] = _cubic_root(t, x, idx[j])
    return out


@njit
def cubic_coefficients(t, x, k):
    """(a, c): the polynomial through the samples around [t_k, t_k+1] (four, fewer when
    there are fewer samples) as sum_i c[i] (s - a)^i, a = t_k (lowest degree first): Newton's
    divided differences expanded into powers of (s - a)."""
    n_all = t.size
    lo = max(0, min(k - 1, n_all - 4))
    hi = min(n_all, lo + 4)
    a = t[k]
    n = hi - lo
    tt = np.empty(n)
    d = np.empty(n)
    for i in range(n):
        tt[i] = t[lo + i] - a
        d[i] = x[lo + i]
    for j in range(1, n):                         # d[i] <- f[tt[i-j], ..., tt[i]]
        for i in range(n - 1, j - 1, -1):
            d[i] = (d[i] - d[i - 1]) / (tt[i] - tt[i - j])
    c = np.zeros(n)                               # Horner on the Newton form:
    c[0] = d[n - 1]                               # c <- c (s - tt[i]) + d[i]
    deg = 0
    for i in range(n - 2, -1, -1):
        deg += 1
        for m in range(deg, 0, -1):               # multiply by s: shift up
            c[m] = c[m - 1]
        c[0] = 0.0
        for m in range(deg):
            c[m] -= tt[i] * c[m + 1]
        c[0] += d[i]
    return a, c


@njit
def _poly(c, s):
    value, slope = 0.0, 0.0
    for i in range(c.size - 1, -1, -1):
        slope = slope * s + value
        value = value * s + c[i]
    return value, slope


_EPS = float(np.finfo(float).eps)


@njit
def _cubic_root(t, x, k):
    a, c = cubic_coefficients(t, x, k)
    lo, hi = 0.0, t[k + 1] - a
    flo = x[k]
    s = lo + (hi - lo) * (-flo) / (x[k + 1] - flo)     # the linear-interpolation root
    for _ in range(50):
        f, df = _poly(c, s)
        if (f < 0.0) == (flo < 0.0):
            lo = s
        else:
            hi = s
        step = f / df if df != 0.0 else math.inf
        s_new = s - step
        if not lo < s_new < hi:                          # Newton left the bracket: bisect
            s_new = 0.5 * (lo + hi)
        if abs(s_new - s) <= 1e-15 * max(1.0, abs(a)) + 4 * _EPS * abs(s):
            return a + s_new
        s = s_new
    return a + s


def peak(t: np.ndarray, x: np.ndarray) -> float:
    """The largest value of x(t) between the samples (a smooth x).

    The largest sample x_k is refined by the stationary points of the cubics through the four
    samples around each interval next to it (:func:`cubic_coefficients`, as :func:`period`
    locates its crossings): the error is O(dt^4) instead of the samples' O(dt^2). Never less
    than the largest sample. At a jump or a kink the cubic overshoots (a sampled step: by 6 % of
    the jump): use max there.
    """
    return peak_at(np.ascontiguousarray(t, dtype=float),
                   np.ascontiguousarray(x, dtype=float))[0]


def trough(t: np.ndarray, x: np.ndarray) -> float:
    """The smallest value of x(t) between the samples: -peak(t, -x)."""
    return -peak(t, -np.asarray(x, dtype=float))


@njit
def peak_at(t, x):
    """(value, j, s) of :func:`peak`: the value at t_j + s, s in [0, t_j+1 - t_j] (s = 0 and
    j = k at the largest sample x_k itself when no cubic rises above it)."""
    k = int(np.argmax(x))
    best, jb, sb = x[k], k, 0.0
    if x.size < 3:
        return best, jb, sb
    for j in range(max(0, k - 1), min(k + 1, x.size - 1)):    # the intervals next to x_k
        a, c = cubic_coefficients(t, x, j)
        h = t[j + 1] - a
        # stationary points: c1 + 2 c2 s + 3 c3 s^2 = 0, the maxima among them (p'' < 0)
        c1, c2 = c[1], c[2]
        c3 = c[3] if c.size > 3 else 0.0
        qa, qb, qc = 3.0 * c3, 2.0 * c2, c1
        roots = np.empty(2)
        nr = 0
        if qa == 0.0:
            if qb != 0.0:
                roots[0] = -qc / qb
                nr = 1
        else:
            disc = qb * qb - 4.0 * qa * qc
            if disc >= 0.0:
                r = -0.5 * (qb + math.copysign(math.sqrt(disc), qb))   # the stable pair
                if r != 0.0:
                    roots[0], roots[1] = r / qa, qc / r
                    nr = 2
                else:
                    roots[0] = 0.0
                    nr = 1
        for i in range(nr):
            s = roots[i]
            if 0.0 < s < h and qb + 2.0 * qa * s < 0.0:
                v = _poly(c, s)[0]
                if v > best:
                    best, jb, sb = v, j, s
    return best, jb, sb


REDUCTIONS: dict = {
    "max": lambda t, x: float(np.max(x)),
    "min": lambda t, x: float(np.min(x)),
    "absmax": lambda t, x: float(np.max(np.abs(x))),
    "peak": peak,
    "trough": trough,
    "final": lambda t, x: float(x[-1]),
    "initial": lambda t, x: float(x[0]),
    "mean": lambda t, x: float(np.mean(x)),
    "rms": lambda t, x: float(np.sqrt(np.mean(np.square(x)))),
    "period": period,
}


@dataclass
class Output:
    """One output: ``name`` in the result; ``column`` and ``reduction`` (None: the series), or
    ``function(results) -> float``."""

    name: str
    column: Optional[str] = None
    reduction: Optional[str] = None
    function: Optional[Callable] = None

    @property
    def series(self) -> bool:
        return self.function is None and self.reduction is None

    def evaluate(self, columns: "Columns"):
        if self.function is not None:
            return float(self.function(columns.results))
        x = columns.get(self.column)
        if self.reduction is None:
            return np.asarray(x, dtype=float)
        if x.size == 0:
            return math.nan
        return REDUCTIONS[self.reduction](columns.results.t, x)


def _parse_one(name, spec) -> Output:
    if callable(spec):
        return Output(name or getattr(spec, "__name__", "output"), function=spec)
    if not isinstance(spec, str) or not spec.strip():
        raise ModelError(f"output {name or spec!r}: expected 'reduction(column)', a column name "
                         f"or a callable, got {spec!r}")
    m = _SPEC.match(spec)
    if m:
        red, col = m.group(1), m.group(2)
        if red not in REDUCTIONS:
            raise ModelError(f"output {spec!r}: unknown reduction {red!r}; valid: "
                             f"{', '.join(REDUCTIONS)} (or just the column for its time series)")
        return Output(name or spec.replace(" ", ""), col, red)
    if "(" in spec or ")" in spec:
        raise ModelError(f"output {spec!r}: write reduction(column), e.g. max(pendulum.z)")
    return Output(name or spec.strip(), spec.strip(), None)


def parse_outputs(outputs) -> list:
    """A list of :class:`Output` from a string, a list of specs or a {name: spec} dict."""
    if outputs is None:
        raise ModelError("a sweep needs at least one output, e.g. outputs=['max(pendulum.z)']")
    if isinstance(outputs, (str, Output)) or callable(outputs):
        outputs = [outputs]
    if isinstance(outputs, dict):
        out = [_parse_one(str(k), v) for k, v in outputs.items()]
    else:
        out = [o if isinstance(o, Output) else _parse_one(None, o) for o in outputs]
    if not out:
        raise ModelError("a sweep needs at least one output, e.g. outputs=['max(pendulum.z)']")
    names = [o.name for o in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ModelError(f"outputs: duplicate names {dup}; give a dict {{name: spec}}")
    return out


def _engineering(results) -> dict:
    """The engineering output columns of a result (its own requests), without the reactions
    and energies the full table computes."""
    from ..outputs import compute_outputs
    try:
        return compute_outputs(results)
    except (AttributeError, TypeError):          # a result without what the outputs need
        return {}


class Columns:
    """Result columns by name, each computed on first use (reactions, energies and the
    constraint violation are computed once for all their columns)."""

    def __init__(self, results):
        self.results = results
        self._cache: dict = {}
        self._frame = None

    def get(self, name: str) -> np.ndarray:
        if name not in self._cache:
            self._cache[name] = self._compute(name)
        return self._cache[name]

    def _compute(self, name: str) -> np.ndarray:
        r = self.results
        model = r.model
        if name == "t":
            return np.asarray(r.t)
        parts = name.split(".")
        if len(parts) == 2 and parts[0] in model.body_names:
            k = model.body_names.index(parts[0])
            c = parts[1]
            if c in BODY_POSITION:
                return r.q[:, k, BODY_POSITION.index(c)]
            if c in BODY_VELOCITY:
                return r.v[:, k, BODY_VELOCITY.index(c)]
            if c in BODY_ACCELERATION:
                return r.vdot[:, k, BODY_ACCELERATION.index(c)]
        if len(parts) == 3 and f"{parts[0]}.{parts[1]}" in model.points and parts[2] in _POINT:
            key, j = _POINT[parts[2]]
            return r.point(f"{parts[0]}.{parts[1]}")[key][:, j]
        if hasattr(r, "energy") and len(parts) == 2 and parts[0] == "energy":
            en = self._group("energy", r.energy)
            if parts[1] in en:
                return en[parts[1]]
        if hasattr(r, "constraint_violation") and len(parts) == 2 and parts[0] == "violation":
            vi = self._group("violation", r.constraint_violation)
            if parts[1] in vi:
                return vi[parts[1]]
        if hasattr(r, "reactions") and len(parts) == 3:
            reac = self._group("reactions", r.reactions)
            if parts[0] in reac and parts[2] in REACTION:
                jr = reac[parts[0]]
                j = "xyz".index(parts[2][1])
                kind = "force" if parts[2][0] == "f" else "moment"
                if parts[1] == jr.body_i:
                    return getattr(jr, f"{kind}_i")[:, j]
                if parts[1] == jr.body_j:
                    return getattr(jr, f"{kind}_j")[:, j]
        if getattr(r, "output_requests", None) and len(parts) >= 2:
            eng = self._group("engineering", lambda: _engineering(r))
            if name in eng:                      # joint coordinates, force and driver outputs
                return eng[name]
        return self._from_frame(name)

    def _group(self, key, fn):
        k = "__" + key
        if k not in self._cache:
            self._cache[k] = fn()
        return self._cache[k]

    def _from_frame(self, name):
        r = self.results
        if self._frame is None and hasattr(r, "to_dataframe"):
            self._frame = r.to_dataframe()
        if self._frame is not None and name in self._frame.columns:
            return self._frame[name].to_numpy()
        raise ModelError(f"output column {name!r} does not exist; columns are "
                         f"<body>.<{'|'.join(BODY_POSITION + BODY_VELOCITY + BODY_ACCELERATION)}>, "
                         "<body>.<point>.<x|..|vz>, "
                         f"<joint>.<body>.<{'|'.join(REACTION)}>, energy.<{'|'.join(ENERGY)}>, "
                         f"violation.<{'|'.join(VIOLATION)}>, the requested outputs "
                         "(`spatialmbd info` lists them); bodies: "
                         + ", ".join(r.model.body_names))
