"""The ``mesh_contact`` force element: a convex shape against a triangle mesh or a height field
(non-convex: a terrain, a bowl, a part; on the ground or on a body), compiled.

Keys: ``body_i`` and ``shape_i``, the mesh: ``{"type": "mesh", "vertices": ..., "faces": ...}``
or ``{"type": "mesh", "file": ..., "scale": ...}`` (:mod:`.mesh_shape`) or ``{"type":
"heightfield", "heights": ..., "size": [Lx, Ly]}`` (:mod:`.heightfield`), with ``center`` and
``axes`` in body i's axes as every shape; ``body_j`` and ``shape_j``, a sphere, capsule, box,
cylinder, ellipsoid or convex shape (the ``contact`` element's dicts); the normal law
``linear`` (``stiffness``, ``damping``) or ``hertz`` (``stiffness``, ``exponent``) and the
friction of :mod:`.laws` (``friction``, ``mu``, ..., ``creep_velocity``; not lugre), as for a
``sphere_set``: the contact points come and go as the shape moves over the triangles, so no
impact velocity or bristle state is kept per point.

The contacts are found at every evaluation (:mod:`.mesh_query`: the triangles near the shape,
the narrow phase per triangle, the manifold merged across triangles by the rule stated there),
and each applies the law at its point P (midway between the surfaces) along its normal, as a
``contact`` element's point does; the first instance carries the element's elastic energy and
dissipated power. Instances: one per triangle (``name[t]``), holding the triangle, its
neighbours and two nodes of the tree in its parameter row; the first runs the query.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...errors import ModelError
from ...jit import njit
from ..base import ForceType, check_body, check_unknown, register
from . import convex_shapes as CS
from . import heightfield as HF
from . import laws as L
from . import mesh_query as MQ
from . import mesh_shape as MS
from . import support as sup
from .element import _err, _vec, law_params, parse_shape
from .sphere_set import _contact

#: columns of :meth:`MeshContact.contacts`
CONTACT_COLUMNS = ("point_x", "point_y", "point_z", "normal_x", "normal_y", "normal_z", "gap")
MESH_KEYS = {"type", "center", "axes", "vertices", "faces", "file", "scale", "mesh", "heights",
             "size"}


@njit
def kernel(S, G, k, g, energy, power, D):
    """Instance k: nothing unless it is the element's first; the first finds the contacts of
    the shape with the mesh and applies the law at each."""
    energy[k] = 0.0
    power[k] = 0.0
    if G.param[k, MS.C_FIRST] != 0.0:
        return
    C, keep, nk = MQ.collect(S, G, k)
    r = G.param[k, MS.C_SIDE + sup.S_RADIUS]
    E, W = 0.0, 0.0
    for m in range(nk):
        c = keep[m]
        n = (C[c, 6], C[c, 7], C[c, 8])
        P = (0.5 * (C[c, 0] + C[c, 3] - r * n[0]), 0.5 * (C[c, 1] + C[c, 4] - r * n[1]),
             0.5 * (C[c, 2] + C[c, 5] - r * n[2]))
        e, p = _contact(S, G, k, G.bi[k], G.bj[k], P, n, -C[c, 9], g)
        E += e
        W += p
    energy[k] = E
    power[k] = W


@njit
def contact_rows(S, G, k, out):
    """The contacts of the element whose first row is k into out (rows of CONTACT_COLUMNS);
    returns their number (at most out's rows are written)."""
    C, keep, nk = MQ.collect(S, G, k)
    r = G.param[k, MS.C_SIDE + sup.S_RADIUS]
    for m in range(min(nk, out.shape[0])):
        c = keep[m]
        for a in range(3):
            out[m, a] = 0.5 * (C[c, a] + C[c, 3 + a] - r * C[c, 6 + a])
            out[m, 3 + a] = C[c, 6 + a]
        out[m, 6] = C[c, 9]
    return nk


def parse_mesh_shape(name, shape, builder, body):
    """(centre (3,), axes (3, 3), vertices, faces, neighbours, grid or None) of shape_i."""
    key = f"forces[{name!r}].shape_i"
    if not isinstance(shape, dict) or shape.get("type") not in ("mesh", "heightfield"):
        raise ModelError(f"{key}: expected a mesh {{type: mesh, vertices, faces}} (or file) or "
                         f"a height field {{type: heightfield, heights, size}}, got {shape!r:.80}")
    extra = set(shape) - MESH_KEYS
    if extra:
        raise ModelError(f"{key}: unknown key(s) {sorted(extra)}; allowed: {sorted(MESH_KEYS)}")
    where = shape.get("center")
    if isinstance(where, str):
        pts = {} if body == "ground" else builder.bodies[body].points
        if where not in pts:
            raise ModelError(f"{key}.center: body {body!r} has no point named {where!r}")
        centre = np.array(pts[where], dtype=float)
    else:
        centre = _vec(name, "shape_i.center", where, (0.0, 0.0, 0.0))
    axes = np.eye(3)
    if shape.get("axes") is not None:
        axes = np.array(shape["axes"], dtype=float).reshape(3, 3)
        if not np.allclose(axes.T @ axes, np.eye(3), atol=1e-9) or np.linalg.det(axes) < 0:
            raise ModelError(f"{key}.axes: must be a 3x3 rotation matrix (shape -> body axes)")
    if shape["type"] == "heightfield":
        V, F, nb, grid = HF.parse_heightfield(shape, key)
        return centre, axes, V, F, nb, grid
    V, F, nb = MS.parse_mesh(shape, key)
    return centre, axes, V, F, nb, None


@register
class MeshContact(ForceType):
    """A convex shape against a triangle mesh or a height field (a terrain, a bowl): the
    triangles found through a tree or the grid, contacts merged across triangles."""

    name = "mesh_contact"
    kernel = staticmethod(kernel)
    n_param = MS.N_COLUMNS
    required = ("body_i", "body_j", "shape_i", "shape_j", "stiffness")
    parameters = {"body_i": "body", "body_j": "body", "shape_i": "any", "shape_j": "any",
                  "law": "string", "stiffness": "number", "exponent": "number",
                  "damping": "number", "friction": "string", "mu": "number",
                  "mu_static": "number", "mu_dynamic": "number",
                  "stribeck_velocity": "number", "creep_velocity": "number",
                  "viscous": "number"}

    def __init__(self, names, element, bi, bj, s_i, s_j, R_i, R_j, param, size):
        super().__init__(names)
        self.element = list(element)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.s_i, self.s_j = np.asarray(s_i, float), np.asarray(s_j, float)
        self.R_i, self.R_j = np.asarray(R_i, float), np.asarray(R_j, float)
        self.param = np.asarray(param, dtype=float).reshape(-1, MS.N_COLUMNS)
        self.size = np.asarray(size, dtype=float)

    @classmethod
    def validate(cls, spec, builder):
        cls._rows(spec, builder)

    @classmethod
    def _rows(cls, spec, builder):
        """(body i, body j, mesh centre, mesh axes, shape centre, shape axes, rows, shape
        size) of one element (checked)."""
        check_unknown(spec, cls.allowed)
        name, p = spec.name, spec.params
        bodies = [check_body(spec, builder, key, ground_ok=True) for key in ("body_i", "body_j")]
        if bodies[0] == bodies[1]:
            raise ModelError(f"forces[{name!r}]: both shapes are on body {bodies[0]!r}")
        for b in bodies:
            if b != "ground" and not builder.bodies[b].mass > 0:
                raise ModelError(f"forces[{name!r}]: body {b!r} has no mass; a contact shape "
                                 "needs a body with mass (or the ground)")
        ci, Ai, V, F, nb, grid = parse_mesh_shape(name, p.get("shape_i"), builder, bodies[0])
        kind, cj, Aj, rad, hl, half, verts = parse_shape(name, "shape_j", p.get("shape_j"),
                                                         builder, bodies[1])
        if kind not in CS.CONVEX_KINDS:
            kinds = ", ".join(CS.CONVEX_KINDS)
            raise _err(name, "shape_j.type", f"a mesh touches a convex shape ({kinds}), not a "
                                             f"{kind}")
        law = p.get("law", "linear")
        if law not in ("linear", "hertz"):
            raise _err(name, "law", f"a mesh contact takes the law 'linear' (with damping) or "
                                    f"'hertz', not {law!r}: its contact points come and go "
                                    "over the triangles, so no impact velocity is kept")
        if p.get("friction") == "lugre":
            raise _err(name, "friction", "the lugre law keeps a bristle state per contact "
                                         "point, and a mesh's points come and go: use coulomb "
                                         "or stribeck")
        law_row = law_params(dataclasses.replace(spec, params=dict(p, law=law)), (0.0, 0.0),
                              ("sphere", "sphere"))
        nodes = MS.build_bvh(V, F) if grid is None else None
        rows = MS.mesh_rows(V, F, nb, nodes, grid)
        rows[:, L.C_LAW:L.N_COLUMNS] = law_row
        rows[0, MS.C_SIDE:MS.C_SIDE + sup.SIDE_WIDTH] = CS.side_block(kind, rad, hl, half, verts)
        size = CS.size(kind, rad, hl, half, verts)
        return bodies[0], bodies[1], ci, Ai, cj, Aj, rows, size

    @classmethod
    def build(cls, specs, ctx):
        cols = ([] for _ in range(10))
        names, element, bi, bj, s_i, s_j, R_i, R_j, param, size = cols
        for spec in specs:
            b1, b2, c1, A1, c2, A2, rows, sz = cls._rows(spec, ctx.builder)
            for t, row in enumerate(rows):
                names.append(f"{spec.name}[{t}]")
                element.append(spec.name)
                bi.append(ctx.index[b1])
                bj.append(ctx.index[b2])
                s_i.append(c1)
                s_j.append(c2)
                R_i.append(A1)
                R_j.append(A2)
                param.append(row)
                size.append(sz)
        group = cls(names, element, bi, bj, s_i, s_j, R_i, R_j, param, size)
        group._check_initial(ctx)
        return group

    def _firsts(self):
        return np.flatnonzero(self.param[:, MS.C_FIRST] == 0.0)

    def _check_initial(self, ctx):
        """Deep interpenetration at the initial configuration (more than half the shape's
        smallest size: the contact normal is meaningless there) is an error, as for
        ``contact``."""
        from ...state import BodyState
        q = np.zeros((ctx.nb, 7))
        for name, b in ctx.index.items():
            if name != "ground" and b < ctx.nb:
                spec = ctx.builder.bodies[name]
                q[b, :3], q[b, 3:] = spec.r, spec.p
        state = BodyState.from_qv(q, None)
        for k in self._firsts():
            c = self.contacts(state, k)
            if c.shape[0] and -c[:, 6].min() > 0.5 * self.size[k]:
                raise ModelError(f"forces[{self.element[k]!r}]: the shape is {-c[:, 6].min():.4g}"
                                 f" m into the mesh at the initial configuration (more than "
                                 f"half its size {self.size[k]:.4g} m); move the bodies apart")

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, s_i=self.s_i, s_j=self.s_j, R_i=self.R_i,
                    R_j=self.R_j, param=self.param)

    def contacts(self, state, first=0) -> np.ndarray:
        """(m, len(CONTACT_COLUMNS)) the merged contacts (point, normal, gap; gap < 0 in
        contact) of the element whose first instance is ``first``, at ``state``."""
        from ..kernels import ForceTable
        G = ForceTable([self], only_compiled=False).G
        out = np.zeros((64, len(CONTACT_COLUMNS)))
        n = contact_rows(state.arrays(), G, int(first), out)
        if n > out.shape[0]:
            out = np.zeros((n, len(CONTACT_COLUMNS)))
            n = contact_rows(state.arrays(), G, int(first), out)
        return out[:n].copy()
