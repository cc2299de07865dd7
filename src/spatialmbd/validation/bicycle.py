"""The benchmark bicycle (models.whipple_bicycle) in the coordinates of the bicycle literature.

The nonlinear benchmark of Basu-Mandal, Chatterjee and Papadopoulos (2007) states a general
motion of the Meijaard et al. (2007) bicycle -- leaning, steering, pitching, its wheels turning
-- and the accelerations of its equations of motion there. Their coordinates, and those of
Moore (2012) through which they are usually converted, are angles of frames in a chain; ours
are the bodies' absolute poses. This module maps one to the other, so that our equations of
motion can be evaluated at their state and their accelerations read back.

Moore's frames, in Meijaard's axes (x forward, y right, z down; the origin on the ground):

    A = N Rz(q3)       yaw                 B = A Rx(q4)   roll
    C = B Ry(q5)       pitch: rear frame   D = C Ry(q6)   rear wheel
    E = C Rz(q7)       steer: front frame  F = E Ry(q8)   front wheel

with c3 along the steer axis, so that upright and straight the pitch q5 is the steer-axis tilt
lam (C = Ry(lam) there, as are D, E and F with the wheel angles zero). The angular velocities
follow from the rates u3..u8 = q3'..q8': w_C = u3 a3 + u4 b1 + u5 c2, w_D = w_C + u6 c2,
w_E = w_C + u7 c3, w_F = w_E + u8 e2. The rear wheel centre is rR above the rear contact point
along -b3, and rolls about it.

Basu-Mandal's coordinates are those with x and y reversed in direction and angles measured
otherwise: theta = -q3, psi = pi/2 - q4, phi = pi + lam - q5, psi_f = -q7, beta_r = -q6,
beta_f = -q8, (x, y, z) the rear wheel centre in axes (-x, y, -z) of Meijaard's (z up) --
the conversion of Moore's thesis (and of the DynamicistToolKit's dtk.bicycle).
"""
from __future__ import annotations

import math

import numpy as np

from .. import models
from ..rotations import p_from_A
from .exact import rotation_matrix

#: Meijaard's axes (x forward, y right, z down) in ours (x forward, y left, z up): a half turn
#: about x, its own inverse
FLIP = np.diag([1.0, -1.0, -1.0])


def _rx(a):
    return rotation_matrix((1.0, 0.0, 0.0), a)


def _ry(a):
    return rotation_matrix((0.0, 1.0, 0.0), a)


def _rz(a):
    return rotation_matrix((0.0, 0.0, 1.0), a)


def moore_from_basu(basu: dict) -> tuple[np.ndarray, np.ndarray]:
    """Moore's (q3..q8) and (u3..u8) from Basu-Mandal's angles and rates (theta, psi, phi,
    psif, betar, betaf and the same with "d")."""
    lam = models.MEIJAARD["lam"]
    q = np.array([-basu["theta"], math.pi / 2 - basu["psi"], math.pi + lam - basu["phi"],
                  -basu["betar"], -basu["psif"], -basu["betaf"]])
    u = -np.array([basu["thetad"], basu["psid"], basu["phid"], basu["betard"], basu["psifd"],
                   basu["betafd"]])
    return q, u


class MooreFrames:
    """The frames and their angular velocities of Moore's chain at (q3..q8, u3..u8), in
    Meijaard's axes."""

    def __init__(self, q, u):
        q3, q4, q5, q6, q7, q8 = q
        self.u = np.asarray(u, dtype=float)
        u3, u4, u5, u6, u7, u8 = self.u
        self.A = _rz(q3)
        self.B = self.A @ _rx(q4)
        self.C = self.B @ _ry(q5)
        self.D = self.C @ _ry(q6)
        self.E = self.C @ _rz(q7)
        self.F = self.E @ _ry(q8)
        self.a3, self.b1, self.c2 = self.A[:, 2], self.B[:, 0], self.C[:, 1]
        self.c3, self.e2 = self.C[:, 2], self.E[:, 1]
        self.wA = u3 * self.a3
        self.wB = self.wA + u4 * self.b1
        self.wC = self.wB + u5 * self.c2
        self.wD = self.wC + u6 * self.c2
        self.wE = self.wC + u7 * self.c3
        self.wF = self.wE + u8 * self.e2

    def rates_dot(self, wdot: dict) -> np.ndarray:
        """(q3''..q8'') from the bodies' angular accelerations (Meijaard's axes, keys C, D, E,
        F): w_C' = q3'' a3 + q4'' b1 + q5'' c2 + q4' (w_A x b1) + q5' (w_B x c2), and the
        relative rates' derivatives along their axes (whose own rates are normal to them)."""
        u4, u5 = self.u[1], self.u[2]
        rhs = wdot["C"] - u4 * np.cross(self.wA, self.b1) - u5 * np.cross(self.wB, self.c2)
        q3dd, q4dd, q5dd = np.linalg.solve(np.column_stack([self.a3, self.b1, self.c2]), rhs)
        return np.array([q3dd, q4dd, q5dd, self.c2 @ (wdot["D"] - wdot["C"]),
                         self.c3 @ (wdot["E"] - wdot["C"]), self.e2 @ (wdot["F"] - wdot["E"])])


#: the bodies of models.whipple_bicycle and Moore's frame of each
BODY_FRAME = {"rear_frame": "C", "rear_wheel": "D", "front_frame": "E", "front_wheel": "F"}


def body_state(model, q, u) -> tuple[np.ndarray, np.ndarray, MooreFrames]:
    """Body coordinates (q (4, 7), v (4, 6)) of models.whipple_bicycle at Moore's (q3..q8,
    u3..u8), the rear contact point at the origin and at rest. Each body is turned from its
    place in the model (upright, straight, where Moore's frames are Ry(lam)) by its frame's
    rotation from there; the rear wheel centre sits rR above the contact point along -b3, the
    other bodies hang from it through the hub and the steer axis; velocities by rolling about
    the rear contact point and rigid motion through the same joints."""
    P = models.MEIJAARD
    fr = MooreFrames(q, u)
    ref = _ry(P["lam"])
    names = list(model.body_names)
    orient = {n: FLIP @ getattr(fr, BODY_FRAME[n]) @ ref.T @ FLIP for n in names}
    omega = {n: FLIP @ getattr(fr, "w" + BODY_FRAME[n]) for n in names}
    place = {n: model.q0[k, :3] for k, n in enumerate(names)}
    hub0, foot0 = np.array([0.0, 0.0, P["rR"]]), np.array([P["w"] + P["c"], 0.0, 0.0])
    hub = FLIP @ (-P["rR"] * fr.B[:, 2])
    foot = hub + orient["rear_frame"] @ (foot0 - hub0)
    r = {"rear_wheel": hub,
         "rear_frame": hub + orient["rear_frame"] @ (place["rear_frame"] - hub0),
         "front_frame": foot + orient["front_frame"] @ (place["front_frame"] - foot0),
         "front_wheel": foot + orient["front_frame"] @ (place["front_wheel"] - foot0)}
    v_hub = np.cross(omega["rear_wheel"], hub)                     # contact point at rest
    v_foot = v_hub + np.cross(omega["rear_frame"], foot - hub)
    vel = {"rear_wheel": v_hub,
           "rear_frame": v_hub + np.cross(omega["rear_frame"], r["rear_frame"] - hub),
           "front_frame": v_foot + np.cross(omega["front_frame"], r["front_frame"] - foot),
           "front_wheel": v_foot + np.cross(omega["front_frame"], r["front_wheel"] - foot)}
    qq = np.array([np.concatenate([r[n], p_from_A(orient[n])]) for n in names])
    vv = np.array([np.concatenate([vel[n], omega[n]]) for n in names])
    return qq, vv, fr


def basu_accelerations(model, vdot, fr: MooreFrames) -> dict:
    """Basu-Mandal's accelerations (xdd, ydd, zdd of the rear wheel centre; thetadd, psidd,
    phidd, psifdd, betardd, betafdd) from the bodies' accelerations vdot (4, 6)."""
    names = list(model.body_names)
    wdot = {BODY_FRAME[n]: FLIP @ vdot[k, 3:] for k, n in enumerate(names)}
    a = FLIP @ vdot[names.index("rear_wheel"), :3]
    qdd = fr.rates_dot(wdot)
    return dict(xdd=-a[0], ydd=a[1], zdd=-a[2], thetadd=-qdd[0], psidd=-qdd[1],
                phidd=-qdd[2], psifdd=-qdd[4], betardd=-qdd[3], betafdd=-qdd[5])


def basu_rear_hub_velocity(model, v) -> np.ndarray:
    """(xd, yd, zd) of the rear wheel centre in Basu-Mandal's axes."""
    vh = FLIP @ v[list(model.body_names).index("rear_wheel"), :3]
    return np.array([-vh[0], vh[1], -vh[2]])
