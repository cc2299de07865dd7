"""Velocity servo: effort = gear kv (qdot_ref - L') on a joint coordinate (MJCF <velocity>).

L' = gear q' is the actuator's rate (the joint's with the default gear 1), qdot_ref(t) the
``reference`` (a number, a motion law's value, a time series or a sampled controller's
output), clipped to ``ctrlrange``; the force is clipped to ``forcerange`` (:mod:`.common`).
"""
from __future__ import annotations

from ..base import register
from .common import COMMON, ActuatorType, _number


@register
class VelocityServo(ActuatorType):
    name = "velocity_servo"
    parameters = {**COMMON, "kv": "number", "reference": "law"}
    required = ("joint", "kv")
    command_key = "reference"

    @classmethod
    def coefficients(cls, spec):
        kv = _number(spec, "kv", None, nonnegative=True)
        return kv, 0.0, 0.0, 0.0, -kv
