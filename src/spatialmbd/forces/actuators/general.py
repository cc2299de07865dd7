"""General actuator: f = gain u + b0 + b1 L + b2 L' on a joint coordinate (MJCF <general>
with gaintype fixed and biastype affine: gainprm[0], biasprm[0:3]).

L = gear q, L' = gear q'; u the ``command`` clipped to ``ctrlrange``, f clipped to
``forcerange``, the joint's effort gear f (:mod:`.common`). ``bias`` = [b0, b1, b2] (1 to 3
numbers, missing ones 0).
"""
from __future__ import annotations

import math

from ...errors import ModelError
from ..base import register
from .common import COMMON, ActuatorType, _number


@register
class General(ActuatorType):
    name = "general"
    parameters = {**COMMON, "gain": "number", "bias": "any", "command": "law"}
    command_key = "command"

    @classmethod
    def coefficients(cls, spec):
        gain = _number(spec, "gain", 1.0)
        bias = spec.params.get("bias", (0.0, 0.0, 0.0))
        try:
            b = [float(x) for x in bias]
        except (TypeError, ValueError):
            b = []
        if not 1 <= len(b) <= 3 or not all(math.isfinite(x) for x in b):
            raise ModelError(f"forces[{spec.name!r}].bias: give 1 to 3 finite numbers [b0, b1, "
                             f"b2] of f = gain u + b0 + b1 L + b2 L'; got {bias!r}")
        b += [0.0] * (3 - len(b))
        return gain, 0.0, b[0], b[1], b[2]
