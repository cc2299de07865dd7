"""Turning the builder's specs into the frozen Model: joint geometry in body axes, groups by type."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..constraints import DRIVER_TYPES, JOINT_TYPES, JointGeometry
from ..constraints.drivers import COORDINATES
from ..errors import ModelError
from ..rotations import A_from_p
from .specs import BodySpec, JointSpec

GROUND = "ground"

LOCAL_NAME = {"point": "point_i", "point2": "point_j", "axis": "axis_i", "axis2": "axis_j"}


def _pose(bodies: dict, name: str):
    if name == GROUND:
        return np.zeros(3), np.eye(3), {}
    body: BodySpec = bodies[name]
    return body.r, A_from_p(body.p), body.points


def _unit(vec, what) -> np.ndarray:
    vec = np.array(vec, dtype=float).reshape(-1)
    if vec.size != 3 or not np.all(np.isfinite(vec)):
        raise ModelError(f"{what}: expected 3 finite numbers, got {vec.tolist()}")
    norm = np.linalg.norm(vec)
    if norm < 1e-12:
        raise ModelError(f"{what}: zero-length axis {vec.tolist()}; give a direction")
    return vec / norm


def _perpendicular(u: np.ndarray) -> np.ndarray:
    """A deterministic unit vector normal to the unit vector u."""
    helper = np.eye(3)[np.argmin(np.abs(u))]
    a = helper - u * (helper @ u)
    return a / np.linalg.norm(a)


def _triad(u: np.ndarray, ref, what: str) -> np.ndarray:
    """Columns [u, a, b] with a the part of ``ref`` normal to u (or a default normal), b = u x a."""
    if ref is None:
        a = _perpendicular(u)
    else:
        ref = np.array(ref, dtype=float).reshape(3)
        a = ref - u * (ref @ u)
        if np.linalg.norm(a) < 1e-9 * max(1.0, np.linalg.norm(ref)):
            raise ModelError(f"{what}: reference vector {ref.tolist()} is parallel to the axis "
                             f"{u.tolist()}; give a direction normal to the axis")
        a = a / np.linalg.norm(a)
    return np.column_stack([u, a, np.cross(u, a)])


def _local_point(value, points: dict, what: str) -> np.ndarray:
    if isinstance(value, str):
        if value not in points:
            raise ModelError(f"{what}: the body has no point named {value!r} (points: "
                             f"{', '.join(points) or 'none'})")
        return np.array(points[value], dtype=float)
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: expected 3 finite numbers or a point name, got {value!r}")
    return arr


def resolve_joint(spec: JointSpec, bodies: dict) -> JointGeometry:
    """Local geometry (s_i, s_j, R_i, R_j, length) of one joint, from global or local input."""
    what = f"joints[{spec.name!r}]"
    g = spec.geometry
    jtype = JOINT_TYPES[spec.type]
    needs = jtype.inputs
    r_i, A_i, pts_i = _pose(bodies, spec.body_i)
    r_j, A_j, pts_j = _pose(bodies, spec.body_j)
    local = any(k in g for k in ("point_i", "point_j", "axis_i", "axis_j", "ref_i", "ref_j"))

    if not local:
        missing = [k for k in sorted(needs) if k not in g]
        if missing:
            raise ModelError(f"{what}: a {spec.type} joint needs {', '.join(missing)} (global, "
                             "in the assembled configuration) or the local form "
                             + ", ".join(LOCAL_NAME[k] for k in missing))
        extra = [k for k in ("point2", "axis2") if k in g and k not in needs]
        if extra:
            raise ModelError(f"{what}: a {spec.type} joint takes no {', '.join(extra)}")
        P_i = _vector3(g.get("point", r_j), f"{what}.point")
        P_j = _vector3(g["point2"], f"{what}.point2") if "point2" in needs else P_i
        s_i = A_i.T @ (P_i - r_i)
        s_j = A_j.T @ (P_j - r_j)
        u = _unit(g["axis"], f"{what}.axis") if "axis" in g else np.array([0.0, 0.0, 1.0])
        T = _triad(u, g.get("reference"), f"{what}.reference")
        if "axis2" in needs:
            u2 = _unit(g["axis2"], f"{what}.axis2")
            T2 = _triad(u2, None, f"{what}.axis2")
        else:
            T2 = T
        R_i, R_j = A_i.T @ T, A_j.T @ T2
    else:
        if "point" in needs and "point_i" not in g:
            raise ModelError(f"{what}: local geometry needs point_i (in body {spec.body_i!r} "
                             "axes)")
        s_i = _local_point(g.get("point_i", (0, 0, 0)), pts_i, f"{what}.point_i")
        if "point_j" in g:
            s_j = _local_point(g["point_j"], pts_j, f"{what}.point_j")
        elif "point2" in needs:
            raise ModelError(f"{what}: local geometry of a {spec.type} joint needs point_j")
        else:
            s_j = A_j.T @ (r_i + A_i @ s_i - r_j)       # the same point, as assembled
        if "axis" in needs or "axis_i" in g:
            if "axis_i" not in g:
                raise ModelError(f"{what}: local geometry of a {spec.type} joint needs axis_i")
            u_i = _unit(g["axis_i"], f"{what}.axis_i")
        else:
            u_i = np.array([0.0, 0.0, 1.0])
        R_i = _triad(u_i, g.get("ref_i"), f"{what}.ref_i")
        if "axis_j" in g:
            u_j = _unit(g["axis_j"], f"{what}.axis_j")
        elif "axis2" in needs:
            raise ModelError(f"{what}: local geometry of a {spec.type} joint needs axis_j")
        else:
            u_j = A_j.T @ A_i @ u_i
        if "ref_j" in g:
            R_j = _triad(u_j, g["ref_j"], f"{what}.ref_j")
        else:
            guess = A_j.T @ A_i @ R_i[:, 1]
            guess = guess - u_j * (guess @ u_j)
            R_j = _triad(u_j, guess if np.linalg.norm(guess) > 1e-6 else None, f"{what}.ref_j")
        P_i, P_j = r_i + A_i @ s_i, r_j + A_j @ s_j
    jtype.check_assembled(what, A_i @ R_i[:, 0], A_j @ R_j[:, 0])
    param = jtype.resolve_parameters(spec.params, P_i, P_j, what)
    return JointGeometry(s_i=s_i[None], s_j=s_j[None], R_i=R_i[None], R_j=R_j[None],
                         param=param[None])


def _vector3(value, what) -> np.ndarray:
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: expected 3 finite numbers, got {value!r}")
    return arr


def compile_model(builder):
    """The frozen Model of a ModelBuilder (all checks that need the whole model happen here)."""
    from .model import Model
    if not builder.bodies:
        raise ModelError("the model has no bodies; add at least one with add_body")
    names = list(builder.bodies)
    index = {name: k for k, name in enumerate(names)}
    nb = len(names)
    index[GROUND] = nb
    bodies = [builder.bodies[n] for n in names]

    groups = []
    joint_geometry = {}
    by_type: dict[str, list] = {}
    for spec in builder.joints.values():
        geom = resolve_joint(spec, builder.bodies)
        joint_geometry[spec.name] = geom
        by_type.setdefault(spec.type, []).append(spec)
    for jtype, specs in by_type.items():
        geoms = [joint_geometry[s.name] for s in specs]
        group = JOINT_TYPES[jtype]([s.name for s in specs],
                                   [index[s.body_i] for s in specs],
                                   [index[s.body_j] for s in specs], JointGeometry.stack(geoms))
        groups.append(group)

    groups += _coupler_groups(builder, index, joint_geometry)

    drivers_by_kind: dict[str, list] = {}
    for spec in builder.drivers.values():
        drivers_by_kind.setdefault(spec.kind, []).append(spec)
    for kind, specs in drivers_by_kind.items():
        if kind == "coordinate":
            zero = JointGeometry(np.zeros((1, 3)), np.zeros((1, 3)), np.eye(3)[None],
                                 np.eye(3)[None], np.zeros((1, 0)))
            geom = JointGeometry.stack([zero] * len(specs))
            bi = [index[s.body] for s in specs]
            bj = [nb] * len(specs)
            coord = [COORDINATES.index(s.coordinate) for s in specs]
        else:
            geom = JointGeometry.stack([replace(joint_geometry[s.joint], param=np.zeros((1, 0)))
                                        for s in specs])
            bi = [index[builder.joints[s.joint].body_i] for s in specs]
            bj = [index[builder.joints[s.joint].body_j] for s in specs]
            coord = None
        groups.append(DRIVER_TYPES[kind]([s.name for s in specs], bi, bj, geom,
                                         laws=[s.law for s in specs], coordinate=coord))

    from ..forces import build_force_groups
    force_groups = build_force_groups(builder, index, resolve_joint)

    return Model(
        name=builder.name,
        gravity=np.array(builder.gravity, dtype=float),
        body_names=tuple(names),
        mass=np.array([b.mass for b in bodies]),
        inertia=np.array([b.inertia for b in bodies]),
        q0=np.array([np.concatenate([b.r, b.p]) for b in bodies]),
        v0=np.array([np.concatenate([b.rdot, b.omega]) for b in bodies]),
        points={f"{b.name}.{k}": (index[b.name], np.array(v)) for b in bodies
                for k, v in b.points.items()},
        constraint_groups=tuple(groups),
        force_groups=tuple(force_groups),
        builder_state=_snapshot(builder),
    )


def _snapshot(builder) -> dict:
    """A deep copy of the builder's specs, kept by the Model for files and round trips."""
    import copy
    return dict(name=builder.name, gravity=np.array(builder.gravity),
                bodies=copy.deepcopy(builder.bodies), joints=copy.deepcopy(builder.joints),
                drivers=copy.deepcopy(builder.drivers), forces=copy.copy(builder.forces),
                couplers=copy.deepcopy(getattr(builder, "couplers", {})),
                ground_shapes=copy.deepcopy(builder.ground_shapes))


def _coupler_groups(builder, index: dict, joint_geometry: dict) -> list:
    """One group per coupler type: the row on the (at most two) moving bodies of the two
    joints, the joints' geometry and the coefficients in the parameter block."""
    from ..constraints.couplers import COUPLER_TYPES, joint_block
    couplers = getattr(builder, "couplers", {})
    if not couplers:
        return []
    nb = len(builder.bodies)
    q0 = np.array([np.concatenate([b.r, b.p]) for b in builder.bodies.values()])
    by_type: dict[str, list] = {}
    for spec in couplers.values():
        by_type.setdefault(spec.type, []).append(spec)
    groups = []
    for ctype, specs in by_type.items():
        cls = COUPLER_TYPES[ctype]
        rows, params = [], []
        for spec in specs:
            what = f"couplers[{spec.name!r}]"
            j1, j2 = builder.joints[spec.joint1], builder.joints[spec.joint2]
            moving = []
            for j in (j1, j2):
                for body in (j.body_i, j.body_j):
                    if index[body] < nb and index[body] not in moving:
                        moving.append(index[body])
            row = (moving + [nb, nb])[:2]
            c1, c2, c0 = cls.coefficients(spec.params, what)
            params.append(np.concatenate([
                joint_block(j1, joint_geometry[j1.name], index, tuple(row), q0, what, "joint1"),
                joint_block(j2, joint_geometry[j2.name], index, tuple(row), q0, what, "joint2"),
                [c1, c2, c0]]))
            rows.append(row)
        n = len(specs)
        geom = JointGeometry(np.zeros((n, 3)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                             np.tile(np.eye(3), (n, 1, 1)), np.array(params))
        groups.append(cls([s.name for s in specs], [r[0] for r in rows], [r[1] for r in rows],
                          geom))
    return groups
