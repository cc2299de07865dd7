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
    if _info.name not in ("base", "kernels", "kernel_tools"):
        importlib.import_module(f"{__name__}.{_info.name}")
from . import kernels  # noqa: E402,F401  (the dispatch, generated from the types just registered)


@dataclass
class BuildContext:
    """What a force type's ``build`` may use: the builder, the body index, and the joint
    geometry resolver of the model compiler (passed in: forces sit below the model layer)."""

    builder: object
    index: dict
    nb: int
    resolve_joint: object = None

    def pose(self, body):
        from ..rotations import A_from_p
        if body == "ground":
            return np.zeros(3), np.eye(3)
        spec = self.builder.bodies[body]
        return spec.r, A_from_p(spec.p)

    def joint_geometry(self, joint):
        return self.resolve_joint(self.builder.joints[joint], self.builder.bodies)


def build_force_groups(builder, index, resolve_joint) -> list:
    """One group per force type present in the builder, in order of first appearance.
    resolve_joint(spec, bodies) -> JointGeometry: the model compiler's."""
    ctx = BuildContext(builder=builder, index=index, nb=len(builder.bodies),
                       resolve_joint=resolve_joint)
    by_type: dict[str, list] = {}
    for spec in builder.forces.values():
        by_type.setdefault(spec.type, []).append(spec)
    return [FORCE_TYPES[t].build(specs, ctx) for t, specs in by_type.items()]


__all__ = ["FORCE_TYPES", "ForceType", "build_force_groups", "register"]
