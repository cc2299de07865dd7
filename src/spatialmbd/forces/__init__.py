"""Force elements, one module per type, registered by name (gravity is a model setting).

Every module of this package is imported here and registers its types with
:func:`.base.register`; :data:`FORCE_TYPES` is the live registry, so types registered from
user code appear in it too. Adding a force type is one module plus its test file
(docs/architecture.md).
"""
from __future__ import annotations

import importlib
import os
import pkgutil
from dataclasses import dataclass

import numpy as np

from .base import FORCE_TYPES, ForceType, register

for _info in sorted(pkgutil.iter_modules([os.path.dirname(__file__)]), key=lambda m: m.name):
    if _info.name != "base":
        importlib.import_module(f"{__name__}.{_info.name}")


@dataclass
class BuildContext:
    builder: object
    index: dict
    nb: int

    def pose(self, body):
        from ..rotations import A_from_p
        if body == "ground":
            return np.zeros(3), np.eye(3)
        spec = self.builder.bodies[body]
        return spec.r, A_from_p(spec.p)

    def joint_geometry(self, joint):
        from ..model.compile import resolve_joint
        return resolve_joint(self.builder.joints[joint], self.builder.bodies)


def build_force_groups(builder, index, element_of_joint=None, groups=None) -> list:
    """One group per force type present in the builder, in order of first appearance."""
    ctx = BuildContext(builder=builder, index=index, nb=len(builder.bodies))
    by_type: dict[str, list] = {}
    for spec in builder.forces.values():
        by_type.setdefault(spec.type, []).append(spec)
    return [FORCE_TYPES[t].build(specs, ctx) for t, specs in by_type.items()]


__all__ = ["FORCE_TYPES", "ForceType", "build_force_groups", "register"]
