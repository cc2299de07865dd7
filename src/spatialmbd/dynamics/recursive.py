"""Recursive forward dynamics in joint coordinates for open trees (method "recursive").

A model whose joints are revolute or translational (prismatic) and connect every body to the
ground by exactly one chain is a tree: its configuration is its joint coordinates z (one angle
or one slide per joint), with no constraint equations left and no drift. This module
integrates z and its rates with an articulated-body (O(N)) evaluation of the accelerations, as
recursive codes do, and hands the body coordinates (positions, Euler parameters, velocities)
to the Results at the output times, where every other output (accelerations, reactions from
the multipliers, energies) is evaluated as for the body-coordinate methods.

Per right-hand side (compiled, no Python per body):

* forward kinematics, parents first (:func:`joint_kinematics`): for joint k between parent P
  and child C, with the axis u' fixed in P, the joint points s'_P (in P) and s'_C (in C), the
  relative orientation p0 at z = 0 and the slide offset sigma0:
  p_C = p_P (x) p_axis(theta) (x) p0 (revolute; p_axis the rotation by theta about u'), or
  p_P (x) p0 (translational); r_C = r_P + A_P (s'_P + u' (sigma0 + s)) - A_C s'_C; omega_C =
  omega_P + u theta_dot; rdot_C = rdot_P + omega_P x A_P (s'_P + u' sigma) + u s_dot +
  omega_C x (-A_C s'_C), u = A_P u' (4.13, 5.9, 5.7);
* the body terms of the body-coordinate formulation at that state (as
  :func:`.system.stage_state`, without the constraint equations: M = diag(m I, J), g =
  gravity, -omega~ J omega, the compiled force elements (10.4, 11.1));
* the articulated-body recursion in world axes, about the centres of mass: with the rigid
  transfer X from P to C (d = r_C - r_P), the motion subspace H and the velocity-product
  acceleration c of each joint,

      revolute:       H = [u x d_JC; u],  c = [omega_P x (omega_P x d_PJ) + omega_C x (omega_C x
                      d_JC) + ((omega_P x u) theta_dot) x d_JC;  (omega_P x u) theta_dot],
      translational:  H = [u; 0],         c = [2 omega_P x u s_dot + omega_P x (omega_P x d); 0],

  (d_PJ = r_J - r_P, d_JC = r_C - r_J), vdot_C = X vdot_P + H zdd + c; backward (leaves first)
  U = I_C H, D = H^T U, Ia = I_C - U U^T / D, p~ = p_C - U H^T p_C / D, I_P += X^T Ia X,
  p_P += X^T (p~ - Ia c) (initially I_b = M_b, p_b = g_b); forward zdd = (H^T p_C - U^T w) / D,
  w = X vdot_P + c.

The state is x = [z (nj), zdot (nj), W] (W: the work of the non-conservative forces, as in
:mod:`..simulate`). The compiled driver :func:`dopri_joint` integrates it by Dormand-Prince
5(4) with the controller of :class:`..integrators.runge_kutta_adaptive.DormandPrince45`.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..integrators.controller import end_step, min_step_size
from ..integrators.runge_kutta_adaptive import (DOPRI_NODES, DOPRI_TABLEAU, dopri_error,
                                                dopri_interpolate)
from ..jit import njit
from ..jit import array_view
from ..rotations import A_into, quat_multiply_scalar
from ..state import state_into
from .layout import body_views, force_views
from .system import _forces, body_terms

__all__ = ["JointTree", "JOINT_KINDS", "Recursive", "joint_kinematics", "rhs_joint",
           "dopri_joint", "body_rows", "joint_right_hand_side"]

#: constraint types the recursive method turns into joint coordinates: one coordinate each
JOINT_KINDS = {"revolute": 0, "translational": 1}
REVOLUTE, TRANSLATIONAL = 0, 1


class JointTree:
    """The joints of a tree model in joint coordinates, from its (assembled) initial state.

    Arrays (per joint, parents first): ``parent``, ``child`` (body indices, the ground nb),
    ``kind`` (0 revolute, 1 translational), ``axis`` (u' in the parent's axes; the ground's:
    global), ``s_parent`` (the joint point in the parent's axes), ``s_child`` (in the
    child's), ``p0`` (the child's Euler parameters relative to the parent at z = 0),
    ``sigma0`` (the initial slide between the joint points). ``z0``, ``zd0``: the initial joint
    coordinates (0) and rates (from v0). Raises ModelError for what it cannot represent,
    naming the element.
    """

    def __init__(self, model, q0, v0):
        nb = model.nb
        q0 = np.asarray(q0, dtype=float).reshape(nb, 7)
        v0 = np.asarray(v0, dtype=float).reshape(nb, 6)
        joints = []                                    # (group, instance)
        for g in model.constraint_groups:
            if g.name not in JOINT_KINDS or getattr(g, "rheonomic", False):
                raise ModelError(
                    f"method 'recursive': {g.name} {', '.join(g.names)} cannot be written in "
                    f"joint coordinates (supported: {', '.join(JOINT_KINDS)} joints of a "
                    "tree, no drivers); use method 'standard' or 'projection'")
            joints += [(g, n) for n in range(g.n)]
        for f in model.force_groups:
            if not f.compiled:
                raise ModelError(f"method 'recursive': the force element(s) {', '.join(f.names)}"
                                 f" ({f.name}) have no compiled kernel; use method 'standard'")
        edges = [[] for _ in range(nb + 1)]
        for k, (g, n) in enumerate(joints):
            a, b = int(g.body_i[n]), int(g.body_j[n])
            edges[a].append((b, k))
            edges[b].append((a, k))
        A = _rotations(q0)
        seen = np.zeros(nb + 1, dtype=bool)
        seen[nb] = True
        order, queue, used = [], [nb], set()
        while queue:
            node = queue.pop(0)
            for other, k in edges[node]:
                if k in used:
                    continue
                used.add(k)
                g, n = joints[k]
                if seen[other]:
                    raise ModelError(f"method 'recursive': joint {g.names[n]} closes a loop "
                                     "(only open trees have joint coordinates here); use "
                                     "method 'projection'")
                seen[other] = True
                order.append((k, node, other))
                queue.append(other)
        free = [model.body_names[b] for b in range(nb) if not seen[b]]
        if free:
            raise ModelError(f"method 'recursive': body(ies) {', '.join(free)} have no chain of "
                             "joints to the ground (free bodies are not supported yet); use "
                             "method 'standard'")
        nj = len(order)
        self.n = nj
        self.names = []
        self.parent = np.empty(nj, np.int64)
        self.child = np.empty(nj, np.int64)
        self.kind = np.empty(nj, np.int64)
        self.axis = np.empty((nj, 3))
        self.s_parent = np.empty((nj, 3))
        self.s_child = np.empty((nj, 3))
        self.p0 = np.empty((nj, 4))
        self.sigma0 = np.zeros(nj)
        zd0 = np.zeros(nj)
        Ag = np.vstack([A, np.eye(3)[None]])
        r = np.vstack([q0[:, :3], np.zeros((1, 3))])
        p = np.vstack([q0[:, 3:], [[1.0, 0.0, 0.0, 0.0]]])
        rd = np.vstack([v0[:, :3], np.zeros((1, 3))])
        w = np.vstack([v0[:, 3:], np.zeros((1, 3))])
        for t, (k, P, C) in enumerate(order):
            g, n = joints[k]
            geo = g.geometry
            i_is_parent = int(g.body_i[n]) == P
            s_i, s_j = geo.s_i[n], geo.s_j[n]
            u_world = Ag[int(g.body_i[n])] @ geo.R_i[n][:, 0]      # the axis, fixed on i
            sP, sC = (s_i, s_j) if i_is_parent else (s_j, s_i)
            self.names.append(g.names[n])
            self.parent[t], self.child[t] = P, C
            self.kind[t] = JOINT_KINDS[g.name]
            self.axis[t] = Ag[P].T @ u_world / np.linalg.norm(u_world)
            self.s_parent[t], self.s_child[t] = sP, sC
            self.p0[t] = _quat(_conj(p[P]), p[C])
            JP = r[P] + Ag[P] @ sP
            JC = r[C] + Ag[C] @ sC
            u = Ag[P] @ self.axis[t]
            if self.kind[t] == TRANSLATIONAL:
                self.sigma0[t] = u @ (JC - JP)
                vJC = rd[C] + np.cross(w[C], Ag[C] @ sC)
                vJP = rd[P] + np.cross(w[P], JC - r[P])
                zd0[t] = u @ (vJC - vJP)
            else:
                zd0[t] = u @ (w[C] - w[P])
        self.z0 = np.zeros(nj)
        self.zd0 = zd0
        self.nb = nb
        self.scratch = np.zeros((nb, 6, 6)), np.zeros((nb, 6)), np.zeros((max(nj, 1), 6, 4))

    def arrays(self):
        """The tuple the compiled kernels take."""
        return (self.parent, self.child, self.kind, self.axis, self.s_parent, self.s_child,
                self.p0, self.sigma0) + self.scratch

    def check_initial(self, q0, tol: float = 1e-6) -> float:
        """Largest difference between the bodies placed by the joints at z0 and q0 (positions
        in m, Euler parameters); ModelError when it exceeds tol (an unassembled start)."""
        nb = self.nb
        y = np.zeros(13 * nb)
        joint_kinematics(np.zeros(self.n), np.zeros(self.n), self.arrays(), nb, y)
        q = y[:7 * nb].reshape(nb, 7)
        q0 = np.asarray(q0, dtype=float).reshape(nb, 7)
        sign = np.where(np.sum(q[:, 3:] * q0[:, 3:], axis=1) < 0, -1.0, 1.0)
        err = max(np.abs(q[:, :3] - q0[:, :3]).max(),
                  np.abs(q[:, 3:] - sign[:, None] * q0[:, 3:]).max())
        if err > tol:
            raise ModelError(f"method 'recursive': the initial positions do not satisfy the "
                             f"joints (the bodies placed by the joints differ by {err:.3g}); "
                             "assemble the model first (correct_initial=True)")
        return err


def _rotations(q):
    from ..rotations import A_from_p
    return A_from_p(q[:, 3:])


def _conj(p):
    return np.array([p[0], -p[1], -p[2], -p[3]])


def _quat(a, b):
    return np.array(quat_multiply_scalar((a[0], a[1], a[2], a[3]), (b[0], b[1], b[2], b[3])))


# ----------------------------------------------------------------------------- kinematics
@njit
def joint_kinematics(z, zd, T, nb, y):
    """y[:13 nb] = [q (7 nb), v (6 nb)] of the bodies at joint coordinates z and rates zd
    (parents before children: every parent's row is written before it is read)."""
    parent, child, kind, axis, s_parent, s_child, p0, sigma0 = T[:8]
    nj = parent.size
    Ab = np.empty((2, 3, 3))
    pp = np.empty((2, 4))
    for k in range(nj):
        P, C = parent[k], child[k]
        if P < nb:
            oq, ov = 7 * P, 7 * nb + 6 * P
            pP = (y[oq + 3], y[oq + 4], y[oq + 5], y[oq + 6])
            rP = (y[oq], y[oq + 1], y[oq + 2])
            vP = (y[ov], y[ov + 1], y[ov + 2])
            wP = (y[ov + 3], y[ov + 4], y[ov + 5])
        else:
            pP = (1.0, 0.0, 0.0, 0.0)
            rP = (0.0, 0.0, 0.0)
            vP = (0.0, 0.0, 0.0)
            wP = (0.0, 0.0, 0.0)
        pp[0, 0], pp[0, 1], pp[0, 2], pp[0, 3] = pP
        A_into(pp, 0, Ab)
        u0 = Ab[0, 0, 0] * axis[k, 0] + Ab[0, 0, 1] * axis[k, 1] + Ab[0, 0, 2] * axis[k, 2]
        u1 = Ab[0, 1, 0] * axis[k, 0] + Ab[0, 1, 1] * axis[k, 1] + Ab[0, 1, 2] * axis[k, 2]
        u2 = Ab[0, 2, 0] * axis[k, 0] + Ab[0, 2, 1] * axis[k, 1] + Ab[0, 2, 2] * axis[k, 2]
        sigma = 0.0
        if kind[k] == REVOLUTE:
            h = 0.5 * z[k]
            sh = math.sin(h)
            pa = (math.cos(h), sh * axis[k, 0], sh * axis[k, 1], sh * axis[k, 2])
            pC = quat_multiply_scalar(quat_multiply_scalar(pP, pa),
                                      (p0[k, 0], p0[k, 1], p0[k, 2], p0[k, 3]))
            wC = (wP[0] + u0 * zd[k], wP[1] + u1 * zd[k], wP[2] + u2 * zd[k])
            sd = 0.0
        else:
            pC = quat_multiply_scalar(pP, (p0[k, 0], p0[k, 1], p0[k, 2], p0[k, 3]))
            wC = wP
            sigma = sigma0[k] + z[k]
            sd = zd[k]
        pp[1, 0], pp[1, 1], pp[1, 2], pp[1, 3] = pC
        A_into(pp, 1, Ab)
        # d_PJ = A_P (s'_P + u' sigma), d_JC = -A_C s'_C
        a0 = s_parent[k, 0] + axis[k, 0] * sigma
        a1 = s_parent[k, 1] + axis[k, 1] * sigma
        a2 = s_parent[k, 2] + axis[k, 2] * sigma
        e0 = Ab[0, 0, 0] * a0 + Ab[0, 0, 1] * a1 + Ab[0, 0, 2] * a2
        e1 = Ab[0, 1, 0] * a0 + Ab[0, 1, 1] * a1 + Ab[0, 1, 2] * a2
        e2 = Ab[0, 2, 0] * a0 + Ab[0, 2, 1] * a1 + Ab[0, 2, 2] * a2
        f0 = -(Ab[1, 0, 0] * s_child[k, 0] + Ab[1, 0, 1] * s_child[k, 1]
               + Ab[1, 0, 2] * s_child[k, 2])
        f1 = -(Ab[1, 1, 0] * s_child[k, 0] + Ab[1, 1, 1] * s_child[k, 1]
               + Ab[1, 1, 2] * s_child[k, 2])
        f2 = -(Ab[1, 2, 0] * s_child[k, 0] + Ab[1, 2, 1] * s_child[k, 1]
               + Ab[1, 2, 2] * s_child[k, 2])
        oq, ov = 7 * C, 7 * nb + 6 * C
        y[oq], y[oq + 1], y[oq + 2] = rP[0] + e0 + f0, rP[1] + e1 + f1, rP[2] + e2 + f2
        y[oq + 3], y[oq + 4], y[oq + 5], y[oq + 6] = pC
        # rdot_C = rdot_P + omega_P x d_PJ + u s_dot + omega_C x d_JC
        y[ov] = vP[0] + wP[1] * e2 - wP[2] * e1 + u0 * sd + wC[1] * f2 - wC[2] * f1
        y[ov + 1] = vP[1] + wP[2] * e0 - wP[0] * e2 + u1 * sd + wC[2] * f0 - wC[0] * f2
        y[ov + 2] = vP[2] + wP[0] * e1 - wP[1] * e0 + u2 * sd + wC[0] * f1 - wC[1] * f0
        y[ov + 3], y[ov + 4], y[ov + 5] = wC


@njit
def body_rows(X, T, nb, Y):
    """Y[k, :13 nb] = the bodies' q and v at the joint states X[k] = [z, zd, ...] and Y[k, -1]
    = X[k, -1] (the work W)."""
    nj = T[0].size
    for k in range(X.shape[0]):
        joint_kinematics(X[k, :nj], X[k, nj:2 * nj], T, nb, Y[k])
        Y[k, Y.shape[1] - 1] = X[k, X.shape[1] - 1]


# ----------------------------------------------------------------------------- dynamics
@njit(inline="always")
def _bodies_stage(y, F, I, W):
    """The body terms of :func:`.system.stage_state` -- A, J = A J' A^T, g (gravity,
    -omega~ J omega, the compiled force elements) -- without the constraint equations, which
    the joint coordinates satisfy by construction. False if g is not finite."""
    bo, fo = body_views(F, I, W), force_views(F, I, W)
    nb = bo.mass.size
    q = array_view(y, 0, (nb, 7))
    v = array_view(y, 7 * nb, (nb, 6))
    state_into(q, v, False, bo.r, bo.A, bo.rdot, bo.omega, bo.p)
    body_terms(bo.A, bo.omega, bo.Jl, bo.Jl_inv, bo.weight, bo.J, bo.Jinv, bo.g)
    _forces(bo, fo)
    for i in range(bo.g.size):
        if not math.isfinite(bo.g[i]):
            return False
    return True


@njit
def rhs_joint(t, x, xd, y, T, F, I, W):
    """xd = [zd, zdd, power of the non-conservative forces] at x = [z, zd, W]; y: the body
    state work row (13 nb + 1). Returns False if the accelerations are not finite or an
    articulated inertia is singular."""
    parent, child, kind, axis, s_parent, s_child, p0, sigma0, TI, Tp, TJ = T
    nj = parent.size
    bo = body_views(F, I, W)
    nb = bo.mass.size
    z, zd = x[:nj], x[nj:2 * nj]
    joint_kinematics(z, zd, T, nb, y)
    if not _bodies_stage(y, F, I, W):
        return False
    r, om, J, g = bo.r, bo.omega, bo.J, bo.g
    for b in range(nb):                          # I_b = M_b = diag(m I, J) (10.6), p_b = g_b
        Ib = TI[b]
        for i in range(6):
            for j in range(6):
                Ib[i, j] = 0.0
            Tp[b, i] = g[6 * b + i]
        for i in range(3):
            Ib[i, i] = bo.mass[b]
            for j in range(3):
                Ib[3 + i, 3 + j] = J[b, i, j]
    # per joint: H (col 0), c (col 1), U / D (col 2), [D, u = H^T p_C / D, ...] (col 3)
    for k in range(nj):
        P, C = parent[k], child[k]
        H, c = TJ[k, :, 0], TJ[k, :, 1]
        wP0, wP1, wP2 = (om[P, 0], om[P, 1], om[P, 2]) if P < nb else (0.0, 0.0, 0.0)
        rP0, rP1, rP2 = (r[P, 0], r[P, 1], r[P, 2]) if P < nb else (0.0, 0.0, 0.0)
        AP = bo.A[P]
        u0 = AP[0, 0] * axis[k, 0] + AP[0, 1] * axis[k, 1] + AP[0, 2] * axis[k, 2]
        u1 = AP[1, 0] * axis[k, 0] + AP[1, 1] * axis[k, 1] + AP[1, 2] * axis[k, 2]
        u2 = AP[2, 0] * axis[k, 0] + AP[2, 1] * axis[k, 1] + AP[2, 2] * axis[k, 2]
        # omega_P x u
        x0, x1, x2 = wP1 * u2 - wP2 * u1, wP2 * u0 - wP0 * u2, wP0 * u1 - wP1 * u0
        if kind[k] == REVOLUTE:
            AC = bo.A[C]
            j0 = -(AC[0, 0] * s_child[k, 0] + AC[0, 1] * s_child[k, 1] + AC[0, 2] * s_child[k, 2])
            j1 = -(AC[1, 0] * s_child[k, 0] + AC[1, 1] * s_child[k, 1] + AC[1, 2] * s_child[k, 2])
            j2 = -(AC[2, 0] * s_child[k, 0] + AC[2, 1] * s_child[k, 1] + AC[2, 2] * s_child[k, 2])
            # d_PJ = r_C - d_JC - r_P
            a0, a1, a2 = r[C, 0] - j0 - rP0, r[C, 1] - j1 - rP1, r[C, 2] - j2 - rP2
            wC0, wC1, wC2 = om[C, 0], om[C, 1], om[C, 2]
            H[0], H[1], H[2] = u1 * j2 - u2 * j1, u2 * j0 - u0 * j2, u0 * j1 - u1 * j0
            H[3], H[4], H[5] = u0, u1, u2
            th = zd[k]
            # omega_P x (omega_P x d_PJ)
            b0, b1, b2 = wP1 * a2 - wP2 * a1, wP2 * a0 - wP0 * a2, wP0 * a1 - wP1 * a0
            c0, c1, c2 = wP1 * b2 - wP2 * b1, wP2 * b0 - wP0 * b2, wP0 * b1 - wP1 * b0
            # omega_C x (omega_C x d_JC)
            b0, b1, b2 = wC1 * j2 - wC2 * j1, wC2 * j0 - wC0 * j2, wC0 * j1 - wC1 * j0
            c0 += wC1 * b2 - wC2 * b1
            c1 += wC2 * b0 - wC0 * b2
            c2 += wC0 * b1 - wC1 * b0
            # ((omega_P x u) theta_dot) x d_JC
            c0 += th * (x1 * j2 - x2 * j1)
            c1 += th * (x2 * j0 - x0 * j2)
            c2 += th * (x0 * j1 - x1 * j0)
            c[0], c[1], c[2] = c0, c1, c2
            c[3], c[4], c[5] = x0 * th, x1 * th, x2 * th
        else:
            H[0], H[1], H[2], H[3], H[4], H[5] = u0, u1, u2, 0.0, 0.0, 0.0
            sd = zd[k]
            d0, d1, d2 = r[C, 0] - rP0, r[C, 1] - rP1, r[C, 2] - rP2
            b0, b1, b2 = wP1 * d2 - wP2 * d1, wP2 * d0 - wP0 * d2, wP0 * d1 - wP1 * d0
            c[0] = 2.0 * x0 * sd + wP1 * b2 - wP2 * b1
            c[1] = 2.0 * x1 * sd + wP2 * b0 - wP0 * b2
            c[2] = 2.0 * x2 * sd + wP0 * b1 - wP1 * b0
            c[3], c[4], c[5] = 0.0, 0.0, 0.0
    # backward: leaves first
    Ia = np.empty((6, 6))
    G = np.empty((3, 3))
    S = np.empty((3, 3))
    wv = np.empty(6)
    for k in range(nj - 1, -1, -1):
        P, C = parent[k], child[k]
        H, c, K, aux = TJ[k, :, 0], TJ[k, :, 1], TJ[k, :, 2], TJ[k, :, 3]
        Ic, pc = TI[C], Tp[C]
        D = 0.0
        hp = 0.0
        for i in range(6):
            s = 0.0
            for l in range(6):
                s += Ic[i, l] * H[l]
            K[i] = s
            D += H[i] * s
            hp += H[i] * pc[i]
        if not D > 0.0:
            return False
        aux[0] = D
        aux[1] = hp / D                          # u = H^T p_C / D
        for i in range(6):
            for j in range(6):
                Ia[i, j] = Ic[i, j] - K[i] * K[j] / D
        for i in range(6):                       # K <- U / D
            K[i] /= D
        for i in range(6):                       # w = p~ - Ia c, p~ = p_C - U H^T p_C / D
            s = pc[i] - K[i] * hp
            for l in range(6):
                s -= Ia[i, l] * c[l]
            wv[i] = s
        if P >= nb:
            continue
        IP, pP = TI[P], Tp[P]
        d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
        # X = [[I, S], [0, I]], S x = x cross d; X^T Ia X = [[Ar, G], [G^T, S^T G + B^T S + C]]
        S[0, 0], S[0, 1], S[0, 2] = 0.0, d2, -d1
        S[1, 0], S[1, 1], S[1, 2] = -d2, 0.0, d0
        S[2, 0], S[2, 1], S[2, 2] = d1, -d0, 0.0
        for i in range(3):
            for j in range(3):
                G[i, j] = (Ia[i, 0] * S[0, j] + Ia[i, 1] * S[1, j] + Ia[i, 2] * S[2, j]
                           + Ia[i, 3 + j])
        for i in range(3):
            for j in range(3):
                IP[i, j] += Ia[i, j]
                IP[i, 3 + j] += G[i, j]
                IP[3 + j, i] += G[i, j]
                IP[3 + i, 3 + j] += (S[0, i] * G[0, j] + S[1, i] * G[1, j] + S[2, i] * G[2, j]
                                     + Ia[0, 3 + i] * S[0, j] + Ia[1, 3 + i] * S[1, j]
                                     + Ia[2, 3 + i] * S[2, j] + Ia[3 + i, 3 + j])
        pP[0] += wv[0]
        pP[1] += wv[1]
        pP[2] += wv[2]
        pP[3] += wv[3] + d1 * wv[2] - d2 * wv[1]
        pP[4] += wv[4] + d2 * wv[0] - d0 * wv[2]
        pP[5] += wv[5] + d0 * wv[1] - d1 * wv[0]
    # forward: roots first; vdot of the bodies into bo.vdot
    vd = bo.vdot
    for k in range(nj):
        P, C = parent[k], child[k]
        H, c, K, aux = TJ[k, :, 0], TJ[k, :, 1], TJ[k, :, 2], TJ[k, :, 3]
        for i in range(6):
            wv[i] = c[i]
        if P < nb:
            o = 6 * P
            d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
            wv[0] += vd[o] + vd[o + 4] * d2 - vd[o + 5] * d1
            wv[1] += vd[o + 1] + vd[o + 5] * d0 - vd[o + 3] * d2
            wv[2] += vd[o + 2] + vd[o + 3] * d1 - vd[o + 4] * d0
            wv[3] += vd[o + 3]
            wv[4] += vd[o + 4]
            wv[5] += vd[o + 5]
        a = aux[1]                               # zdd = u - (U / D)^T w
        for i in range(6):
            a -= K[i] * wv[i]
        for i in range(6):
            vd[6 * C + i] = wv[i] + H[i] * a
        xd[nj + k] = a
        xd[k] = zd[k]
    xd[2 * nj] = bo.g_power[0]
    for k in range(2 * nj + 1):
        if not math.isfinite(xd[k]):
            return False
    return True


# ----------------------------------------------------------------------------- the driver
#: status codes of :func:`dopri_joint`
OK, RHS_FAILED, UNDERFLOW, TOO_MANY_STEPS = 0, 1, 2, 4
SAFETY, MIN_FACTOR, MAX_FACTOR, BETA = 0.9, 0.2, 10.0, 0.04


@njit
def _rms(x, scale):
    acc = 0.0
    for i in range(x.size):
        e = x[i] / scale[i]
        acc += e * e
    return math.sqrt(acc / x.size)


@njit
def dopri_joint(t, x, K0, h, err_prev, T, F, I, W, t0, t_out, k_out, rtol, atol, max_step,
                max_steps, X, counters):
    """Up to ``max_steps`` accepted Dormand-Prince 5(4) steps of the joint state x from t
    (FSAL derivative K0, proposed step h; h = 0 starts the run: output at t, K0 and Hairer's
    starting step), every output time t_out[k_out:] reached written into X[k]. The controller
    of DormandPrince45 (PI, beta 0.04, safety 0.9, factors 0.2..10, dense output). Returns
    (status, t, h, err_prev, k_out); call again to continue. counters: (nfev, steps,
    rejected)."""
    n = x.size
    nb = body_views(F, I, W).mass.size
    yb = np.zeros(13 * nb + 1)
    t_end = t_out[-1]
    span = t_end - t0
    nt = t_out.size
    if h <= 0.0:
        if k_out < nt and t_out[k_out] == t:
            for i in range(n):
                X[k_out, i] = x[i]
            k_out += 1
        if t >= t_end:
            return OK, t, h, err_prev, k_out
        if not rhs_joint(t, x, K0, yb, T, F, I, W):
            return RHS_FAILED, t, h, err_prev, k_out
        counters[0] += 1
        scale = np.empty(n)
        for i in range(n):
            scale[i] = atol + abs(x[i]) * rtol
        d0, d1 = _rms(x, scale), _rms(K0, scale)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, max_step, abs(span))
        x1 = np.empty(n)
        f1 = np.empty(n)
        for i in range(n):
            x1[i] = x[i] + h0 * K0[i]
        if not rhs_joint(t + h0, x1, f1, yb, T, F, I, W):
            return RHS_FAILED, t, h, err_prev, k_out
        counters[0] += 1
        for i in range(n):
            x1[i] = f1[i] - K0[i]
        d2 = _rms(x1, scale) / h0
        if not math.isfinite(d2):
            h = h0
        elif d1 <= 1e-15 and d2 <= 1e-15:
            h = min(100.0 * h0, max(1e-6, h0 * 1e-3), max_step, abs(span))
        else:
            h = min(100.0 * h0, (0.01 / max(d1, d2)) ** 0.2, max_step, abs(span))
    K = np.empty((7, n))
    for i in range(n):
        K[0, i] = K0[i]
    x_new = np.empty(n)
    xo = np.empty(n)
    tmp = np.empty(n)
    atol_v = np.full(n, atol)
    empty = np.zeros(0)
    alpha = 0.2 - 0.75 * BETA
    after_reject = False
    steps = 0
    while t < t_end and steps < max_steps:
        h_min = min_step_size(t, span, 0.0)
        while True:
            hs = end_step(t, h, t_end)
            if hs < h_min:
                return UNDERFLOW, t, h, err_prev, k_out
            t_new = t_end if hs == t_end - t else t + hs
            ok = True
            for s in range(1, 7):
                for i in range(n):
                    acc = 0.0
                    for j in range(s):
                        acc += DOPRI_TABLEAU[s, j] * K[j, i]
                    tmp[i] = x[i] + hs * acc
                ts = t_new if s == 6 else t + DOPRI_NODES[s] * hs
                if not rhs_joint(ts, tmp, K[s], yb, T, F, I, W):
                    ok = False
                    break
            counters[0] += 6
            if ok:
                for i in range(n):
                    x_new[i] = tmp[i]
                err = dopri_error(x, x_new, K, hs, atol_v, rtol)
            else:
                err = math.inf
            if err <= 1.0:
                break
            counters[2] += 1
            fac = MIN_FACTOR if not math.isfinite(err) else max(MIN_FACTOR,
                                                                min(0.9, SAFETY * err ** -0.2))
            h = hs * fac
            after_reject = True
        fac = MAX_FACTOR if err == 0.0 else SAFETY * err ** (-alpha) * err_prev ** BETA
        err_prev = max(err, 1e-4)
        fac = min(MAX_FACTOR, max(MIN_FACTOR, fac))
        if after_reject:
            fac = min(fac, 1.0)
        after_reject = False
        while k_out < nt and t_out[k_out] <= t_new:
            to = t_out[k_out]
            if to == t_new:
                for i in range(n):
                    X[k_out, i] = x_new[i]
            else:
                dopri_interpolate(x, hs, K, (to - t) / hs, empty, xo)
                for i in range(n):
                    X[k_out, i] = xo[i]
            k_out += 1
        for i in range(n):
            x[i] = x_new[i]
            K[0, i] = K[6, i]
        t = t_new
        h = hs * fac
        steps += 1
        counters[1] += 1
    for i in range(n):
        K0[i] = K[0, i]
    return OK, t, h, err_prev, k_out


# ----------------------------------------------------------------------------- the method
from .base import register  # noqa: E402
from .standard import Standard  # noqa: E402


@register
class Recursive(Standard):
    """Joint coordinates of an open tree (revolute and translational joints), accelerations by
    the articulated-body recursion, integrated by the compiled Dormand-Prince 5(4) driver: no
    constraint equations, so no drift and no projection. The outputs (accelerations, reactions,
    energies) are evaluated at the output times as the standard method's, at the body
    coordinates the joints give. Models it cannot represent raise ModelError naming the
    element (use "standard" or "projection" for them)."""

    name = "recursive"
    joint_coordinates = True

    def __init__(self):
        super().__init__("schur")

    def parameters(self):
        return {}


def joint_right_hand_side(model, q0=None, v0=None):
    """(f, x0): the x' = f(t, x) the recursive method integrates (x = [z, zdot, W], joint
    coordinates from the assembled state q0, v0, default the model's) and its initial state;
    for benchmarks and one's own integrators (as :func:`..simulate.right_hand_side`)."""
    from .system import System
    q0 = model.q0 if q0 is None else q0
    v0 = model.v0 if v0 is None else v0
    tree = JointTree(model, q0, v0)
    tree.check_initial(q0)
    T = tree.arrays()
    system = System.for_model(model)
    F, I, W = system.F, system.I, system.W
    yb = np.zeros(13 * model.nb + 1)

    def f(t, x):
        xd = np.empty(x.size)
        if not rhs_joint(float(t), x, xd, yb, T, F, I, W):
            raise ModelError(f"t = {t:.6g} s: the accelerations are not finite (an "
                             "articulated inertia is singular)")
        return xd
    return f, np.concatenate([tree.z0, tree.zd0, [0.0]])
