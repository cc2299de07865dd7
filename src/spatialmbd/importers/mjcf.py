"""Import MJCF and URDF files through MuJoCo's compiler (optional extra ``spatialmbd[mjcf]``).

MuJoCo parses both formats, applies its defaults, computes mass properties from geoms where a
body gives none (boxes, spheres, cylinders, capsules, ellipsoids and meshes, at their density),
and compiles a model in its reference configuration ``qpos0``.  This module reads that compiled
model and builds the equivalent :class:`~spatialmbd.model.builder.ModelBuilder`:

* bodies: one spatialmbd body per MuJoCo *weld group* (a body and the children welded to it
  without joints; a group welded to the world is part of the ground).  The body frame is the
  inertial frame of the group's root body (its centre of mass and principal axes, MuJoCo's
  ``ipos``/``iquat``), so a group of one body has a diagonal inertia; a larger group gets the
  combined mass, centre of mass and full inertia tensor (parallel-axis theorem).  Geoms become
  display shapes; sites become named points.
* joints: hinge -> revolute, slide -> translational, ball -> spherical, free -> none (a free
  body).  Several joints in one body map when they form a joint of ours exactly: two hinges
  through one point with perpendicular axes -> universal, three or more hinges through one point
  spanning space -> spherical, hinge + slide on one axis -> cylindrical.
  Hinge stiffness / damping -> a rotational_spring_damper (exact: tau = -k (q - q_spring) - c qdot).
* equality constraints: connect -> spherical, weld -> fixed (both exact: MuJoCo's soft loop
  closure becomes a rigid one).
* gravity: ``opt.gravity`` (zero when gravity is disabled).

Everything with no exact counterpart is named: by default (``strict=True``) a
:class:`~spatialmbd.errors.ModelError` lists every such feature (tendons, actuators, joint and
tendon equalities, explicit contact pairs, armature, friction loss, damping/stiffness of slide
and ball joints, ...); with ``strict=False`` they are left out with an
:class:`MJCFImportWarning` that lists them.  Joint limits and geom collisions only act when
reached / touching: they are always left out with a warning naming them (spatialmbd has neither
limits nor contact).
"""
from __future__ import annotations

import pathlib
import re
import warnings
from dataclasses import dataclass, field
from typing import Optional, Union

import numpy as np

from ..errors import ModelError
from ..model.builder import ModelBuilder
from ..rotations import p_from_A

__all__ = ["import_mjcf", "read_mjcf", "MJCFImport", "MJCFImportWarning"]

_PALETTE_GREY = (0.5, 0.5, 0.5)


class MJCFImportWarning(UserWarning):
    """An MJCF/URDF feature was left out of the imported model (the message names it)."""


@dataclass
class MJCFImport:
    """The result of :func:`read_mjcf`.

    builder: the ModelBuilder. groups: spatialmbd body name -> MuJoCo body ids merged into it.
    left_out: descriptions of the features not imported (also reported as warnings).
    mj_model: the compiled ``mujoco.MjModel`` (for comparisons).
    """

    builder: ModelBuilder
    groups: dict
    left_out: list = field(default_factory=list)
    mj_model: object = None


def _mujoco():
    try:
        import mujoco
    except ImportError:
        raise ModelError("importing MJCF/URDF needs MuJoCo's compiler: pip install "
                         "'spatialmbd[mjcf]'") from None
    return mujoco


def _urdf_links_without_inertial(source) -> set:
    """Names of the URDF links that have no <inertial> element (empty for MJCF)."""
    import xml.etree.ElementTree as ET
    text = str(source)
    try:
        root = ET.fromstring(text) if text.lstrip().startswith("<") else \
            ET.parse(str(source)).getroot()
    except (ET.ParseError, OSError):
        return set()
    if root.tag != "robot":
        return set()
    return {link.get("name") for link in root.iter("link") if link.find("inertial") is None}


def _compile(source) -> tuple:
    mujoco = _mujoco()
    text = str(source)
    try:
        if isinstance(source, (str, pathlib.Path)) and not text.lstrip().startswith("<"):
            path = pathlib.Path(source)
            if not path.is_file():
                raise ModelError(f"no such MJCF/URDF file: {source}")
            return mujoco.MjModel.from_xml_path(str(path)), path.stem
        return mujoco.MjModel.from_xml_string(text), None
    except ValueError as exc:  # MuJoCo's compiler errors
        raise ModelError(f"MuJoCo could not compile {source if len(text) < 200 else 'the XML'}"
                         f": {exc}") from None


def _name(mujoco, m, objtype, i, fallback) -> str:
    name = mujoco.mj_id2name(m, objtype, i) or fallback
    return re.sub(r"[.\s]", "_", name)


def _hex(rgba) -> Optional[str]:
    r, g, b = (float(x) for x in rgba[:3])
    if np.allclose((r, g, b), _PALETTE_GREY):
        return None                       # MuJoCo's default grey: let the viewer pick colours
    return "#" + "".join(f"{int(round(255 * min(max(c, 0.0), 1.0))):02x}" for c in (r, g, b))


def _clean(values, scale: float = 1.0) -> list:
    """Plain floats with round-off (below 1e-12 of the scale) set to zero."""
    a = np.asarray(values, dtype=float)
    a = np.where(np.abs(a) < 1e-12 * max(scale, float(np.max(np.abs(a), initial=0.0))), 0.0, a)
    return [float(x) + 0.0 for x in a]


def _geom_shapes(mujoco, m, d, g, R, c) -> list:
    """Display shapes of geom g in the frame (origin c, axes R: body -> global)."""
    G = mujoco.mjtGeom
    kind = int(m.geom_type[g])
    size = np.asarray(m.geom_size[g], dtype=float)
    Rg = R.T @ np.asarray(d.geom_xmat[g], dtype=float).reshape(3, 3)
    center = R.T @ (np.asarray(d.geom_xpos[g], dtype=float) - c)
    color = _hex(m.geom_rgba[g])
    extra = {"color": color} if color else {}
    zaxis = Rg[:, 2]
    if kind == G.mjGEOM_PLANE:
        return []                          # an infinite plane: the viewer draws its own floor
    if kind == G.mjGEOM_SPHERE:
        return [dict(type="sphere", radius=float(size[0]), center=_clean(center), **extra)]
    if kind == G.mjGEOM_CYLINDER:
        return [dict(type="cylinder", radius=float(size[0]), length=float(2 * size[1]),
                     center=_clean(center), axis=_clean(zaxis), **extra)]
    if kind == G.mjGEOM_CAPSULE:
        return [dict(type="capsule", radius=float(size[0]), length=float(2 * size[1]),
                     center=_clean(center), axis=_clean(zaxis), **extra)]
    if kind == G.mjGEOM_BOX or kind == G.mjGEOM_ELLIPSOID:
        return [dict(type="box", size=(2 * size[:3]).tolist(), center=_clean(center),
                     p=_clean(p_from_A(Rg)), **extra)]
    if kind == G.mjGEOM_MESH and int(m.geom_dataid[g]) >= 0:
        # the compiled mesh, in the geom frame (MuJoCo re-centres it on the geom's pos/quat)
        k = int(m.geom_dataid[g])
        v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
        f0, nf = int(m.mesh_faceadr[k]), int(m.mesh_facenum[k])
        vertices = np.asarray(m.mesh_vert[v0:v0 + nv], dtype=float)
        faces = np.asarray(m.mesh_face[f0:f0 + nf], dtype=np.int64)
        return [dict(type="mesh", vertices=[_clean(v) for v in vertices],
                     faces=faces.tolist(), center=_clean(center), p=_clean(p_from_A(Rg)),
                     **extra)]
    # hfields, sdf: their bounding box in the geom frame
    aabb = np.asarray(m.geom_aabb[g], dtype=float)
    half = np.maximum(aabb[3:], 1e-6)
    return [dict(type="box", size=(2 * half).tolist(), center=_clean(center + Rg @ aabb[:3]),
                 p=_clean(p_from_A(Rg)), **extra)]


def read_mjcf(source: Union[str, pathlib.Path], *, strict: bool = True,
              name: Optional[str] = None) -> MJCFImport:
    """Compile an MJCF or URDF file (or XML text) with MuJoCo and build the spatialmbd model.

    source: path of a .xml (MJCF) or .urdf file, or the XML text. strict: raise a ModelError
    naming every feature with no exact counterpart (True), or leave them out with a warning
    (False). name: the model name (default: the file name).
    """
    mujoco = _mujoco()
    m, stem = _compile(source)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)               # qpos = qpos0: the reference configuration
    OBJ, J, EQ = mujoco.mjtObj, mujoco.mjtJoint, mujoco.mjtEq
    unsupported: list[str] = []           # no exact counterpart (error when strict)
    inactive: list[str] = []              # only act when reached / touching (always warned)

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

    # ----------------------------------------------------------------- features left out
    for t in range(m.ntendon):
        unsupported.append(f"tendon {_name(mujoco, m, OBJ.mjOBJ_TENDON, t, f'tendon{t}')!r}")
    for u in range(m.nu):
        unsupported.append(f"actuator {_name(mujoco, m, OBJ.mjOBJ_ACTUATOR, u, f'actuator{u}')!r}"
                           " (actuator dynamics and forces)")
    for p in range(m.npair):
        unsupported.append(f"contact pair {_name(mujoco, m, OBJ.mjOBJ_PAIR, p, f'pair{p}')!r} "
                           "(spatialmbd has no contact yet)")
    if m.nflex:
        unsupported.append(f"{m.nflex} flex object(s) (deformable bodies)")
    for j in range(m.njnt):
        dof = int(m.jnt_dofadr[j])
        ndof = {int(J.mjJNT_FREE): 6, int(J.mjJNT_BALL): 3}.get(int(m.jnt_type[j]), 1)
        dofs = slice(dof, dof + ndof)
        if np.any(m.dof_armature[dofs] != 0):
            unsupported.append(f"armature of joint {jname(j)!r}")
        if np.any(m.dof_frictionloss[dofs] != 0):
            unsupported.append(f"frictionloss of joint {jname(j)!r}")
        if m.jnt_limited[j]:
            inactive.append(f"limits of joint {jname(j)!r}")
        springy = m.jnt_stiffness[j] != 0 or np.any(m.dof_damping[dofs] != 0)
        if springy and int(m.jnt_type[j]) != int(J.mjJNT_HINGE):
            unsupported.append(f"stiffness/damping of {J(int(m.jnt_type[j])).name[6:].lower()} "
                               f"joint {jname(j)!r} (only hinge springs map exactly)")
    if m.nkey:
        keys = [_name(mujoco, m, OBJ.mjOBJ_KEY, k, f"key{k}") for k in range(m.nkey)]
        inactive.append(f"keyframes {keys} are not used: the model starts from qpos0 (MuJoCo's "
                        "reference configuration), at rest")
    contact_on = not (m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_CONTACT))
    if contact_on:
        colliding = [_name(mujoco, m, OBJ.mjOBJ_GEOM, g,
                           f"geom{g} of {body_name.get(int(m.geom_bodyid[g]), 'world')}")
                     for g in range(m.ngeom)
                     if (m.geom_contype[g] or m.geom_conaffinity[g])
                     and m.body_weldid[m.geom_bodyid[g]] != 0]
        if colliding:
            shown = ", ".join(repr(x) for x in colliding[:8])
            more = f" and {len(colliding) - 8} more" if len(colliding) > 8 else ""
            inactive.append(f"collisions of geoms {shown}{more} (no contact yet)")

    # URDF links without <inertial>: MuJoCo fills their mass from the geoms at its default
    # density (1000 kg/m^3), an assumption the file does not make -- say so
    bare = _urdf_links_without_inertial(source)
    for b in range(1, m.nbody):
        nm = mujoco.mj_id2name(m, OBJ.mjOBJ_BODY, b)
        if nm in bare and m.body_weldid[b] != 0 and m.body_mass[b] > 0:
            has_mesh = any(m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
                           for g in range(m.ngeom) if m.geom_bodyid[g] == b)
            inactive.append(f"URDF link {nm!r} has no <inertial>: its mass "
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
        for g in range(m.ngeom):
            if m.geom_bodyid[g] in ids and m.geom_rgba[g][3] > 0:
                shapes += _geom_shapes(mujoco, m, d, g, R, c)
        for s in range(m.nsite):
            if m.site_bodyid[s] in ids:
                points[_name(mujoco, m, OBJ.mjOBJ_SITE, s, f"site{s}")] = _clean(
                    R.T @ (np.asarray(d.site_xpos[s]) - c))
        builder.add_body(body_name[r], total, inertia, r=c.tolist(), A=R, points=points,
                         shapes=shapes)
        groups[body_name[r]] = list(ids)
    ground_shapes = []
    for g in range(m.ngeom):
        if m.body_weldid[m.geom_bodyid[g]] == 0 and m.geom_rgba[g][3] > 0:
            ground_shapes += _geom_shapes(mujoco, m, d, g, np.eye(3), np.zeros(3))
    for s in ground_shapes:
        builder.add_ground_shape(s)

    def ours(b) -> str:
        root = int(m.body_weldid[b])
        return "ground" if root == 0 else body_name[root]

    # ----------------------------------------------------------------- joints
    single = {}                           # MuJoCo joint id -> our joint (one hinge or slide)
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
            unsupported.append(f"joints {names} of body {child!r} (this combination has no "
                               "single joint type here)")
            continue
        for j, jn, t in zip(jids, names, types):
            k, c = float(m.jnt_stiffness[j]), float(m.dof_damping[m.jnt_dofadr[j]])
            if t == int(J.mjJNT_HINGE) and len(jids) == 1 and (k != 0 or c != 0):
                q0 = float(m.qpos0[m.jnt_qposadr[j]])
                rest = float(m.qpos_spring[m.jnt_qposadr[j]]) - q0
                builder.add_force("rotational_spring_damper", fresh(f"{jn}_spring"),
                                  joint=joint_name, stiffness=k, damping=c, rest_angle=rest)
            elif t == int(J.mjJNT_HINGE) and (k != 0 or c != 0):
                unsupported.append(f"stiffness/damping of joint {jn!r} (part of a combined "
                                   "joint)")

    # ----------------------------------------------------------------- equality constraints
    def local(b, x_world):
        root = int(m.body_weldid[b])
        c, R = frames[root]
        return _clean(R.T @ (np.asarray(x_world, dtype=float) - c))

    for e in range(m.neq):
        ename = _name(mujoco, m, OBJ.mjOBJ_EQUALITY, e, f"equality{e}")
        etype = int(m.eq_type[e])
        if etype == int(EQ.mjEQ_JOINT) and m.eq_active0[e]:
            _joint_equality(m, e, ename, single, builder, fresh, unsupported)
            continue
        if etype not in (int(EQ.mjEQ_CONNECT), int(EQ.mjEQ_WELD)):
            unsupported.append(f"{EQ(etype).name[5:].lower()} equality {ename!r} (no exact "
                               "coupling constraint here)")
            continue
        if not m.eq_active0[e]:
            unsupported.append(f"inactive equality {ename!r} (constraints cannot be switched)")
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
    # loop closures must hold at qpos0, or they would be assembled differently
    _check_equalities_hold(mujoco, m, d, unsupported)

    left_out = []
    if unsupported:
        text = ("MJCF/URDF features with no exact counterpart in spatialmbd: "
                + "; ".join(unsupported))
        if strict:
            raise ModelError(text + ". Remove them from the file, or import with strict=False "
                             "(CLI: --lenient) to leave them out with a warning")
        warnings.warn(text + " -- left out", MJCFImportWarning, stacklevel=2)
        left_out += unsupported
    if inactive:
        warnings.warn("note (limits and contacts are left out: they act only when reached or "
                      "touching, and spatialmbd has neither yet; keyframes are not used): "
                      + "; ".join(inactive),
                      MJCFImportWarning, stacklevel=2)
        left_out += inactive
    return MJCFImport(builder=builder, groups=groups, left_out=left_out, mj_model=m)


def _joint_equality(m, e, ename, single, builder, fresh, unsupported) -> None:
    """MJCF <equality><joint joint1 joint2 polycoef="a0 a1 0 0 0">: MuJoCo's
    q1 - q1_ref = a0 + a1 (q2 - q2_ref), exactly our coupler q1 - a1 q2 = a0 (joint coordinates
    measured from the reference configuration, which is ours as assembled)."""
    j1, j2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
    poly = np.asarray(m.eq_data[e][:5], dtype=float)
    if j2 < 0:
        unsupported.append(f"joint equality {ename!r} with one joint (it locks the joint: use "
                           "a driver)")
        return
    if np.any(poly[2:] != 0):
        unsupported.append(f"joint equality {ename!r} with a nonlinear polycoef "
                           f"{poly.tolist()} (only a0 + a1 x couples exactly)")
        return
    if j1 not in single or j2 not in single:
        unsupported.append(f"joint equality {ename!r}: its joints must each be a single hinge "
                           "or slide")
        return
    try:
        builder.add_coupler("coupler", fresh(ename), single[j1], single[j2], c1=1.0,
                            c2=-float(poly[1]), c0=float(poly[0]))
    except ModelError as exc:
        unsupported.append(f"joint equality {ename!r}: {exc}")


def _check_equalities_hold(mujoco, m, d, unsupported) -> None:
    """Equality rows of MuJoCo's constraint set must vanish at qpos0 (the model's q0)."""
    rows = np.flatnonzero(np.asarray(d.efc_type) == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY))
    for r in rows:
        e = int(d.efc_id[r])
        if int(m.eq_type[e]) in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)) \
                and abs(float(d.efc_pos[r])) > 1e-6:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or f"equality{e}"
            msg = (f"equality {name!r} does not hold in the reference configuration "
                   f"(residual {float(d.efc_pos[r]):.3g}); place the bodies so that it holds")
            if msg not in unsupported:
                unsupported.append(msg)


def import_mjcf(source, *, strict: bool = True, name: Optional[str] = None) -> ModelBuilder:
    """The ModelBuilder of an MJCF/URDF file (see :func:`read_mjcf`)."""
    return read_mjcf(source, strict=strict, name=name).builder

