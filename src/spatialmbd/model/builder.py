"""ModelBuilder: the mutable way to describe a multibody system, compiled into a frozen Model.

Example::

    b = ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("link", mass=7.02, inertia=(0.5855265, 0.0010530, 0.5855265), r=(0, 0.5, 0))
    b.add_joint("revolute", "pivot", "ground", "link", point=(0, 0, 0), axis=(1, 0, 0))
    model = b.compile()

Every check names the element, the offending value and the fix, and raises
:class:`spatialmbd.errors.ModelError`.
"""
from __future__ import annotations

import math
from typing import Iterable, Optional

import numpy as np

from ..constraints import DRIVER_TYPES, JOINT_TYPES
from ..constraints.drivers import COORDINATES
from ..errors import ModelError
from .. import rotations as rot
from .model import register_builder
from .specs import BodySpec, CouplerSpec, DriverSpec, ForceSpec, JointSpec

GROUND = "ground"
#: Euler parameters whose norm differs from 1 by less than this are normalised silently
#: (documented); farther ones are rejected.
P_NORM_TOLERANCE = 1e-3

GLOBAL_KEYS = {"point", "point2", "axis", "axis2", "reference"}
LOCAL_KEYS = {"point_i", "point_j", "axis_i", "axis_j", "ref_i", "ref_j"}


def _vector(value, what: str, size: int = 3) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected {size} numbers, got {value!r}") from None
    if arr.size != size:
        raise ModelError(f"{what}: expected {size} numbers, got {arr.size} ({value!r})")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: values must be finite, got {value!r}")
    return arr


def check_mass(mass, what: str) -> float:
    """A validated mass (kg): a finite positive number."""
    try:
        mass = float(mass)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected a number, got {mass!r}") from None
    if not (math.isfinite(mass) and mass > 0):
        raise ModelError(f"{what}: must be positive and finite, got {mass!r} (kg)")
    return mass


def check_inertia(inertia, what: str) -> np.ndarray:
    """A validated (3, 3) inertia tensor from 3 principal moments or a 3x3 matrix (kg m^2)."""
    arr = np.array(inertia, dtype=float)
    if arr.shape == (3,):
        arr = np.diag(arr)
    if arr.shape != (3, 3):
        raise ModelError(f"{what}: give 3 principal moments or a 3x3 tensor, got shape "
                         f"{np.shape(inertia)}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: values must be finite")
    scale = np.abs(arr).max()
    if scale == 0:
        raise ModelError(f"{what}: the inertia is zero; give the moments of inertia about the "
                         "centre of mass in body axes (kg m^2)")
    if np.abs(arr - arr.T).max() > 1e-9 * scale:
        raise ModelError(f"{what}: inertia tensor is not symmetric ({arr.tolist()}); products "
                         "of inertia I_xy and I_yx must be equal")
    arr = 0.5 * (arr + arr.T)
    moments = np.linalg.eigvalsh(arr)
    if moments[0] <= 0:
        raise ModelError(f"{what}: inertia is not positive definite (principal moments "
                         f"{moments.tolist()}); every principal moment must be > 0")
    if moments[0] + moments[1] < moments[2] * (1 - 1e-9):
        raise ModelError(f"{what}: principal moments {moments.tolist()} break the triangle "
                         "inequality I1 + I2 >= I3, no rigid body has them; check the values "
                         "and their units (kg m^2)")
    return arr


def orientation_to_p(what: str, p=None, euler_zxz=None, bryant=None, A=None) -> np.ndarray:
    """Unit Euler parameters from exactly one orientation form (identity when none is given).

    Euler parameters within P_NORM_TOLERANCE of unit length are normalised (so values rounded
    to a few digits are accepted); others are rejected.
    """
    given = {k: v for k, v in dict(p=p, euler_zxz=euler_zxz, bryant=bryant, A=A).items()
             if v is not None}
    if len(given) > 1:
        raise ModelError(f"{what}: give one orientation, not {sorted(given)}")
    if not given:
        return np.array([1.0, 0.0, 0.0, 0.0])
    key, value = next(iter(given.items()))
    if key == "p":
        pv = _vector(value, f"{what}.p", 4)
        # an exactly rounded sum, not BLAS: the normalised parameters are the same bits on
        # every machine (OpenBLAS's dot differs in the last bit between its kernels)
        norm = math.sqrt(math.fsum(pv * pv))
        if abs(norm - 1.0) > P_NORM_TOLERANCE:
            raise ModelError(f"{what}.p: Euler parameters {pv.tolist()} have norm {norm:.6g}, "
                             "far from 1; give e0^2 + e1^2 + e2^2 + e3^2 = 1 (or use "
                             "euler_zxz / bryant angles)")
        return pv / norm
    if key == "A":
        Am = np.array(value, dtype=float)
        if Am.shape != (3, 3) or not np.all(np.isfinite(Am)):
            raise ModelError(f"{what}.A: a rotation matrix must be 3x3 and finite")
        err = np.abs(Am @ Am.T - np.eye(3)).max()
        if err > 1e-6 or np.linalg.det(Am) < 0:
            raise ModelError(f"{what}.A: not a rotation matrix (|A A^T - I| = {err:.3g}, "
                             f"det = {np.linalg.det(Am):.6g}); it must be orthonormal with "
                             "det +1")
        return rot.p_from_A(Am)
    angles = _vector(value, f"{what}.{key}", 3)
    if key == "euler_zxz":
        return rot.p_from_A(rot.A_from_euler_zxz(angles))
    return rot.p_from_A(rot.A_from_bryant(angles))


class ModelBuilder:
    """Collects bodies, joints, drivers and forces; ``compile()`` returns a frozen Model."""

    def __init__(self, name: str = "model", gravity: Iterable[float] = (0.0, 0.0, -9.81)):
        self.name = str(name)
        self.gravity = _vector(gravity, "gravity")
        self.bodies: dict[str, BodySpec] = {}
        self.joints: dict[str, JointSpec] = {}
        self.drivers: dict[str, DriverSpec] = {}
        self.forces: dict[str, ForceSpec] = {}
        self.couplers: dict[str, CouplerSpec] = {}
        self.ground_shapes: list = []

    # ----------------------------------------------------------------------------- bodies
    def add_body(self, name: str, mass: float, inertia, r=None, *, p=None,
                 euler_zxz=None, bryant=None, A=None, rdot=None, omega=None,
                 omega_local=None, points: Optional[dict] = None,
                 vectors: Optional[dict] = None, shapes: Optional[list] = None,
                 color: Optional[str] = None, position=None, velocity=None,
                 angular_velocity=None, angular_velocity_local=None, euler_parameters=None,
                 matrix=None, euler_zxz_deg=None, bryant_deg=None) -> str:
        """Add a rigid body.

        mass: kg > 0. inertia: 3 principal moments or a 3x3 tensor about the centre of mass in
        body axes (kg m^2). r: centre-of-mass position (m). Orientation: one of p (Euler
        parameters), euler_zxz (psi, theta, sigma; rad, Eq. 4.2), bryant (phi1, phi2, phi3; rad,
        Eq. 4.5) or A (3x3 rotation matrix, body -> global); identity if none.
        rdot: m/s. omega: angular velocity in global axes, or omega_local in body axes (rad/s).
        points / vectors: named points (m) and vectors fixed on the body, in body axes.

        The model file's names are accepted too, so a file and a script read alike:
        position (= r), velocity (= rdot), angular_velocity (= omega), angular_velocity_local
        (= omega_local), euler_parameters (= p), matrix (= A), and the angle sets in degrees,
        euler_zxz_deg and bryant_deg. The book's symbols r, rdot, omega, p, A stay valid.
        """
        what = f"bodies[{name!r}]"
        import math as _math

        def one(symbol, value, word, other):
            if value is not None and other is not None:
                raise ModelError(f"{what}: give {symbol} or {word}, not both (the same input)")
            return value if value is not None else other
        r = one("r", r, "position", position)
        rdot = one("rdot", rdot, "velocity", velocity)
        omega = one("omega", omega, "angular_velocity", angular_velocity)
        omega_local = one("omega_local", omega_local, "angular_velocity_local",
                          angular_velocity_local)
        p = one("p", p, "euler_parameters", euler_parameters)
        A = one("A", A, "matrix", matrix)
        for deg, key in ((euler_zxz_deg, "euler_zxz"), (bryant_deg, "bryant")):
            if deg is not None:
                rad = [_math.radians(float(x)) for x in _vector(deg, f"{what}.{key}_deg")]
                if key == "euler_zxz":
                    euler_zxz = one("euler_zxz", euler_zxz, "euler_zxz_deg", rad)
                else:
                    bryant = one("bryant", bryant, "bryant_deg", rad)
        r = (0.0, 0.0, 0.0) if r is None else r
        rdot = (0.0, 0.0, 0.0) if rdot is None else rdot
        self._check_new_name(name, "body")
        mass = check_mass(mass, f"{what}.mass")
        J = check_inertia(inertia, f"{what}.inertia")
        pv = orientation_to_p(what, p=p, euler_zxz=euler_zxz, bryant=bryant, A=A)
        if omega is not None and omega_local is not None:
            raise ModelError(f"{what}: give omega (global axes) or omega_local (body axes), "
                             "not both")
        if omega_local is not None:
            w = rot.A_from_p(pv) @ _vector(omega_local, f"{what}.omega_local")
        else:
            w = _vector(omega if omega is not None else (0, 0, 0), f"{what}.omega")
        pts = {}
        for key, value in (points or {}).items():
            pts[str(key)] = _vector(value, f"{what}.points[{key!r}]")
        vecs = {}
        for key, value in (vectors or {}).items():
            vec = _vector(value, f"{what}.vectors[{key!r}]")
            if np.linalg.norm(vec) == 0:
                raise ModelError(f"{what}.vectors[{key!r}]: zero-length vector; give a "
                                 "direction")
            vecs[str(key)] = vec
        for k, shape in enumerate(shapes or []):   # inline meshes: faces, finite vertices
            if isinstance(shape, dict) and shape.get("type") == "mesh" and \
                    shape.get("file") is None:
                from ..meshes import mesh_arrays
                mesh_arrays(shape, f"{what}.shapes[{k}] (mesh)")
        self.bodies[name] = BodySpec(name=name, mass=mass, inertia=J,
                                     r=_vector(r, f"{what}.r"), p=pv,
                                     rdot=_vector(rdot, f"{what}.rdot"), omega=w, points=pts,
                                     vectors=vecs, shapes=list(shapes or []), color=color)
        return name

    # ----------------------------------------------------------------------------- joints
    def add_joint(self, type: str, name: str, body_i: str, body_j: str, **keywords) -> str:
        """Add a joint of ``type`` (see spatialmbd.constraints.JOINT_TYPES) between two bodies.

        Geometry, either global (in the initial configuration):
            point (m), axis, reference (a direction normal to axis fixing the zero of the
            joint angle), point2 (second point, on body j, of composite joints and n2/p2),
            axis2 (second axis, on body j: universal cross axis, n1/p1 vector);
        or local (body axes; a point may also be the name of a named point of the body):
            point_i, point_j, axis_i, axis_j, ref_i, ref_j.
        Parameters of the type by name (its ``parameters`` declaration), e.g. length of
        spherical_spherical / spherical_revolute (m; default: as assembled), pitch of a screw.
        """
        from ..constraints import canonical_name
        what = f"joints[{name!r}]"
        if type not in JOINT_TYPES:
            raise ModelError(f"{what}: unknown joint type {type!r}; valid types: "
                             + ", ".join(sorted(JOINT_TYPES)))
        type = canonical_name(type)
        jtype = JOINT_TYPES[type]
        self._check_new_name(name, "joint")
        for body in (body_i, body_j):
            if body != GROUND and body not in self.bodies:
                raise ModelError(f"{what}: unknown body {body!r}; add it with add_body first "
                                 f"(bodies: {', '.join(self.bodies) or 'none'}, or 'ground')")
        if body_i == body_j:
            raise ModelError(f"{what}: joins body {body_i!r} to itself; a joint needs two "
                             "different bodies")
        param_names = [par.name for par in jtype.parameters]
        params = {k: v for k, v in keywords.items() if k in param_names and v is not None}
        geometry = {k: v for k, v in keywords.items() if k not in param_names}
        keys = set(geometry)
        unknown = keys - GLOBAL_KEYS - LOCAL_KEYS
        if unknown:
            import difflib
            close = difflib.get_close_matches(sorted(unknown)[0], sorted(GLOBAL_KEYS | LOCAL_KEYS)
                                              + param_names, n=1)
            raise ModelError(f"{what}: unknown geometry keyword(s) {sorted(unknown)}"
                             + (f" (did you mean {close[0]!r}?)" if close else "")
                             + f" for a {type} joint; use {sorted(GLOBAL_KEYS)} (global) or "
                             f"{sorted(LOCAL_KEYS)} "
                             "(local)" + (f", and its parameters {param_names}"
                                          if param_names else ""))
        if keys & GLOBAL_KEYS and keys & LOCAL_KEYS:
            raise ModelError(f"{what}: mixes global ({sorted(keys & GLOBAL_KEYS)}) and local "
                             f"({sorted(keys & LOCAL_KEYS)}) geometry; use one form")
        for par in jtype.parameters:
            if par.name in params:
                params[par.name] = par.check(params[par.name], what)
        spec = JointSpec(type=type, name=name, body_i=body_i, body_j=body_j,
                         geometry=dict(geometry), params=params)
        from .compile import resolve_joint  # validates the geometry now, with the bodies known
        resolve_joint(spec, self.bodies)
        self.joints[name] = spec
        return name

    # ----------------------------------------------------------------------------- drivers
    def add_driver(self, kind: str, name: str, law, *, joint: Optional[str] = None,
                   body: Optional[str] = None, coordinate: Optional[str] = None) -> str:
        """Add a driver of ``kind`` named ``name`` prescribing f(t) (a MotionLaw, a number, or a
        law dict) -- the argument order of add_joint(type, name, ...) and add_force.

        kind "angle": rotation of a revolute/cylindrical/screw ``joint`` (rad);
        kind "translation": translation along a translational/cylindrical/screw ``joint`` (m);
        kind "coordinate": ``coordinate`` (x, y, z, e0..e3) of ``body``.
        (The old order add_driver(name, kind, ...) still works, with a DeprecationWarning.)
        """
        from ..motion import make_law
        if kind not in DRIVER_TYPES and isinstance(name, str) and name in DRIVER_TYPES:
            import warnings
            warnings.warn(f"add_driver({kind!r}, {name!r}, ...): the driver kind comes first "
                          f"now, as in add_joint and add_force; write add_driver({name!r}, "
                          f"{kind!r}, ...)", DeprecationWarning, stacklevel=2)
            kind, name = name, kind
        what = f"drivers[{name!r}]"
        self._check_new_name(name, "driver")
        if kind not in DRIVER_TYPES:
            raise ModelError(f"{what}: unknown driver kind {kind!r}; valid: "
                             + ", ".join(DRIVER_TYPES))
        law = make_law(law)
        if kind == "coordinate":
            if body not in self.bodies:
                raise ModelError(f"{what}: unknown body {body!r}; a coordinate driver needs "
                                 "body=<name of a body>")
            if coordinate not in COORDINATES:
                raise ModelError(f"{what}: coordinate {coordinate!r} is not one of "
                                 + ", ".join(COORDINATES))
            if joint is not None:
                raise ModelError(f"{what}: a coordinate driver acts on a body, not a joint")
        else:
            if joint not in self.joints:
                raise ModelError(f"{what}: unknown joint {joint!r}; an {kind} driver needs "
                                 "joint=<name of a joint>")
            jtype = self.joints[joint].type
            if kind not in JOINT_TYPES[jtype].driver_kinds:
                able = [t for t, c in JOINT_TYPES.items() if kind in c.driver_kinds]
                raise ModelError(f"{what}: a {jtype} joint ({joint!r}) cannot take an {kind} "
                                 f"driver; {kind} drivers act on {', '.join(able)} joints")
            if body is not None or coordinate is not None:
                raise ModelError(f"{what}: body/coordinate apply to coordinate drivers only")
        self.drivers[name] = DriverSpec(name=name, kind=kind, law=law, joint=joint, body=body,
                                        coordinate=coordinate)
        return name

    # ----------------------------------------------------------------------------- forces
    def add_coupler(self, type: str, name: str, joint1: str, joint2: str, **params) -> str:
        """Add a coupler ``type`` named ``name``: one equation between the coordinates of two
        joints added before (constraints.couplers).

        "gear": ratio (q2 = ratio q1, two revolute joints; external pair: -z1 / z2);
        "rack_pinion": radius (m; x2 = radius theta1, a revolute then a translational joint);
        "coupler": c1, c2, c0 (c1 q1 + c2 q2 = c0, any two joint coordinates, SI units).
        """
        from ..constraints.couplers import COORDINATE_OF, COUPLER_TYPES, NEEDS
        what = f"couplers[{name!r}]"
        if type not in COUPLER_TYPES:
            raise ModelError(f"{what}: unknown coupler type {type!r}; use "
                             + ", ".join(COUPLER_TYPES))
        self._check_new_name(name, "coupler")
        cls = COUPLER_TYPES[type]
        allowed = {p.name for p in cls.parameters}
        extra = set(params) - allowed
        if extra:
            raise ModelError(f"{what}: unknown parameter(s) {sorted(extra)} for a {type}; "
                             f"allowed: {sorted(allowed)}")
        cls.coefficients(params, what)
        joints = []
        for key, joint, need in zip(("joint1", "joint2"), (joint1, joint2), NEEDS[type]):
            if joint not in self.joints:
                raise ModelError(f"{what}.{key}: unknown joint {joint!r}; add it with add_joint "
                                 f"first (joints: {', '.join(self.joints) or 'none'})")
            kind = COORDINATE_OF.get(self.joints[joint].type)
            if kind is None:
                raise ModelError(f"{what}.{key}: joint {joint!r} is a "
                                 f"{self.joints[joint].type}; couplers take "
                                 f"{', '.join(COORDINATE_OF)} joints")
            if need is not None and kind != need:
                raise ModelError(f"{what}.{key}: a {type} needs a "
                                 + ("revolute (turning)" if need == 0 else "translational")
                                 + f" joint, got the {self.joints[joint].type} {joint!r}")
            joints.append(self.joints[joint])
        if joint1 == joint2:
            raise ModelError(f"{what}: couples joint {joint1!r} with itself")
        moving = []
        for j in joints:
            for body in (j.body_i, j.body_j):
                if body != GROUND and body not in moving:
                    moving.append(body)
        if len(moving) > 2:
            raise ModelError(f"{what}: the joints {joint1!r} and {joint2!r} move the bodies "
                             f"{', '.join(moving)}; a coupler's equation may involve at most two "
                             "moving bodies (both joints on the ground, or one on the ground "
                             "and one on the same body), so a moving carrier is not supported "
                             "yet; fix the carrier to the ground or couple other joints")
        self.couplers[name] = CouplerSpec(type=type, name=name, joint1=joint1, joint2=joint2,
                                          params=dict(params))
        return name

    def add_force(self, type: str, name: str, **params) -> str:
        """Add a force element (see spatialmbd.forces.FORCE_TYPES for types and parameters)."""
        from ..forces import FORCE_TYPES
        what = f"forces[{name!r}]"
        self._check_new_name(name, "force")
        if type not in FORCE_TYPES:
            raise ModelError(f"{what}: unknown force type {type!r}; valid types: "
                             + ", ".join(sorted(FORCE_TYPES)))
        spec = ForceSpec(type=type, name=name, params=dict(params))
        FORCE_TYPES[type].validate(spec, self)
        self.forces[name] = spec
        return name

    def add_ground_shape(self, shape: dict) -> None:
        """Display geometry fixed in global axes (animation only)."""
        self.ground_shapes.append(dict(shape))

    # ----------------------------------------------------------------------------- compile
    def compile(self):
        """Validate the whole model and return the frozen :class:`Model`."""
        from .compile import compile_model
        return compile_model(self)

    # ----------------------------------------------------------------------------- helpers
    def _check_new_name(self, name, kind):
        if not isinstance(name, str) or not name:
            raise ModelError(f"{kind} name must be a non-empty string, got {name!r}")
        if name == GROUND:
            raise ModelError(f"{kind} name {name!r} is reserved for the fixed ground")
        if "." in name:
            raise ModelError(f"{kind} name {name!r}: '.' is not allowed in names (it separates "
                             "names in result columns)")
        for other, table in (("body", self.bodies), ("joint", self.joints),
                             ("driver", self.drivers), ("force", self.forces),
                             ("coupler", getattr(self, "couplers", {}))):
            if name in table:
                raise ModelError(f"duplicate name {name!r}: a {other} already has it; names of "
                                 "bodies, joints, drivers and forces must be unique")


register_builder(ModelBuilder)
