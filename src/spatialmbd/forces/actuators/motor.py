"""Motor: a force or torque on a joint coordinate, effort = gear x command (MJCF <motor>).

The command u(t) -- a number, a motion law, a time series (``{type: time_series, file:
commands.csv}``) or a sampled controller's output -- is clipped to ``ctrlrange``, the actuator
force f = u to ``forcerange``, and the joint receives tau = gear f (N m on an angle, N on a
translation; :mod:`.common`).
"""
from __future__ import annotations

from ..base import register
from .common import COMMON, ActuatorType


@register
class Motor(ActuatorType):
    name = "motor"
    parameters = {**COMMON, "command": "law"}
    command_key = "command"

    @classmethod
    def coefficients(cls, spec):
        return 1.0, 0.0, 0.0, 0.0, 0.0
