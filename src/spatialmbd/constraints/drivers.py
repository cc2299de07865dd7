"""Drivers: rheonomic constraints Phi = coordinate(q) - f(t) (text ch. 7).

    nu    = f'(t)                          (7.4: nu = -dPhi/dt)
    gamma = -(coordinate'')_quadratic + f''(t)

Kinds:
    angle        rotation angle of a revolute or cylindrical joint, theta = atan2(b_i.a_j, a_i.a_j)
                 (zero in the assembled configuration of a joint defined globally);
                 Phi = wrap(theta - f) to (-pi, pi], so f may grow past pi (constant speed).
    translation  translation u_i.d of a translational or cylindrical joint.
    coordinate   a body coordinate x, y, z (of r) or e0..e3 (of p).
"""
from __future__ import annotations

import numpy as np

from ..motion import MotionLawSet
from ..rotations import G_matrix, pdot_from_omega
from . import primitives as prim
from .base import ConstraintEval, ConstraintType, register

COORDINATES = ("x", "y", "z", "e0", "e1", "e2", "e3")


class _Driver(ConstraintType):
    rheonomic = True
    n_eq = 1

    def __init__(self, names, body_i, body_j, geometry, laws, coordinate=None):
        super().__init__(names, body_i, body_j, geometry)
        self.laws = tuple(laws)
        self._lawset = MotionLawSet(self.laws)
        self.coordinate = None if coordinate is None else np.asarray(coordinate, dtype=np.intp)


@register
class AngleDriver(_Driver):
    name = "angle"
    eq_labels = ("angle",)

    def evaluate(self, state, t):
        g = self.geometry
        theta, D, _, quad = prim.relative_angle(state, self.body_i, self.body_j, g.R_i, g.R_j)
        f, fd, fdd = self._lawset(t)
        phi = np.remainder(theta - f + np.pi, 2.0 * np.pi) - np.pi
        return ConstraintEval(phi[:, None], D[:, None, :], fd[:, None], (fdd - quad)[:, None])


@register
class TranslationDriver(_Driver):
    name = "translation"
    eq_labels = ("translation",)

    def evaluate(self, state, t):
        g = self.geometry
        x, D, _, quad = prim.relative_translation(state, self.body_i, self.body_j, g.s_i, g.s_j,
                                                  g.R_i)
        f, fd, fdd = self._lawset(t)
        return ConstraintEval((x - f)[:, None], D[:, None, :], fd[:, None], (fdd - quad)[:, None])


@register
class CoordinateDriver(_Driver):
    """Prescribed body coordinate; ``coordinate`` holds indices into COORDINATES (n,)."""

    name = "coordinate"
    eq_labels = ("coordinate",)

    def evaluate(self, state, t):
        n = self.n
        k = self.coordinate
        b = self.body_i
        f, fd, fdd = self._lawset(t)
        value = np.empty(n)
        D = np.zeros((n, 1, 12))
        quad = np.zeros(n)
        trans = k < 3
        rows = np.nonzero(trans)[0]
        value[rows] = state.r[b[rows], k[rows]]
        D[rows, 0, k[rows]] = 1.0
        rows = np.nonzero(~trans)[0]
        if rows.size:
            e = k[rows] - 3
            p = state.p[b[rows]]
            w = state.omega[b[rows]]
            GT = np.swapaxes(G_matrix(p), 1, 2)                 # (m, 4, 3)
            value[rows] = p[np.arange(rows.size), e]
            D[rows, 0, 3:6] = 0.5 * GT[np.arange(rows.size), e]  # Eq. (5.12)
            pd = pdot_from_omega(p, w)
            # pddot = 1/2 G(pdot)^T omega + 1/2 G(p)^T omegadot (G is linear in p)
            quad[rows] = pdot_from_omega(pd, w)[np.arange(rows.size), e]
        return ConstraintEval((value - f)[:, None], D, fd[:, None], (fdd - quad)[:, None])
