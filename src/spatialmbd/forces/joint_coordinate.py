"""What the force elements on one joint coordinate share (joint limits, joint friction): the
joint and its coordinate (:func:`joint_coordinate_kind`), and :class:`JointCoordinateForce`,
the base class of their groups -- per instance the joint's bodies, joint points and triads (its
geometry as assembled) and one parameter row. Their compiled helpers are in
:mod:`.kernel_tools` (``joint_coordinate``, ``add_coordinate_force``)."""
from __future__ import annotations

import abc

import numpy as np

from ..constraints.base import CONSTRAINT_TYPES, canonical_name
from ..errors import ModelError
from .base import ForceType


def joint_coordinate_kind(spec, builder, allowed=("angle", "translation", "cone")):
    """(joint spec, coordinate name) of an element acting on a joint's coordinate: the joint
    exists, its type has the coordinate (``coordinate`` required when it has two)."""
    name = spec.name
    joint = spec.params.get("joint")
    if joint not in builder.joints:
        raise ModelError(f"forces[{name!r}].joint: unknown joint {joint!r} (joints: "
                         f"{', '.join(builder.joints) or 'none'})")
    jtype = canonical_name(builder.joints[joint].type)
    kinds = tuple(getattr(CONSTRAINT_TYPES.get(jtype), "driver_kinds", ()))
    if jtype == "spherical":
        kinds = tuple(k for k in allowed if k not in ("angle", "translation"))
    kinds = tuple(k for k in kinds if k in allowed)
    if not kinds:
        raise ModelError(f"forces[{name!r}]: a {spec.type} acts on the coordinate of a "
                         "revolute, translational, cylindrical, screw or spherical joint; "
                         f"{joint!r} is a {jtype} joint")
    coordinate = spec.params.get("coordinate")
    if coordinate is None:
        if len(kinds) > 1:
            raise ModelError(f"forces[{name!r}].coordinate: joint {joint!r} is a {jtype} joint "
                             f"with the coordinates {', '.join(kinds)}; say which")
        coordinate = kinds[0]
    if coordinate not in kinds:
        raise ModelError(f"forces[{name!r}].coordinate: {coordinate!r} is not a coordinate of "
                         f"the {jtype} joint {joint!r} (it has: {', '.join(kinds)})")
    return builder.joints[joint], coordinate


class JointCoordinateForce(ForceType):
    """A force-element type acting on a joint's coordinate. Instance k acts between the joint's
    bodies bi[k], bj[k] (n,) at its joint points s_i, s_j (n, 3) with its triads R_i, R_j
    (n, 3, 3), all in body axes, with the parameter row param[k] (n, n_param);
    ``coordinates`` names each instance's coordinate ("angle", "translation", ...).

    A type declares ``_row(spec, builder)`` -> (joint spec, coordinate, parameter row), which
    makes every check of one element (``validate`` runs it), and may change the triads of an
    instance in ``_triads``; ``build`` and ``columns`` are shared."""

    required = ("joint",)

    def __init__(self, names, bi, bj, s_i, s_j, R_i, R_j, param, coordinates):
        super().__init__(names)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.s_i, self.s_j = np.asarray(s_i, float), np.asarray(s_j, float)
        self.R_i, self.R_j = np.asarray(R_i, float), np.asarray(R_j, float)
        self.param = np.asarray(param, dtype=float).reshape(-1, self.n_param)
        self.coordinates = tuple(coordinates)

    @classmethod
    def validate(cls, spec, builder):
        cls._row(spec, builder)

    @classmethod
    @abc.abstractmethod
    def _row(cls, spec, builder) -> tuple:
        """(joint spec, coordinate name, parameter row (n_param,)) of one element; ModelError
        naming the element and the value if a parameter is wrong."""

    @classmethod
    def _triads(cls, spec, coordinate, geom) -> tuple:
        """(R_i, R_j) (3, 3) of one instance: the joint's triads as assembled."""
        return geom.R_i[0], geom.R_j[0]

    @classmethod
    def build(cls, specs, ctx):
        cols = [[] for _ in range(7)]
        coords = []
        for spec in specs:
            joint, coordinate, row = cls._row(spec, ctx.builder)
            geom = ctx.joint_geometry(spec.params["joint"])
            R_i, R_j = cls._triads(spec, coordinate, geom)
            for c, value in enumerate((ctx.index[joint.body_i], ctx.index[joint.body_j],
                                       geom.s_i[0], geom.s_j[0], R_i, R_j, row)):
                cols[c].append(value)
            coords.append(coordinate)
        group = cls([s.name for s in specs], *cols, coords)
        group.joint_names = tuple(spec.params["joint"] for spec in specs)
        return group

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, s_i=self.s_i, s_j=self.s_j, R_i=self.R_i,
                    R_j=self.R_j, param=self.param)
