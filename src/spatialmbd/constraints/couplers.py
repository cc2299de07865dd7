"""Couplers: one equation between the coordinates of two joints (gears, rack and pinion, linear
couplers; MJCF's joint equalities).

    Phi = c1 q1 + c2 q2 - c0

q1, q2 are the joint coordinates of two joints as the drivers and outputs define them: the
angle theta = atan2(b_i . a_j, a_i . a_j) of a revolute (or cylindrical, screw) joint, zero as
assembled, or the translation u_i . d of a translational joint measured from its assembled value.
Their rates, Jacobians and velocity-quadratic parts are those of :func:`.primitives.angle_row`
and :func:`.primitives.translation_row`, so

    D = c1 D_q1 + c2 D_q2,     gamma = -(c1 q1''_quad + c2 q2''_quad),     nu = 0.

* ``gear``: q2 = ratio q1 (c1 = ratio, c2 = -1): two revolute joints; an external pair turns
  the other way, ratio = -z1 / z2.
* ``rack_pinion``: x2 = radius theta1 (joint 1 turns, joint 2 slides).
* ``coupler``: c1 q1 + c2 q2 = c0, any two joint coordinates (SI units of each).

Angles over many turns: atan2 gives theta in (-pi, pi], so each coupler keeps the last unwrapped
angle of its joints as a reference (per run, in the law columns of its rows; never on the
Model) and reads theta = ref + wrap(theta_raw - ref). The references are advanced after every
accepted integration step, every kinematic-analysis instant and along the outputs
(:func:`advance`), so a gear may turn any number of revolutions as long as no joint turns by
half a revolution within one step.

The equation's row lives on the (at most two) moving bodies of the two joints: both joints on
the ground (a gear train in a fixed frame), or one on the ground and one between the same body
and another (a coupled finger). Joints on more than two moving bodies (a planet carrier that
moves) need a row over three or four bodies, which the row storage does not have yet: that is a
ModelError naming the bodies.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..jit import njit
from .base import ConstraintType, Param, register
from .primitives import add_dot_row, clear_row, dot_gamma, dot_rate, dot_value, kin_sub, \
    point_at, vector_at

#: parameter columns of one joint: s_i (3), s_j (3), R_i (9), R_j (9), side_i, side_j,
#: body_i, body_j, kind (0 angle, 1 translation), x0 (the assembled translation)
JOINT_BLOCK = 30
KIND_ANGLE, KIND_TRANSLATION = 0, 1


# ------------------------------------------------------------------------------ kernel
@njit
def _point(S, b, P, off, side):
    """Kin of the point P[off:off+3] (body axes) of body b (side -1: the ground's)."""
    return point_at(S, b, P[off], P[off + 1], P[off + 2], side)


@njit
def _vector(S, b, P, off, col, side):
    """Kin of column col of the triad P[off:off+9] (row-major, body axes) fixed on body b."""
    return vector_at(S, b, P[off + col], P[off + 3 + col], P[off + 6 + col], side)


@njit
def joint_coordinate(S, P, off, c, ref, D, row):
    """q of the joint whose block starts at P[off] (the angle unwrapped about ref); adds c D_q
    to D[row]; returns (q, qdot, velocity-quadratic part of q'')."""
    si, sj = int(P[off + 24]), int(P[off + 25])
    bi, bj = int(P[off + 26]), int(P[off + 27])
    if int(P[off + 28]) == KIND_TRANSLATION:
        d = kin_sub(_point(S, bj, P, off + 3, sj), _point(S, bi, P, off, si))
        u = _vector(S, bi, P, off + 6, 0, si)
        add_dot_row(u, d, c, D, row)
        return dot_value(u, d) - P[off + 29], dot_rate(u, d), -dot_gamma(u, d)
    a_i = _vector(S, bi, P, off + 6, 1, si)
    b_i = _vector(S, bi, P, off + 6, 2, si)
    a_j = _vector(S, bj, P, off + 15, 1, sj)
    x, y = dot_value(a_i, a_j), dot_value(b_i, a_j)
    xd, yd = dot_rate(a_i, a_j), dot_rate(b_i, a_j)
    gx, gy = dot_gamma(a_i, a_j), dot_gamma(b_i, a_j)
    r2 = x * x + y * y
    add_dot_row(b_i, a_j, c * x / r2, D, row)
    add_dot_row(a_i, a_j, -c * y / r2, D, row)
    thetad = (x * yd - y * xd) / r2
    quad = (x * (-gy) - y * (-gx)) / r2 - 2.0 * thetad * (x * xd + y * yd) / r2
    raw = math.atan2(y, x)
    return ref + ((raw - ref + math.pi) % (2.0 * math.pi) - math.pi), thetad, quad


@njit
def kernel(S, G, k, row, out):
    """Phi = c1 q1 + c2 q2 - c0 (param: the two joint blocks, then c1, c2, c0)."""
    phi, D, nu, gamma = out
    P = G.param[k]
    c1, c2, c0 = P[2 * JOINT_BLOCK], P[2 * JOINT_BLOCK + 1], P[2 * JOINT_BLOCK + 2]
    clear_row(D, row)
    q1, _, quad1 = joint_coordinate(S, P, 0, c1, G.law[k, 0], D, row)
    q2, _, quad2 = joint_coordinate(S, P, JOINT_BLOCK, c2, G.law[k, 1], D, row)
    phi[row] = c1 * q1 + c2 * q2 - c0
    nu[row] = 0.0
    gamma[row] = -(c1 * quad1 + c2 * quad2)


@njit
def _coordinates(S, P, refs, out):
    """The two joint coordinates of every instance (rows of P), angles unwrapped about refs."""
    D = np.zeros((1, 12))
    for k in range(P.shape[0]):
        out[k, 0] = joint_coordinate(S, P[k], 0, 0.0, refs[k, 0], D, 0)[0]
        out[k, 1] = joint_coordinate(S, P[k], JOINT_BLOCK, 0.0, refs[k, 1], D, 0)[0]


# ------------------------------------------------------------------------------ types
class Coupler(ConstraintType):
    """The equation c1 q1 + c2 q2 = c0 between the coordinates of two joints."""

    name = "coupler"
    coupler = True                   # relates two joints: not in JOINT_TYPES nor DRIVER_TYPES
    n_eq = 1
    eq_labels = ("coupling",)
    parameters = (Param("c1", "SI/q1", "coefficient of the first joint's coordinate"),
                  Param("c2", "SI/q2", "coefficient of the second joint's coordinate"),
                  Param("c0", "SI", "right-hand side", default=0.0))
    kernel = staticmethod(kernel)

    @classmethod
    def param_columns(cls) -> int:
        return 2 * JOINT_BLOCK + 3

    @classmethod
    def coefficients(cls, params: dict, what: str) -> tuple:
        c1 = cls.parameters[0].check(params.get("c1"), what)
        c2 = cls.parameters[1].check(params.get("c2"), what)
        c0 = cls.parameters[2].check(params.get("c0", 0.0), what)
        if c1 == 0 and c2 == 0:
            raise ModelError(f"{what}: c1 and c2 are both zero; give at least one")
        return c1, c2, c0


register(Coupler)


class Gear(Coupler):
    """Gear pair: the second revolute joint turns ratio times the first (external pair:
    ratio = -z1 / z2)."""

    name = "gear"
    parameters = (Param("ratio", "-", "q2 = ratio q1 (negative: opposite senses)",
                        nonzero=True),)

    @classmethod
    def coefficients(cls, params, what):
        return cls.parameters[0].check(params.get("ratio"), what), -1.0, 0.0


class RackPinion(Coupler):
    """Rack and pinion: the translation of the second joint is radius times the angle of the
    first."""

    name = "rack_pinion"
    parameters = (Param("radius", "m", "x2 = radius theta1 (the pinion's pitch radius; "
                        "negative: the other sense)", nonzero=True),)

    @classmethod
    def coefficients(cls, params, what):
        return cls.parameters[0].check(params.get("radius"), what), -1.0, 0.0


register(Gear)
register(RackPinion)

#: coupler types by name
COUPLER_TYPES = {cls.name: cls for cls in (Coupler, Gear, RackPinion)}
#: what each joint type offers as its coordinate
COORDINATE_OF = {"revolute": KIND_ANGLE, "cylindrical": KIND_ANGLE, "screw": KIND_ANGLE,
                 "translational": KIND_TRANSLATION}
#: the coordinate kind each coupler needs of its joints (None: any)
NEEDS = {"gear": (KIND_ANGLE, KIND_ANGLE), "rack_pinion": (KIND_ANGLE, KIND_TRANSLATION),
         "coupler": (None, None)}


def joint_block(jspec, geom, index: dict, row_bodies: tuple, q0: np.ndarray, what: str,
                which: str) -> np.ndarray:
    """The parameter block of one coupled joint (see JOINT_BLOCK) from its spec and geometry."""
    kind = COORDINATE_OF.get(jspec.type)
    if kind is None:
        raise ModelError(f"{what}.{which}: joint {jspec.name!r} is a {jspec.type}; couplers "
                         f"take {', '.join(COORDINATE_OF)} joints")
    bi, bj = index[jspec.body_i], index[jspec.body_j]
    side = [row_bodies.index(b) if b in row_bodies else -1 for b in (bi, bj)]
    out = np.zeros(JOINT_BLOCK)
    out[0:3], out[3:6] = geom.s_i[0], geom.s_j[0]
    out[6:15], out[15:24] = geom.R_i[0].ravel(), geom.R_j[0].ravel()
    out[24:26] = side
    out[26:28] = bi, bj
    out[28] = kind
    if kind == KIND_TRANSLATION:                      # the assembled translation u_i . d
        from ..rotations import A_from_p

        def pose(b):
            if b >= q0.shape[0]:
                return np.zeros(3), np.eye(3)
            return q0[b, :3], A_from_p(q0[b, 3:])
        r_i, A_i = pose(bi)
        r_j, A_j = pose(bj)
        d = r_j + A_j @ geom.s_j[0] - r_i - A_i @ geom.s_i[0]
        out[29] = float((A_i @ geom.R_i[0][:, 0]) @ d)
    return out


def advance(groups_and_rows, law: np.ndarray, state) -> None:
    """Advance the angle references of the couplers (groups with their first row in the
    table whose ``law`` column is given) to their unwrapped angles at ``state``."""
    for group, sl in groups_and_rows:
        out = np.empty((group.n, 2))
        _coordinates(state.arrays(), np.ascontiguousarray(group.geometry.param),
                     np.ascontiguousarray(law[sl, :2]), out)
        law[sl, 0:2] = out
