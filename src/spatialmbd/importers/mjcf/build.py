"""The compiled MuJoCo model -> a ModelBuilder: weld groups as bodies, joints, equalities, and
the list of what was left out (:mod:`.report`)."""
from __future__ import annotations

import re

import numpy as np

from ...errors import ModelError
from ...model.builder import ModelBuilder
from .contacts import add_contacts
from .geoms import GeomShapes, clean, role
from .joint_elements import JointElements
from .report import LeftOut


def _name(mujoco, m, objtype, i, fallback) -> str:
    name = mujoco.mj_id2name(m, objtype, i) or fallback
    return re.sub(r"[.\s]", "_", name)


def urdf_links_without_inertial(text) -> set:
    """Names of the URDF links that have no <inertial> element (empty for MJCF)."""
    import xml.etree.ElementTree as ET
    try:
        root = ET.fromstring(text)
    except ET.ParseError:
        return set()
    if root.tag != "robot":
        return set()
    return {link.get("name") for link in root.iter("link") if link.find("inertial") is None}


def left_out_features(mujoco, m, body_name, jname, keyframe=None, contacts=False) -> list:
    """The features of the compiled model that the import leaves out (LeftOut items) besides
    those of :mod:`.joint_elements` (limits, friction loss, springs, actuators, tendons) and,
    with ``contacts``, of :mod:`.contacts`."""
    OBJ, J = mujoco.mjtObj, mujoco.mjtJoint
    out = []
    for p in range(0 if contacts else m.npair):
        out.append(LeftOut("contact pair", _name(mujoco, m, OBJ.mjOBJ_PAIR, p, f"pair{p}"),
                           "no contact here yet"))
    for f in range(m.nflex):
        out.append(LeftOut("flex", f"flex{f}", "deformable body"))
    for j in range(m.njnt):               # (a hinge's or slide's: .joint_elements)
        dof = int(m.jnt_dofadr[j])
        if int(m.jnt_type[j]) == int(J.mjJNT_FREE) and np.any(m.dof_armature[dof:dof + 6]):
            out.append(LeftOut("armature", jname(j),
                               f"{float(np.max(m.dof_armature[dof:dof + 6])):.6g}: a free "
                               "joint's armature has no counterpart here"))
    for k in range(m.nkey):
        if keyframe is not None and mujoco.mj_id2name(m, OBJ.mjOBJ_KEY, k) == keyframe:
            continue                                      # the one the model starts from
        out.append(LeftOut("keyframe", _name(mujoco, m, OBJ.mjOBJ_KEY, k, f"key{k}"),
                           f"the model starts from {keyframe!r}" if keyframe is not None else
                           "the model starts from qpos0 (MuJoCo's reference configuration), "
                           "at rest (CLI: --keyframe NAME)"))
    if not contacts and not m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT):
        for g in range(m.ngeom):
            if role(m, g) == "collision" and m.body_weldid[m.geom_bodyid[g]] != 0:
                owner = body_name.get(int(m.body_weldid[m.geom_bodyid[g]]), "world")
                name = _name(mujoco, m, OBJ.mjOBJ_GEOM, g, f"geom{g} of {owner}")
                out.append(LeftOut("colliding geom", name, f"of body {owner!r}: no contact "
                                   "elements are added (import with contacts=True, CLI "
                                   "--contacts: docs/import.md)"))
    return out


def build(mujoco, m, d, stem, text, name=None, keyframe=None, contacts=False) -> tuple:
    """(builder, groups, left_out (LeftOut list), notes (strings)) of the compiled model in
    the configuration and with the velocities and commands of ``d`` (qpos0 at rest, or a
    keyframe's); contacts: the colliding geom pairs as contact elements (:mod:`.contacts`)."""
    OBJ, J, EQ = mujoco.mjtObj, mujoco.mjtJoint, mujoco.mjtEq
    body_name = {}
    used = {"ground", "world"}
    for b in range(1, m.nbody):
        nm = _name(mujoco, m, OBJ.mjOBJ_BODY, b, f"body{b}")
        while nm in used:
            nm += "_"
        used.add(nm)
        body_name[b] = nm

    def jname(j):
        return _name(mujoco, m, OBJ.mjOBJ_JOINT, j, f"joint{j}")

    def fresh(name):
        """``name``, made unique: MJCF names are unique per kind only, ours across kinds."""
        while name in used:
            name += "_"
        used.add(name)
        return name

    left_out = left_out_features(mujoco, m, body_name, jname, keyframe, contacts)
    notes = []
    # URDF links without <inertial>: MuJoCo fills their mass from the geoms at its default
    # density (1000 kg/m^3), an assumption the file does not make -- say so
    bare = urdf_links_without_inertial(text)
    for b in range(1, m.nbody):
        nm = mujoco.mj_id2name(m, OBJ.mjOBJ_BODY, b)
        if nm in bare and m.body_weldid[b] != 0 and m.body_mass[b] > 0:
            has_mesh = any(m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
                           for g in range(m.ngeom) if m.geom_bodyid[g] == b)
            notes.append(f"URDF link {nm!r} has no <inertial>: its mass "
                         f"{float(m.body_mass[b]):.6g} kg and inertia were computed by "
                         "MuJoCo from its collision " + ("mesh " if has_mesh else "")
                         + "geometry at 1000 kg/m^3 (give an <inertial> element)")

    # ----------------------------------------------------------------- bodies (weld groups)
    roots = [b for b in range(1, m.nbody) if m.body_weldid[b] == b]
    members = {r: [b for b in range(1, m.nbody) if m.body_weldid[b] == r] for r in roots}
    gravity = np.zeros(3) if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY) \
        else np.asarray(m.opt.gravity, dtype=float)
    model_name = m.names[:m.names.index(b"\0")].decode() if m.names else ""
    if model_name in ("", "MuJoCo Model"):
        model_name = stem or "mjcf_model"
    builder = ModelBuilder(name or re.sub(r"[.\s]", "_", model_name), gravity=gravity)
    frames = {0: (np.zeros(3), np.eye(3))}  # weld root -> (origin, axes) of our body frame
    groups = {}
    geoms = GeomShapes(mujoco, m, d)
    geoms_of = {}
    for g in range(m.ngeom):
        geoms_of.setdefault(int(m.body_weldid[m.geom_bodyid[g]]), []).append(g)
    for r in roots:
        ids = members[r]
        masses = np.array([m.body_mass[b] for b in ids])
        total = float(masses.sum())
        if not total > 0:
            raise ModelError(f"MuJoCo body {body_name[r]!r} (with the bodies welded to it: "
                             f"{[body_name[b] for b in ids]}) has no mass; give it mass and "
                             "inertia (inertial element) or geoms with a density")
        R = np.asarray(d.ximat[r], dtype=float).reshape(3, 3)
        if len(ids) == 1:
            c = np.asarray(d.xipos[r], dtype=float)
            inertia = np.asarray(m.body_inertia[r], dtype=float).tolist()
        else:
            c = sum(m.body_mass[b] * np.asarray(d.xipos[b]) for b in ids) / total
            I_world = np.zeros((3, 3))
            for b in ids:
                Rb = np.asarray(d.ximat[b], dtype=float).reshape(3, 3)
                off = np.asarray(d.xipos[b]) - c
                I_world += Rb @ np.diag(m.body_inertia[b]) @ Rb.T + m.body_mass[b] * (
                    off @ off * np.eye(3) - np.outer(off, off))
            inertia = (R.T @ I_world @ R).tolist()
        frames[r] = (c, R)
        shapes, points = [], {}
        for g in geoms_of.get(r, []):
            if geoms.visible(g):
                shapes += geoms.shapes(g, R, c)
        for s in range(m.nsite):
            if m.site_bodyid[s] in ids:
                points[_name(mujoco, m, OBJ.mjOBJ_SITE, s, f"site{s}")] = clean(
                    R.T @ (np.asarray(d.site_xpos[s]) - c))
        # the group's velocity (a keyframe's qvel): MuJoCo's (omega, v) at the root body's
        # centre of mass (mjOBJ_BODY: at xipos, world axes), moved to the group's
        motion = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, OBJ.mjOBJ_BODY, r, motion, 0)
        omega = clean(motion[:3])
        rdot = clean(motion[3:] + np.cross(motion[:3], c - np.asarray(d.xipos[r])))
        builder.add_body(body_name[r], total, inertia, r=c.tolist(), A=R, points=points,
                         shapes=shapes, rdot=rdot, omega=omega)
        groups[body_name[r]] = list(ids)
    for g in geoms_of.get(0, []):
        if geoms.visible(g):
            for s in geoms.shapes(g, np.eye(3), np.zeros(3)):
                builder.add_ground_shape(s)

    def ours(b) -> str:
        root = int(m.body_weldid[b])
        return "ground" if root == 0 else body_name[root]

    # ----------------------------------------------------------------- joints
    single = {}                           # MuJoCo joint id -> our joint (one hinge or slide)
    joint_of = {}                         # MuJoCo joint id -> (our joint, its type)
    for r in roots:
        jids = [j for b in members[r] for j in range(m.body_jntadr[b],
                                                     m.body_jntadr[b] + m.body_jntnum[b])
                if m.body_jntnum[b] > 0]
        if not jids:
            continue
        parent = ours(int(m.body_parentid[r]))
        child = body_name[r]
        types = [int(m.jnt_type[j]) for j in jids]
        anchors = [np.asarray(d.xanchor[j], dtype=float) for j in jids]
        axes = [np.asarray(d.xaxis[j], dtype=float) for j in jids]
        names = [jname(j) for j in jids]
        same_point = all(np.linalg.norm(a - anchors[0]) < 1e-9 for a in anchors)
        if types == [int(J.mjJNT_FREE)]:
            continue                      # a free body: no joint
        if len(jids) == 1:
            kind = {int(J.mjJNT_HINGE): "revolute", int(J.mjJNT_SLIDE): "translational",
                    int(J.mjJNT_BALL): "spherical"}[types[0]]
            geometry = {"point": anchors[0].tolist()}
            if kind != "spherical":
                geometry["axis"] = axes[0].tolist()
            joint_name = fresh(names[0])
            builder.add_joint(kind, joint_name, parent, child, **geometry)
            if kind != "spherical":
                single[jids[0]] = joint_name
        elif (types == [int(J.mjJNT_HINGE)] * 2 and same_point
              and abs(axes[0] @ axes[1]) < 1e-9):
            joint_name = fresh("_".join(names))
            builder.add_joint("universal", joint_name, parent, child,
                              point=anchors[0].tolist(), axis=axes[0].tolist(),
                              axis2=axes[1].tolist())
        elif (all(t == int(J.mjJNT_HINGE) for t in types) and len(types) >= 3 and same_point
              and np.linalg.matrix_rank(np.array(axes), tol=1e-6) == 3):
            joint_name = fresh("_".join(names))
            builder.add_joint("spherical", joint_name, parent, child,
                              point=anchors[0].tolist())
        elif (sorted(types) == sorted([int(J.mjJNT_HINGE), int(J.mjJNT_SLIDE)])
              and np.linalg.norm(np.cross(axes[0], axes[1])) < 1e-9
              and np.linalg.norm(np.cross(anchors[1] - anchors[0], axes[0])) < 1e-9):
            h = types.index(int(J.mjJNT_HINGE))
            joint_name = fresh("_".join(names))
            builder.add_joint("cylindrical", joint_name, parent, child,
                              point=anchors[h].tolist(), axis=axes[h].tolist())
        else:
            left_out.append(LeftOut("joint combination", "_".join(names),
                                    f"joints {names} of body {child!r}: this combination has "
                                    "no single joint type here"))
            continue
        for j in jids:
            joint_of[j] = (joint_name, builder.joints[joint_name].type)

    # ----------------------------------------------------------------- joint elements
    # limits, friction loss, springs and dampers, actuators (fixed tendons: after equalities)
    by_name = {body_name[r]: r for r in roots}

    def local_of(body, x_world):
        if body == "ground":
            return np.asarray(x_world, dtype=float).tolist()
        c, R = frames[by_name[body]]
        return clean(R.T @ (np.asarray(x_world, dtype=float) - c))

    elements = JointElements(mujoco, m, d, builder, joint_of=joint_of, single=single,
                             local_of=local_of, fresh=fresh, jname=jname, left_out=left_out,
                             qref=d.qpos, ctrl=d.ctrl)
    elements.add_joint_features()
    elements.add_actuators()

    # ----------------------------------------------------------------- equality constraints
    def local(b, x_world):
        root = int(m.body_weldid[b])
        c, R = frames[root]
        return clean(R.T @ (np.asarray(x_world, dtype=float) - c))

    for e in range(m.neq):
        ename = _name(mujoco, m, OBJ.mjOBJ_EQUALITY, e, f"equality{e}")
        etype = int(m.eq_type[e])
        if etype == int(EQ.mjEQ_JOINT) and m.eq_active0[e]:
            _joint_equality(m, e, ename, single, builder, fresh, left_out, d.qpos)
            continue
        if etype == int(EQ.mjEQ_TENDON):
            continue                      # JointElements.add_tendons
        if etype not in (int(EQ.mjEQ_CONNECT), int(EQ.mjEQ_WELD)):
            left_out.append(LeftOut("equality", ename, f"{EQ(etype).name[5:].lower()} "
                                    "equality: no exact coupling constraint here"))
            continue
        if not m.eq_active0[e]:
            left_out.append(LeftOut("equality", ename, "inactive: constraints cannot be "
                                    "switched"))
            continue
        o1, o2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        data = np.asarray(m.eq_data[e], dtype=float)
        if int(m.eq_objtype[e]) == int(OBJ.mjOBJ_SITE):
            b1, b2 = int(m.site_bodyid[o1]), int(m.site_bodyid[o2])
            x1, x2 = np.asarray(d.site_xpos[o1]), np.asarray(d.site_xpos[o2])
        else:
            b1, b2 = o1, o2
            x1 = d.xpos[b1] + d.xmat[b1].reshape(3, 3) @ data[0:3]
            x2 = d.xpos[b2] + d.xmat[b2].reshape(3, 3) @ data[3:6]
        bi, bj = ours(b1), ours(b2)
        if bi == bj:
            continue                      # both in one weld group: already rigid
        kind = "spherical" if etype == int(EQ.mjEQ_CONNECT) else "fixed"
        if bi == "ground":
            # ground points are global; make the moving body body j
            bi, bj, x1, x2, b1, b2 = bj, bi, x2, x1, b2, b1
        geometry = {"point_i": local(b1, x1)}
        geometry["point_j"] = np.asarray(x2, dtype=float).tolist() if bj == "ground" else \
            local(b2, x2)
        if kind == "fixed":
            # welded as in the reference configuration (MuJoCo's relpose there: the residual
            # check below makes sure it is)
            geometry = {"point": np.asarray(x1, dtype=float).tolist()}
        builder.add_joint(kind, fresh(ename), bi, bj, **geometry)
    elements.add_tendons()              # fixed tendons held by tendon equalities
    if contacts:
        add_contacts(mujoco, m, d, builder, ours=ours, frames=frames, fresh=fresh,
                     geom_name=lambda g: _name(mujoco, m, OBJ.mjOBJ_GEOM, g, f"geom{g}"),
                     left_out=left_out)
    # loop closures must hold at qpos0, or they would be assembled differently
    _check_equalities_hold(mujoco, m, d, left_out)
    return builder, groups, left_out, notes


def _joint_equality(m, e, ename, single, builder, fresh, left_out, qref) -> None:
    """MJCF <equality><joint joint1 joint2 polycoef="a0 a1 0 0 0">: MuJoCo's
    q1 - q1_0 = a0 + a1 (q2 - q2_0) (q_0: qpos0), exactly our coupler
    x1 - a1 x2 = a0 + a1 s2 - s1 with x = q - qref measured from the assembly and
    s = qref - q_0 (0 unless a keyframe is the assembly)."""
    j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
    poly = np.asarray(m.eq_data[e][:5], dtype=float)
    if j2 < 0:
        left_out.append(LeftOut("equality", ename, "joint equality with one joint (it locks "
                                "the joint: use a driver)"))
        return
    if np.any(poly[2:] != 0):
        left_out.append(LeftOut("equality", ename, f"joint equality with a nonlinear "
                                f"polycoef {poly.tolist()} (only a0 + a1 x couples exactly)"))
        return
    if j1 not in single or j2 not in single:
        left_out.append(LeftOut("equality", ename, "joint equality: its joints must each be a "
                                "single hinge or slide"))
        return
    s1, s2 = (float(qref[m.jnt_qposadr[j]] - m.qpos0[m.jnt_qposadr[j]]) for j in (j1, j2))
    try:
        builder.add_coupler("coupler", fresh(ename), single[j1], single[j2], c1=1.0,
                            c2=-float(poly[1]), c0=float(poly[0]) + float(poly[1]) * s2 - s1)
    except ModelError as exc:
        left_out.append(LeftOut("equality", ename, f"joint equality: {exc}"))


def _check_equalities_hold(mujoco, m, d, left_out) -> None:
    """Equality rows of MuJoCo's constraint set must vanish at qpos0 (the model's q0)."""
    rows = np.flatnonzero(np.asarray(d.efc_type) == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY))
    seen = set()
    for r in rows:
        e = int(d.efc_id[r])
        if int(m.eq_type[e]) in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)) \
                and abs(float(d.efc_pos[r])) > 1e-6 and e not in seen:
            seen.add(e)
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or f"equality{e}"
            left_out.append(LeftOut("equality", name, f"does not hold in the reference "
                                    f"configuration (residual {float(d.efc_pos[r]):.3g}); "
                                    "place the bodies so that it holds"))
