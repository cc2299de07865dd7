"""Plain descriptions of model elements, as the builder collects them (and model files hold them).

Specs keep what the user gave, validated but not yet turned into arrays; ``ModelBuilder.compile``
turns them into a frozen :class:`spatialmbd.model.Model`. Units are SI throughout.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np


@dataclass
class BodySpec:
    """A rigid body.

    mass: kg. inertia: (3, 3) kg m^2 about the centre of mass in body axes.
    r: (3,) m centre-of-mass position; p: (4,) unit Euler parameters (body -> global).
    rdot: (3,) m/s; omega: (3,) rad/s in global axes.
    points: name -> (3,) m in body axes; vectors: name -> (3,) in body axes.
    shapes: display geometry (dicts, body axes), used by the animation only.
    """

    name: str
    mass: float
    inertia: np.ndarray
    r: np.ndarray
    p: np.ndarray
    rdot: np.ndarray
    omega: np.ndarray
    points: dict = field(default_factory=dict)
    vectors: dict = field(default_factory=dict)
    shapes: list = field(default_factory=list)
    color: Optional[str] = None


@dataclass
class JointSpec:
    """A joint (or basic constraint) between body_i and body_j ("ground" allowed).

    geometry: the keywords given to ``add_joint``; either global ones in the assembled
    configuration (point, point2, axis, axis2, reference) or local ones on each body (point_i,
    point_j, axis_i, axis_j, ref_i, ref_j). params: the type's parameters by name (see the
    type's ``parameters``), e.g. length of composite joints (m; absent = as assembled), pitch.
    """

    type: str
    name: str
    body_i: str
    body_j: str
    geometry: dict
    params: dict = field(default_factory=dict)

    @property
    def length(self) -> Optional[float]:
        """The link length of composite joints (m), None = as assembled."""
        return self.params.get("length")


@dataclass
class DriverSpec:
    """A driver: kind "angle"/"translation" (on ``joint``) or "coordinate" (of ``body``)."""

    name: str
    kind: str
    law: Any
    joint: Optional[str] = None
    body: Optional[str] = None
    coordinate: Optional[str] = None


@dataclass
class CouplerSpec:
    """A coupler (gear, rack_pinion, coupler) between the coordinates of two joints."""

    type: str
    name: str
    joint1: str
    joint2: str
    params: dict


@dataclass
class ForceSpec:
    """A force element: ``type`` names the element class, ``params`` its keyword arguments."""

    type: str
    name: str
    params: dict
