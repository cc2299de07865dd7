"""Model file -> ModelBuilder: every section checked with the schema's checks (:mod:`.schema`),
every problem collected with its place and line, then :func:`load_builder` / :func:`load_model`.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import ModelError
from ..model import Model, ModelBuilder
from ..model.builder import GROUND, check_inertia, check_mass, orientation_to_p
from .analysis import Analysis, _parse_analysis
from .schema import (_BASE_DIR, _BODY_FIELDS, BODY_KEYS, _BUILD_ERRORS, _color, _density_body,
                     _describe, DRIVER_KEYS, _EPS, _finite, GEOMETRY_KEYS, _is_number, joint_keys,
                     _law, _list, _mapping, _matrix, _member, ModelFileError, _name, _number,
                     ORIENTATION_KEYS, _Problems, _range_checks, _reference, _relabel,
                     SCHEMA_VERSION, _shape, _string, _suggest, TOP_KEYS, _vector)
from .source import _read


# ============================================================================ file -> builder
def _section(data: dict, key: str):
    """An optional list section; absent or empty (null, e.g. all entries commented out): []."""
    value = data.get(key)
    return [] if value is None else value


def _parse(P, data, default_name="model"):
    """(builder, analysis) from the file's data; problems go to P."""
    from ..constraints import DRIVER_TYPES, JOINT_TYPES
    from ..constraints.drivers import COORDINATES
    from ..forces import FORCE_TYPES

    if data is None:
        P.add((), f"the file is empty; a model file starts with 'spatialmbd: {SCHEMA_VERSION}'")
        return None, None
    if not isinstance(data, dict):
        P.add((), f"expected a mapping (spatialmbd, name, gravity, bodies, ...), got "
                  f"{_describe(data)}")
        return None, None
    if "spatialmbd" not in data:
        P.add((), f"missing the schema version: add 'spatialmbd: {SCHEMA_VERSION}' as the "
                  "first line")
    else:
        version = data["spatialmbd"]
        if not (_is_number(version) and _finite(version) and version == int(version)):
            P.add(("spatialmbd",), f"the schema version must be an integer, got "
                                   f"{_describe(version)}")
        elif version != SCHEMA_VERSION:
            P.add(("spatialmbd",), f"this file uses schema version {int(version)}; this "
                                   f"spatialmbd reads version {SCHEMA_VERSION}"
                                   + (" (upgrade spatialmbd)" if version > SCHEMA_VERSION
                                      else ""))
            return None, None
    _mapping(P, (), data, TOP_KEYS)
    _range_checks(P, {k: v for k, v in data.items() if k in TOP_KEYS})

    name = data.get("name", default_name)
    if not _string(P, ("name",), name, "a model name (string)"):
        name = default_name
    gravity = data.get("gravity", [0.0, 0.0, -9.81])
    if not _vector(P, ("gravity",), gravity):
        gravity = [0.0, 0.0, -9.81]
    b = ModelBuilder(name, gravity)

    # ------------------------------------------------------------------ bodies
    declared_bodies, ok_bodies = [], set()
    bodies = data.get("bodies")
    if "bodies" not in data:
        P.add((), "missing required key 'bodies' (a list of bodies)")
        bodies = []
    elif _list(P, ("bodies",), bodies, "bodies"):
        if not bodies:
            P.add(("bodies",), "the model has no bodies; give at least one")
    else:
        bodies = []
    for i, d in enumerate(bodies):
        path = ("bodies", i)
        by_density = isinstance(d, dict) and "density" in d
        if not _mapping(P, path, d, BODY_KEYS,
                        ("name", "shapes") if by_density else ("name", "mass", "inertia")):
            continue
        n0 = len(P)             # unknown keys (reported) do not stop the builder's checks
        if by_density:          # mass properties from the shapes (importers.massprops)
            d = _density_body(P, path, d)
        complete = all(k in d for k in ("name", "mass", "inertia"))
        if "name" in d and _string(P, path + ("name",), d["name"], "a body name (string)"):
            declared_bodies.append(d["name"])
        if "mass" in d:
            _number(P, path + ("mass",), d["mass"])
        if "inertia" in d:
            J = d["inertia"]
            if isinstance(J, list) and J and isinstance(J[0], list):
                _matrix(P, path + ("inertia",), J)
            elif not (isinstance(J, list) and len(J) == 3):
                P.add(path + ("inertia",), f"expected 3 principal moments [Ixx, Iyy, Izz] or a "
                                           f"3x3 tensor (kg m^2), got {_describe(J)}")
            else:
                _vector(P, path + ("inertia",), J)
        for key in ("position", "velocity", "angular_velocity", "angular_velocity_local"):
            if key in d:
                _vector(P, path + (key,), d[key])
        if "angular_velocity" in d and "angular_velocity_local" in d:
            P.add(path, "give angular_velocity (global axes) or angular_velocity_local (body "
                        "axes), not both")
        orient = {}
        if "orientation" in d:
            o = d["orientation"]
            opath = path + ("orientation",)
            if _mapping(P, opath, o, ORIENTATION_KEYS,
                        what="a mapping with one of " + ", ".join(ORIENTATION_KEYS)):
                given = [k for k in o if k in ORIENTATION_KEYS]
                if len(given) != 1:
                    P.add(opath, f"give exactly one of {', '.join(ORIENTATION_KEYS)}"
                                 + (f", not {len(given)} ({', '.join(given)})" if given else ""))
                else:
                    key = given[0]
                    val = o[key]
                    if key == "matrix":
                        if _matrix(P, opath + (key,), val):
                            orient["A"] = val
                    elif _vector(P, opath + (key,), val, 4 if key == "euler_parameters" else 3):
                        if key == "euler_parameters":
                            orient["p"] = val
                        elif key.endswith("_deg"):
                            orient[key[:-4]] = [math.radians(x) for x in val]
                        else:
                            orient[key] = val
        for key in ("points", "vectors"):
            if key in d:
                table = d[key]
                if not isinstance(table, dict):
                    P.add(path + (key,), f"expected a mapping name: [x, y, z], got "
                                         f"{_describe(table)}")
                    continue
                for pname, vec in table.items():
                    if not isinstance(pname, str):
                        P.add(path + (key, pname), f"{key[:-1]} names must be strings, got "
                                                   f"{_describe(pname)}")
                    _vector(P, path + (key, pname), vec)
        if "shapes" in d and _list(P, path + ("shapes",), d["shapes"], "shapes"):
            for k, s in enumerate(d["shapes"]):
                _shape(P, path + ("shapes", k), s, owner=f"body {d.get('name')!r}")
        if "color" in d:
            _color(P, path + ("color",), d["color"])
        if len(P) != n0 or P.flagged(path) or not complete:
            continue
        kwargs = dict(r=d.get("position", (0.0, 0.0, 0.0)),
                      rdot=d.get("velocity", (0.0, 0.0, 0.0)),
                      omega=d.get("angular_velocity"),
                      omega_local=d.get("angular_velocity_local"),
                      points=d.get("points"), vectors=d.get("vectors"),
                      shapes=d.get("shapes"), color=d.get("color"), **orient)
        fields = dict(_BODY_FIELDS)
        for key in ("euler_zxz", "bryant"):
            if key + "_deg" in (d.get("orientation") or {}):
                fields[key] = ("orientation", key + "_deg")
        # the physical checks are independent: report each of them, not only the first
        label = f"bodies[{d['name']!r}]"
        checks = (lambda: check_mass(d["mass"], f"{label}.mass"),
                  lambda: check_inertia(d["inertia"], f"{label}.inertia"),
                  lambda: orientation_to_p(label, **orient))
        failed = False
        for check in checks:
            try:
                check()
            except _BUILD_ERRORS as exc:
                _relabel(P, path, label, str(exc), fields)
                failed = True
        if failed:
            continue
        try:
            b.add_body(d["name"], d["mass"], d["inertia"], **kwargs)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, label, str(exc), fields)
            continue
        if "p" in orient:
            # keep Euler parameters that are unit to rounding bit for bit (exact round trips)
            given = np.array(orient["p"], dtype=float)
            if abs(float(np.linalg.norm(given)) - 1.0) <= 4 * _EPS:
                b.bodies[d["name"]].p = given
        ok_bodies.add(d["name"])

    # ------------------------------------------------------------------ joints
    declared_joints, ok_joints = [], set()
    joints = _section(data, "joints")
    if not _list(P, ("joints",), joints, "joints"):
        joints = []
    for i, d in enumerate(joints):
        path = ("joints", i)
        if not _mapping(P, path, d, joint_keys(d.get("type") if isinstance(d, dict) else None),
                        ("name", "type", "body_i", "body_j")):
            continue
        n0 = len(P)
        complete = all(k in d for k in ("name", "type", "body_i", "body_j"))
        if "name" in d and _string(P, path + ("name",), d["name"], "a joint name (string)"):
            declared_joints.append(d["name"])
        if "type" in d and not _member(d["type"], JOINT_TYPES):
            P.add(path + ("type",), f"unknown joint type {_name(d['type'])}"
                                    f"{_suggest(d['type'], JOINT_TYPES)}; valid types: "
                                    + ", ".join(sorted(JOINT_TYPES)))
        for key in ("body_i", "body_j"):
            if key in d:
                _reference(P, path + (key,), d[key], declared_bodies, "body", (GROUND,))
        geometry = {k: d[k] for k in GEOMETRY_KEYS if k in d}
        for key, val in geometry.items():
            _vector(P, path + (key,), val, or_name=key in ("point_i", "point_j"))
        params = {}
        if isinstance(d.get("type"), str) and d["type"] in JOINT_TYPES:
            for par in JOINT_TYPES[d["type"]].parameters:
                if par.name not in d:
                    continue
                value = d[par.name]
                if par.size > 1:                 # a list of 1 to size numbers
                    if not isinstance(value, list) or not 1 <= len(value) <= par.size:
                        P.add(path + (par.name,), f"expected a list of 1 to {par.size} "
                                                  f"numbers ({par.unit}), got "
                                                  f"{_describe(value)}")
                    elif all([_number(P, path + (par.name, k), x, positive=par.positive)
                              for k, x in enumerate(value)]):
                        params[par.name] = value
                elif _number(P, path + (par.name,), value, positive=par.positive):
                    params[par.name] = value
        if len(P) != n0 or P.flagged(path) or not complete or \
                not {d["body_i"], d["body_j"]} <= ok_bodies | {GROUND}:
            continue        # problems here, or in a body it joins (reported there)
        try:
            b.add_joint(d["type"], d["name"], d["body_i"], d["body_j"], **params, **geometry)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"joints[{d['name']!r}]", str(exc))
            continue
        ok_joints.add(d["name"])

    # ------------------------------------------------------------------ drivers
    drivers = _section(data, "drivers")
    if not _list(P, ("drivers",), drivers, "drivers"):
        drivers = []
    for i, d in enumerate(drivers):
        path = ("drivers", i)
        if not _mapping(P, path, d, DRIVER_KEYS, ("name", "kind", "law")):
            continue
        n0 = len(P)
        complete = all(k in d for k in ("name", "kind", "law"))
        if "name" in d:
            _string(P, path + ("name",), d["name"], "a driver name (string)")
        kind = d.get("kind")
        if "kind" in d and not _member(kind, DRIVER_TYPES):
            P.add(path + ("kind",), f"unknown driver kind {_name(kind)}"
                                    f"{_suggest(kind, DRIVER_TYPES)}; valid: "
                                    + ", ".join(DRIVER_TYPES))
        if kind == "coordinate":
            for key in ("body", "coordinate"):
                if key not in d:
                    P.add(path, f"missing required key {key!r} (a coordinate driver acts on a "
                                "coordinate of a body)")
            if "joint" in d:
                P.add(path + ("joint",), "a coordinate driver acts on a body, not a joint")
            if "body" in d:
                _reference(P, path + ("body",), d["body"], declared_bodies, "body")
            if "coordinate" in d and not _member(d["coordinate"], COORDINATES):
                P.add(path + ("coordinate",), f"{_describe(d['coordinate'])} is not one of "
                                              + ", ".join(COORDINATES))
        elif _member(kind, DRIVER_TYPES):
            if "joint" not in d:
                P.add(path, f"missing required key 'joint' (an {kind} driver acts on a joint)")
            else:
                _reference(P, path + ("joint",), d["joint"], declared_joints, "joint")
            for key in ("body", "coordinate"):
                if key in d:
                    P.add(path + (key,), "applies to coordinate drivers only")
        law = _law(P, path + ("law",), d["law"]) if "law" in d else None
        if len(P) != n0 or P.flagged(path) or not complete:
            continue
        if (d.get("joint") is not None and d["joint"] not in ok_joints) or \
                (d.get("body") is not None and d["body"] not in ok_bodies):
            continue
        try:
            b.add_driver(kind, d["name"], law, joint=d.get("joint"), body=d.get("body"),
                         coordinate=d.get("coordinate"))
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"drivers[{d['name']!r}]", str(exc))

    # ------------------------------------------------------------------ couplers
    from ..constraints.couplers import COUPLER_TYPES
    couplers = _section(data, "couplers")
    if not _list(P, ("couplers",), couplers, "couplers"):
        couplers = []
    for i, d in enumerate(couplers):
        path = ("couplers", i)
        ctype = d.get("type") if isinstance(d, dict) else None
        params = [p.name for p in COUPLER_TYPES[ctype].parameters] \
            if _member(ctype, COUPLER_TYPES) else ["ratio", "radius", "c1", "c2", "c0"]
        if not _mapping(P, path, d, ("name", "type", "joint1", "joint2") + tuple(params),
                        ("name", "type", "joint1", "joint2")) or \
                not all(k in d for k in ("name", "type", "joint1", "joint2")):
            continue
        n0 = len(P)
        _string(P, path + ("name",), d["name"], "a coupler name (string)")
        if not _member(ctype, COUPLER_TYPES):
            P.add(path + ("type",), f"unknown coupler type {_name(ctype)}"
                                    f"{_suggest(ctype, COUPLER_TYPES)}; valid: "
                                    + ", ".join(COUPLER_TYPES))
        for key in ("joint1", "joint2"):
            _reference(P, path + (key,), d[key], declared_joints, "joint")
        for key in params:
            if key in d:
                _number(P, path + (key,), d[key])
        if len(P) != n0 or P.flagged(path) or d["joint1"] not in ok_joints or \
                d["joint2"] not in ok_joints:
            continue
        try:
            b.add_coupler(ctype, d["name"], d["joint1"], d["joint2"],
                          **{k: d[k] for k in params if k in d})
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"couplers[{d['name']!r}]", str(exc))

    # ------------------------------------------------------------------ forces, controls
    refs = (declared_bodies, ok_bodies, declared_joints, ok_joints)
    _force_section(P, b, data, "forces", FORCE_TYPES, refs)
    # controls: the actuators (spatialmbd.forces.actuators), entries as in forces
    _force_section(P, b, data, "controls", FORCE_TYPES, refs, actuators_only=True)

    # ------------------------------------------------------------------ contacts
    # contact elements (spatialmbd.forces.contact): {name, body_i, body_j, shape_i, shape_j,
    # law, ...}, the parameters of the "contact" force type
    contacts = _section(data, "contacts")
    if not _list(P, ("contacts",), contacts, "contact elements"):
        contacts = []
    ctype = FORCE_TYPES["contact"]
    for i, d in enumerate(contacts):
        path = ("contacts", i)
        if not isinstance(d, dict):
            P.add(path, f"expected a mapping {{name, body_i, body_j, shape_i, shape_j, ...}}, "
                        f"got {_describe(d)}")
            continue
        allowed = ("name",) + ctype.allowed()
        required = ("name",) + tuple(ctype.required)
        _mapping(P, path, d, allowed, required)
        n0 = len(P)
        if "name" in d:
            _string(P, path + ("name",), d["name"], "a contact name (string)")
        params, refs_ok = {}, True
        for key, val in d.items():
            if key == "name" or key not in allowed:
                continue
            kind = ctype.parameters.get(key, "any")
            where = path + (key,)
            if kind == "body":
                if _reference(P, where, val, declared_bodies, "body", (GROUND,)):
                    refs_ok = refs_ok and (val in ok_bodies or val == GROUND)
            elif kind == "string":
                _string(P, where, val)
            elif kind == "number":
                _number(P, where, val)
            elif not isinstance(val, dict):
                P.add(where, f"expected a shape mapping {{type, ...}}, got {_describe(val)}")
            params[key] = val
        if len(P) != n0 or P.flagged(path) or not all(k in d for k in required) or not refs_ok:
            continue
        try:
            b.add_force("contact", d["name"], **params)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"forces[{d['name']!r}]", str(exc))

    # ------------------------------------------------------------------ ground shapes
    shapes = _section(data, "ground_shapes")
    if _list(P, ("ground_shapes",), shapes, "shapes"):
        for k, s in enumerate(shapes):
            if _shape(P, ("ground_shapes", k), s, owner="the ground"):
                b.add_ground_shape(s)

    # ------------------------------------------------------------------ analysis
    if data.get("analysis") is None:
        analysis = Analysis()
    else:
        analysis = _parse_analysis(P, ("analysis",), data["analysis"], declared_bodies)
    if analysis is not None:
        analysis.outputs = _parse_outputs_section(P, data)
    _check_fmu_section(P, data)
    return b, analysis


def _check_fmu_section(P, data) -> None:
    """The ``fmu:`` section's shape (docs/fmi.md); its names are checked against the model
    when an FMU is exported (:func:`spatialmbd.fmi.export.export_fmu`)."""
    from .schema import FMU_KEYS
    fmu = data.get("fmu")
    if fmu is None or not _mapping(P, ("fmu",), fmu, FMU_KEYS):
        return
    for key in ("inputs", "outputs", "parameters"):
        if key in fmu and _list(P, ("fmu", key), fmu[key], "names"):
            for k, name in enumerate(fmu[key]):
                _string(P, ("fmu", key, k), name, "a name")
    for key in ("start_time", "stop_time", "rtol", "atol"):
        if key in fmu:
            _number(P, ("fmu", key), fmu[key], nonneg=True)
    if "step" in fmu:
        _number(P, ("fmu", "step"), fmu["step"], positive=True)
    for key in ("method", "integrator"):
        if key in fmu:
            _string(P, ("fmu", key), fmu[key])


def _force_section(P, b, data, section, FORCE_TYPES, refs, actuators_only=False):
    """The entries {name, type, ...} of the ``forces:`` (or ``controls:``: actuator types
    only) section into the builder; problems to P."""
    declared_bodies, ok_bodies, declared_joints, ok_joints = refs
    forces = _section(data, section)
    if not _list(P, (section,), forces, "force elements" if section == "forces" else
                 "actuators"):
        forces = []
    valid_types = [t for t, cls in FORCE_TYPES.items() if cls.in_files and
                   (not actuators_only or hasattr(cls, "output_columns"))]
    for i, d in enumerate(forces):
        path = (section, i)
        if not isinstance(d, dict):
            P.add(path, f"expected a mapping {{name, type, ...}}, got {_describe(d)}")
            continue
        ftype = d.get("type")
        if "type" not in d:
            P.add(path, "missing required key 'type' (force types: "
                        + ", ".join(valid_types) + ")")
            continue
        if isinstance(ftype, str) and ftype in FORCE_TYPES and not FORCE_TYPES[ftype].in_files:
            P.add(path + ("type",), f"{ftype} forces take a Python callable (or other Python "
                                    "objects) and cannot be "
                                    "described in a model file; add them in Python with "
                                    f"ModelBuilder.add_force({ftype!r}, ...) after load_builder()")
            continue
        if not _member(ftype, FORCE_TYPES) or ftype not in valid_types:
            P.add(path + ("type",), f"unknown force type {_name(ftype)}"
                                    f"{_suggest(ftype, valid_types)}; valid types: "
                                    + ", ".join(valid_types))
            continue
        allowed = ("name", "type") + FORCE_TYPES[ftype].allowed()
        required = ("name",) + tuple(FORCE_TYPES[ftype].required)
        _mapping(P, path, d, allowed, required)
        n0 = len(P)
        complete = all(k in d for k in required)
        if "name" in d:
            _string(P, path + ("name",), d["name"], "a force name (string)")
        params, refs_ok = {}, True
        for key, val in d.items():
            if key in ("name", "type") or key not in allowed:
                continue
            kind = FORCE_TYPES[ftype].parameters.get(key, "any")
            where = path + (key,)
            if kind == "body":
                if _reference(P, where, val, declared_bodies, "body", (GROUND,)):
                    refs_ok = refs_ok and (val in ok_bodies or val == GROUND)
            elif kind == "joint":
                if _reference(P, where, val, declared_joints, "joint"):
                    refs_ok = refs_ok and val in ok_joints
            elif kind == "point":
                _vector(P, where, val, or_name=True)
            elif kind == "vector":
                _vector(P, where, val)
            elif kind == "matrix":
                _matrix(P, where, val)
            elif kind == "string":
                _string(P, where, val)
            elif kind == "number":
                _number(P, where, val)
            elif kind == "law":
                if not _is_number(val):
                    val = _law(P, where, val)
                else:
                    _number(P, where, val)
            params[key] = val
        if len(P) != n0 or P.flagged(path) or not complete or not refs_ok:
            continue
        try:
            b.add_force(ftype, d["name"], **params)
        except _BUILD_ERRORS as exc:
            _relabel(P, path, f"forces[{d['name']!r}]", str(exc))


def _parse_outputs_section(P, data) -> list:
    """The top-level ``outputs:`` list (docs/outputs.md): shape and keys checked here, element
    names once the model is compiled (:func:`load_model`)."""
    from ..outputs import Output
    items = _section(data, "outputs")
    out = []
    if not _list(P, ("outputs",), items, "output requests"):
        return out
    for k, item in enumerate(items):
        if isinstance(item, str):
            out.append(item)
            continue
        try:
            out.append(Output.from_dict(item).to_dict())
        except _BUILD_ERRORS as exc:
            P.add(("outputs", k), str(exc))
    return out


def load_builder(path_or_dict, *, external_files: bool = True) -> tuple[ModelBuilder,
                                                                        Analysis]:
    """A ModelBuilder and the Analysis of a model file (.yaml/.yml/.json) or a model dict.

    The whole file is checked first; every problem is reported at once in one
    :class:`ModelFileError` (``problems``: one string per problem, with its place).
    external_files=False (an untrusted model): files named outside the model file's folder
    (meshes, sidecars, time series; :mod:`.external`) are refused before any is read.
    """
    data, source, lines, duplicates, default_name = _read(path_or_dict)
    P = _Problems(lines)
    for where, line in duplicates:
        P.add(where, f"duplicate key {where[-1]!r} (each key may appear once per mapping)",
              line)
    base_dir = None if source is None else str(Path(source).resolve().parent)
    if not external_files:
        from .external import refusal, scan
        refused = scan(data, base_dir)
        for path, real in refused:
            P.add(path, refusal(real, base_dir))
        if refused:
            raise P.error(source)
    token = _BASE_DIR.set(base_dir)
    try:
        builder, analysis = _parse(P, data, default_name)
    finally:
        _BASE_DIR.reset(token)
    if len(P):
        raise P.error(source)
    return builder, analysis


def load_model(path_or_dict, *, external_files: bool = True) -> tuple[Model, Analysis]:
    """The compiled Model and the Analysis of a model file or dict (see :func:`load_builder`;
    external_files=False refuses files outside the model's folder)."""
    builder, analysis = load_builder(path_or_dict, external_files=external_files)
    try:
        model = builder.compile()
    except ModelFileError:
        raise
    except ModelError as exc:
        source = None if isinstance(path_or_dict, dict) else path_or_dict
        raise ModelFileError([str(exc)], source) from None
    except _BUILD_ERRORS as exc:        # numerical trouble with extreme (but in-range) values
        source = None if isinstance(path_or_dict, dict) else path_or_dict
        raise ModelFileError([f"(top level): the model cannot be compiled: "
                              f"{type(exc).__name__}: {exc}; check extreme values"],
                             source) from None
    if analysis is not None and analysis.outputs:
        from ..outputs import parse_outputs
        try:
            parse_outputs(model, analysis.outputs)
        except ModelError as exc:
            source = None if isinstance(path_or_dict, dict) else path_or_dict
            raise ModelFileError([f"outputs: {exc}"], source) from None
    return model, analysis
