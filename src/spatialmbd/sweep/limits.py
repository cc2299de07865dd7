"""Limits of a sweep, checked before anything is allocated or started.

* members: a grid, a range or a Latin hypercube of more than :data:`MAX_MEMBERS` members is
  refused with the count, an estimate of the memory it would take and the fix (fewer values,
  or a higher ``max_members=`` / ``--max-members``), before its table of values exists;
* memory: a sweep whose parameters and results (time-series outputs included) are estimated
  above half of the machine's physical memory is refused the same way;
* workers: local worker processes are at most ``min(cores, members)``; more are cut to that
  with a note (each worker is a process with its own copy of the package).
"""
from __future__ import annotations

import os
from typing import Optional

from ..errors import ModelError

__all__ = ["SweepNote", "MAX_MEMBERS", "BYTES_PER_MEMBER", "check_members", "estimate_bytes",
           "check_memory", "cap_workers", "physical_memory"]

class SweepNote(UserWarning):
    """A sweep setting that was changed (more workers asked than can run)."""


#: members of one sweep; raise it with ``max_members=`` (Python) or ``--max-members`` (CLI)
MAX_MEMBERS = 1_000_000
#: memory a member takes besides its values and outputs (its status, message and row), bytes
BYTES_PER_MEMBER = 400


def estimate_bytes(n_members: float, n_params: int, n_values: float = 1.0) -> float:
    """Estimated memory (bytes) of a sweep of ``n_members``: the (n_members, n_params) table
    of values, ``n_values`` numbers of output per member (a scalar output is 1, a time series
    its number of times), and :data:`BYTES_PER_MEMBER` of book-keeping each."""
    return float(n_members) * (8.0 * (n_params + n_values) + BYTES_PER_MEMBER)


def _size(nbytes: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} bytes"


def check_members(n_members: float, n_params: int, what: str,
                  max_members: Optional[int] = None) -> None:
    """Refuse a sweep of more than ``max_members`` (default :data:`MAX_MEMBERS`) members.
    ``what`` says where the count comes from ("a grid of 1000 x 1000 x 1000 values")."""
    limit = MAX_MEMBERS if max_members is None else int(max_members)
    if n_members > limit:
        raise ModelError(
            f"{what} makes {n_members:.4g} members, more than the limit of {limit:,} "
            f"members of one sweep (about {_size(estimate_bytes(n_members, n_params))} for "
            "its values and one output each, before any run); use fewer values, or raise "
            "the limit with sweep(..., max_members=N) / spatialmbd sweep --max-members N")


def physical_memory() -> Optional[float]:
    """The machine's physical memory in bytes (None where it cannot be told)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE")) * float(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return None


def check_memory(n_members: int, n_params: int, n_values: float, what: str = "the sweep",
                 memory: Optional[float] = None) -> float:
    """Refuse a sweep estimated (:func:`estimate_bytes`) above half of ``memory`` (default
    the physical memory); returns the estimate."""
    need = estimate_bytes(n_members, n_params, n_values)
    memory = physical_memory() if memory is None else memory
    if memory and need > 0.5 * memory:
        raise ModelError(
            f"{what}: {n_members:,} members with {n_values:.4g} output values each need about "
            f"{_size(need)}, more than half of this machine's memory ({_size(memory)}); use "
            "fewer members, scalar outputs (max(...), final(...)) instead of time series, "
            "or a longer analysis.output_step")
    return need


def cap_workers(workers: int, n_members: int, cores: Optional[int] = None) -> tuple:
    """(workers, note): local worker processes cut to ``min(cores, members)`` (at least 1);
    the note says so, or is empty."""
    cores = int(cores or os.cpu_count() or 1)
    try:
        asked = int(workers)
    except (TypeError, ValueError):
        raise ModelError(f"workers: expected a whole number, got {workers!r}") from None
    if asked < 1:
        raise ModelError(f"workers must be at least 1, got {asked}")
    capped = max(1, min(asked, cores, int(n_members)))
    if capped == asked:
        return asked, ""
    why = "cores" if cores <= n_members else "members"
    return capped, (f"{asked} workers asked; starting {capped} (one per "
                    f"{'core' if why == 'cores' else 'member'}: {cores} cores, {n_members} "
                    "members)")
