"""User force: a callable of time and state returning forces and torques on the bodies.

    function(t, q, v) -> (forces (nb, 3), torques (nb, 3))   [frame="global"]

q: (nb, 7), v: (nb, 6) as in the text (omega global). Forces act at the centres of mass and
torques are moments about them, in global axes. The element is treated as non-conservative in
the energy balance (its power is f.rdot + n.omega).
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError, SimulationError
from .base import ForceType, check_unknown, register


@register
class UserForce(ForceType):
    name = "user"
    in_files = False
    parameters = {"function": "any"}

    def __init__(self, names, functions, nb):
        super().__init__(names)
        self.functions = tuple(functions)
        self.nb = nb

    @classmethod
    def validate(cls, spec, builder):
        check_unknown(spec, cls.allowed)
        if not callable(spec.params.get("function")):
            raise ModelError(f"forces[{spec.name!r}].function: give a callable "
                             "f(t, q, v) -> (forces (nb, 3), torques (nb, 3))")

    @classmethod
    def build(cls, specs, ctx):
        return cls([s.name for s in specs], [s.params["function"] for s in specs], ctx.nb)

    def _call(self, state, t):
        nb = self.nb
        q = np.concatenate([state.r[:nb], state.p[:nb]], axis=1)
        v = np.concatenate([state.rdot[:nb], state.omega[:nb]], axis=1)
        total = np.zeros((nb, 6))
        for name, fn in zip(self.names, self.functions):
            out = fn(t, q, v)
            try:
                f, n = (np.asarray(x, dtype=float).reshape(nb, 3) for x in out)
            except (TypeError, ValueError):
                raise SimulationError(f"user force {name!r} must return (forces, torques) of "
                                      f"shape ({nb}, 3) each") from None
            total[:, :3] += f
            total[:, 3:] += n
        return total, v

    def evaluate(self, state, t, g):
        total, _ = self._call(state, t)
        g[:self.nb] += total

    def nonconservative_power(self, state, t):
        total, v = self._call(state, t)
        return float(np.sum(total * v))
