"""Recursive forward dynamics in joint coordinates for open trees (method "recursive").

A model whose joints are revolute, translational (prismatic) or spherical and connect every
body to the ground by at most one chain is a tree: its configuration is its joint coordinates z
(an angle or a slide per joint, the relative Euler parameters of a spherical joint, position and
Euler parameters of a body without a joint: a free joint), with no constraint equations left and
no drift. This module
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
5(4) or 8(5,3) with the default controller of the integrator
(:mod:`..integrators.pairs`).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..errors import ModelError
from ..integrators.controller import (end_step, min_step_size, pi_factor, rejected_factor,
                                      start_first_guess, start_step)
from ..integrators.pairs import (DP8, pair_dense, pair_error, pair_interpolate,
                                 pair_stages)
from ..jit import njit
from ..jit import array_view
from ..rotations import A_into, pdot_scalar, quat_multiply_scalar
from ..state import state_into
from .fused import OK, RHS_FAILED, UNDERFLOW, _rms
from .layout import bare, body_views, force_views
from .standard import rhs_standard
from .system import _forces, body_terms

__all__ = ["JointTree", "JOINT_KINDS", "Recursive", "joint_kinematics", "rhs_joint",
           "dopri_joint", "body_rows", "joint_right_hand_side"]

#: constraint types the recursive method turns into joint coordinates: (kind, coordinates,
#: rates) -- an angle, a slide, or the relative Euler parameters and angular velocity; a body
#: without a joint to the ground gets a free joint (position and Euler parameters, velocity
#: and angular velocity in global axes)
JOINT_KINDS = {"revolute": 0, "translational": 1, "spherical": 2}
REVOLUTE, TRANSLATIONAL, SPHERICAL, FREE = 0, 1, 2, 3
#: coordinates and rates per joint kind
SIZES_Q = np.array([1, 1, 4, 7], dtype=np.int64)
SIZES_V = np.array([1, 1, 3, 6], dtype=np.int64)


#: the arrays of a tree, declared once: (name, pack, shape in nj (joints), n1 = max(nj, 1),
#: nb (bodies), nqu (Euler-parameter sets)). Two packs -- Ti (int64) and Tf (float64) --
#: hold them; Ti[:3] = (nj, nb, nqu) and Ti[3 + k] the offset of field k in its pack, so the
#: compiled code reads views without reference counting (:func:`tree_views`), which saves
#: about 0.2 us per evaluation over a tuple of 21 separately passed arrays.
TREE_FIELDS = (
    ("parent", "i", ("nj",)), ("child", "i", ("nj",)), ("kind", "i", ("nj",)),
    ("qo", "i", ("nj",)), ("vo", "i", ("nj",)), ("quats", "i", ("nqu",)),
    ("axis", "f", ("nj", 3)), ("s_parent", "f", ("nj", 3)), ("s_child", "f", ("nj", 3)),
    ("p0", "f", ("nj", 4)), ("sigma0", "f", ("nj",)),
    # work of an evaluation: per body I and p, per joint H, c, U D^-1, u (allocated once: an
    # allocation in the compiled right-hand side costs about 40 ns)
    ("TI", "f", ("nb", 6, 6)), ("Tp", "f", ("nb", 6)), ("TH", "f", ("n1", 6, 6)),
    ("Tc", "f", ("n1", 6)), ("TK", "f", ("n1", 6, 6)), ("Tu", "f", ("n1", 6)),
    ("w66", "f", (3, 6, 6)), ("w33", "f", (2, 3, 3)), ("w6", "f", (3, 6)), ("w4", "f", (2, 4)),
)
Tree = namedtuple("Tree", [f[0] for f in TREE_FIELDS])


def _tree_packs(nj: int, nb: int, nqu: int):
    """Zeroed packs (Ti, Tf) for TREE_FIELDS with the header filled in, and the NumPy views
    of the fields (a dict)."""
    dims = {"nj": nj, "n1": max(nj, 1), "nb": nb, "nqu": nqu}
    shapes = [tuple(dims.get(d, d) for d in shape) for _, _, shape in TREE_FIELDS]
    sizes = [math.prod(sh) for sh in shapes]
    head = 3 + len(TREE_FIELDS)
    ni = head + sum(z for (_, pk, _), z in zip(TREE_FIELDS, sizes) if pk == "i")
    nf = sum(z for (_, pk, _), z in zip(TREE_FIELDS, sizes) if pk == "f")
    Ti, Tf = np.zeros(ni, np.int64), np.zeros(nf)
    Ti[:3] = nj, nb, nqu
    views, oi, of = {}, head, 0
    for k, ((name, pk, _), shape, size) in enumerate(zip(TREE_FIELDS, shapes, sizes)):
        buf, o = (Ti, oi) if pk == "i" else (Tf, of)
        Ti[3 + k] = o
        views[name] = buf[o:o + size].reshape(shape)
        if pk == "i":
            oi += size
        else:
            of += size
    return Ti, Tf, views


@njit(inline="always")
def tree_views(T):
    """The fields of the packs T = (Ti, Tf) as views (order and shapes of TREE_FIELDS)."""
    Ti, Tf = bare(T[0]), bare(T[1])
    nj, nb, nqu = Ti[0], Ti[1], Ti[2]
    n1 = max(nj, 1)
    return Tree(
        array_view(Ti, Ti[3], (nj,)), array_view(Ti, Ti[4], (nj,)),
        array_view(Ti, Ti[5], (nj,)), array_view(Ti, Ti[6], (nj,)),
        array_view(Ti, Ti[7], (nj,)), array_view(Ti, Ti[8], (nqu,)),
        array_view(Tf, Ti[9], (nj, 3)), array_view(Tf, Ti[10], (nj, 3)),
        array_view(Tf, Ti[11], (nj, 3)), array_view(Tf, Ti[12], (nj, 4)),
        array_view(Tf, Ti[13], (nj,)),
        array_view(Tf, Ti[14], (nb, 6, 6)), array_view(Tf, Ti[15], (nb, 6)),
        array_view(Tf, Ti[16], (n1, 6, 6)), array_view(Tf, Ti[17], (n1, 6)),
        array_view(Tf, Ti[18], (n1, 6, 6)), array_view(Tf, Ti[19], (n1, 6)),
        array_view(Tf, Ti[20], (3, 6, 6)), array_view(Tf, Ti[21], (2, 3, 3)),
        array_view(Tf, Ti[22], (3, 6)), array_view(Tf, Ti[23], (2, 4)))


class JointTree:
    """The joints of a tree model in joint coordinates, from its (assembled) initial state.

    Arrays (per joint, parents first): ``parent``, ``child`` (body indices, the ground nb),
    ``kind`` (:data:`REVOLUTE`, :data:`TRANSLATIONAL`, :data:`SPHERICAL`, :data:`FREE`),
    ``qo`` / ``vo`` (offsets of its coordinates in z and of its rates in zdot), ``axis`` (u' in
    the parent's axes; the ground's: global), ``s_parent`` (the joint point in the parent's
    axes), ``s_child`` (in the child's), ``p0`` (the child's Euler parameters relative to the
    parent at the initial state), ``sigma0`` (the initial slide between the joint points).
    ``x0`` = [z0, zdot0, 0]: the initial coordinates (angles and slides 0, relative Euler
    parameters (1, 0, 0, 0), a free body's own q) and rates (from v0). Raises ModelError for
    what it cannot represent, naming the element.
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
        seen = np.zeros(nb + 1, dtype=bool)
        order, used = [], set()                        # (joint or -1 for free, parent, child)
        for root in [nb] + list(range(nb)):
            if seen[root]:
                continue
            seen[root] = True
            if root < nb:
                order.append((-1, nb, root))           # a free joint to the ground
            queue = [root]
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
        nj = len(order)
        self.n = nj
        self.names = []
        nqu = sum(1 for k, P, C in order if k < 0 or joints[k][0].name == "spherical")
        self.Ti, self.Tf, views = _tree_packs(nj, nb, nqu)
        for name, view in views.items():             # tree.parent, tree.axis, ... (NumPy)
            setattr(self, name, view)
        Ag = np.vstack([_rotations(q0), np.eye(3)[None]])
        r = np.vstack([q0[:, :3], np.zeros((1, 3))])
        p = np.vstack([q0[:, 3:], [[1.0, 0.0, 0.0, 0.0]]])
        rd = np.vstack([v0[:, :3], np.zeros((1, 3))])
        w = np.vstack([v0[:, 3:], np.zeros((1, 3))])
        zq, zv = [], []
        for t, (k, P, C) in enumerate(order):
            self.parent[t], self.child[t] = P, C
            self.qo[t], self.vo[t] = len(zq), len(zv)
            if k < 0:
                self.names.append(f"{model.body_names[C]} (free)")
                self.kind[t] = FREE
                self.p0[t] = (1.0, 0.0, 0.0, 0.0)
                zq += list(q0[C])
                zv += list(v0[C])
                continue
            g, n = joints[k]
            geo = g.geometry
            i_is_parent = int(g.body_i[n]) == P
            sP, sC = (geo.s_i[n], geo.s_j[n]) if i_is_parent else (geo.s_j[n], geo.s_i[n])
            self.names.append(g.names[n])
            kind = self.kind[t] = JOINT_KINDS[g.name]
            self.s_parent[t], self.s_child[t] = sP, sC
            self.p0[t] = _quat(_conj(p[P]), p[C])
            JP = r[P] + Ag[P] @ sP
            JC = r[C] + Ag[C] @ sC
            if kind == SPHERICAL:
                zq += [1.0, 0.0, 0.0, 0.0]
                zv += list(Ag[P].T @ (w[C] - w[P]))
                continue
            u_world = Ag[int(g.body_i[n])] @ geo.R_i[n][:, 0]      # the axis, fixed on i
            self.axis[t] = Ag[P].T @ u_world / np.linalg.norm(u_world)
            u = Ag[P] @ self.axis[t]
            zq.append(0.0)
            if kind == TRANSLATIONAL:
                self.sigma0[t] = u @ (JC - JP)
                vJC = rd[C] + np.cross(w[C], Ag[C] @ sC)
                vJP = rd[P] + np.cross(w[P], JC - r[P])
                zv.append(u @ (vJC - vJP))
            else:
                zv.append(u @ (w[C] - w[P]))
        self.nq, self.nv = len(zq), len(zv)
        self.x0 = np.array(zq + zv + [0.0])
        self.quats[:] = [self.qo[t] + (3 if self.kind[t] == FREE else 0)
                         for t in range(nj) if self.kind[t] in (SPHERICAL, FREE)]
        self.nb = nb

    def arrays(self):
        """The packs (Ti, Tf) the compiled kernels take (:data:`TREE_FIELDS`)."""
        return (self.Ti, self.Tf)

    def check_initial(self, q0, tol: float = 1e-6) -> float:
        """Largest difference between the bodies placed by the joints at x0 and q0 (positions
        in m, Euler parameters); ModelError when it exceeds tol (an unassembled start)."""
        nb = self.nb
        y = np.zeros(13 * nb)
        joint_kinematics(self.x0[:self.nq], self.x0[self.nq:self.nq + self.nv], self.arrays(),
                         nb, y)
        q = y[:7 * nb].reshape(nb, 7)
        q0 = np.asarray(q0, dtype=float).reshape(nb, 7)
        sign = np.where(np.sum(q[:, 3:] * q0[:, 3:], axis=1) < 0, -1.0, 1.0)
        err = max(np.abs(q[:, :3] - q0[:, :3]).max(initial=0.0),
                  np.abs(q[:, 3:] - sign[:, None] * q0[:, 3:]).max(initial=0.0))
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


@njit(inline="always")
def _unit(z, o):
    n = math.sqrt(z[o] * z[o] + z[o + 1] * z[o + 1] + z[o + 2] * z[o + 2] + z[o + 3] * z[o + 3])
    return (z[o] / n, z[o + 1] / n, z[o + 2] / n, z[o + 3] / n)


# ----------------------------------------------------------------------------- kinematics
@njit
def joint_kinematics(zq, zv, T, nb, y):
    """y[:13 nb] = [q (7 nb), v (6 nb)] of the bodies at joint coordinates zq and rates zv
    (parents before children: every parent's row is written before it is read; Euler
    parameters in zq are used divided by their length)."""
    tv = tree_views(T)
    parent, child, kind, qo, vo, axis = tv.parent, tv.child, tv.kind, tv.qo, tv.vo, tv.axis
    s_parent, s_child, p0, sigma0 = tv.s_parent, tv.s_child, tv.p0, tv.sigma0
    nj = parent.size
    Ab, pp = tv.w33, tv.w4                       # work: two rotation matrices, two p
    for k in range(nj):
        P, C = parent[k], child[k]
        oq, ov = 7 * C, 7 * nb + 6 * C
        kd = kind[k]
        if kd == FREE:
            pC = _unit(zq, qo[k] + 3)
            for i in range(3):
                y[oq + i] = zq[qo[k] + i]
            y[oq + 3], y[oq + 4], y[oq + 5], y[oq + 6] = pC
            for i in range(6):
                y[ov + i] = zv[vo[k] + i]
            continue
        if P < nb:
            oqP, ovP = 7 * P, 7 * nb + 6 * P
            pP = (y[oqP + 3], y[oqP + 4], y[oqP + 5], y[oqP + 6])
            rP = (y[oqP], y[oqP + 1], y[oqP + 2])
            vP = (y[ovP], y[ovP + 1], y[ovP + 2])
            wP = (y[ovP + 3], y[ovP + 4], y[ovP + 5])
        else:
            pP = (1.0, 0.0, 0.0, 0.0)
            rP = (0.0, 0.0, 0.0)
            vP = (0.0, 0.0, 0.0)
            wP = (0.0, 0.0, 0.0)
        pp[0, 0], pp[0, 1], pp[0, 2], pp[0, 3] = pP
        A_into(pp, 0, Ab)
        sigma = 0.0
        sd = 0.0
        pk = (p0[k, 0], p0[k, 1], p0[k, 2], p0[k, 3])
        if kd == SPHERICAL:
            pC = quat_multiply_scalar(quat_multiply_scalar(pP, _unit(zq, qo[k])), pk)
            o = vo[k]
            wC = (wP[0] + Ab[0, 0, 0] * zv[o] + Ab[0, 0, 1] * zv[o + 1] + Ab[0, 0, 2] * zv[o + 2],
                  wP[1] + Ab[0, 1, 0] * zv[o] + Ab[0, 1, 1] * zv[o + 1] + Ab[0, 1, 2] * zv[o + 2],
                  wP[2] + Ab[0, 2, 0] * zv[o] + Ab[0, 2, 1] * zv[o + 1] + Ab[0, 2, 2] * zv[o + 2])
            u0 = u1 = u2 = 0.0
        else:
            u0 = Ab[0, 0, 0] * axis[k, 0] + Ab[0, 0, 1] * axis[k, 1] + Ab[0, 0, 2] * axis[k, 2]
            u1 = Ab[0, 1, 0] * axis[k, 0] + Ab[0, 1, 1] * axis[k, 1] + Ab[0, 1, 2] * axis[k, 2]
            u2 = Ab[0, 2, 0] * axis[k, 0] + Ab[0, 2, 1] * axis[k, 1] + Ab[0, 2, 2] * axis[k, 2]
            if kd == REVOLUTE:
                h = 0.5 * zq[qo[k]]
                sh = math.sin(h)
                pa = (math.cos(h), sh * axis[k, 0], sh * axis[k, 1], sh * axis[k, 2])
                pC = quat_multiply_scalar(quat_multiply_scalar(pP, pa), pk)
                th = zv[vo[k]]
                wC = (wP[0] + u0 * th, wP[1] + u1 * th, wP[2] + u2 * th)
            else:
                pC = quat_multiply_scalar(pP, pk)
                wC = wP
                sigma = sigma0[k] + zq[qo[k]]
                sd = zv[vo[k]]
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
        y[oq], y[oq + 1], y[oq + 2] = rP[0] + e0 + f0, rP[1] + e1 + f1, rP[2] + e2 + f2
        y[oq + 3], y[oq + 4], y[oq + 5], y[oq + 6] = pC
        # rdot_C = rdot_P + omega_P x d_PJ + u s_dot + omega_C x d_JC
        y[ov] = vP[0] + wP[1] * e2 - wP[2] * e1 + u0 * sd + wC[1] * f2 - wC[2] * f1
        y[ov + 1] = vP[1] + wP[2] * e0 - wP[0] * e2 + u1 * sd + wC[2] * f0 - wC[0] * f2
        y[ov + 2] = vP[2] + wP[0] * e1 - wP[1] * e0 + u2 * sd + wC[0] * f1 - wC[1] * f0
        y[ov + 3], y[ov + 4], y[ov + 5] = wC


@njit
def body_rows(X, T, nb, nq, Y):
    """Y[k, :13 nb] = the bodies' q and v at the joint states X[k] = [z (nq), zdot, W] and
    Y[k, -1] = X[k, -1] (the work W)."""
    nv = X.shape[1] - 1 - nq
    for k in range(X.shape[0]):
        joint_kinematics(X[k, :nq], X[k, nq:nq + nv], T, nb, Y[k])
        Y[k, Y.shape[1] - 1] = X[k, X.shape[1] - 1]


@njit
def output_accelerations(t_out, Y, F, I, W, mp, lam_off, Yd, Lam):
    """Yd[k], Lam[k] = vdot and lambda of the standard method (12.3) at the body states Y[k]
    (what :meth:`..results.Results.from_integration` would evaluate row by row in Python; NaN
    where the solve fails)."""
    ydot = np.empty(Y.shape[1])
    nv, m = Yd.shape[1], Lam.shape[1]
    for k in range(Y.shape[0]):
        if rhs_standard(t_out[k], Y[k], ydot, F, I, W, mp) < 0:
            for j in range(nv):
                Yd[k, j] = np.nan
            for j in range(m):
                Lam[k, j] = np.nan
            continue
        for j in range(nv):                      # ydot = [qdot (7 nb), vdot (6 nb), ...]
            Yd[k, j] = ydot[7 * (nv // 6) + j]
        for j in range(m):
            Lam[k, j] = W[lam_off + j]


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
    body_terms(bo.A, bo.omega, bo.Jl, bo.Jl_inv, bo.weight, bo.J, bo.Jinv, bo.g, False)
    _forces(bo, fo)
    for i in range(bo.g.size):
        if not math.isfinite(bo.g[i]):
            return False
    return True


@njit(inline="always")
def _chol(A, n):
    """In-place Cholesky of the leading n x n block of A (lower triangle); False if not
    positive definite."""
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / d
    return True


@njit(inline="always")
def _chol_solve(L, n, x):
    """x <- A^-1 x with the factor of :func:`_chol` (leading n entries of x)."""
    for i in range(n):
        s = x[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(inline="always")
def _articulate(H, K, Ic, pc, hp, u, L, Kt, Ia, row, n):
    """For n rates: D = H^T U (U = I_C H, given in K), hp = H^T p_C, u = D^-1 hp,
    Ia = I_C - U D^-1 U^T and K <- U D^-1. False if D is not positive definite."""
    for i in range(n):
        for j in range(i + 1):
            s = 0.0
            for l in range(6):
                s += H[l, i] * K[l, j]
            L[i, j] = s
        s = 0.0
        for l in range(6):
            s += H[l, i] * pc[l]
        hp[i] = s
        u[i] = s
    if not _chol(L, n):
        return False
    _chol_solve(L, n, u)
    for i in range(6):                           # Kt = U D^-1, row by row
        for j in range(n):
            row[j] = K[i, j]
        _chol_solve(L, n, row)
        for j in range(n):
            Kt[i, j] = row[j]
    for i in range(6):
        for j in range(6):
            s = Ic[i, j]
            for l in range(n):
                s -= Kt[i, l] * K[j, l]
            Ia[i, j] = s
    for i in range(6):
        for j in range(n):
            K[i, j] = Kt[i, j]
    return True


@njit(inline="always")
def _articulate3(H, K, Ic, pc, hp, u, Kt, Ia):
    """:func:`_articulate` for three rates (a spherical joint), with D^-1 from an unrolled
    3 x 3 Cholesky factor (False if D is not positive definite)."""
    d00 = d01 = d02 = d11 = d12 = d22 = 0.0
    h0 = h1 = h2 = 0.0
    for l in range(6):
        d00 += H[l, 0] * K[l, 0]
        d01 += H[l, 0] * K[l, 1]
        d02 += H[l, 0] * K[l, 2]
        d11 += H[l, 1] * K[l, 1]
        d12 += H[l, 1] * K[l, 2]
        d22 += H[l, 2] * K[l, 2]
        h0 += H[l, 0] * pc[l]
        h1 += H[l, 1] * pc[l]
        h2 += H[l, 2] * pc[l]
    # D = L L^T (Cholesky, unrolled)
    if not d00 > 0.0:
        return False
    l00 = math.sqrt(d00)
    l10, l20 = d01 / l00, d02 / l00
    s11 = d11 - l10 * l10
    if not s11 > 0.0:
        return False
    l11 = math.sqrt(s11)
    l21 = (d12 - l20 * l10) / l11
    s22 = d22 - l20 * l20 - l21 * l21
    if not s22 > 0.0:
        return False
    l22 = math.sqrt(s22)
    hp[0], hp[1], hp[2] = h0, h1, h2
    # x = D^-1 b by forward and back substitution with L (as _chol_solve, unrolled)
    y0 = h0 / l00
    y1 = (h1 - l10 * y0) / l11
    y2 = (h2 - l20 * y0 - l21 * y1) / l22
    u[2] = y2 / l22
    u[1] = (y1 - l21 * u[2]) / l11
    u[0] = (y0 - l10 * u[1] - l20 * u[2]) / l00
    for i in range(6):                           # Kt = U D^-1, row by row
        y0 = K[i, 0] / l00
        y1 = (K[i, 1] - l10 * y0) / l11
        y2 = (K[i, 2] - l20 * y0 - l21 * y1) / l22
        x2 = y2 / l22
        x1 = (y1 - l21 * x2) / l11
        Kt[i, 0], Kt[i, 1], Kt[i, 2] = (y0 - l10 * x1 - l20 * x2) / l00, x1, x2
    for i in range(6):                           # Ia = I_C - U D^-1 U^T
        for j in range(6):
            Ia[i, j] = Ic[i, j] - (Kt[i, 0] * K[j, 0] + Kt[i, 1] * K[j, 1]
                                   + Kt[i, 2] * K[j, 2])
    for i in range(6):
        K[i, 0], K[i, 1], K[i, 2] = Kt[i, 0], Kt[i, 1], Kt[i, 2]
    return True


@njit
def rhs_joint(t, x, xd, y, T, F, I, W):
    """xd = [zdot, zddot, power of the non-conservative forces] at x = [z, zdot, W]
    (zdot of Euler parameters: 1/2 G^T omega, 5.12); y: the body-state work row
    (13 nb + 1). Returns False if the accelerations are not finite or an articulated inertia
    is singular."""
    tv = tree_views(T)
    parent, child, kind, qo, vo, axis = tv.parent, tv.child, tv.kind, tv.qo, tv.vo, tv.axis
    s_child = tv.s_child
    TI, Tp, TH, Tc, TK, Tu = tv.TI, tv.Tp, tv.TH, tv.Tc, tv.TK, tv.Tu
    nj = parent.size
    bo = body_views(F, I, W)
    nb = bo.mass.size
    nq = qo[nj - 1] + SIZES_Q[kind[nj - 1]] if nj else 0
    nv = x.size - 1 - nq
    zq, zv = array_view(x, 0, (nq,)), array_view(x, nq, (nv,))
    joint_kinematics(zq, zv, T, nb, y)
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
    # per joint: motion subspace H (6 x n, world axes) and velocity-product acceleration c
    for k in range(nj):
        P, C = parent[k], child[k]
        H, c = TH[k], Tc[k]
        kd = kind[k]
        if kd == FREE:
            for i in range(6):
                for j in range(6):
                    H[i, j] = 1.0 if i == j else 0.0
                c[i] = 0.0
            continue
        wP0, wP1, wP2 = om[P, 0], om[P, 1], om[P, 2]         # the ground's row is 0
        AP, AC = bo.A[P], bo.A[C]
        j0 = -(AC[0, 0] * s_child[k, 0] + AC[0, 1] * s_child[k, 1] + AC[0, 2] * s_child[k, 2])
        j1 = -(AC[1, 0] * s_child[k, 0] + AC[1, 1] * s_child[k, 1] + AC[1, 2] * s_child[k, 2])
        j2 = -(AC[2, 0] * s_child[k, 0] + AC[2, 1] * s_child[k, 1] + AC[2, 2] * s_child[k, 2])
        if kd == TRANSLATIONAL:
            u0 = AP[0, 0] * axis[k, 0] + AP[0, 1] * axis[k, 1] + AP[0, 2] * axis[k, 2]
            u1 = AP[1, 0] * axis[k, 0] + AP[1, 1] * axis[k, 1] + AP[1, 2] * axis[k, 2]
            u2 = AP[2, 0] * axis[k, 0] + AP[2, 1] * axis[k, 1] + AP[2, 2] * axis[k, 2]
            H[0, 0], H[1, 0], H[2, 0], H[3, 0], H[4, 0], H[5, 0] = u0, u1, u2, 0.0, 0.0, 0.0
            sd = zv[vo[k]]
            x0, x1, x2 = wP1 * u2 - wP2 * u1, wP2 * u0 - wP0 * u2, wP0 * u1 - wP1 * u0
            d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
            b0, b1, b2 = wP1 * d2 - wP2 * d1, wP2 * d0 - wP0 * d2, wP0 * d1 - wP1 * d0
            c[0] = 2.0 * x0 * sd + wP1 * b2 - wP2 * b1
            c[1] = 2.0 * x1 * sd + wP2 * b0 - wP0 * b2
            c[2] = 2.0 * x2 * sd + wP0 * b1 - wP1 * b0
            c[3], c[4], c[5] = 0.0, 0.0, 0.0
            continue
        # revolute and spherical: omega_C = omega_P + (rates in world axes); c_w = omega_P x
        # (those rates), c_r = omega_P x (omega_P x d_PJ) + omega_C x (omega_C x d_JC)
        # + c_w x d_JC (d_PJ = r_J - r_P, d_JC = r_C - r_J)
        if kd == REVOLUTE:
            u0 = AP[0, 0] * axis[k, 0] + AP[0, 1] * axis[k, 1] + AP[0, 2] * axis[k, 2]
            u1 = AP[1, 0] * axis[k, 0] + AP[1, 1] * axis[k, 1] + AP[1, 2] * axis[k, 2]
            u2 = AP[2, 0] * axis[k, 0] + AP[2, 1] * axis[k, 1] + AP[2, 2] * axis[k, 2]
            H[0, 0], H[1, 0], H[2, 0] = u1 * j2 - u2 * j1, u2 * j0 - u0 * j2, u0 * j1 - u1 * j0
            H[3, 0], H[4, 0], H[5, 0] = u0, u1, u2
            th = zv[vo[k]]
            e0, e1, e2 = u0 * th, u1 * th, u2 * th
        else:
            o = vo[k]
            for col in range(3):                 # the parent's axis col, and its moment arm
                a0, a1, a2 = AP[0, col], AP[1, col], AP[2, col]
                H[0, col], H[1, col], H[2, col] = a1 * j2 - a2 * j1, a2 * j0 - a0 * j2, \
                    a0 * j1 - a1 * j0
                H[3, col], H[4, col], H[5, col] = a0, a1, a2
            e0 = AP[0, 0] * zv[o] + AP[0, 1] * zv[o + 1] + AP[0, 2] * zv[o + 2]
            e1 = AP[1, 0] * zv[o] + AP[1, 1] * zv[o + 1] + AP[1, 2] * zv[o + 2]
            e2 = AP[2, 0] * zv[o] + AP[2, 1] * zv[o + 1] + AP[2, 2] * zv[o + 2]
        x0, x1, x2 = wP1 * e2 - wP2 * e1, wP2 * e0 - wP0 * e2, wP0 * e1 - wP1 * e0   # c_w
        a0, a1, a2 = r[C, 0] - j0 - r[P, 0], r[C, 1] - j1 - r[P, 1], r[C, 2] - j2 - r[P, 2]
        wC0, wC1, wC2 = om[C, 0], om[C, 1], om[C, 2]
        b0, b1, b2 = wP1 * a2 - wP2 * a1, wP2 * a0 - wP0 * a2, wP0 * a1 - wP1 * a0
        c0, c1, c2 = wP1 * b2 - wP2 * b1, wP2 * b0 - wP0 * b2, wP0 * b1 - wP1 * b0
        b0, b1, b2 = wC1 * j2 - wC2 * j1, wC2 * j0 - wC0 * j2, wC0 * j1 - wC1 * j0
        c0 += wC1 * b2 - wC2 * b1 + (x1 * j2 - x2 * j1)
        c1 += wC2 * b0 - wC0 * b2 + (x2 * j0 - x0 * j2)
        c2 += wC0 * b1 - wC1 * b0 + (x0 * j1 - x1 * j0)
        c[0], c[1], c[2], c[3], c[4], c[5] = c0, c1, c2, x0, x1, x2
    # backward: leaves first
    Ia, L, Kt = tv.w66[0], tv.w66[1], tv.w66[2]  # work arrays of the tree (no allocation;
    G, S = tv.w33[0], tv.w33[1]                  # joint_kinematics is done with w33)
    wv, hp, row = tv.w6[0], tv.w6[1], tv.w6[2]
    for k in range(nj - 1, -1, -1):
        P, C = parent[k], child[k]
        n = SIZES_V[kind[k]]
        H, c, K, u = TH[k], Tc[k], TK[k], Tu[k]
        Ic, pc = TI[C], Tp[C]
        for i in range(6):                       # U = I_C H (in K)
            for j in range(n):
                s = 0.0
                for l in range(6):
                    s += Ic[i, l] * H[l, j]
                K[i, j] = s
        if n == 1:                               # one rate (revolute, translational)
            dk = 0.0
            hp0 = 0.0
            for l in range(6):
                dk += H[l, 0] * K[l, 0]
                hp0 += H[l, 0] * pc[l]
            if not dk > 0.0:
                return False
            hp[0] = hp0
            u[0] = hp0 / dk
            if P < nb:                           # (a root's Ia and w go nowhere)
                for i in range(6):
                    for j in range(6):
                        Ia[i, j] = Ic[i, j] - K[i, 0] * K[j, 0] / dk
            for i in range(6):
                K[i, 0] /= dk
        elif n == 3:
            if not _articulate3(H, K, Ic, pc, hp, u, Kt, Ia):
                return False
        else:
            if not _articulate(H, K, Ic, pc, hp, u, L, Kt, Ia, row, n):
                return False
        if P >= nb:
            continue
        for i in range(6):                       # w = p~ - Ia c, p~ = p_C - U D^-1 H^T p_C
            s = pc[i]
            for l in range(n):
                s -= K[i, l] * hp[l]
            for l in range(6):
                s -= Ia[i, l] * c[l]
            wv[i] = s
        IP, pP = TI[P], Tp[P]
        d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
        # X = [[I, S], [0, I]], S x = x cross d; X^T Ia X = [[Ar, G], [G^T, S^T G + B^T S + C]]
        # with Ia = [[Ar, B], [B^T, C]], G = Ar S + B; X^T w = [w_r, w_w + d x w_r]
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
    # forward: roots first; the bodies' vdot into bo.vdot, zddot into xd
    vd = bo.vdot
    for k in range(nj):
        P, C = parent[k], child[k]
        n = SIZES_V[kind[k]]
        H, c, K, u = TH[k], Tc[k], TK[k], Tu[k]
        for i in range(6):
            wv[i] = c[i]
        if P < nb:                               # w = X vdot_P + c
            o = 6 * P
            d0, d1, d2 = r[C, 0] - r[P, 0], r[C, 1] - r[P, 1], r[C, 2] - r[P, 2]
            wv[0] += vd[o] + vd[o + 4] * d2 - vd[o + 5] * d1
            wv[1] += vd[o + 1] + vd[o + 5] * d0 - vd[o + 3] * d2
            wv[2] += vd[o + 2] + vd[o + 3] * d1 - vd[o + 4] * d0
            wv[3] += vd[o + 3]
            wv[4] += vd[o + 4]
            wv[5] += vd[o + 5]
        for j in range(n):                       # zdd = u - K^T w
            s = u[j]
            for i in range(6):
                s -= K[i, j] * wv[i]
            row[j] = s
            xd[nq + vo[k] + j] = s
        for i in range(6):                       # vdot_C = w + H zdd
            s = wv[i]
            for j in range(n):
                s += H[i, j] * row[j]
            vd[6 * C + i] = s
        # zdot: the rates, or 1/2 G^T omega for Euler parameters (5.12)
        oq, ov = qo[k], vo[k]
        if kind[k] == SPHERICAL:
            pd = pdot_scalar(_unit(zq, oq), (zv[ov], zv[ov + 1], zv[ov + 2]))
            xd[oq], xd[oq + 1], xd[oq + 2], xd[oq + 3] = pd
        elif kind[k] == FREE:
            for i in range(3):
                xd[oq + i] = zv[ov + i]
            pd = pdot_scalar(_unit(zq, oq + 3), (zv[ov + 3], zv[ov + 4], zv[ov + 5]))
            xd[oq + 3], xd[oq + 4], xd[oq + 5], xd[oq + 6] = pd
        else:
            xd[oq] = zv[ov]
    xd[nq + nv] = bo.g_power[0]
    for k in range(nq + nv + 1):
        if not math.isfinite(xd[k]):
            return False
    return True


# ----------------------------------------------------------------------------- the driver
# dopri_joint shares the status codes (OK, RHS_FAILED, UNDERFLOW), the embedded pairs
# (..integrators.pairs: rk45 and dop853 with their default controllers) and the weighted norm
# of the compiled drivers of .fused


@njit
def _joint_stages(t, x, hs, tableau, nodes, K, s0, s1, tmp, t_last, yb, T, F, I, W):
    """Stages s0 .. s1-1 of the joint state: tmp = x + hs sum_j tableau[s, j] K[j],
    K[s] = f(t + nodes[s] hs, tmp) (t_last for the last). False if one failed."""
    n = x.size
    for s in range(s0, s1):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += tableau[s, j] * K[j, i]
            tmp[i] = x[i] + hs * acc
        ts = t_last if s == s1 - 1 else t + nodes[s] * hs
        if not rhs_joint(ts, tmp, K[s], yb, T, F, I, W):
            return False
    return True


@njit
def dopri_joint(t, x, K0, h, err_prev, T, F, I, W, pair, t0, t_out, k_out, rtol, atol,
                max_step, max_steps, X, counters):
    """Up to ``max_steps`` accepted steps of the Dormand-Prince pair ``pair`` (rk45 or
    dop853 with its default controller) of the joint state x from t (FSAL derivative K0,
    proposed step h; h = 0 starts the run: output at t, K0 and Hairer's starting step), every
    output time t_out[k_out:] reached written into X[k] (dense output). Returns
    (status, t, h, err_prev, k_out); call again to continue. counters: (nfev, steps,
    rejected)."""
    kind, tableau, nodes, ctrl = pair
    k_inv, beta, safety, min_factor, max_factor = ctrl[0], ctrl[1], ctrl[2], ctrl[3], ctrl[4]
    S = pair_stages(kind)
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
        h0 = start_first_guess(d0, d1, max_step, span)
        x1 = np.empty(n)
        f1 = np.empty(n)
        for i in range(n):
            x1[i] = x[i] + h0 * K0[i]
        if not rhs_joint(t + h0, x1, f1, yb, T, F, I, W):
            return RHS_FAILED, t, h, err_prev, k_out
        counters[0] += 1
        for i in range(n):
            x1[i] = f1[i] - K0[i]
        h = start_step(h0, d1, _rms(x1, scale) / h0, ctrl[5], max_step, span)
    K = np.empty((tableau.shape[0], n))
    for i in range(n):
        K[0, i] = K0[i]
    x_new = np.empty(n)
    xo = np.empty(n)
    tmp = np.empty(n)
    atol_v = np.full(n, atol)
    coef = np.empty((7, n))
    empty = np.zeros(0)
    alpha = k_inv - 0.75 * beta
    after_reject = False
    steps = 0
    while t < t_end and steps < max_steps:
        h_min = min_step_size(t, span, 0.0)
        while True:
            hs = end_step(t, h, t_end)
            if hs < h_min:
                return UNDERFLOW, t, h, err_prev, k_out
            t_new = t_end if hs == t_end - t else t + hs
            ok = _joint_stages(t, x, hs, tableau, nodes, K, 1, S, tmp, t_new, yb, T, F, I, W)
            counters[0] += S - 1
            if ok:
                for i in range(n):
                    x_new[i] = tmp[i]
                err = pair_error(kind, x, x_new, K, hs, atol_v, rtol)
            else:
                err = math.inf
            if err <= 1.0:
                break
            counters[2] += 1
            h = hs * rejected_factor(err, k_inv, safety, min_factor)
            after_reject = True
        if k_out < nt and t_out[k_out] < t_new:      # an output inside: the dense output
            if kind == DP8:
                if not _joint_stages(t, x, hs, tableau, nodes, K, S, S + 3, tmp,
                                     t + nodes[S + 2] * hs, yb, T, F, I, W):
                    return RHS_FAILED, t, h, err_prev, k_out
                counters[0] += 3
            pair_dense(kind, x, x_new, K, hs, coef)
        quats = tree_views(T).quats              # Euler parameters back to unit length
        for q in range(quats.size):              # (the right-hand side uses p / |p|)
            o = quats[q]
            nrm = math.sqrt(x_new[o] ** 2 + x_new[o + 1] ** 2 + x_new[o + 2] ** 2
                            + x_new[o + 3] ** 2)
            for i in range(4):
                x_new[o + i] /= nrm
        fac, err_prev = pi_factor(err, err_prev, alpha, beta, safety, min_factor, max_factor,
                                  after_reject)
        after_reject = False
        while k_out < nt and t_out[k_out] <= t_new:
            to = t_out[k_out]
            if to == t_new:
                for i in range(n):
                    X[k_out, i] = x_new[i]
            else:
                pair_interpolate(kind, x, hs, coef, (to - t) / hs, empty, xo)
                for i in range(n):
                    X[k_out, i] = xo[i]
            k_out += 1
        for i in range(n):
            x[i] = x_new[i]
            K[0, i] = K[S - 1, i]
        t = t_new
        h = min(hs * fac, max_step)
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
    """Joint coordinates of an open tree (revolute, translational and spherical joints, free
    bodies), accelerations by
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
    coordinates from the assembled state q0, v0, default the model's; :class:`JointTree`)
    and its initial state;
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
        x = np.ascontiguousarray(x, dtype=float)
        xd = np.empty(x.size)
        if not rhs_joint(float(t), x, xd, yb, T, F, I, W):
            raise ModelError(f"t = {t:.6g} s: the accelerations are not finite (an "
                             "articulated inertia is singular)")
        return xd
    return f, tree.x0.copy()
