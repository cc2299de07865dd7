"""Kinematic state of all bodies, computed once per evaluation and shared by every kernel.

Coordinates (text ch. 6):
    q: (nb, 7) per body [r (3), p (4)]  -- r: centre-of-mass position (m), p: Euler parameters
    v: (nb, 6) per body [rdot (3), omega (3)] -- omega in global components (rad/s)
Flattened forms q (7 nb,) and v (6 nb,) are used by the solvers.

The ground is appended as an extra body with index ``nb`` (r = 0, A = I, v = 0), so that kernels
can gather ``body_i``/``body_j`` indices without branching; its Jacobian columns are dropped at
assembly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rotations import A_from_p


@dataclass
class BodyState:
    """Positions, rotation matrices and velocities of the bodies plus the ground (last row).

    r: (nb+1, 3) m; A: (nb+1, 3, 3); rdot: (nb+1, 3) m/s; omega: (nb+1, 3) rad/s (global);
    p: (nb+1, 4) Euler parameters.
    """

    r: np.ndarray
    A: np.ndarray
    rdot: np.ndarray
    omega: np.ndarray
    p: np.ndarray
    t: float = 0.0

    @classmethod
    def from_qv(cls, q: np.ndarray, v: np.ndarray | None, t: float = 0.0) -> "BodyState":
        """q: (nb, 7) or (7 nb,); v: (nb, 6) or (6 nb,) or None (zero velocities)."""
        q = np.asarray(q, dtype=float).reshape(-1, 7)
        nb = q.shape[0]
        r = np.zeros((nb + 1, 3))
        r[:nb] = q[:, :3]
        p = np.empty((nb + 1, 4))
        p[:nb] = q[:, 3:]
        p[nb] = (1.0, 0.0, 0.0, 0.0)
        A = A_from_p(p)
        rdot = np.zeros((nb + 1, 3))
        omega = np.zeros((nb + 1, 3))
        if v is not None:
            v = np.asarray(v, dtype=float).reshape(nb, 6)
            rdot[:nb] = v[:, :3]
            omega[:nb] = v[:, 3:]
        return cls(r=r, A=A, rdot=rdot, omega=omega, p=p, t=t)


def qdot_from_v(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """qdot = T(q) v: rdot as is and pdot = 1/2 G^T omega, Eq. (5.12).

    q: (nb, 7) or flat, v: (nb, 6) or flat -> same layout as q.
    """
    shape = np.shape(q)
    q = np.asarray(q, dtype=float).reshape(-1, 7)
    v = np.asarray(v, dtype=float).reshape(-1, 6)
    e0, e1, e2, e3 = q[:, 3], q[:, 4], q[:, 5], q[:, 6]
    wx, wy, wz = v[:, 3], v[:, 4], v[:, 5]
    qd = np.empty_like(q)
    qd[:, :3] = v[:, :3]
    qd[:, 3] = 0.5 * (-e1 * wx - e2 * wy - e3 * wz)
    qd[:, 4] = 0.5 * (e0 * wx + e3 * wy - e2 * wz)
    qd[:, 5] = 0.5 * (-e3 * wx + e0 * wy + e1 * wz)
    qd[:, 6] = 0.5 * (e2 * wx - e1 * wy + e0 * wz)
    return qd.reshape(shape)


def normalize_q(q: np.ndarray) -> np.ndarray:
    """A copy of q with every body's Euler parameters scaled to unit length."""
    shape = np.shape(q)
    q = np.array(q, dtype=float).reshape(-1, 7)
    q[:, 3:] /= np.linalg.norm(q[:, 3:], axis=1, keepdims=True)
    return q.reshape(shape)
