"""Joint and driver constraint types, one module per type, all registered by name.

The modules of this package are discovered and imported by :mod:`.kernels` (each registers its
types with :func:`.base.register`); :data:`JOINT_TYPES` and :data:`DRIVER_TYPES` are live views of
the registry, so types registered later from user code appear in them too.
"""
from collections.abc import Mapping

from . import kernels  # noqa: F401  (discovers and registers every type of the package)
from .base import (ALIASES, CONSTRAINT_TYPES, LINK_LENGTH, ConstraintEval, ConstraintType,
                   JointGeometry, Param, canonical_name, register)


class _RegistryView(Mapping):
    """A read-only, always current view of the registry: joints or drivers."""

    def __init__(self, drivers: bool):
        self._drivers = drivers

    def _names(self):
        return [n for n, c in CONSTRAINT_TYPES.items() if self._mine(c)]

    def _mine(self, cls) -> bool:
        # couplers (constraints.couplers) relate two joints, not two bodies: neither view
        return cls.rheonomic == self._drivers and not cls.coupler

    def __getitem__(self, name):
        cls = CONSTRAINT_TYPES[canonical_name(name)]
        if not self._mine(cls):
            raise KeyError(name)
        return cls

    def __contains__(self, name):
        cls = CONSTRAINT_TYPES.get(canonical_name(name))
        return cls is not None and self._mine(cls)

    def __iter__(self):
        return iter(self._names())

    def __len__(self):
        return len(self._names())

    def __repr__(self):
        return f"{type(self).__name__}({self._names()})"


JOINT_TYPES = _RegistryView(drivers=False)
DRIVER_TYPES = _RegistryView(drivers=True)

__all__ = ["CONSTRAINT_TYPES", "JOINT_TYPES", "DRIVER_TYPES", "ALIASES", "ConstraintEval",
           "ConstraintType", "JointGeometry", "Param", "LINK_LENGTH", "canonical_name",
           "register"]
