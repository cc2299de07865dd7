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
