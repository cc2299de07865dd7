"""The ``shape_set`` force element: many convex shapes (spheres, capsules, boxes, cylinders,
ellipsoids, convex hulls) on many bodies colliding with each other and with fixed walls, the
pairs found at every evaluation by the broad phase (:mod:`spatialmbd.broadphase`), so the cost
per evaluation grows linearly with the number of shapes -- what ``contact`` elements declared
for every pair (N (N - 1) / 2 of them, each tested at every evaluation) cannot do.

One element holds N shapes: ``bodies`` (a list; a body may appear more than once, for a body
made of several shapes, and ``ground`` stands for fixed obstacles: a ramp, a bin's floor as a
box), with ``shape`` (one shape dict for all) or ``shapes`` (one per entry), written as for
``contact`` (:mod:`.element`: ``center``, ``axes`` or ``axis`` in the body's axes); and up to
:data:`MAX_WALLS` walls, planes fixed in global axes (``walls``: ``{"normal": n, "point": p}``,
the normal pointing into the free space). Shapes on the same body do not touch each other.

Every touching pair gets the contact points of the ``contact`` element for the same two shapes
-- sphere and capsule pairs in closed form (.geometry's segments), every other pair by its
narrow phase and face manifold (:func:`.manifold.manifold_points`: box-box by separating axes,
the rest by GJK/EPA; up to four points where faces touch, found once per pair, not once per
point) -- and every shape under a wall the plane's contact points (a box's eight vertices, a
hull's vertices, a capsule's two ends, a cylinder's three rim points per cap, an ellipsoid's
deepest point). Each point gets the normal law and the friction of :mod:`.laws` with the
element's parameters (``law`` linear or hertz, ``stiffness`` per contact point, ``exponent``,
``damping``, ``friction``, ``mu`` ..., ``creep_velocity``, ``margin``). The forces, the elastic
energy and the dissipated power equal those of ``contact`` elements declared for every pair
and wall (tested to round-off).

Broad phase: each shape is bounded by a sphere about its centre (radius: the farthest point of
the shape, fixed for the shape: no update per evaluation); the bounding spheres of the shapes
on moving bodies go to the grid of :func:`spatialmbd.broadphase._pairs_grid` (linear in N for
shapes of comparable size: its cells are as large as the largest shape); each shape on the
ground is tested against every moving one (there are few of them, and they may be large).

As for ``sphere_set``, the pairs change as the run goes, so the hysteresis laws (which need
each touch's impact velocity) and LuGre friction (a bristle state per contact) are not
available here. The element is compiled: its first instance runs the broad phase and every
pair; the others (one per shape, for the outputs' names) do nothing.
"""
from __future__ import annotations

import math

import numpy as np

from ...broadphase import _pairs_grid
from ...constraints.primitives import v_add, v_dot, v_scale, v_sub
from ...errors import ModelError
from ...jit import njit
from ..base import ForceType, check_unknown, register
from . import convex_shapes as CS
from . import laws as L
from . import manifold as MF
from . import plane_convex as PC
from . import support as sup
from .element import _err, _number, parse_shape
from .geometry import segment_closest
from .sphere_set import _contact, set_law, wall_columns

#: walls an element may have (a box: 6)
MAX_WALLS = 6
#: shape types a set takes (the convex ones)
SET_SHAPES = ("sphere", "capsule", "box", "cylinder", "ellipsoid", "convex")
SW = sup.SIDE_WIDTH
# parameter columns after the laws' (.laws): offset to the element's first instance, the number
# of shapes, this shape's bounding radius, the margin, the number of walls, this shape's core
# (.support's side block), then (n, p) per wall (first instance only)
C_FIRST, C_COUNT, C_BOUND, C_MARGIN, C_NWALLS = (L.N_COLUMNS + k for k in range(5))
C_BLOCK = L.N_COLUMNS + 5
C_WALLS = C_BLOCK + SW
N_COLUMNS = C_WALLS + 6 * MAX_WALLS
#: contact points one shape may have under a wall: a hull's vertices (a box: 8, a cylinder: 6)
MAX_WALL_POINTS = max(8, sup.MAX_HULL_VERTICES)


@njit(inline="always")
def _frame(F, a):
    return ((F[a, 0, 0], F[a, 0, 1], F[a, 0, 2]), (F[a, 1, 0], F[a, 1, 1], F[a, 1, 2]),
            (F[a, 2, 0], F[a, 2, 1], F[a, 2, 2]), (F[a, 3, 0], F[a, 3, 1], F[a, 3, 2]))


@njit(inline="always")
def _put(out, m, P, n, delta):
    """Row m of a contact-point table: (P, n, penetration delta)."""
    for c in range(3):
        out[m, c], out[m, 3 + c] = P[c], n[c]
    out[m, 6] = delta


@njit
def pair_points(Pp, fi, fj, margin, Q, out):
    """Contact points of the two cores Pp[0:SW] (frame fi) and Pp[SW:2 SW] (frame fj) into out
    (MAX_SLOTS, 7): rows (P, n from i to j, penetration delta > 0); returns their number. Q: a
    (MAX_SLOTS, 9) work array."""
    ki, kj = int(Pp[sup.S_KIND]), int(Pp[SW + sup.S_KIND])
    ri, rj = Pp[sup.S_RADIUS], Pp[SW + sup.S_RADIUS]
    # the line of centres as a separating axis: two support points (cheap) reject most of
    # the broad phase's candidates that do not touch before the narrow phase runs
    d, dist = sup.unit(v_sub(fj[0], fi[0]))
    if dist > 0.0:
        reach_i = v_dot(d, sup.support(Pp, 0, fi, d)) + ri
        reach_j = v_dot(d, sup.support(Pp, SW, fj, v_scale(-1.0, d))) - rj
        if reach_j - reach_i > margin:
            return 0
    if ki <= sup.SEGMENT and kj <= sup.SEGMENT:        # spheres and capsules: closed form
        ai = v_scale(Pp[sup.S_D2], fi[3])
        aj = v_scale(Pp[SW + sup.S_D2], fj[3])
        p1, p2 = v_sub(fi[0], ai), v_sub(fj[0], aj)
        s, t = segment_closest(p1, v_scale(2.0, ai), p2, v_scale(2.0, aj))
        qi = v_add(p1, v_scale(2.0 * s, ai))
        qj = v_add(p2, v_scale(2.0 * t, aj))
        n, _ = sup.unit(v_sub(qj, qi))
        for c in range(3):
            Q[0, c], Q[0, 3 + c], Q[0, 6 + c] = qi[c], qj[c], n[c]
        count = 1
    else:
        count = MF.manifold_points(Pp, 0, fi, SW, fj, Q)
    m = 0
    for s in range(count):
        qi = (Q[s, 0], Q[s, 1], Q[s, 2])
        qj = (Q[s, 3], Q[s, 4], Q[s, 5])
        n = (Q[s, 6], Q[s, 7], Q[s, 8])
        gap = v_dot(n, v_sub(qj, qi)) - ri - rj - margin
        if gap < 0.0:
            _put(out, m, v_scale(0.5, v_add(v_add(qi, v_scale(ri, n)),
                                            v_sub(qj, v_scale(rj, n)))), n, -gap)
            m += 1
    return m


@njit
def wall_points(B, o, f, nw, pw, margin, out):
    """Contact points of the core B[o:o + SW] (frame f) under the plane (outward normal nw,
    point pw) into out (MAX_WALL_POINTS, 7): rows (P, nw, delta > 0); returns their number.
    The points are those of the ``contact`` element's plane pairs (module docstring)."""
    kind = int(B[o + sup.S_KIND])
    r = B[o + sup.S_RADIUS]
    m = 0
    for s in range(MAX_WALL_POINTS):
        if kind == sup.POINT:
            if s > 0:
                break
            p = f[0]
        elif kind == sup.SEGMENT:
            if s > 1:
                break
            p = v_add(f[0], v_scale((1.0 if s == 0 else -1.0) * B[o + sup.S_D2], f[3]))
        elif kind == sup.BOX:
            if s > 7:
                break
            x = ((1.0 if s & 1 else -1.0) * B[o + sup.S_D0],
                 (1.0 if s & 2 else -1.0) * B[o + sup.S_D1],
                 (1.0 if s & 4 else -1.0) * B[o + sup.S_D2])
            p = sup.to_global(f, x)
        elif kind == sup.HULL:
            if s >= int(B[o + sup.S_NV]):
                break
            v = o + sup.S_VERTS + 3 * s
            p = sup.to_global(f, (B[v], B[v + 1], B[v + 2]))
        elif kind == sup.CYLINDER:
            if s >= 2 * PC.RIM:
                break
            p = PC.plane_core_points(B, o, (pw, nw, nw, nw), f, s)[1]
        else:                                           # ellipsoid: the deepest point
            if s > 0:
                break
            p = sup.support(B, o, f, v_scale(-1.0, nw))
        h = v_dot(nw, v_sub(p, pw))
        gap = h - r - margin
        if gap < 0.0:
            _put(out, m, v_scale(0.5, v_add(v_sub(p, v_scale(h, nw)), v_sub(p, v_scale(r, nw)))),
                 nw, -gap)
            m += 1
    return m


@njit
def _apply(S, G, k, g, bi, bj, pts, count):
    E, W = 0.0, 0.0
    for m in range(count):
        e, p = _contact(S, G, k, bi, bj, (pts[m, 0], pts[m, 1], pts[m, 2]),
                        (pts[m, 3], pts[m, 4], pts[m, 5]), pts[m, 6], g)
        E += e
        W += p
    return E, W


@njit
def _pair(S, G, k, g, a, b, F, Pp, Q, pts, margin):
    """Contacts of shapes a and b (instance offsets from k) applied; (energy, power)."""
    for c in range(SW):
        Pp[c] = G.param[k + a, C_BLOCK + c]
        Pp[SW + c] = G.param[k + b, C_BLOCK + c]
    count = pair_points(Pp, _frame(F, a), _frame(F, b), margin, Q, pts)
    return _apply(S, G, k, g, G.bi[k + a], G.bi[k + b], pts, count)


@njit
def kernel(S, G, k, g, energy, power, D):
    """Instance k: nothing unless it is the element's first; the first finds the pairs by the
    broad phase and applies every shape-shape and shape-wall contact."""
    energy[k] = 0.0
    power[k] = 0.0
    if G.param[k, C_FIRST] != 0.0:
        return
    N = int(G.param[k, C_COUNT])
    margin = G.param[k, C_MARGIN]
    ground = S[0].shape[0] - 1
    F = np.empty((N, 4, 3))
    nmov = 0
    for a in range(N):
        f = sup.frame(S, G.bi[k + a], G.s_i, G.R_i, k + a)
        for r in range(4):
            for c in range(3):
                F[a, r, c] = f[r][c]
        if G.bi[k + a] != ground:
            nmov += 1
    mov = np.empty(nmov, np.int64)
    fixed = np.empty(N - nmov, np.int64)
    centre = np.empty((nmov, 3))
    radius = np.empty(nmov)
    im = ifx = 0
    for a in range(N):
        if G.bi[k + a] != ground:
            mov[im] = a
            for c in range(3):
                centre[im, c] = F[a, 0, c]
            radius[im] = G.param[k + a, C_BOUND]
            im += 1
        else:
            fixed[ifx] = a
            ifx += 1
    Pp = np.empty(2 * SW)
    Q = np.empty((MF.MAX_SLOTS, 9))
    pts = np.empty((MAX_WALL_POINTS, 7))
    E, W = 0.0, 0.0
    # moving shapes with each other: the grid's candidates (bounding spheres within margin)
    start = np.empty(4 * nmov + 1, np.int64)
    order = np.empty(nmov, np.int64)
    cell = np.empty((nmov, 3), np.int64)
    pairs = np.empty((6 * nmov + 16, 2), np.int64)
    count = _pairs_grid(centre, radius, margin, pairs, start, order, cell)
    if count > pairs.shape[0]:
        pairs = np.empty((count, 2), np.int64)
        count = _pairs_grid(centre, radius, margin, pairs, start, order, cell)
    for q in range(count):
        a, b = mov[pairs[q, 0]], mov[pairs[q, 1]]
        if G.bi[k + a] == G.bi[k + b]:
            continue
        e, p = _pair(S, G, k, g, a, b, F, Pp, Q, pts, margin)
        E += e
        W += p
    # shapes on the ground with every moving shape (bounding spheres first)
    for i in range(fixed.size):
        a = fixed[i]
        for j in range(nmov):
            b = mov[j]
            d0 = F[b, 0, 0] - F[a, 0, 0]
            d1 = F[b, 0, 1] - F[a, 0, 1]
            d2 = F[b, 0, 2] - F[a, 0, 2]
            reach = G.param[k + a, C_BOUND] + G.param[k + b, C_BOUND] + margin
            if d0 * d0 + d1 * d1 + d2 * d2 > reach * reach:
                continue
            e, p = _pair(S, G, k, g, a, b, F, Pp, Q, pts, margin)
            E += e
            W += p
    # walls with every moving shape
    for w in range(int(G.param[k, C_NWALLS])):
        o = C_WALLS + 6 * w
        nw = (G.param[k, o], G.param[k, o + 1], G.param[k, o + 2])
        pw = (G.param[k, o + 3], G.param[k, o + 4], G.param[k, o + 5])
        for j in range(nmov):
            b = mov[j]
            h = nw[0] * (F[b, 0, 0] - pw[0]) + nw[1] * (F[b, 0, 1] - pw[1]) + \
                nw[2] * (F[b, 0, 2] - pw[2])
            if h > G.param[k + b, C_BOUND] + margin:
                continue
            n = wall_points(G.param[k + b], C_BLOCK, _frame(F, b), nw, pw, margin, pts)
            e, p = _apply(S, G, k, g, ground, G.bi[k + b], pts, n)
            E += e
            W += p
    energy[k] = E
    power[k] = W


def bounding_radius(kind, radius, half_length, half, verts) -> float:
    """Radius (m) of the smallest sphere about the shape's centre that holds the shape."""
    if kind == "sphere":
        return radius
    if kind == "capsule":
        return half_length + radius
    if kind == "cylinder":
        return math.hypot(half[0], half[2])
    if kind == "ellipsoid":
        return float(half.max())
    if kind == "convex":
        return float(np.linalg.norm(verts, axis=1).max())
    return float(np.linalg.norm(half))


@register
class ShapeSet(ForceType):
    """Many convex shapes on many bodies colliding with each other and with walls (planes),
    the pairs found by a broad phase: linear in the number of shapes."""

    name = "shape_set"
    kernel = staticmethod(kernel)
    n_param = N_COLUMNS
    required = ("bodies", "stiffness")
    parameters = {"bodies": "any", "shape": "any", "shapes": "any", "walls": "any",
                  "law": "string", "stiffness": "number", "exponent": "number",
                  "damping": "number", "friction": "string", "mu": "number",
                  "mu_static": "number", "mu_dynamic": "number",
                  "stribeck_velocity": "number", "creep_velocity": "number",
                  "viscous": "number", "margin": "number"}

    def __init__(self, names, element, bi, s_i, R_i, param, size):
        super().__init__(names)
        self.element = list(element)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.s_i = np.asarray(s_i, dtype=float).reshape(-1, 3)
        self.R_i = np.asarray(R_i, dtype=float).reshape(-1, 3, 3)
        self.param = np.asarray(param, dtype=float).reshape(-1, N_COLUMNS)
        self.size = np.asarray(size, dtype=float)

    @classmethod
    def validate(cls, spec, builder):
        cls._rows(spec, builder)

    @classmethod
    def _rows(cls, spec, builder):
        """(body names, centres (N, 3), axes (N, 3, 3), param rows (N, N_COLUMNS), sizes (N,))
        of one element (checked)."""
        check_unknown(spec, cls.allowed)
        name, p = spec.name, spec.params
        bodies = p.get("bodies")
        if isinstance(bodies, (str, bytes)) or not hasattr(bodies, "__len__") or \
                len(bodies) < 1:
            raise _err(name, "bodies", f"expected a list of body names, got {bodies!r}")
        bodies = list(bodies)
        for m, b in enumerate(bodies):
            if not isinstance(b, str) or (b != "ground" and b not in builder.bodies):
                raise _err(name, f"bodies[{m}]", f"no body named {b!r} (bodies: "
                                                 f"{', '.join(builder.bodies) or 'none'}, "
                                                 "or ground)")
            if b != "ground" and not builder.bodies[b].mass > 0:
                raise _err(name, f"bodies[{m}]", f"body {b!r} has no mass; a contact shape "
                                                 "needs a body with mass (or the ground)")
        if ("shape" in p) == ("shapes" in p):
            raise _err(name, "shape", "give either 'shape' (one shape for every body) or "
                                      "'shapes' (one per body)")
        if "shapes" in p:
            shapes = p["shapes"]
            if isinstance(shapes, dict) or not isinstance(shapes, (list, tuple)) or \
                    len(shapes) != len(bodies):
                raise _err(name, "shapes", f"expected a list of {len(bodies)} shape dicts "
                                           f"(one per body), got {shapes!r:.200}")
            keys = [f"shapes[{m}]" for m in range(len(bodies))]
        else:
            shapes, keys = [p["shape"]] * len(bodies), ["shape"] * len(bodies)
        parsed = []
        for m, (b, shape, key) in enumerate(zip(bodies, shapes, keys)):
            if isinstance(shape, dict) and shape.get("type") not in SET_SHAPES and \
                    shape.get("type") is not None:
                raise _err(name, f"{key}.type", f"a shape set holds convex shapes "
                                                f"({', '.join(SET_SHAPES)}), not "
                                                f"{shape.get('type')!r}; give planes as "
                                                "'walls'")
            parsed.append(parse_shape(name, key, shape, builder, b))
        walls = p.get("walls") or []
        wall_cols = wall_columns(name, walls)
        law_row = set_law(spec, "a shape set", ("box", "box"))
        margin = _number(name, "margin", p.get("margin", 0.0), 0.0)
        rows = np.zeros((len(bodies), N_COLUMNS))
        rows[:, L.C_LAW:L.N_COLUMNS] = law_row
        rows[:, C_FIRST] = np.arange(len(bodies))
        rows[:, C_COUNT] = len(bodies)
        rows[:, C_MARGIN] = margin
        centres, axes, sizes = [], [], []
        for m, (kind, c, A, rad, hl, half, verts) in enumerate(parsed):
            rows[m, C_BLOCK:C_BLOCK + SW] = CS.side_block(kind, rad, hl, half, verts)
            rows[m, C_BOUND] = bounding_radius(kind, rad, hl, half, verts)
            centres.append(c)
            axes.append(A)
            sizes.append(CS.size(kind, rad, hl, half, verts))
        rows[0, C_NWALLS] = len(walls)
        rows[0, C_WALLS:C_WALLS + len(wall_cols)] = wall_cols
        return bodies, np.array(centres), np.array(axes), rows, np.array(sizes)

    @classmethod
    def build(cls, specs, ctx):
        names, element, bi, s_i, R_i, param, size = ([] for _ in range(7))
        for spec in specs:
            bodies, centres, axes, rows, sizes = cls._rows(spec, ctx.builder)
            seen: dict = {}
            for b in bodies:
                seen[b] = seen.get(b, 0) + 1
                label = b if bodies.count(b) == 1 else f"{b}#{seen[b]}"
                names.append(f"{spec.name}[{label}]")
                element.append(spec.name)
                bi.append(ctx.index[b])
            s_i += list(centres)
            R_i += list(axes)
            param += list(rows)
            size += list(sizes)
        group = cls(names, element, bi, s_i, R_i, param, size)
        group._check_initial(ctx)
        return group

    def _check_initial(self, ctx):
        """Deep interpenetration at the initial configuration (more than half the smaller
        shape's size: the contact normal is meaningless there) is an error, as for
        ``contact``."""
        from ...broadphase import sphere_pairs
        from ...rotations import A_from_p
        spec = {ctx.index[n]: b for n, b in ctx.builder.bodies.items()}
        r = np.array([spec[b].r if b in spec else (0.0, 0.0, 0.0) for b in self.bi], float)
        A = A_from_p(np.array([spec[b].p if b in spec else (1.0, 0.0, 0.0, 0.0)
                               for b in self.bi], float))
        c = r + np.einsum("nij,nj->ni", A, self.s_i)
        E = np.einsum("nij,njk->nik", A, self.R_i)
        frames = [(tuple(c[a]), tuple(E[a][:, 0]), tuple(E[a][:, 1]), tuple(E[a][:, 2]))
                  for a in range(self.n)]
        Pp = np.empty(2 * SW)
        Q = np.empty((MF.MAX_SLOTS, 9))
        pts = np.empty((MAX_WALL_POINTS, 7))
        first = 0
        while first < self.n:
            count = int(self.param[first, C_COUNT])
            sl = slice(first, first + count)
            bound = self.param[sl, C_BOUND]
            for a, b in sphere_pairs(c[sl], bound) + first:
                if self.bi[a] == self.bi[b]:
                    continue
                Pp[:SW] = self.param[a, C_BLOCK:C_BLOCK + SW]
                Pp[SW:] = self.param[b, C_BLOCK:C_BLOCK + SW]
                m = pair_points(Pp, frames[a], frames[b], 0.0, Q, pts)
                depth = pts[:m, 6].max(initial=0.0)
                if depth > 0.5 * min(self.size[a], self.size[b]):
                    raise ModelError(f"forces[{self.element[a]!r}]: shapes {self.names[a]!r} "
                                     f"and {self.names[b]!r} interpenetrate by {depth:.4g} m "
                                     "at the initial configuration (more than half the "
                                     "smaller shape's size); move the bodies apart")
            row = self.param[first]
            for w in range(int(row[C_NWALLS])):
                o = C_WALLS + 6 * w
                nw, pw = tuple(row[o:o + 3]), tuple(row[o + 3:o + 6])
                for a in range(first, first + count):
                    if self.bi[a] == ctx.index["ground"]:
                        continue
                    m = wall_points(self.param[a], C_BLOCK, frames[a], nw, pw, 0.0, pts)
                    depth = pts[:m, 6].max(initial=0.0)
                    if depth > 0.5 * self.size[a]:
                        raise ModelError(f"forces[{self.element[a]!r}].walls[{w}]: shape "
                                         f"{self.names[a]!r} is {depth:.4g} m into the wall "
                                         "at the initial configuration (more than half its "
                                         "size); move it out")
            first += count

    def columns(self):
        return dict(bi=self.bi, bj=self.bi, s_i=self.s_i, R_i=self.R_i, param=self.param)
