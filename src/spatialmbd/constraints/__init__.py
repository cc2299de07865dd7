"""Joint and driver constraint types, one module per type, all registered by name."""
from . import (basic, cylindrical, drivers, fixed, planar, revolute, spherical,  # noqa: F401
               spherical_revolute, spherical_spherical, translational, universal)
from .base import CONSTRAINT_TYPES, ConstraintEval, ConstraintType, JointGeometry

JOINT_TYPES = {name: cls for name, cls in CONSTRAINT_TYPES.items()
               if name not in ("angle", "translation", "coordinate")}
DRIVER_TYPES = {name: CONSTRAINT_TYPES[name] for name in ("angle", "translation", "coordinate")}

__all__ = ["CONSTRAINT_TYPES", "JOINT_TYPES", "DRIVER_TYPES", "ConstraintEval", "ConstraintType",
           "JointGeometry"]
