"""Drivers: rheonomic constraints Phi = coordinate(q) - f(t) (text ch. 7).

    nu    = f'(t)                          (7.4: nu = -dPhi/dt)
    gamma = -(coordinate'')_quadratic + f''(t)

Kinds:
    angle        rotation angle of a revolute or cylindrical joint, theta = atan2(b_i.a_j, a_i.a_j)
                 (zero in the assembled configuration of a joint defined globally);
                 Phi = wrap(theta - f) to (-pi, pi], so f may grow past pi (constant speed).
    translation  translation u_i.d of a translational or cylindrical joint.
    coordinate   a body coordinate x, y, z (of r) or e0..e3 (of p).

The motion laws are evaluated in Python (:class:`~spatialmbd.motion.MotionLawSet`, one call per
law class) and reach the compiled kernels as the table column ``law`` = (f, f', f'').
"""
from __future__ import annotations

import math
import threading
import weakref

import numpy as np

from ..jit import njit
from ..motion import MotionLawSet
from ..state import POSITION_NAMES
from .base import ConstraintType, register
from .primitives import angle_row, coordinate_row, translation_row

#: the body coordinates a coordinate driver can prescribe
COORDINATES = POSITION_NAMES


@njit
def _put(out, row, value, law, k, quad):
    phi, D, nu, gamma = out
    phi[row] = value - law[k, 0]
    nu[row] = law[k, 1]
    gamma[row] = law[k, 2] - quad


@njit
def kernel_angle(S, G, k, row, out):
    theta, thetad, quad = angle_row(S, G.bi[k], G.bj[k], G.R_i, G.R_j, k, out[1], row)
    _put(out, row, theta, G.law, k, quad)
    out[0][row] = wrap_angle(theta - G.law[k, 0])


@njit
def wrap_angle(x):
    """x wrapped to [-pi, pi): np.remainder(x + pi, 2 pi) - pi (Python's float modulo)."""
    return (x + math.pi) % (2.0 * math.pi) - math.pi


@njit
def kernel_translation(S, G, k, row, out):
    x, xd, quad = translation_row(S, G.bi[k], G.bj[k], G.s_i, G.s_j, G.R_i, k, out[1], row)
    _put(out, row, x, G.law, k, quad)


@njit
def kernel_coordinate(S, G, k, row, out):
    value, quad = coordinate_row(S, G.bi[k], G.coord[k], out[1], row)
    _put(out, row, value, G.law, k, quad)


_LAST = threading.local()


class _Driver(ConstraintType):
    rheonomic = True
    n_eq = 1

    def __init__(self, names, body_i, body_j, geometry, laws, coordinate=None):
        super().__init__(names, body_i, body_j, geometry)
        self.laws = tuple(laws)
        self._lawset = MotionLawSet(self.laws)
        self.coordinate = None if coordinate is None else np.asarray(coordinate, dtype=np.intp)

    def law_values(self, t: float) -> np.ndarray:
        """(n, 3) f, f', f'' at t (read only). The last time is remembered per thread
        (analyses evaluate the constraints several times at one instant); nothing is stored
        on the group."""
        registry = getattr(_LAST, "registry", None)
        if registry is None:
            registry = _LAST.registry = weakref.WeakKeyDictionary()
        last = registry.get(self)
        if last is not None and last[0] == t:
            return last[1]
        out = np.empty((self.n, 3))
        out[:, 0], out[:, 1], out[:, 2] = self._lawset(t)
        out.setflags(write=False)
        registry[self] = (t, out)
        return out

    def law_history(self, times: np.ndarray) -> np.ndarray:
        """(nt, n, 3) f, f', f'' at every time (the laws evaluated over all times at once)."""
        return self._lawset.over(times)


@register
class AngleDriver(_Driver):
    """Prescribed rotation angle of a revolute, cylindrical or screw joint (rad), wrapped so f may
    grow past pi."""

    name = "angle"
    eq_labels = ("angle",)
    angle_based = True
    kernel = staticmethod(kernel_angle)


@register
class TranslationDriver(_Driver):
    """Prescribed translation of a translational, cylindrical or screw joint along its axis
    (m)."""

    name = "translation"
    eq_labels = ("translation",)
    kernel = staticmethod(kernel_translation)


@register
class CoordinateDriver(_Driver):
    """Prescribed body coordinate x, y, z (m) or e0..e3 of a body.

    ``coordinate`` holds indices into COORDINATES (n,)."""

    name = "coordinate"
    eq_labels = ("coordinate",)
    kernel = staticmethod(kernel_coordinate)
