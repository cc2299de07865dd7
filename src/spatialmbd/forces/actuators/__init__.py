"""Actuators on joint coordinates, one module per kind (:mod:`.common` holds the shared
kernel and law): ``motor``, ``position_servo``, ``velocity_servo``, ``general`` (MJCF gain /
bias); sampled controllers with zero-order hold (:mod:`.controller`); the mapping of MJCF
actuators (:mod:`.mujoco`). docs/actuators.md describes them."""
from .general import General  # noqa: F401  (each module registers its force type)
from .motor import Motor  # noqa: F401
from .position_servo import PositionServo  # noqa: F401
from .velocity_servo import VelocityServo  # noqa: F401
