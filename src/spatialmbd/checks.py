"""Checks of plain values shared by every layer (times, ...): each raises
:class:`~spatialmbd.errors.ModelError` naming the argument, the value and what is expected."""
from __future__ import annotations

import math

import numpy as np

from .errors import ModelError


def check_times(t) -> np.ndarray:
    """Output times (s) as a 1-D float array; ModelError for anything else."""
    try:
        arr = np.atleast_1d(np.asarray(t, dtype=float))
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"t: expected output times in s (numbers), got {t!r:.60}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ModelError(f"t: expected a 1-D array of output times, got shape {arr.shape}")
    return arr


def check_time(name: str, value, positive=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ModelError(f"{name}: expected a number of seconds, got {value!r}")
    try:
        value = float(value)
    except OverflowError:
        raise ModelError(f"{name}: {value!r} is too large for a time in seconds") from None
    if not math.isfinite(value) or (positive and not value > 0):
        raise ModelError(f"{name}: expected a finite{' positive' if positive else ''} number "
                         f"of seconds, got {value!r}")
    return value


# ============================================================================ ranges
#: magnitude limits checked at load time (SI units), so that values that cannot be meant
#: (1e300 m, a mass of 5e-324 kg) are errors naming their place instead of failures deep in
#: a run; see docs/reliability.md. (key -> (smallest non-zero |x|, largest |x|, unit))
RANGES = {
    "length": (1e-100, 1e6, "m"),
    "velocity": (1e-100, 1e6, "m/s"),
    "angular_velocity": (1e-100, 1e6, "rad/s"),
    "gravity": (1e-100, 1e4, "m/s^2"),
    "mass": (1e-12, 1e12, "kg"),
    "inertia": (1e-100, 1e12, "kg m^2"),
    "number": (1e-100, 1e12, ""),
}
_RANGE_KEYS = {"position": "length", "points": "length", "center": "length",
               "size": "length", "radius": "length", "length": "length", "natural_length": "length",
               "velocity": "velocity", "angular_velocity": "angular_velocity",
               "angular_velocity_local": "angular_velocity", "gravity": "gravity",
               "mass": "mass", "inertia": "inertia"}
_RANGE_KEYS.update({k: "length" for k in ("point", "point2", "point_i", "point_j")})


def _range_kind(path: tuple, key, kind: str) -> str:
    """The quantity a value at path + (key,) is checked as (RANGES), given its parent's:
    the nearest key naming one (a point's name under "points" names none)."""
    return _RANGE_KEYS.get(key, kind) if isinstance(key, str) and not (
        path and path[-1] == "points") else kind


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:12]}...{text[-6:]} ({len(text)} digits)"


def range_problems(data) -> list:
    """(path, message) of every finite number of a plain structure (dicts, lists, numbers as a
    model file gives them) outside RANGES, by the nearest key naming a quantity: the rule of
    the model-file reader, shared with the importers."""
    out = []
    stack = [(data, (), "number")]
    while stack:
        value, path, kind = stack.pop()
        if isinstance(value, dict):
            for k, v in value.items():
                stack.append((v, path + (k,), _range_kind(path, k, kind)))
        elif isinstance(value, (list, tuple)):
            stack.extend((v, path + (k,), kind) for k, v in enumerate(value))
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and value != 0:
            try:
                if not math.isfinite(value):
                    continue
            except OverflowError:
                continue
            low, high, unit = RANGES[kind]
            size = abs(float(value))
            what = {"number": "a number", "inertia": "an inertia",
                    "angular_velocity": "an angular velocity"}.get(kind, f"a {kind}")
            if size > high:
                out.append((path, f"{_short(value)}{' ' + unit if unit else ''} is out of range "
                                  f"for {what} (|x| <= {high:g}{' ' + unit if unit else ''}); "
                                  "check the value and its units"))
            elif size < low:
                out.append((path, f"{_short(value)}{' ' + unit if unit else ''} is too small "
                                  f"for {what} (|x| >= {low:g}{' ' + unit if unit else ''}, or "
                                  "0); check the value and its units"))
    return out
