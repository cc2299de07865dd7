"""Position servo (PD): effort = gear (kp (q_ref - L) + kv (q_ref' - L')) on a joint coordinate.

L = gear q is the actuator's coordinate (the joint's with the default gear 1), q_ref(t) the
``reference`` (a number, a motion law, a time series or a sampled controller's output), q_ref'
its rate (the law's analytic derivative; 0 from a controller or where ``ctrlrange`` clips the
reference). ``velocity_feedforward: false`` drops the kv q_ref' term: MJCF <position>,
f = kp (ctrl - L) - kv L'. The force is clipped to ``forcerange`` (:mod:`.common`).
"""
from __future__ import annotations

from ..base import register
from .common import COMMON, ActuatorType, _number


@register
class PositionServo(ActuatorType):
    name = "position_servo"
    parameters = {**COMMON, "kp": "number", "kv": "number", "reference": "law",
                  "velocity_feedforward": "any"}
    required = ("joint", "kp")
    command_key = "reference"

    @classmethod
    def coefficients(cls, spec):
        from ...errors import ModelError
        kp = _number(spec, "kp", None, nonnegative=True)
        kv = _number(spec, "kv", 0.0, nonnegative=True)
        feed = spec.params.get("velocity_feedforward", True)
        if not isinstance(feed, bool):
            raise ModelError(f"forces[{spec.name!r}].velocity_feedforward: true or false, got "
                             f"{feed!r}")
        return kp, kv if feed else 0.0, 0.0, -kp, -kv
