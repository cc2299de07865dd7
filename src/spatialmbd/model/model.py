"""The frozen, compiled model: arrays per body, constraints grouped by type.

Everything computed during an analysis lives apart from the model (state, results); the model
itself never changes after ``ModelBuilder.compile()``.

Array names and shapes (nb bodies, ground excluded):
    mass        (nb,)        kg
    inertia     (nb, 3, 3)   kg m^2, about the centre of mass, body axes (the text's J')
    q0          (nb, 7)      initial [r, p]
    v0          (nb, 6)      initial [rdot, omega] (omega global)
    gravity     (3,)         m/s^2
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ..errors import ModelError


#: the builder class, registered by :mod:`.builder` (which sits above this module: builder ->
#: compile -> model): Model.to_builder makes one
_BUILDER: list = []


def register_builder(cls) -> None:
    """The class :meth:`Model.to_builder` returns (:class:`.builder.ModelBuilder`)."""
    _BUILDER[:] = [cls]


@dataclass(frozen=True, eq=False)
class Model:
    name: str
    gravity: np.ndarray
    body_names: tuple
    mass: np.ndarray
    inertia: np.ndarray
    q0: np.ndarray
    v0: np.ndarray
    points: dict
    constraint_groups: tuple
    force_groups: tuple
    builder_state: dict = field(repr=False)

    def __post_init__(self):
        for name in ("gravity", "mass", "inertia", "q0", "v0"):
            getattr(self, name).setflags(write=False)

    # ------------------------------------------------------------------------ sizes and names
    @property
    def nb(self) -> int:
        """Number of bodies (ground excluded)."""
        return len(self.body_names)

    @cached_property
    def n_eq(self) -> int:
        """Number of constraint equations (joints and drivers)."""
        return sum(g.size for g in self.constraint_groups)

    @cached_property
    def inertia_inverse(self) -> np.ndarray:
        """(nb, 3, 3) inverse of the local inertia tensors (computed once)."""
        return np.linalg.inv(self.inertia)

    def body_index(self, name: str) -> int:
        if name == "ground":
            return self.nb
        try:
            return self.body_names.index(name)
        except ValueError:
            raise ModelError(f"unknown body {name!r}; bodies: {', '.join(self.body_names)}") \
                from None

    @cached_property
    def equation_labels(self) -> list:
        """One (element name, element type, equation label) per constraint equation, in order."""
        out = []
        for g in self.constraint_groups:
            for name in g.names:
                out.extend((name, g.name, lab) for lab in g.eq_labels)
        return out

    @cached_property
    def group_offsets(self) -> np.ndarray:
        """Row offset of each constraint group in Phi (len = number of groups + 1)."""
        return np.cumsum([0] + [g.size for g in self.constraint_groups])

    @property
    def joint_names(self) -> list:
        return [n for g in self.constraint_groups if not g.rheonomic for n in g.names]

    @property
    def driver_names(self) -> list:
        return [n for g in self.constraint_groups if g.rheonomic for n in g.names]

    def element(self, name: str):
        """(group, instance index, row slice in Phi) of a joint or driver by name."""
        for k, g in enumerate(self.constraint_groups):
            if name in g.names:
                i = g.names.index(name)
                start = self.group_offsets[k] + i * g.n_eq
                return g, i, slice(start, start + g.n_eq)
        raise ModelError(f"no joint or driver named {name!r}")

    @property
    def grubler_dof(self) -> int:
        """Gruebler-Kutzbach count n_DoF = 6 n_b - m, Eq. (2.1) (drivers counted as equations)."""
        return 6 * self.nb - self.n_eq

    @property
    def assembler(self):
        """The constraint assembler of this thread's workspace (:func:`.data.thread_data`):
        the Model itself holds no workspace."""
        from .data import thread_data
        return thread_data(self).assembler

    def summary(self) -> str:
        lines = [f"model {self.name!r}: {self.nb} bodies, {self.n_eq} constraint equations"]
        for g in self.constraint_groups:
            lines.append(f"  {g.name:20s} x{g.n:<5d} ({g.n_eq} eq. each): "
                         + ", ".join(g.names[:6]) + (" ..." if g.n > 6 else ""))
        for g in self.force_groups:
            lines.append(f"  force {g.name:14s} x{g.n:<5d}: " + ", ".join(g.names[:6])
                         + (" ..." if g.n > 6 else ""))
            lines.extend(getattr(g, "summary_lines", list)())
        return "\n".join(lines)

    def to_builder(self) -> Any:
        """A new ModelBuilder holding the same specs (for editing a copy or writing a file)."""
        import copy
        s = self.builder_state
        b = _BUILDER[0](s["name"], s["gravity"])
        b.bodies = copy.deepcopy(s["bodies"])
        b.joints = copy.deepcopy(s["joints"])
        b.drivers = copy.deepcopy(s["drivers"])
        b.forces = copy.copy(s["forces"])
        b.ground_shapes = copy.deepcopy(s["ground_shapes"])
        return b
