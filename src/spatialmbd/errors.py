"""Exceptions raised by spatialmbd.

Every error names the element involved, the offending value and what to do about it.
"""
from __future__ import annotations


class SpatialMBDError(Exception):
    """Base class of every error raised by spatialmbd."""


class ModelError(SpatialMBDError, ValueError):
    """A malformed model: bad parameters, unknown or duplicate names, inconsistent joints."""


class ConvergenceError(SpatialMBDError):
    """A Newton-Raphson iteration did not converge."""


class SingularMatrixError(SpatialMBDError):
    """A linear system (constraint Jacobian, system matrix) is singular."""


class SimulationError(SpatialMBDError):
    """A simulation could not continue (NaN, step-size underflow, ...)."""
