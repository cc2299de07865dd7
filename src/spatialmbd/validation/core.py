"""Result types of the validation suite, comparison helpers and the reference-data location.

Tolerances derived from the integrator settings (:func:`integration_bound`): a tolerance-
controlled integrator keeps the local error of every accepted step below rtol |y| + atol per
component, so after N accepted steps the global error of a quantity of size ``scale`` is
bounded by N (rtol scale + atol) as long as errors accumulate without amplification (the
5(4) pair propagates the fifth-order solution, whose local error is well below the estimate
of the fourth-order one, which covers the mild growth of the non-chaotic cases used here).
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np


@dataclass
class Check:
    """One compared quantity.

    reference / ours: the values compared (for a time history: the reference and our value at
    the instant and component of the largest error); error: |ours - reference| (max over the
    history); tolerance: the allowed error and ``basis`` how it was derived; note: the metric
    (e.g. "max over 501 rows, RMS 1.2e-6") or other details.
    """

    quantity: str
    reference: float
    ours: float
    error: float
    tolerance: float
    basis: str = ""
    note: str = ""
    unit: str = ""

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.error) and self.error <= self.tolerance)


@dataclass
class CaseResult:
    """The checks of one validation case, its reference provenance and its run time."""

    name: str
    description: str
    provenance: str
    checks: list = field(default_factory=list)
    runtime: float = 0.0
    error: Optional[str] = None          # an exception raised by the case, if any
    notes: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return self.error is None and bool(self.checks) and all(c.passed for c in self.checks)

    def add(self, *args, **kwargs) -> Check:
        c = Check(*args, **kwargs)
        self.checks.append(c)
        return c


# ------------------------------------------------------------------------------ comparisons
def compare_history(case: CaseResult, quantity: str, ours, ref, tolerance: float, basis: str,
                    unit: str = "", t=None) -> Check:
    """Max |ours - ref| over every row and component (arrays (n,) or (n, k)); the check shows
    the values at the worst entry and the RMS error in its note."""
    ours = np.asarray(ours, dtype=float)
    ref = np.asarray(ref, dtype=float)
    diff = np.abs(ours - ref)
    if not np.all(np.isfinite(diff)):
        err, k = np.inf, 0
    else:
        k = int(np.argmax(diff))
        err = float(diff.reshape(-1)[k])
    rms = float(np.sqrt(np.mean(diff**2))) if np.all(np.isfinite(diff)) else np.inf
    n = ours.shape[0]
    where = ""
    if t is not None and np.isfinite(err):
        row = np.unravel_index(k, diff.shape)[0]
        where = f", worst at t = {np.asarray(t)[row]:.3g} s"
    note = f"max over {n} instants (RMS {rms:.2g}{where})"
    return case.add(quantity, float(ref.reshape(-1)[k]), float(ours.reshape(-1)[k]), err,
                    float(tolerance), basis, note, unit)


def compare_value(case: CaseResult, quantity: str, ours: float, ref: float, tolerance: float,
                  basis: str, unit: str = "", note: str = "") -> Check:
    return case.add(quantity, float(ref), float(ours), float(abs(ours - ref)),
                    float(tolerance), basis, note, unit)


def integration_bound(res, scale: float) -> float:
    """N (rtol scale + atol) for the run ``res`` (N accepted steps); see the module docstring."""
    opts = res.settings.get("integrator_options", {})
    rtol = float(opts.get("rtol", 1e-6))
    atol = opts.get("atol", 1e-9)
    atol = float(np.max(atol)) if np.ndim(atol) else float(atol)
    return int(res.counters["steps"]) * (rtol * float(scale) + atol)


def bound_basis(res, scale: float, what: str = "") -> str:
    opts = res.settings.get("integrator_options", {})
    return (f"N (rtol s + atol): N = {res.counters['steps']} steps, rtol {opts.get('rtol')}, "
            f"s = {scale:.3g}{' ' + what if what else ''}")


# ------------------------------------------------------------------------------ reference data
def reference_dir() -> Path:
    """Where the reference data live: $SPATIALMBD_REFERENCE_DIR, else the package data
    directory ``spatialmbd/validation/data`` (shipped with every install)."""
    env = os.environ.get("SPATIALMBD_REFERENCE_DIR")
    if env:
        return Path(env)
    return Path(__file__).resolve().parent / "data"


def adams_dir() -> Path:
    """The ADAMS decks and tables: <reference>/adams."""
    d = reference_dir() / "adams"
    if not d.is_dir():
        raise FileNotFoundError(f"ADAMS reference files not found in {d}; reinstall spatialmbd "
                                "or point SPATIALMBD_REFERENCE_DIR at a directory holding "
                                "references.json and adams/")
    return d


_REFERENCES = None


def references() -> dict:
    """references.json (package data): every reference value with its provenance."""
    global _REFERENCES
    if _REFERENCES is None:
        with open(reference_dir() / "references.json") as fh:
            _REFERENCES = json.load(fh)
    return _REFERENCES


def hermite_crossings(t, y, ydot) -> np.ndarray:
    """Times where y(t) crosses zero, located on the cubic Hermite interpolant of (y, y')."""
    out = []
    for k in np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]:
        h = t[k + 1] - t[k]
        p0, p1, m0, m1 = y[k], y[k + 1], ydot[k] * h, ydot[k + 1] * h
        # Newton on the Hermite cubic in s in [0, 1], started from the secant root
        s = p0 / (p0 - p1)
        for _ in range(50):
            h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
            h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
            f = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
            df = ((6 * s**2 - 6 * s) * p0 + (3 * s**2 - 4 * s + 1) * m0
                  + (-6 * s**2 + 6 * s) * p1 + (3 * s**2 - 2 * s) * m1)
            step = f / df
            s -= step
            if abs(step) < 1e-15:
                break
        out.append(t[k] + s * h)
    return np.array(out)


class Timer:
    def __enter__(self):
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.elapsed = time.perf_counter() - self.start
