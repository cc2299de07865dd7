"""The ``sphere_set`` force element: many spheres on many bodies colliding with each other and
with fixed walls, the pairs found at every evaluation by the broad phase
(:mod:`spatialmbd.broadphase`), so the cost per evaluation is linear in the number of spheres.

One element holds N spheres, one per body (``bodies``; ``radius`` one value or one per body;
``center`` the sphere centre in body axes, default the centre of mass) and up to
:data:`MAX_WALLS` walls, planes fixed in global axes (``walls``: ``{"normal": n, "point": p}``,
the normal pointing into the free space). Every sphere-sphere pair and every sphere-wall pair
in contact gets the normal law and the friction of :mod:`.laws` with the element's parameters
(the ``contact`` element's names: ``law`` linear or hertz, ``stiffness``, ``exponent``,
``damping``, ``friction``, ``mu`` ..., ``creep_velocity``), at the contact point:

    sphere a, sphere b:  n = (c_b - c_a) / |c_b - c_a|,  delta = r_a + r_b - |c_b - c_a|,
                         P = c_a + (r_a - delta / 2) n
    sphere a, wall w:    delta = r_a - n_w^T (c_a - p_w),  P = c_a - (r_a - delta / 2) n_w

with the relative velocity of the two material points at P giving delta' and the slip. The
forces, the elastic energy and the dissipated power are the same as those of ``contact``
elements declared for every pair (tested to round-off).

The pairs change as the run goes, so a law that needs the impact velocity of each touch (the
hysteresis laws) is not available here: use ``linear`` with ``damping`` (Kelvin-Voigt, the
law of granular codes) or ``hertz``. The element is compiled: its first instance runs the
broad phase and every pair; the others (one per sphere, for the outputs' names) do nothing.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...broadphase import _pairs_grid
from ...errors import ModelError
from ...jit import njit
from ..base import ForceType, check_unknown, register
from ..kernel_tools import add_wrench
from . import laws as L
from .element import _err, law_params, _number, _vec

#: walls an element may have (a box: 6)
MAX_WALLS = 6
# parameter columns after the laws' (see .laws): offset to the element's first instance, the
# number of spheres, this sphere's radius, the number of walls, then (n, p) per wall
C_FIRST, C_COUNT, C_RADIUS, C_NWALLS, C_WALLS = (L.N_COLUMNS + k for k in range(5))
N_COLUMNS = C_WALLS + 6 * MAX_WALLS


@njit
def _contact(S, G, k, bi, bj, P, n, delta, g):
    """Normal and friction force at P along n (from side i to side j) with penetration delta:
    applied to both bodies; returns (elastic energy, dissipated power)."""
    r, rdot, omega = S[0], S[2], S[3]
    ai = (P[0] - r[bi, 0], P[1] - r[bi, 1], P[2] - r[bi, 2])
    aj = (P[0] - r[bj, 0], P[1] - r[bj, 1], P[2] - r[bj, 2])
    vi0 = rdot[bi, 0] + omega[bi, 1] * ai[2] - omega[bi, 2] * ai[1]
    vi1 = rdot[bi, 1] + omega[bi, 2] * ai[0] - omega[bi, 0] * ai[2]
    vi2 = rdot[bi, 2] + omega[bi, 0] * ai[1] - omega[bi, 1] * ai[0]
    vj0 = rdot[bj, 0] + omega[bj, 1] * aj[2] - omega[bj, 2] * aj[1]
    vj1 = rdot[bj, 1] + omega[bj, 2] * aj[0] - omega[bj, 0] * aj[2]
    vj2 = rdot[bj, 2] + omega[bj, 0] * aj[1] - omega[bj, 1] * aj[0]
    w0, w1, w2 = vj0 - vi0, vj1 - vi1, vj2 - vi2                   # v_P,j - v_P,i
    gd = w0 * n[0] + w1 * n[1] + w2 * n[2]                          # gap rate
    t0, t1, t2 = w0 - gd * n[0], w1 - gd * n[1], w2 - gd * n[2]     # slip
    fN, el, energy = L.normal_force(G.param, k, delta, -gd, 0.0)
    s = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    a, cv = L.friction_factor(G.param, k, fN, s)
    c = -(a + cv)
    F0, F1, F2 = fN * n[0] + c * t0, fN * n[1] + c * t1, fN * n[2] + c * t2   # on body j
    add_wrench(g, bj, F0, F1, F2, aj[1] * F2 - aj[2] * F1, aj[2] * F0 - aj[0] * F2,
               aj[0] * F1 - aj[1] * F0)
    add_wrench(g, bi, -F0, -F1, -F2, -(ai[1] * F2 - ai[2] * F1), -(ai[2] * F0 - ai[0] * F2),
               -(ai[0] * F1 - ai[1] * F0))
    return energy, (fN - el) * gd + c * (t0 * t0 + t1 * t1 + t2 * t2)


@njit
def kernel(S, G, k, g, energy, power, D):
    """Instance k: nothing unless it is the element's first; the first finds the pairs by the
    broad phase and applies every sphere-sphere and sphere-wall contact."""
    energy[k] = 0.0
    power[k] = 0.0
    if G.param[k, C_FIRST] != 0.0:
        return
    N = int(G.param[k, C_COUNT])
    r_, A = S[0], S[1]
    centre = np.empty((N, 3))
    radius = np.empty(N)
    for a in range(N):
        m = k + a
        b = G.bi[m]
        for x in range(3):
            centre[a, x] = r_[b, x] + A[b, x, 0] * G.s_i[m, 0] + A[b, x, 1] * G.s_i[m, 1] + \
                A[b, x, 2] * G.s_i[m, 2]
        radius[a] = G.param[m, C_RADIUS]
    ground = S[0].shape[0] - 1
    E, W = 0.0, 0.0
    # sphere-sphere: the broad phase's candidates (exact distance test inside)
    start = np.empty(4 * N + 1, np.int64)
    order = np.empty(N, np.int64)
    cell = np.empty((N, 3), np.int64)
    pairs = np.empty((6 * N + 16, 2), np.int64)
    count = _pairs_grid(centre, radius, 0.0, pairs, start, order, cell)
    if count > pairs.shape[0]:
        pairs = np.empty((count, 2), np.int64)
        count = _pairs_grid(centre, radius, 0.0, pairs, start, order, cell)
    for q in range(count):
        a, b = pairs[q, 0], pairs[q, 1]
        d0 = centre[b, 0] - centre[a, 0]
        d1 = centre[b, 1] - centre[a, 1]
        d2 = centre[b, 2] - centre[a, 2]
        dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        delta = radius[a] + radius[b] - dist
        if delta <= 0.0 or dist == 0.0:
            continue
        n = (d0 / dist, d1 / dist, d2 / dist)
        h = radius[a] - 0.5 * delta
        P = (centre[a, 0] + h * n[0], centre[a, 1] + h * n[1], centre[a, 2] + h * n[2])
        e, p = _contact(S, G, k, G.bi[k + a], G.bi[k + b], P, n, delta, g)
        E += e
        W += p
    # sphere-wall
    for w in range(int(G.param[k, C_NWALLS])):
        o = C_WALLS + 6 * w
        nw = (G.param[k, o], G.param[k, o + 1], G.param[k, o + 2])
        for a in range(N):
            dist = nw[0] * (centre[a, 0] - G.param[k, o + 3]) + \
                nw[1] * (centre[a, 1] - G.param[k, o + 4]) + \
                nw[2] * (centre[a, 2] - G.param[k, o + 5])
            delta = radius[a] - dist
            if delta <= 0.0:
                continue
            h = radius[a] - 0.5 * delta
            P = (centre[a, 0] - h * nw[0], centre[a, 1] - h * nw[1], centre[a, 2] - h * nw[2])
            e, p = _contact(S, G, k, ground, G.bi[k + a], P, nw, delta, g)
            E += e
            W += p
    energy[k] = E
    power[k] = W


def set_law(spec, what, kinds):
    """The law columns (C_LAW .. C_RELAX) of an element whose pairs come and go as it runs (a
    sphere or shape set, ``what`` in the errors): the law ``linear`` (default) or ``hertz``
    only -- the hysteresis laws need each touch's impact velocity, LuGre a bristle state per
    contact, and neither is kept for pairs that change."""
    name, p = spec.name, spec.params
    law = p.get("law", "linear")
    if law not in ("linear", "hertz"):
        raise _err(name, "law", f"{what} takes the law 'linear' (with damping) or 'hertz', "
                                f"not {law!r}: its pairs change as it runs, so the impact "
                                "velocity the hysteresis laws need is not kept; declare "
                                "'contact' elements per pair for those")
    if p.get("friction") == "lugre":
        raise _err(name, "friction", f"the lugre law keeps a bristle state per contact, and "
                                     f"{what}'s pairs change as it runs: use coulomb or "
                                     "stribeck here, or 'contact' elements per pair")
    return law_params(dataclasses.replace(spec, params=dict(p, law=law)), (0.0, 0.0), kinds)


def wall_columns(name, walls) -> list:
    """(n (unit), p) of each wall ``{normal, point}`` in global axes, flattened (checked: at
    most MAX_WALLS, a non-zero normal)."""
    if not isinstance(walls, (list, tuple)) or len(walls) > MAX_WALLS:
        raise _err(name, "walls", f"expected a list of at most {MAX_WALLS} walls "
                                  f"{{normal, point}}, got {walls!r:.200}")
    cols = []
    for w, wall in enumerate(walls):
        if not isinstance(wall, dict) or set(wall) - {"normal", "point"} or \
                "normal" not in wall:
            raise _err(name, f"walls[{w}]", f"expected {{normal: [x, y, z], point: "
                                            f"[x, y, z]}}, got {wall!r}")
        nw = _vec(name, f"walls[{w}].normal", wall["normal"], None)
        if not np.linalg.norm(nw) > 0:
            raise _err(name, f"walls[{w}].normal", "must not be zero")
        cols += list(nw / np.linalg.norm(nw))
        cols += list(_vec(name, f"walls[{w}].point", wall.get("point"), (0.0, 0.0, 0.0)))
    return cols


@register
class SphereSet(ForceType):
    """Many spheres on many bodies colliding with each other and with walls (planes), the
    pairs found by a broad phase: linear in the number of spheres."""

    name = "sphere_set"
    kernel = staticmethod(kernel)
    n_param = N_COLUMNS
    required = ("bodies", "radius")
    parameters = {"bodies": "any", "radius": "any", "center": "vector", "walls": "any",
                  "law": "string", "stiffness": "number", "exponent": "number",
                  "damping": "number", "friction": "string", "mu": "number",
                  "mu_static": "number", "mu_dynamic": "number",
                  "stribeck_velocity": "number", "creep_velocity": "number",
                  "viscous": "number"}

    def __init__(self, names, element, bi, s_i, param):
        super().__init__(names)
        self.element = list(element)
        self.bi = np.asarray(bi, dtype=np.intp)
        self.s_i = np.asarray(s_i, dtype=float).reshape(-1, 3)
        self.param = np.asarray(param, dtype=float).reshape(-1, N_COLUMNS)

    @classmethod
    def validate(cls, spec, builder):
        cls._rows(spec, builder)

    @classmethod
    def _rows(cls, spec, builder):
        """(body names, centre (3,), param rows (N, N_COLUMNS)) of one element (checked)."""
        check_unknown(spec, cls.allowed)
        name, p = spec.name, spec.params
        bodies = p.get("bodies")
        if isinstance(bodies, (str, bytes)) or not hasattr(bodies, "__len__") or \
                len(bodies) < 1:
            raise _err(name, "bodies", f"expected a list of body names, got {bodies!r}")
        bodies = list(bodies)
        for b in bodies:
            if not isinstance(b, str) or b not in builder.bodies:
                raise _err(name, "bodies", f"no body named {b!r} (bodies: "
                                           f"{', '.join(builder.bodies) or 'none'})")
            if not builder.bodies[b].mass > 0:
                raise _err(name, "bodies", f"body {b!r} has no mass")
        if len(set(bodies)) != len(bodies):
            dup = sorted({b for b in bodies if bodies.count(b) > 1})
            raise _err(name, "bodies", f"each body at most once; repeated: {', '.join(dup)}")
        radius = p.get("radius")
        if isinstance(radius, (list, tuple, np.ndarray)):
            if len(radius) != len(bodies):
                raise _err(name, "radius", f"one radius per body ({len(bodies)}), got "
                                           f"{len(radius)}")
            radii = [_number(name, f"radius[{m}]", x, 0.0, True) for m, x in enumerate(radius)]
        else:
            radii = [_number(name, "radius", radius, 0.0, True)] * len(bodies)
        centre = _vec(name, "center", p.get("center"), (0.0, 0.0, 0.0))
        if "stiffness" not in p:
            raise _err(name, "stiffness", "give the contact stiffness (N/m for linear, "
                                          "N/m^1.5 for hertz)")
        walls = p.get("walls") or []
        wall_cols = wall_columns(name, walls)
        law_row = set_law(spec, "a sphere set", ("sphere", "sphere"))
        rows = np.zeros((len(bodies), N_COLUMNS))
        rows[:, L.C_LAW:L.N_COLUMNS] = law_row
        rows[:, C_FIRST] = np.arange(len(bodies))
        rows[:, C_COUNT] = len(bodies)
        rows[:, C_RADIUS] = radii
        rows[0, C_NWALLS] = len(walls)
        rows[0, C_WALLS:C_WALLS + len(wall_cols)] = wall_cols
        return bodies, centre, rows

    @classmethod
    def build(cls, specs, ctx):
        names, element, bi, s_i, param = [], [], [], [], []
        for spec in specs:
            bodies, centre, rows = cls._rows(spec, ctx.builder)
            for b, row in zip(bodies, rows):
                names.append(f"{spec.name}[{b}]")
                element.append(spec.name)
                bi.append(ctx.index[b])
                s_i.append(centre)
                param.append(row)
        group = cls(names, element, bi, s_i, param)
        group._check_initial(ctx)
        return group

    def _check_initial(self, ctx):
        """Deep interpenetration at the initial configuration (more than half the smaller
        radius: the contact normal is meaningless there) is an error, as for ``contact``."""
        from ...broadphase import sphere_pairs
        from ...rotations import A_from_p
        spec = {ctx.index[n]: b for n, b in ctx.builder.bodies.items()}
        r = np.array([spec[b].r for b in self.bi], dtype=float)
        A = A_from_p(np.array([spec[b].p for b in self.bi], dtype=float))
        c = r + np.einsum("nij,nj->ni", A, self.s_i)
        rad = self.param[:, C_RADIUS]
        for a, b in sphere_pairs(c, rad):
            depth = rad[a] + rad[b] - np.linalg.norm(c[b] - c[a])
            if depth > 0.5 * min(rad[a], rad[b]):
                raise ModelError(f"forces[{self.element[a]!r}]: spheres {self.names[a]!r} and "
                                 f"{self.names[b]!r} interpenetrate by {depth:.4g} m at the "
                                 "initial configuration (more than half the smaller radius); "
                                 "move the bodies apart")
        first = 0
        while first < self.n:
            count = int(self.param[first, C_COUNT])
            row = self.param[first]
            for w in range(int(row[C_NWALLS])):
                nw, pw = row[C_WALLS + 6 * w:C_WALLS + 6 * w + 3], \
                    row[C_WALLS + 6 * w + 3:C_WALLS + 6 * w + 6]
                depth = rad[first:first + count] - (c[first:first + count] - pw) @ nw
                for a in np.flatnonzero(depth > 0.5 * rad[first:first + count]):
                    raise ModelError(f"forces[{self.element[first]!r}].walls[{w}]: sphere "
                                     f"{self.names[first + a]!r} is {depth[a]:.4g} m into the "
                                     "wall at the initial configuration (more than half its "
                                     "radius); move it out")
            first += count

    def columns(self):
        return dict(bi=self.bi, bj=self.bi, s_i=self.s_i, param=self.param)
