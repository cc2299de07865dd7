"""What an import left out or approximated: one :class:`LeftOut` per feature (kind, element,
detail), counted per kind for the short summary the CLI prints (``left out: 2 actuators,
5 joint limits``; ``approximated: 4 joint limits, 2 friction losses``)."""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

__all__ = ["LeftOut", "KINDS", "summary", "details", "UNSUPPORTED_KINDS",
           "APPROXIMATION_KINDS"]

#: kind -> (singular, plural) of the summary
KINDS = {
    "actuator": ("actuator", "actuators"),
    "actuator force range": ("joint actuator force range", "joint actuator force ranges"),
    "tendon": ("tendon", "tendons"),
    "contact pair": ("contact pair", "contact pairs"),
    "flex": ("flex object", "flex objects"),
    "armature": ("armature value", "armature values"),
    "frictionloss": ("friction loss value", "friction loss values"),
    "joint spring": ("spring/damper of a combined joint", "springs/dampers of combined joints"),
    "joint combination": ("joint combination", "joint combinations"),
    "equality": ("equality constraint", "equality constraints"),
    "joint limit": ("joint limit", "joint limits"),
    "colliding geom": ("colliding geom", "colliding geoms"),
    "keyframe": ("keyframe", "keyframes"),
    "limit approximation": ("joint limit", "joint limits"),
    "frictionloss approximation": ("friction loss", "friction losses"),
    "contact approximation": ("contact", "contacts"),
}
#: kinds of what is imported, but approximately (MuJoCo's soft constraints as force laws):
#: listed in the summary as approximated, refused with strict=True
APPROXIMATION_KINDS = ("limit approximation", "frictionloss approximation",
                       "contact approximation")
#: kinds with no exact counterpart (an error with strict=True); the others (limits,
#: collisions, keyframes) act only when reached, touching or chosen, and are never an error
UNSUPPORTED_KINDS = ("actuator", "actuator force range", "tendon", "contact pair", "flex",
                     "armature", "frictionloss", "joint spring", "joint combination",
                     "equality")


@dataclass(frozen=True)
class LeftOut:
    """A feature of the MJCF/URDF file not in the imported model.

    kind: one of :data:`KINDS`; element: the MuJoCo element's name (made unique as in the
    model); detail: why, or what it was.
    """

    kind: str
    element: str
    detail: str = ""

    @property
    def unsupported(self) -> bool:
        """Whether it has no exact counterpart (strict imports refuse it)."""
        return self.kind in UNSUPPORTED_KINDS

    @property
    def approximation(self) -> bool:
        """Whether it is imported, but approximately (strict imports refuse it too)."""
        return self.kind in APPROXIMATION_KINDS

    def __str__(self) -> str:
        text = f"{KINDS.get(self.kind, (self.kind,))[0]} {self.element!r}"
        if self.approximation:
            text = "approximated " + text
        return f"{text} ({self.detail})" if self.detail else text


def summary(items) -> str:
    """``"2 actuators, 1 tendon, 5 joint limits"`` (in the order of KINDS)."""
    counts = Counter(item.kind for item in items)
    order = list(KINDS) + sorted(k for k in counts if k not in KINDS)
    parts = []
    for kind in order:
        n = counts.get(kind, 0)
        if n:
            one, many = KINDS.get(kind, (kind, kind + "s"))
            parts.append(f"{n} {one if n == 1 else many}")
    return ", ".join(parts)


def details(items) -> list:
    """One line per left-out feature, grouped by kind."""
    order = {kind: k for k, kind in enumerate(KINDS)}
    return [str(item) for item in sorted(items, key=lambda i: order.get(i.kind, len(order)))]
