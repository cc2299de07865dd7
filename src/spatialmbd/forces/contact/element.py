"""The ``contact`` force element: a pair of contact shapes on two bodies (or the ground), a
normal-force law and a friction law, compiled into the fused right-hand side.

Shapes (dicts, in the body's axes; ``center`` a 3-vector or a point name of the body, default
the centre of mass; ``axes`` a 3x3 rotation, shape -> body axes, default identity):

* ``{"type": "sphere", "radius": R}``
* ``{"type": "plane", "normal": n, "point": p}``  the half-space behind the plane (n outward)
* ``{"type": "box", "half_extents": (a, b, c)}``
* ``{"type": "cylinder", "radius": R, "half_length": h, "axis": u}``, ``{"type": "ellipsoid",
  "semi_axes": (a, b, c)}``, ``{"type": "convex", "vertices": [[x, y, z], ...]}`` (the hull of
  the points: a convex mesh), see :mod:`.convex_shapes`
* ``{"type": "capsule", "radius": R, "half_length": L, "axis": u}``  segment of length 2L
* ``{"type": "socket", "radius": R}``  spherical cavity (ball-in-socket clearance joint)
* ``{"type": "bearing", "radius": R, "axis": u}``  cylindrical bore; with a ``journal``
  (``{"type": "journal", "radius": R}``, a circle in the bearing's plane) the radial-clearance
  revolute joint

Pairs: plane-sphere, plane-box (8 vertex contacts), plane-capsule (2 end contacts),
plane-convex (a contact per hull vertex), plane-cylinder (3 rim points per cap),
plane-ellipsoid, sphere / capsule pairs, box-sphere, socket-sphere, bearing-journal, and every
other pair of sphere, capsule, box, cylinder, ellipsoid and convex (box-box by separating axes,
the rest by GJK/EPA, with a face manifold of up to 4 points: :mod:`.manifold`). One element may
stand for several contact points (a box's vertices, manifold slots): its instances are named
``name``, or ``name[0]``, ...

Parameters: see :mod:`.laws` for the laws; ``stiffness`` K (N/m^n, per contact point) given or from
the materials ``young_i``, ``poisson_i``, ``young_j``, ``poisson_j`` (Pa, -; a side without them
is rigid): Hertz for curved shapes, the flat punch for flat faces (:mod:`.stiffness`);
``exponent`` n (default 1.5, 1 for linear and for a flat punch from materials); ``damping`` c (N
s/m, linear law); ``restitution`` e in (0, 1] (hysteresis laws);
``min_impact_velocity`` (m/s, default 1e-3: the floor of v0 in the hysteresis term);
``margin`` (m, default 0: the shapes touch when their distance falls below it, MuJoCo's geom
margin); ``track_dissipation`` (default false: integrate each instance's dissipated energies,
normal damping and friction, with the run: ``res.contacts()``);
``friction`` (none, coulomb, stribeck, viscous), ``mu`` (or ``mu_static``, ``mu_dynamic``),
``stribeck_velocity`` (m/s), ``creep_velocity`` v_eps (m/s, default 1e-4), ``viscous`` c_v
(N s/m).
"""
from __future__ import annotations

import math

import numpy as np

from ...constraints.primitives import v_cross, v_dot, v_scale, v_sub
from ...errors import ModelError
from ...jit import njit
from ..base import ForceType, check_body, check_unknown, register
from ..kernel_tools import add_wrench
from . import geometry as geo
from . import convex_shapes as CS
from . import laws as L
from . import stiffness as ST
from . import support as sup

SHAPES = ("sphere", "plane", "box", "capsule", "socket", "bearing", "journal", "cylinder",
          "ellipsoid", "convex")
#: details columns (:func:`details`)
DETAIL_COLUMNS = ("gap", "gap_rate", "impact_velocity", "normal_force", "friction_x",
                  "friction_y", "friction_z", "slip_x", "slip_y", "slip_z", "point_x",
                  "point_y", "point_z", "normal_x", "normal_y", "normal_z", "active",
                  "power_normal", "power_friction", "damping")


@njit(inline="always")
def evaluate_pair(S, G, k):
    """(gap, gap rate, v0, f_N, f_t, v_t, P, n, elastic part, energy, pb) of instance k:
    energy = elastic energy of the contact and of its LuGre bristles, pb = the rate of the
    bristles' energy (its part of the dissipated power). A LuGre contact reads its bristle
    deflection z from G.law[k, 3:] and writes its rate z' there (forces.kernels)."""
    gap, n, P, vrel = geo.pair_geometry(S, G, k)
    gd = v_dot(n, vrel)
    vt = v_sub(vrel, v_scale(gd, n))
    v0 = G.law[k, 0]
    lugre = G.param[k, L.C_FRICTION] == L.LUGRE
    eb, pb = 0.0, 0.0
    if lugre:
        z = (G.law[k, 3], G.law[k, 4], G.law[k, 5])
        z = v_sub(z, v_scale(v_dot(z, n), n))          # the bristles bend in the tangent plane
    if gap >= 0.0:
        if lugre:                                      # open: the bristles relax
            r = 1.0 / G.param[k, L.C_RELAX]
            for c in range(3):
                G.law[k, 3 + c] = -r * z[c]
            eb = 0.5 * G.param[k, L.C_SIGMA0] * v_dot(z, z)
            pb = -2.0 * r * eb
        return gap, gd, v0, 0.0, (0.0, 0.0, 0.0), vt, P, n, 0.0, eb, pb
    fN, el, energy = L.normal_force(G.param, k, -gap, -gd, v0)
    if lugre:
        ft, zd, pb, eb = L.lugre(G.param, k, fN, vt, z)
        for c in range(3):
            G.law[k, 3 + c] = zd[c]
        return gap, gd, v0, fN, ft, vt, P, n, el, energy + eb, pb
    s = math.sqrt(v_dot(vt, vt))
    a, cv = L.friction_factor(G.param, k, fN, s)
    ft = v_scale(-(a + cv), vt)
    return gap, gd, v0, fN, ft, vt, P, n, el, energy, 0.0


@njit(inline="always")
def dissipation(G, k, gap, gd, fN, el, ft, vt, pb):
    """(normal-damping power (f_N - K delta^n) g', friction power f_t . v_t + sigma_0 z . z')
    of instance k (W, <= 0 for a dissipative law; 0, pb while open)."""
    if gap >= 0.0:
        return 0.0, pb
    return (fN - el) * gd, v_dot(ft, vt) + pb


@njit
def kernel(S, G, k, g, energy, power, D):
    """Normal and friction force of contact k on both bodies at the contact point, its elastic
    energy and the power of its dissipative parts (f_N - K delta^n) g' + f_t . v_t <= 0 (with
    LuGre bristles: + sigma_0 z . z', their energy counted as elastic). The rates of the
    instance's accumulated dissipated energies (normal damping, friction; J) go to
    G.law[k, 6], G.law[k, 7] (its internal states 3 and 4 when it is stateful)."""
    gap, gd, v0, fN, ft, vt, P, n, el, e, pb = evaluate_pair(S, G, k)
    energy[k] = e
    pn, pf = dissipation(G, k, gap, gd, fN, el, ft, vt, pb)
    if G.param[k, L.C_FRICTION] != L.LUGRE:
        G.law[k, 3], G.law[k, 4], G.law[k, 5] = 0.0, 0.0, 0.0
    G.law[k, 6], G.law[k, 7] = -pn, -pf
    power[k] = pn + pf
    if gap >= 0.0:
        return
    F = (fN * n[0] + ft[0], fN * n[1] + ft[1], fN * n[2] + ft[2])      # on body j
    i, j = G.bi[k], G.bj[k]
    r = S[0]
    aj = (P[0] - r[j, 0], P[1] - r[j, 1], P[2] - r[j, 2])
    ai = (P[0] - r[i, 0], P[1] - r[i, 1], P[2] - r[i, 2])
    tj, ti = v_cross(aj, F), v_cross(ai, F)
    add_wrench(g, j, F[0], F[1], F[2], tj[0], tj[1], tj[2])
    add_wrench(g, i, -F[0], -F[1], -F[2], -ti[0], -ti[1], -ti[2])


@njit
def details(S, G, out):
    """out[k] = the :data:`DETAIL_COLUMNS` of every instance k."""
    for k in range(out.shape[0]):
        gap, gd, v0, fN, ft, vt, P, n, el, e, pb = evaluate_pair(S, G, k)
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = gap, gd, v0, fN
        for c in range(3):
            out[k, 4 + c] = ft[c]
            out[k, 7 + c] = vt[c]
            out[k, 10 + c] = P[c]
            out[k, 13 + c] = n[c]
        out[k, 16] = 1.0 if gap < 0.0 else 0.0
        out[k, 17], out[k, 18] = dissipation(G, k, gap, gd, fN, el, ft, vt, pb)
        out[k, 19] = damping_in_use(G.param, k, gap, el, v0)


@njit(inline="always")
def damping_in_use(param, k, gap, el, v0):
    """d f_N / d delta' (N s/m): c of the linear law; K delta^n chi / v0 of a hysteresis law
    while closed (0 open, 0 for hertz)."""
    law = int(param[k, L.C_LAW])
    if law == L.LINEAR:
        return param[k, L.C_C]
    if law == L.HERTZ or gap >= 0.0:
        return 0.0
    vi = v0 if v0 > param[k, L.C_VMIN] else param[k, L.C_VMIN]
    return el * param[k, L.C_C] / vi


@njit
def gaps(S, G, out):
    for k in range(out.size):
        out[k] = geo.pair_geometry(S, G, k)[0]


# ------------------------------------------------------------------------------ parsing
def _err(name, key, text):
    return ModelError(f"forces[{name!r}].{key}: {text}")


def _number(name, key, value, lo=None, lo_open=False, hi=None):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise _err(name, key, f"expected a number, got {value!r}") from None
    if not math.isfinite(x):
        raise _err(name, key, f"must be finite, got {value!r}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise _err(name, key, f"must be {'>' if lo_open else '>='} {lo}, got {x:g}")
    if hi is not None and x > hi:
        raise _err(name, key, f"must be <= {hi}, got {x:g}")
    return x


def _vec(name, key, value, default):
    if value is None:
        return np.array(default, dtype=float)
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise _err(name, key, f"expected 3 numbers, got {value!r}")
    return arr


def _axes_from_z(u):
    z = u / np.linalg.norm(u)
    t = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(t, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def parse_shape(name, key, shape, builder, body):
    """(type, centre (3,), axes (3, 3), radius, half_length, half_extents (3,), vertices
    (nv, 3) or None) in body axes (the vertices in the shape frame)."""
    if not isinstance(shape, dict) or "type" not in shape:
        raise _err(name, key, f"expected a shape dict with a 'type' ({', '.join(SHAPES)}), got "
                              f"{shape!r}")
    kind = shape["type"]
    if kind not in SHAPES:
        raise _err(name, key + ".type", f"unknown shape {kind!r}; valid: {', '.join(SHAPES)}")
    allowed = {"type", "center", "axes", "radius", "half_length", "half_extents", "axis",
               "normal", "point", "semi_axes", "vertices"}
    extra = set(shape) - allowed
    if extra:
        raise _err(name, key, f"unknown shape key(s) {sorted(extra)}; allowed: {sorted(allowed)}")
    where = shape.get("center", shape.get("point"))
    if isinstance(where, str):
        pts = {} if body == "ground" else builder.bodies[body].points
        if where not in pts:
            raise _err(name, key + ".center", f"body {body!r} has no point named {where!r}")
        centre = np.array(pts[where], dtype=float)
    else:
        centre = _vec(name, key + ".center", where, (0.0, 0.0, 0.0))
    axes = np.eye(3)
    if shape.get("axes") is not None:
        axes = np.array(shape["axes"], dtype=float).reshape(3, 3)
        if not np.allclose(axes.T @ axes, np.eye(3), atol=1e-9) or np.linalg.det(axes) < 0:
            raise _err(name, key + ".axes", "must be a 3x3 rotation matrix (shape -> body axes)")
    direction = shape.get("normal", shape.get("axis"))
    if direction is not None:
        u = _vec(name, key + ".normal" if "normal" in shape else key + ".axis", direction, None)
        if not np.linalg.norm(u) > 0:
            raise _err(name, key, "the normal / axis must not be zero")
        axes = _axes_from_z(u)
    radius = half_length = 0.0
    half = np.zeros(3)
    if kind in ("cylinder", "ellipsoid", "convex"):
        radius, half_length, half, verts = CS.parse(name, key, kind, shape)
        return kind, centre, axes, radius, half_length, half, verts
    if kind in ("sphere", "capsule", "socket", "bearing", "journal"):
        radius = _number(name, key + ".radius", shape.get("radius", float("nan")), 0.0, True)
    if kind == "capsule":
        half_length = _number(name, key + ".half_length", shape.get("half_length", float("nan")),
                              0.0)
    if kind == "box":
        half = _vec(name, key + ".half_extents", shape.get("half_extents"), (np.nan,) * 3)
        if not np.all(half > 0):
            raise _err(name, key + ".half_extents", f"must be 3 positive numbers (m), got "
                                                    f"{shape.get('half_extents')!r}")
    return kind, centre, axes, radius, half_length, half, None


def _pairing(name, a, b):
    """(pair kind, swap): which geometry kernel, and whether shape j comes first."""
    table = {("plane", "sphere"): geo.PLANE_POINT, ("plane", "box"): geo.PLANE_POINT,
             ("plane", "capsule"): geo.PLANE_POINT, ("plane", "journal"): geo.PLANE_POINT,
             ("sphere", "sphere"): geo.SEGMENTS, ("capsule", "capsule"): geo.SEGMENTS,
             ("capsule", "sphere"): geo.SEGMENTS, ("box", "sphere"): geo.BOX_SPHERE,
             ("socket", "sphere"): geo.SOCKET_BALL, ("bearing", "journal"): geo.BEARING_JOURNAL,
             ("bearing", "sphere"): geo.BEARING_JOURNAL}
    if (a, b) in table:
        return table[(a, b)], False
    if (b, a) in table:
        return table[(b, a)], True
    if a in CS.CONVEX_KINDS and b in CS.CONVEX_KINDS:
        return geo.CONVEX, False
    if "plane" in (a, b) and {a, b} & {"cylinder", "ellipsoid", "convex"}:
        return (geo.PLANE_POINT if "convex" in (a, b) else geo.PLANE_CONVEX), b == "plane"
    pairs = sorted(f"{x}-{y}" for x, y in table)
    raise ModelError(f"forces[{name!r}]: no contact geometry for a {a}-{b} pair; available: "
                     f"{', '.join(pairs)}, plane with cylinder, ellipsoid or convex, and any "
                     f"two of {', '.join(CS.CONVEX_KINDS)}")


#: other names of the normal laws: the Carvalho-Martins law of this package is the one of
#: exact restitution (its chi inverts the produced restitution), which is also its name
LAW_ALIASES = {"exact_restitution": "carvalho_martins"}


def law_params(spec, radii, kinds, shapes=None):
    """(law id, K, n, c, vmin) and the friction columns (:func:`friction_params`) of a spec
    (checked): the columns C_LAW .. C_RELAX of the contact table. shapes: the two parsed
    shapes (kind, radius, half_length, half, vertices) for the stiffness from materials."""
    name, p = spec.name, spec.params
    law = p.get("law", "hunt_crossley")
    law = LAW_ALIASES.get(law, law)
    if law not in L.NORMAL_LAWS:
        raise _err(name, "law", f"unknown normal law {law!r}; valid: "
                                f"{', '.join(L.NORMAL_LAWS + tuple(LAW_ALIASES))}")
    n = _number(name, "exponent", p.get("exponent", 1.0 if law == "linear" else 1.5), 0.0, True)
    if "stiffness" in p:
        K = _number(name, "stiffness", p["stiffness"], 0.0, True)
    else:
        if shapes is None:
            shapes = [(k, r, 0.0, np.zeros(3), None) for k, r in zip(kinds, radii)]
        if not all(x[0] in ST.FLAT + CS.CONVEX_KINDS + ("socket", "bearing", "journal")
                   for x in shapes):
            raise _err(name, "stiffness", f"no stiffness from materials for a "
                                          f"{kinds[0]}-{kinds[1]} pair: give a stiffness")
        K, n_mat = ST.from_materials(spec, shapes[0], shapes[1], _number)
        if "exponent" not in p:
            n = n_mat
    c = 0.0
    if law == "linear":
        c = _number(name, "damping", p.get("damping", 0.0), 0.0)
    elif law in L.HYSTERESIS:
        if "restitution" not in p:
            raise _err(name, "restitution", f"the {law} law needs a coefficient of restitution "
                                             "in (0, 1]")
        e = _number(name, "restitution", p["restitution"])
        if not 0.0 < e <= 1.0:
            raise _err(name, "restitution", f"must be in (0, 1], got {e:g}")
        c = L.CHI[law](e)
    for key in ("damping", "restitution"):
        if key in p and not (law == "linear" if key == "damping" else law in L.HYSTERESIS):
            raise _err(name, key, f"not a parameter of the {law} law")
    vmin = _number(name, "min_impact_velocity", p.get("min_impact_velocity", 1e-3), 0.0, True)
    return (L.NORMAL_LAWS.index(law), K, n, c, vmin) + friction_params(name, p)


def friction_params(name, p, default="none"):
    """(mu_d, mu_s, v_s, v_eps, c_v, lugre, sigma_0, sigma_1, relaxation) -- the columns
    C_MUD .. C_RELAX -- of the friction keys of a spec's parameters ``p`` (checked, errors
    naming forces[name].key); ``default``: the law when neither ``friction`` nor a ``mu`` is
    given. Shared by the contact and the joint-friction elements."""
    fr = p.get("friction", default if not any(k in p for k in ("mu", "mu_dynamic")) else
               "coulomb")
    if fr not in L.FRICTION_LAWS:
        raise _err(name, "friction", f"unknown friction law {fr!r}; valid: "
                                     f"{', '.join(L.FRICTION_LAWS)}")
    mud = mus = vs = cv = 0.0
    veps = _number(name, "creep_velocity", p.get("creep_velocity", 1e-4), 0.0, True)
    if fr == "coulomb":
        mud = mus = _number(name, "mu", p.get("mu", p.get("mu_dynamic", float("nan"))), 0.0)
    elif fr == "stribeck":
        mud = _number(name, "mu_dynamic", p.get("mu_dynamic", float("nan")), 0.0)
        mus = _number(name, "mu_static", p.get("mu_static", float("nan")), 0.0)
        vs = _number(name, "stribeck_velocity", p.get("stribeck_velocity", float("nan")), 0.0,
                     True)
    sigma0 = sigma1 = 0.0
    relax = 1e-3
    if fr == "lugre":
        # mu alone: Coulomb levels; mu_static, mu_dynamic, stribeck_velocity: a Stribeck curve
        if "mu_static" in p or "mu_dynamic" in p:
            mud = _number(name, "mu_dynamic", p.get("mu_dynamic", float("nan")), 0.0)
            mus = _number(name, "mu_static", p.get("mu_static", float("nan")), 0.0)
            vs = _number(name, "stribeck_velocity", p.get("stribeck_velocity", float("nan")),
                         0.0, True)
        else:
            mud = mus = _number(name, "mu", p.get("mu", float("nan")), 0.0)
        sigma0 = _number(name, "bristle_stiffness", p.get("bristle_stiffness", float("nan")),
                         0.0, True)
        sigma1 = _number(name, "bristle_damping", p.get("bristle_damping", 0.0), 0.0)
        relax = _number(name, "bristle_relaxation", p.get("bristle_relaxation", 1e-3), 0.0,
                        True)
    else:
        for key in ("bristle_stiffness", "bristle_damping", "bristle_relaxation"):
            if key in p:
                raise _err(name, key, f"a parameter of the lugre friction law, not of {fr!r}")
    if fr in ("viscous", "coulomb", "stribeck", "lugre"):
        cv = _number(name, "viscous", p.get("viscous", 0.0), 0.0)
    return (mud, mus, vs, veps, cv, float(fr == "lugre"), sigma0, sigma1, relax)


def track_dissipation(spec) -> bool:
    """The ``track_dissipation`` key (default false): integrate the instance's dissipated
    energies (normal damping, friction) with the run, as two internal states."""
    value = spec.params.get("track_dissipation", False)
    if not isinstance(value, (bool, np.bool_)):
        raise _err(spec.name, "track_dissipation", f"expected true or false, got {value!r}")
    return bool(value)


@register
class Contact(ForceType):
    """Contact between two shapes on two bodies: a normal-force law and friction."""

    name = "contact"
    kernel = staticmethod(kernel)
    n_param = sup.N_COLUMNS
    #: the impact-velocity memory (.memory): every instance records its touches
    records_impacts = True
    details_kernel = staticmethod(details)
    n_details = len(DETAIL_COLUMNS)
    required = ("body_i", "body_j", "shape_i", "shape_j")
    parameters = {"body_i": "body", "body_j": "body", "shape_i": "any", "shape_j": "any",
                  "law": "string", "stiffness": "number", "exponent": "number",
                  "damping": "number", "restitution": "number", "young_i": "number",
                  "poisson_i": "number", "young_j": "number", "poisson_j": "number",
                  "min_impact_velocity": "number", "friction": "string", "mu": "number",
                  "mu_static": "number", "mu_dynamic": "number",
                  "stribeck_velocity": "number", "creep_velocity": "number",
                  "viscous": "number", "bristle_stiffness": "number",
                  "bristle_damping": "number", "bristle_relaxation": "number",
                  "track_dissipation": "any", "margin": "number"}

    def __init__(self, names, element, bi, bj, s_i, s_j, R_i, R_j, param, size, track=None):
        super().__init__(names)
        #: the instances that integrate their dissipated energies (``track_dissipation``)
        self.track = np.zeros(len(names), bool) if track is None else np.asarray(track, bool)
        self.element = list(element)          # the element name of each instance
        self.bi = np.asarray(bi, dtype=np.intp)
        self.bj = np.asarray(bj, dtype=np.intp)
        self.s_i, self.s_j = np.asarray(s_i, float), np.asarray(s_j, float)
        self.R_i, self.R_j = np.asarray(R_i, float), np.asarray(R_j, float)
        self.param = np.asarray(param, dtype=float).reshape(-1, sup.N_COLUMNS)
        self.size = np.asarray(size, dtype=float)

    @classmethod
    def validate(cls, spec, builder):
        cls._instances(spec, builder)
        track_dissipation(spec)

    @classmethod
    def _instances(cls, spec, builder):
        """The expanded instances of one element: list of (bi name, bj name, s_i, s_j, R_i,
        R_j, param row, size)."""
        check_unknown(spec, cls.allowed)
        p = spec.params
        bodies = [check_body(spec, builder, key, ground_ok=True) for key in ("body_i", "body_j")]
        if bodies[0] == bodies[1]:
            raise ModelError(f"forces[{spec.name!r}]: both shapes are on body {bodies[0]!r}")
        for b in bodies:
            if b != "ground" and not builder.bodies[b].mass > 0:
                raise ModelError(f"forces[{spec.name!r}]: body {b!r} has no mass; a contact "
                                 "shape needs a body with mass (or the ground)")
        sh = [parse_shape(spec.name, key, p.get(key), builder, b)
              for key, b in (("shape_i", bodies[0]), ("shape_j", bodies[1]))]
        pair, swap = _pairing(spec.name, sh[0][0], sh[1][0])
        if swap:
            sh, bodies = sh[::-1], bodies[::-1]
        (ki, ci, Ai, rad_i, li, hi, vi), (kj, cj, Aj, rad_j, lj, hj, vj) = sh
        law = law_params(spec, (rad_i, rad_j), (ki, kj),
                         [(x[0],) + tuple(x[3:]) for x in sh])
        row = np.zeros(sup.N_COLUMNS)
        row[geo.C_PAIR] = pair
        row[geo.C_RI], row[geo.C_RJ] = rad_i, rad_j
        row[geo.C_LI], row[geo.C_LJ] = li, lj
        row[geo.C_HX:geo.C_HZ + 1] = hi
        row[L.C_LAW:L.N_COLUMNS] = law
        row[sup.C_MARGIN] = _number(spec.name, "margin", p.get("margin", 0.0), 0.0)
        if pair == geo.SOCKET_BALL and not rad_j < rad_i:
            raise _err(spec.name, "shape_j.radius", f"the ball (radius {rad_j:g} m) must be "
                                                    f"smaller than the socket ({rad_i:g} m)")
        if pair == geo.BEARING_JOURNAL and not rad_j < rad_i:
            raise _err(spec.name, "shape_j.radius", f"the journal (radius {rad_j:g} m) must "
                                                    f"be smaller than the bearing ({rad_i:g} m)")
        out = []
        if pair == geo.PLANE_POINT and kj == "box":
            for sx in (-1, 1):
                for sy in (-1, 1):
                    for sz in (-1, 1):
                        v = cj + Aj @ (hj * np.array([sx, sy, sz]))
                        r = row.copy()
                        r[geo.C_RJ] = 0.0
                        out.append((v, r, float(hj.min())))
        elif pair == geo.PLANE_POINT and kj == "capsule":
            for sz in (-1, 1):
                out.append((cj + sz * lj * Aj[:, 2], row.copy(), rad_j))
        elif pair == geo.PLANE_POINT and kj == "convex":
            for v in vj:
                out.append((cj + Aj @ v, row.copy(), float(hj.min())))
        elif pair in (geo.CONVEX, geo.PLANE_CONVEX):
            if ki != "plane":
                row[sup.C_SIDE_I:sup.C_SIDE_J] = CS.side_block(*sh[0][:1], *sh[0][3:])
            row[sup.C_SIDE_J:sup.C_SIDE_J + sup.SIDE_WIDTH] = CS.side_block(*sh[1][:1],
                                                                          *sh[1][3:])
            sz = CS.size(*sh[1][:1], *sh[1][3:])
            if pair == geo.CONVEX:
                sz = min(sz, CS.size(*sh[0][:1], *sh[0][3:]))
            count = CS.slots(ki, kj) if pair == geo.CONVEX else \
                (6 if kj == "cylinder" else 1)
            for slot in range(count):
                r = row.copy()
                r[sup.C_SLOT] = slot
                out.append((cj, r, sz))
        else:
            sizes = [x for x in (rad_i, rad_j) if x > 0] + list(hi[hi > 0])
            if pair in (geo.SOCKET_BALL, geo.BEARING_JOURNAL):
                sizes = [rad_i - rad_j]
            out.append((cj, row, float(min(sizes))))
        return [(bodies[0], bodies[1], ci, s, Ai, Aj, r, size) for s, r, size in out]

    @classmethod
    def build(cls, specs, ctx):
        names, element, bi, bj, s_i, s_j, R_i, R_j, param, size, track = \
            ([] for _ in range(11))
        for spec in specs:
            inst = cls._instances(spec, ctx.builder)
            track += [track_dissipation(spec)] * len(inst)
            for m, (b1, b2, c1, c2, A1, A2, row, sz) in enumerate(inst):
                names.append(spec.name if len(inst) == 1 else f"{spec.name}[{m}]")
                element.append(spec.name)
                bi.append(ctx.index[b1])
                bj.append(ctx.index[b2])
                s_i.append(c1)
                s_j.append(c2)
                R_i.append(A1)
                R_j.append(A2)
                param.append(row)
                size.append(sz)
        group = cls(names, element, bi, bj, s_i, s_j, R_i, R_j, param, size, track)
        group._check_initial(ctx)
        return group

    def _check_initial(self, ctx):
        """Deep interpenetration at the initial configuration: penetration above half the
        smallest shape size (then the contact normal is meaningless) is an error."""
        from ...state import BodyState
        nb = ctx.nb
        q = np.zeros((nb, 7))
        for name, b in ctx.index.items():
            if name != "ground" and b < nb:
                spec = ctx.builder.bodies[name]
                q[b, :3], q[b, 3:] = spec.r, spec.p
        state = BodyState.from_qv(q, None)
        g = self.gaps(state)
        for k in np.flatnonzero(-g > 0.5 * self.size):
            raise ModelError(f"forces[{self.element[k]!r}]: the shapes interpenetrate by "
                             f"{-g[k]:.4g} m at the initial configuration (instance "
                             f"{self.names[k]!r}; more than half the shape size "
                             f"{self.size[k]:.4g} m); move the bodies apart")

    def summary_lines(self) -> list:
        """One line per element: the normal law, the stiffness and the damping in use, and the
        friction (:meth:`spatialmbd.model.Model.summary`)."""
        lines = []
        for name in dict.fromkeys(self.element):
            ks = [k for k, e in enumerate(self.element) if e == name]
            p = self.param[ks[0]]
            law = L.NORMAL_LAWS[int(p[L.C_LAW])]
            K, n, c = p[L.C_K], p[L.C_N], p[L.C_C]
            unit = "N/m" if n == 1.0 else f"N/m^{n:g}"
            text = f"    {name}: {len(ks)} point(s), {law}, K = {K:.4g} {unit} per point"
            if law == "linear":
                text += f", damping c = {c:.4g} N s/m"
            elif law in L.HYSTERESIS:
                text += (f", hysteresis damping K delta^n chi / v0 with chi = {c:.4g} (e_p = "
                         f"{L.produced_restitution(c):.4g})")
            fr = "lugre" if p[L.C_FRICTION] == L.LUGRE else (
                "none" if p[L.C_MUD] == 0 and p[L.C_MUS] == 0 and p[L.C_CV] == 0 else None)
            if fr is None:
                text += (f"; friction mu {p[L.C_MUD]:g}" + (f"/{p[L.C_MUS]:g}" if p[L.C_MUS]
                                                            != p[L.C_MUD] else "")
                         + f", creep velocity {p[L.C_VEPS]:g} m/s")
                if p[L.C_CV]:
                    text += f", viscous {p[L.C_CV]:g} N s/m"
            elif fr == "lugre":
                text += (f"; LuGre friction mu {p[L.C_MUD]:g}/{p[L.C_MUS]:g}, sigma_0 = "
                         f"{p[L.C_SIGMA0]:.4g} N/m, sigma_1 = {p[L.C_SIGMA1]:.4g} N s/m")
            lines.append(text)
        return lines

    def needs_memory(self) -> np.ndarray:
        return np.ones(self.n, dtype=bool)

    def state_rows(self) -> np.ndarray:
        """The LuGre contacts carry their bristle deflection z as an internal state, and with
        it (as do the contacts with ``track_dissipation``) their dissipated energies."""
        return (self.param[:, L.C_FRICTION] == L.LUGRE) | self.track

    def columns(self):
        return dict(bi=self.bi, bj=self.bj, s_i=self.s_i, s_j=self.s_j, R_i=self.R_i,
                    R_j=self.R_j, param=self.param)

    def table(self, memory=None, states=None):
        from ..kernels import ForceTable
        t = ForceTable([self], only_compiled=False)
        if memory is not None:
            t.law[:, 0] = memory
        if states is not None:
            states = np.asarray(states, dtype=float)
            t.law[:, 3:3 + states.shape[1]] = states
        return t

    def gaps(self, state) -> np.ndarray:
        out = np.zeros(self.n)
        gaps(state.arrays(), self.table().G, out)
        return out

    def details(self, state, memory=None, states=None) -> np.ndarray:
        """(n, len(DETAIL_COLUMNS)) of every instance at ``state`` (memory: recorded impact
        speeds, m/s; states: (n, 3) LuGre bristle deflections, m)."""
        out = np.zeros((self.n, len(DETAIL_COLUMNS)))
        details(state.arrays(), self.table(memory, states).G, out)
        return out
