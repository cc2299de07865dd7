"""Import MJCF and URDF files through MuJoCo's compiler (optional extra ``spatialmbd[mjcf]``).

MuJoCo parses both formats, applies its defaults, computes mass properties from geoms where a
body gives none (boxes, spheres, cylinders, capsules, ellipsoids and meshes, at their density),
and compiles a model in its reference configuration ``qpos0``.  This package reads that compiled
model and builds the equivalent :class:`~spatialmbd.model.builder.ModelBuilder` (docs/import.md):

* bodies: one spatialmbd body per MuJoCo *weld group* (a body and the children welded to it
  without joints; a group welded to the world is part of the ground).  The body frame is the
  inertial frame of the group's root body (its centre of mass and principal axes, MuJoCo's
  ``ipos``/``iquat``), so a group of one body has a diagonal inertia; a larger group gets the
  combined mass, centre of mass and full inertia tensor (parallel-axis theorem).  Geoms become
  display shapes with their colour and role (``visual`` or ``collision``, :mod:`.geoms`);
  sites become named points.
* joints: hinge -> revolute, slide -> translational, ball -> spherical, free -> none (a free
  body).  Several joints in one body map when they form a joint of ours exactly: two hinges
  through one point with perpendicular axes -> universal, three or more hinges through one point
  spanning space -> spherical, hinge + slide on one axis -> cylindrical.
* what acts on the joints (:mod:`.joint_elements`): hinge, slide and ball springs and dampers
  (exact), limits -> joint_limit and friction loss -> joint_friction (MuJoCo's soft constraints
  mapped through solref/solimp), hinge and slide armature -> armature (exact),
  motor/position/velocity/general actuators (exact, command 0), fixed two-joint tendons held
  by a tendon equality -> couplers, fixed tendons' springs and dampers and the actuators
  pulling fixed tendons -> fixed_tendon (exact).
* equality constraints: connect -> spherical, weld -> fixed (both exact: MuJoCo's soft loop
  closure becomes a rigid one); joint equalities a0 + a1 x -> couplers.
* gravity: ``opt.gravity`` (zero when gravity is disabled).

What has no counterpart is left out and listed (:class:`.report.LeftOut`: kind, element,
detail) in ``MJCFImport.left_out``, with one :class:`MJCFImportWarning` that counts them per kind
(``left out: 5 joint limits, 9 colliding geoms``); what is imported only approximately --
MuJoCo's soft joint limits and friction loss as force laws -- is listed in
``MJCFImport.approximated`` and counted in the same warning (``approximated: 4 joint limits``).
``strict=True`` instead raises a ModelError naming every left-out feature with no counterpart
(tendons, actuators with dynamics, a ball joint's armature, ...) and every approximation;
left-out joint limits, collisions and keyframes act only when reached, touching or chosen, and
are never an error. The default is ``strict=False``, as in ``spatialmbd import``.

The imported values are checked with the model-file reader's range rules (a mass or position
of 1e300 is refused here, not after the file is written).
"""
from __future__ import annotations

import pathlib
import warnings
from dataclasses import dataclass, field
from typing import Optional, Union

from ...checks import range_problems
from ...errors import ModelError
from ...model.builder import ModelBuilder
from .build import build
from .compile import compile_model, mujoco_module, run_forward
from .report import LeftOut, details, summary

__all__ = ["import_mjcf", "read_mjcf", "MJCFImport", "MJCFImportWarning", "LeftOut"]


class MJCFImportWarning(UserWarning):
    """An MJCF/URDF feature was left out of the imported model (the message counts them)."""


@dataclass
class MJCFImport:
    """The result of :func:`read_mjcf`.

    builder: the ModelBuilder. groups: spatialmbd body name -> MuJoCo body ids merged into it.
    left_out: the features not imported, one :class:`LeftOut` (kind, element, detail) each.
    notes: other remarks (URDF links whose mass MuJoCo computed from their geometry).
    mj_model: the compiled ``mujoco.MjModel`` (for comparisons).
    """

    builder: ModelBuilder
    groups: dict
    left_out: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    mj_model: object = None
    #: what is imported approximately (MuJoCo's soft limits and friction loss as force laws),
    #: one :class:`LeftOut` each (``approximation`` True)
    approximated: list = field(default_factory=list)

    @property
    def summary(self) -> str:
        """What was left out, counted per kind ("" when nothing)."""
        return summary(self.left_out)

    @property
    def approximation_summary(self) -> str:
        """What was approximated, counted per kind ("" when nothing)."""
        return summary(self.approximated)


def _check_ranges(builder) -> None:
    """The model-file reader's range rules (:data:`spatialmbd.checks.RANGES`) on the imported
    values, so that no file is written that the reader refuses; ModelError naming the
    elements. Meshes are checked when read (finite, indices in range, sizes)."""
    import numpy as np

    def plain(x):
        return np.asarray(x, dtype=float).tolist()

    bodies, joints = list(builder.bodies.values()), list(builder.joints.values())
    data = {"gravity": plain(builder.gravity), "bodies": [], "joints": []}
    for spec in bodies:
        shapes = []
        for s in spec.shapes:
            shape = {k: v for k, v in s.items() if k not in ("vertices", "faces")}
            if s.get("vertices") is not None:    # the mesh's extent, checked as a length
                shape["size"] = plain(np.max(np.abs(s["vertices"]), axis=0))
            shapes.append(shape)
        data["bodies"].append({"mass": float(spec.mass), "inertia": plain(spec.inertia),
                               "position": plain(spec.r), "shapes": shapes,
                               "points": {k: plain(v) for k, v in spec.points.items()}})
    for spec in joints:
        data["joints"].append({k: plain(v) for k, v in spec.geometry.items()
                               if v is not None and not isinstance(v, str)})
    problems = range_problems(data)
    if problems:
        def where(path):
            if path and path[0] in ("bodies", "joints"):
                spec = (bodies if path[0] == "bodies" else joints)[path[1]]
                rest = "".join(f"[{k}]" if isinstance(k, int) else f".{k}" for k in path[2:])
                kind = "body" if path[0] == "bodies" else "joint"
                return f"{kind} {spec.name!r}{rest}"
            return ".".join(str(k) for k in path)
        raise ModelError("the imported model has values the model-file reader refuses: "
                         + "; ".join(f"{where(path)}: {message}"
                                     for path, message in sorted(problems, key=str)[:10]))


def read_mjcf(source: Union[str, pathlib.Path], *, strict: bool = False,
              name: Optional[str] = None, keyframe: Optional[str] = None,
              contacts: bool = False) -> MJCFImport:
    """Compile an MJCF or URDF file (or XML text) with MuJoCo and build the spatialmbd model.

    source: path of a .xml (MJCF) or .urdf file, or the XML text. strict: raise a ModelError
    naming every feature with no exact counterpart (True), or leave them out, listed in
    ``left_out`` and counted in one MJCFImportWarning (False, the default). name: the model name
    (default: the file name). keyframe: the name of a keyframe to start from (its qpos is the
    assembled configuration, its qvel the initial velocities, its ctrl the actuators'
    commands); default: qpos0 at rest, commands 0. contacts: the colliding geom pairs become
    ``contact`` elements (MuJoCo's filtering, friction, margin; solref/solimp mapped to a
    linear law: :mod:`.contacts`), listed as approximated; default: left out. Every failure (of the file, of MuJoCo's
    compiler, of the reader's checks on the result) is a ModelError.
    """
    mujoco = mujoco_module()
    m, stem, text = compile_model(source)
    d = run_forward(mujoco, m, keyframe)     # qpos0, or the keyframe's qpos, qvel and ctrl
    builder, groups, left_out, notes = build(mujoco, m, d, stem, text, name, keyframe,
                                             contacts)
    approximated = [item for item in left_out if item.approximation]
    left_out = [item for item in left_out if not item.approximation]
    unsupported = [item for item in left_out if item.unsupported] + approximated
    if strict and unsupported:
        raise ModelError("MJCF/URDF features with no exact counterpart in spatialmbd: "
                         + "; ".join(details(unsupported)) + ". Remove them from the file, or "
                         "import with strict=False (CLI: without --strict) to leave them out "
                         "or approximate them")
    _check_ranges(builder)
    if left_out or approximated:
        parts = ([f"left out: {summary(left_out)}"] if left_out else []) + (
            [f"approximated: {summary(approximated)}"] if approximated else [])
        warnings.warn("; ".join(parts) + " (MJCFImport.left_out and .approximated list them; "
                      "CLI: --verbose)", MJCFImportWarning, stacklevel=2)
    for note in notes:
        warnings.warn(note, MJCFImportWarning, stacklevel=2)
    return MJCFImport(builder=builder, groups=groups, left_out=left_out, notes=notes,
                      mj_model=m, approximated=approximated)


def import_mjcf(source, *, strict: bool = False, name: Optional[str] = None,
                keyframe: Optional[str] = None, contacts: bool = False) -> ModelBuilder:
    """The ModelBuilder of an MJCF/URDF file (see :func:`read_mjcf`)."""
    return read_mjcf(source, strict=strict, name=name, keyframe=keyframe,
                     contacts=contacts).builder
