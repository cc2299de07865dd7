"""Joint coordinates of an open tree (:mod:`.recursive`): the packed tree arrays, the joint
tree built from a model's initial state (:class:`JointTree`), forward kinematics from joint
coordinates to body coordinates, and the standard method's outputs at those states."""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..errors import ModelError
from ..jit import array_view, njit
from ..rotations import A_into, quat_multiply_scalar
from .layout import bare
from .standard import rhs_standard


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
    # the armature J of each joint's coordinate (forces.armature; 0 without), added to its
    # articulated inertia D = H^T I H
    ("armature", "f", ("nj",)),
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
        array_view(Tf, Ti[22], (3, 6)), array_view(Tf, Ti[23], (2, 4)),
        array_view(Tf, Ti[24], (nj,)))


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
        self._armature(model)
        self.quats[:] = [self.qo[t] + (3 if self.kind[t] == FREE else 0)
                         for t in range(nj) if self.kind[t] in (SPHERICAL, FREE)]
        self.nb = nb

    def _armature(self, model):
        """armature[t]: the J of the armatures (forces.armature) on joint t's coordinate."""
        index = {name: t for t, name in enumerate(self.names)}
        for f in model.force_groups:
            if f.name != "armature":
                continue
            for n, joint in enumerate(f.joint_names):
                self.armature[index[joint]] += f.inertia[n]

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
