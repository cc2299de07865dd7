"""Force elements, one module per type, registered by name (gravity is a model setting)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import ForceType
from .point_force import PointForce, Torque
from .rotational_spring_damper import RotationalSpringDamper
from .spring_damper import SpringDamper
from .user import UserForce

FORCE_TYPES: dict[str, type[ForceType]] = {
    cls.name: cls for cls in (PointForce, Torque, SpringDamper, RotationalSpringDamper, UserForce)
}


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


__all__ = ["FORCE_TYPES", "ForceType", "build_force_groups"]
