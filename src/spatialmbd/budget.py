"""Resource limits of a run: checked before work starts, and budgets enforced while it runs.

Before a run (:func:`check_outputs`, :func:`check_fixed_steps`, :func:`check_work`): the number
of output samples and the number of steps a fixed-step integrator (or an adaptive one with a
``max_step``) will take are known in advance; above the limits below the run is refused with an
estimate of its memory and time and what to change. The work of a run -- steps x evaluations of
the equations of motion, plus its output rows -- is estimated from one timed evaluation
(:func:`estimate_work`); above :data:`NOTE_SECONDS` it is announced (a :class:`WorkEstimate`
warning, a note of the CLI), above :data:`MAX_ESTIMATED_TIME` refused unless a budget bounds
the run or ``Budget(max_estimated_time=...)`` raises the limit.

While it runs (:class:`Budget`, :class:`BudgetGuard`): an optional cap on accepted steps and on
wall time. A run stopped by its budget is not an error: it returns its results up to that
point with ``status == "budget"`` (see :func:`spatialmbd.simulate.simulate`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Optional

from .errors import ModelError, SimulationError

#: most output samples a run may request (each costs memory; see docs/reliability.md)
MAX_OUTPUT_SAMPLES = 10_000_000
#: most steps a fixed-step run may take without an explicit step budget (``max_steps``)
MAX_FIXED_STEPS = 20_000_000
#: bytes held per output row and per float of the state while a run is in memory: the
#: integrator's state y, then q, v, vdot, lam of the Results (measured in bench/memory.py)
BYTES_PER_FLOAT_PER_ROW = 8 * 3
#: a run estimated to compute longer than this (s) is refused before it starts, unless a
#: budget bounds it (max_steps, max_wall_time) or Budget(max_estimated_time=...) raises it
MAX_ESTIMATED_TIME = 600.0
#: a run estimated to compute longer than this (s) says so before it starts
NOTE_SECONDS = 10.0
#: the cost model of :func:`estimate_work`, in evaluations of the equations of motion: a step
#: costs its stages plus STEP_EVALUATIONS (the driver's work per step: error control,
#: projection, bookkeeping) and STEP_SECONDS; an output row OUTPUT_EVALUATIONS (dense output
#: and the Results arrays). Fitted to the pendulum and slider-crank runs of rk4, euler, rk45
#: and bdf4 (compiled kernels): the estimate is within a factor of about 2 of the run.
STEP_EVALUATIONS = 6
STEP_SECONDS = 5e-6
OUTPUT_EVALUATIONS = 5


@dataclass(frozen=True)
class Budget:
    """Caps on one run. max_steps: accepted integration steps; max_wall_time: s of wall
    time; max_outputs: output samples (default :data:`MAX_OUTPUT_SAMPLES`);
    max_estimated_time: s of computing a run may be estimated to take before it starts
    (default :data:`MAX_ESTIMATED_TIME`; see :func:`check_work`). None: no cap / default."""

    max_steps: Optional[int] = None
    max_wall_time: Optional[float] = None
    max_outputs: Optional[int] = None
    max_estimated_time: Optional[float] = None

    def __post_init__(self):
        for name in ("max_steps", "max_outputs"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                      or value < 1):
                raise ModelError(f"budget {name}: expected a positive integer, got {value!r}")
        for name in ("max_wall_time", "max_estimated_time"):
            value = getattr(self, name)
            if value is not None:
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not value > 0 or value != value:
                    raise ModelError(f"budget {name}: expected a positive number of "
                                     f"seconds, got {value!r}")

    @classmethod
    def make(cls, budget=None, max_steps=None, max_wall_time=None) -> "Budget":
        """A Budget from simulate's arguments (a Budget, a dict, or the keywords)."""
        if budget is None:
            out = cls()
        elif isinstance(budget, Budget):
            out = budget
        elif isinstance(budget, dict):
            keys = ["max_steps", "max_wall_time", "max_outputs", "max_estimated_time"]
            unknown = sorted(set(map(str, budget)) - set(keys))
            if unknown:
                from .suggest import suggest
                raise ModelError(f"budget takes no {unknown[0]!r}{suggest(unknown[0], keys)}; "
                                 f"valid keys: {', '.join(keys)}")
            out = cls(**budget)
        else:
            raise ModelError(f"budget: expected a Budget or a dict, got "
                             f"{type(budget).__name__}")
        if max_steps is not None or max_wall_time is not None:
            out = cls(max_steps=max_steps if max_steps is not None else out.max_steps,
                      max_wall_time=max_wall_time if max_wall_time is not None
                      else out.max_wall_time, max_outputs=out.max_outputs,
                      max_estimated_time=out.max_estimated_time)
        return out

    @property
    def active(self) -> bool:
        return self.max_steps is not None or self.max_wall_time is not None


class BudgetExceeded(SimulationError):
    """A run reached its step or wall-time budget (status "budget", results kept)."""

    status = "budget"

    def __init__(self, message: str, t: float):
        super().__init__(message)
        self.t = t


class BudgetGuard:
    """Counts accepted steps (through the integrator's progress hook) and checks the wall
    time there and in every function evaluation; raises :class:`BudgetExceeded`."""

    def __init__(self, budget: Budget, inner=None):
        self.budget = budget
        self.inner = inner
        self.steps = 0
        self.start = time.perf_counter()
        self.deadline = None if budget.max_wall_time is None else \
            self.start + budget.max_wall_time

    def __call__(self, t):                      # progress(t) after every accepted step
        self.steps += 1
        b = self.budget
        if b.max_steps is not None and self.steps >= b.max_steps:
            raise BudgetExceeded(f"t = {t:.6g} s: stopped by the step budget after "
                                 f"{self.steps} steps (max_steps={b.max_steps}); raise "
                                 "max_steps or shorten t_end", t)
        self.check_time(t)
        if self.inner is not None:
            self.inner(t)

    def check_time(self, t):
        if self.deadline is not None and time.perf_counter() > self.deadline:
            raise BudgetExceeded(f"t = {t:.6g} s: stopped by the wall-time budget after "
                                 f"{time.perf_counter() - self.start:.3g} s "
                                 f"(max_wall_time={self.budget.max_wall_time} s, "
                                 f"{self.steps} steps); raise max_wall_time or shorten t_end",
                                 t)

    def close(self):
        if hasattr(self.inner, "close"):
            self.inner.close()


def row_bytes(n_state: int, n_eq: int) -> int:
    """Bytes held per output row by a run in memory: y (n_state floats) and the Results
    arrays q, v, vdot (about 2 n_state) and lam (n_eq)."""
    return 8 * (3 * n_state + n_eq) + 64


def _size(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB", "PB"):
        if n < 1024:
            return f"{n:.3g} {unit}"
        n /= 1024
    return f"{n:.3g} EB"


def check_outputs(n: float, span: float, output_step: Optional[float], limit: Optional[int],
                  n_state: int = 14, n_eq: int = 0) -> None:
    """Refuse more than ``limit`` (default MAX_OUTPUT_SAMPLES) output samples."""
    limit = MAX_OUTPUT_SAMPLES if limit is None else limit
    if n > limit:
        raise ModelError(
            f"output_step {output_step!r} s over {span:.6g} s asks for {n:.3g} output samples "
            f"(about {_size(n * row_bytes(n_state, n_eq))} of memory); the limit is {limit:,}: "
            f"use an output_step of at least {span / limit:.3g} s, or raise the limit with "
            "budget=Budget(max_outputs=...)")


def check_fixed_steps(n_steps: float, step: float, span: float, stages: int, budget: Budget,
                      seconds_per_evaluation: Optional[float] = None,
                      output_bytes: Optional[float] = None) -> None:
    """Refuse a fixed-step run of more than MAX_FIXED_STEPS steps unless a budget (steps or
    wall time) bounds it (with an estimate of its time)."""
    if budget.active or n_steps <= MAX_FIXED_STEPS:
        return
    estimate = ""
    if seconds_per_evaluation:
        seconds = n_steps * max(stages, 1) * seconds_per_evaluation
        estimate = f", about {_duration(seconds)} of computing"
    if output_bytes:
        estimate += f" and {_size(output_bytes)} of memory for its outputs"
    raise ModelError(
        f"a fixed step of {step!r} s over {span:.6g} s takes {n_steps:.3g} steps{estimate}; "
        f"the limit without a step budget is {MAX_FIXED_STEPS:,}: use a larger step or an "
        "adaptive integrator (rk45), or pass max_steps=... or max_wall_time=... to run it "
        "under a budget")


class WorkEstimate(UserWarning):
    """The estimated work of a run that will take a while (said before it starts)."""


@dataclass(frozen=True)
class Estimate:
    """The work of a run estimated before it starts (:func:`estimate_work`)."""

    steps: float                   # integration steps (0: not known in advance)
    stages: int                    # evaluations of the equations of motion per step
    outputs: int                   # output rows
    seconds_per_evaluation: float  # one timed evaluation
    seconds: float                 # the estimate

    def text(self) -> str:
        parts = []
        if self.steps:
            parts.append(f"{self.steps:.3g} steps x {self.stages} evaluation"
                         f"{'s' if self.stages != 1 else ''}")
        parts.append(f"{self.outputs:,} output rows")
        return (f"estimated work: {' + '.join(parts)} at "
                f"{self.seconds_per_evaluation * 1e6:.3g} us per evaluation, about "
                f"{_duration(self.seconds)} of computing")


def estimate_work(n_steps: float, stages: int, n_outputs: int,
                  seconds_per_evaluation: float) -> Estimate:
    """The computing time of ``n_steps`` steps of ``stages`` evaluations and ``n_outputs``
    output rows, from the time of one evaluation (cost model: STEP_EVALUATIONS,
    STEP_SECONDS, OUTPUT_EVALUATIONS)."""
    stages = max(int(stages or 1), 1)
    per_step = (stages + STEP_EVALUATIONS) * seconds_per_evaluation + STEP_SECONDS
    seconds = n_steps * per_step + n_outputs * OUTPUT_EVALUATIONS * seconds_per_evaluation
    return Estimate(float(n_steps), stages, int(n_outputs), float(seconds_per_evaluation),
                    float(seconds))


def check_work(estimate: Estimate, budget: Budget) -> None:
    """Announce (:class:`WorkEstimate` warning) a run estimated above NOTE_SECONDS; refuse one
    above ``budget.max_estimated_time`` (default MAX_ESTIMATED_TIME) unless the budget bounds
    it (max_steps or max_wall_time)."""
    import warnings
    limit = budget.max_estimated_time or MAX_ESTIMATED_TIME
    if estimate.seconds > limit and not budget.active:
        raise ModelError(
            f"{estimate.text()}; the limit is {_duration(limit)}: use a larger step or "
            "output_step, a shorter t_end or an adaptive integrator, run it under a budget "
            "(max_wall_time=... / --max-wall-time), or raise the limit with "
            "Budget(max_estimated_time=...) / --max-estimated-time")
    if estimate.seconds > NOTE_SECONDS:
        warnings.warn(estimate.text(), WorkEstimate, stacklevel=3)


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.3g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.3g} h"
    return f"{seconds / 86400:.3g} days"
