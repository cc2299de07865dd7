"""Colliding geoms -> ``contact`` elements (docs/import.md, "Contact").

Which geom pairs collide is MuJoCo's rule (``mj_collision``, engine_collision_driver.c):

* every explicit ``<pair>``, with its own friction, solref, solimp, margin and gap, unfiltered;
* every other pair of geoms on two bodies whose *weld groups* differ, unless (a) the weld
  groups are parent and child and neither is the world (``filterparent``, unless disabled),
  (b) the two bodies are named in an ``<exclude>``, (c) neither ``contype1 & conaffinity2`` nor
  ``contype2 & conaffinity1`` is set, or (d) the pair is also an explicit ``<pair>`` (which
  then replaces it). Its parameters mix the two geoms' as ``mj_contactParam`` does: those of
  the geom of higher ``priority``, else friction and condim the larger, solref and solimp mixed
  by ``solmix``, gap the larger; the margin is MuJoCo's ``margin`` of the pair.

Each pair becomes a ``contact`` element between the two bodies (or the ground), its shapes the
geoms' (in the body's axes), with MuJoCo's soft contact mapped to the linear law as the soft
limits are (:func:`contact_spring`): per contact point K = d^2 k m, c = d b m at the deep
impedance d = dmax of solimp, (k, b) the reference gains of solref, m the mass the contact
moves in MuJoCo's own diagonal approximation (1 / (body_invweight0 of one body + that of the
other), translational part); friction regularized Coulomb with mu = the sliding
friction (none for condim 1); the contact's margin = MuJoCo's ``margin - gap`` (where its
contact turns active). What this cannot be is listed as approximated (kind "contact").
"""
from __future__ import annotations

import numpy as np

from .geoms import clean
from .joint_elements import impedance, reference_gains
from .report import LeftOut

#: MuJoCo's mjMINVAL (solmix below it counts as 0)
MINVAL = 1e-15


def _bitmask_passes(m, g1, g2) -> bool:
    return bool((m.geom_contype[g1] & m.geom_conaffinity[g2])
                or (m.geom_contype[g2] & m.geom_conaffinity[g1]))


def candidate_pairs(mujoco, m) -> list:
    """[(g1, g2, ipair)] of every geom pair MuJoCo may collide (ipair the explicit pair's index,
    -1 for a dynamic pair), by the rules of the module docstring (the bounding-volume tests of
    its broad phase aside: they depend on the poses)."""
    if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT) or \
            m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):
        return []
    out = [(int(m.pair_geom1[p]), int(m.pair_geom2[p]), p) for p in range(m.npair)]
    explicit = {frozenset((g1, g2)) for g1, g2, _ in out}
    excluded = {int(s) for s in np.asarray(m.exclude_signature).reshape(-1)}
    filterparent = not m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    weld = np.asarray(m.body_weldid)
    parent_weld = weld[np.asarray(m.body_parentid)[weld]]
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
            w1, w2 = int(weld[b1]), int(weld[b2])
            if w1 == w2:
                continue
            if filterparent and w1 != 0 and w2 != 0 and (
                    w1 == parent_weld[w2] or w2 == parent_weld[w1]):
                continue
            lo, hi = min(b1, b2), max(b1, b2)
            if (lo << 16) + hi in excluded:
                continue
            if not _bitmask_passes(m, g1, g2) or frozenset((g1, g2)) in explicit:
                continue
            out.append((g1, g2, -1))
    return out


def pair_parameters(mujoco, m, g1, g2, ipair) -> dict:
    """condim, friction (3: sliding, torsional, rolling), solref (2), solimp (5), margin, gap of
    a pair as MuJoCo sets them on its contacts (mj_contactParam, mj_collideGeoms)."""
    if ipair >= 0:
        fr = np.asarray(m.pair_friction[ipair], dtype=float)
        return dict(condim=int(m.pair_dim[ipair]), friction=fr[[0, 2, 3]],
                    solref=np.asarray(m.pair_solref[ipair], dtype=float),
                    solimp=np.asarray(m.pair_solimp[ipair], dtype=float),
                    margin=float(m.pair_margin[ipair]), gap=float(m.pair_gap[ipair]))
    p1, p2 = int(m.geom_priority[g1]), int(m.geom_priority[g2])
    ref1, ref2 = (np.asarray(m.geom_solref[g], dtype=float) for g in (g1, g2))
    imp1, imp2 = (np.asarray(m.geom_solimp[g], dtype=float) for g in (g1, g2))
    fr1, fr2 = (np.asarray(m.geom_friction[g], dtype=float) for g in (g1, g2))
    if p1 != p2:
        g = g1 if p1 > p2 else g2
        condim, solref, solimp, friction = (int(m.geom_condim[g]), (ref1, ref2)[g == g2],
                                            (imp1, imp2)[g == g2], (fr1, fr2)[g == g2])
    else:
        condim = max(int(m.geom_condim[g1]), int(m.geom_condim[g2]))
        s1, s2 = float(m.geom_solmix[g1]), float(m.geom_solmix[g2])
        if s1 >= MINVAL and s2 >= MINVAL:
            mix = s1 / (s1 + s2)
        elif s1 < MINVAL and s2 < MINVAL:
            mix = 0.5
        else:
            mix = 0.0 if s1 < MINVAL else 1.0
        solref = mix * ref1 + (1 - mix) * ref2 if ref1[0] > 0 and ref2[0] > 0 else \
            np.minimum(ref1, ref2)
        solimp = mix * imp1 + (1 - mix) * imp2
        friction = np.maximum(fr1, fr2)
    return dict(condim=condim, friction=friction, solref=solref, solimp=solimp,
                margin=float(m.geom_margin[g1] + m.geom_margin[g2]),
                gap=float(max(m.geom_gap[g1], m.geom_gap[g2])))


def contact_shape(mujoco, m, d, g, R, c):
    """(shape dict in the frame (origin c, axes R: body -> global), None) or (None, why not)
    of geom g as a contact shape."""
    G = mujoco.mjtGeom
    kind = int(m.geom_type[g])
    size = np.asarray(m.geom_size[g], dtype=float)
    Rg = R.T @ np.asarray(d.geom_xmat[g], dtype=float).reshape(3, 3)
    centre = clean(R.T @ (np.asarray(d.geom_xpos[g], dtype=float) - c))
    axes = Rg.tolist()
    if kind == G.mjGEOM_PLANE:
        return dict(type="plane", normal=clean(Rg[:, 2]), point=centre), None
    if kind == G.mjGEOM_SPHERE:
        return dict(type="sphere", radius=float(size[0]), center=centre), None
    if kind in (G.mjGEOM_CAPSULE, G.mjGEOM_CYLINDER):
        name = "capsule" if kind == G.mjGEOM_CAPSULE else "cylinder"
        return dict(type=name, radius=float(size[0]), half_length=float(size[1]),
                    center=centre, axis=clean(Rg[:, 2])), None
    if kind == G.mjGEOM_BOX:
        return dict(type="box", half_extents=size.tolist(), center=centre, axes=axes), None
    if kind == G.mjGEOM_ELLIPSOID:
        return dict(type="ellipsoid", semi_axes=size.tolist(), center=centre, axes=axes), None
    if kind == G.mjGEOM_MESH and int(m.geom_dataid[g]) >= 0:
        # MuJoCo collides with the mesh's convex hull: so does a convex shape of its vertices
        k = int(m.geom_dataid[g])
        v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
        V = np.asarray(m.mesh_vert[v0:v0 + nv], dtype=float)
        from scipy.spatial import ConvexHull
        hull = np.unique(ConvexHull(V).vertices)
        if hull.size > 24:
            return None, (f"a mesh whose convex hull has {hull.size} vertices (a convex "
                          "contact shape keeps at most 24)")
        return dict(type="convex", vertices=V[hull].tolist(), center=centre, axes=axes), None
    return None, f"a {G(kind).name[7:].lower()} geom has no contact shape here"


def contact_spring(mujoco, m, solref, solimp, mass) -> tuple:
    """(K N/m, c N s/m) of the linear law with the free response of MuJoCo's soft contact on
    a mass ``mass``: MuJoCo's normal force f = I m (a_ref - a0) with a_ref = -b v - k I r (I
    the impedance) moves the penetration as r'' = -I b r' - I^2 k r + (1 - I) a0, so
    K = d^2 k m, c = d b m at the deep impedance d = dmax (damping ratio b / (2 sqrt(k)):
    the dampratio of solref)."""
    d = impedance(solimp, np.inf)
    k, b = reference_gains(mujoco, m, solref, d)
    return d * d * k * mass, d * b * mass


def effective_mass(m, b1, b2) -> float:
    """1 / (invweight0 of body b1 + of body b2) (translational; the world: 0), kg."""
    w = float(m.body_invweight0[b1, 0] if b1 else 0.0) + \
        float(m.body_invweight0[b2, 0] if b2 else 0.0)
    return 1.0 / w if w > 0 else 0.0


def add_contacts(mujoco, m, d, builder, *, ours, frames, fresh, geom_name, left_out) -> None:
    """A ``contact`` element for every colliding pair (module docstring); pairs that cannot be
    one are listed in ``left_out`` (kind "colliding geom"), each imported pair once as an
    approximation (kind "contact")."""
    from ...errors import ModelError
    shapes, why = {}, {}
    for g1, g2, ipair in candidate_pairs(mujoco, m):
        for g in (g1, g2):
            if g not in shapes and g not in why:
                w = int(m.body_weldid[m.geom_bodyid[g]])
                c, R = frames[w]
                shapes[g], reason = contact_shape(mujoco, m, d, g, R, c)
                if shapes[g] is None:
                    why[g] = reason
                    del shapes[g]
        bad = [g for g in (g1, g2) if g in why]
        label = f"{geom_name(g1)}-{geom_name(g2)}"
        if bad:
            left_out.append(LeftOut("colliding geom", label, why[bad[0]]))
            continue
        par = pair_parameters(mujoco, m, g1, g2, ipair)
        depth = -float(mujoco.mj_geomDistance(m, d, g1, g2, 1.0, None))
        sizes = [float(np.min(m.geom_size[g][m.geom_size[g] > 0])) for g in (g1, g2)
                 if int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_PLANE)]
        if depth > 0.5 * min(sizes):
            left_out.append(LeftOut("colliding geom", label, f"the geoms interpenetrate by "
                                    f"{depth:.4g} m in the assembled configuration"))
            continue
        b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
        mass = effective_mass(m, int(m.body_weldid[b1]), int(m.body_weldid[b2]))
        K, C = contact_spring(mujoco, m, par["solref"], par["solimp"], mass)
        params = dict(law="linear", stiffness=K, damping=C,
                      margin=max(par["margin"] - par["gap"], 0.0))
        if par["condim"] > 1 and par["friction"][0] > 0:
            params.update(friction="coulomb", mu=float(par["friction"][0]))
        name = fresh(f"contact_{label}")
        try:
            builder.add_force("contact", name, body_i=ours(b1), body_j=ours(b2),
                              shape_i=shapes[g1], shape_j=shapes[g2], **params)
        except ModelError as exc:
            left_out.append(LeftOut("colliding geom", label, str(exc)))
            continue
        detail = (f"MuJoCo's soft contact (solref {np.round(par['solref'], 6).tolist()}, "
                  f"solimp dmax {float(par['solimp'][1]):g}) as a linear law, K = {K:.4g} N/m, "
                  f"c = {C:.4g} N s/m per point")
        if par["condim"] > 3:
            detail += "; its torsional/rolling friction left out"
        left_out.append(LeftOut("contact approximation", name, detail))

