"""Mass properties of solid shapes of uniform density (closed forms) and of meshes (trimesh).

Every function returns :class:`MassProperties`: mass (kg), centre of mass (m) and the inertia
tensor about the centre of mass (kg m^2), both in the axes of the shape description
(``center`` and, for boxes, ``p``; cylinders and capsules along ``axis``).  Shape dictionaries are
those of the viewer and of model files::

    {"type": "box", "size": [lx, ly, lz], "center": [...], "p": [e0, e1, e2, e3]}
    {"type": "cylinder", "radius": r, "length": L, "center": [...], "axis": [...]}
    {"type": "sphere", "radius": r, "center": [...]}
    {"type": "capsule", "radius": r, "length": L, "center": [...], "axis": [...]}   (L: the
        cylindrical part, between the centres of the two hemispherical caps)
    {"type": "mesh", "vertices": (n, 3), "faces": (m, 3)} or {"type": "mesh", "file": path}
        (optional "scale", "center", "p"; see :mod:`spatialmbd.meshes`)

:func:`combine` adds several parts (parallel-axis theorem).  Meshes need the optional extra
``pip install spatialmbd[mesh]`` (trimesh); the mesh must be closed (watertight) so that its
volume is defined.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..meshes import mesh_arrays

__all__ = ["MassProperties", "shape_mass_properties", "combine", "body_mass_properties", "box",
           "cylinder", "sphere", "capsule", "mesh"]


@dataclass(frozen=True)
class MassProperties:
    """mass: kg; com: (3,) m; inertia: (3, 3) kg m^2 about the centre of mass."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


def _axis_frame(axis) -> np.ndarray:
    """Rotation whose third column is the unit ``axis``."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    helper = np.eye(3)[np.argmin(np.abs(u))]
    a = helper - u * (helper @ u)
    a /= np.linalg.norm(a)
    return np.column_stack([a, np.cross(u, a), u])


def box(density: float, size) -> MassProperties:
    """Solid box with sides size = (lx, ly, lz) (m): I_x = m (ly^2 + lz^2) / 12, cyclic."""
    lx, ly, lz = (float(x) for x in size)
    m = density * lx * ly * lz
    return MassProperties(m, np.zeros(3), np.diag([m * (ly**2 + lz**2) / 12,
                                                   m * (lz**2 + lx**2) / 12,
                                                   m * (lx**2 + ly**2) / 12]))


def cylinder(density: float, radius: float, length: float) -> MassProperties:
    """Solid cylinder along z: I_z = m r^2 / 2, I_x = I_y = m (3 r^2 + L^2) / 12."""
    m = density * math.pi * radius**2 * length
    ix = m * (3 * radius**2 + length**2) / 12
    return MassProperties(m, np.zeros(3), np.diag([ix, ix, m * radius**2 / 2]))


def sphere(density: float, radius: float) -> MassProperties:
    """Solid sphere: I = 2 m r^2 / 5."""
    m = density * 4.0 / 3.0 * math.pi * radius**3
    return MassProperties(m, np.zeros(3), np.eye(3) * 0.4 * m * radius**2)


def capsule(density: float, radius: float, length: float) -> MassProperties:
    """Cylinder of length L along z closed by two solid hemispheres of radius r.

    A hemisphere of mass m_h has its centre of mass 3 r / 8 from its flat face; about its own
    centre of mass I_z = 2 m_h r^2 / 5 and I_x = (83 / 320) m_h r^2.  Each sits at
    d = L / 2 + 3 r / 8 from the capsule's centre (parallel-axis theorem).
    """
    cyl = cylinder(density, radius, length)
    mh = density * 2.0 / 3.0 * math.pi * radius**3
    d = length / 2 + 3 * radius / 8
    ix_h = 83.0 / 320.0 * mh * radius**2 + mh * d**2
    iz_h = 0.4 * mh * radius**2
    inertia = cyl.inertia + 2 * np.diag([ix_h, ix_h, iz_h])
    return MassProperties(cyl.mass + 2 * mh, np.zeros(3), inertia)


def mesh(density: float, vertices=None, faces=None, file=None, scale=1.0) -> MassProperties:
    """Closed triangle mesh (m; file, or vertices and faces, see :mod:`spatialmbd.meshes`)
    through trimesh (optional extra ``spatialmbd[mesh]``)."""
    try:
        import trimesh
    except ImportError:
        raise ModelError("mass properties of a mesh need trimesh: pip install "
                         "'spatialmbd[mesh]' (or give the body's mass and inertia)") from None
    V, F = mesh_arrays({"type": "mesh", "vertices": vertices, "faces": faces, "file": file,
                        "scale": scale}, f"mesh {file or ''}".strip())
    tm = trimesh.Trimesh(vertices=V, faces=F, process=True)
    if not tm.is_watertight:
        raise ModelError(f"mesh {file or ''}: not closed (watertight), so its volume and mass "
                         "properties are undefined; repair it or give mass and inertia")
    tm.density = float(density)
    if tm.volume < 0:
        tm.invert()
    return MassProperties(float(tm.mass), np.asarray(tm.center_mass, dtype=float),
                          np.asarray(tm.moment_inertia, dtype=float))


def _rotation_of(shape: dict) -> np.ndarray:
    if shape.get("type") in ("cylinder", "capsule"):
        return _axis_frame(shape.get("axis", (0.0, 0.0, 1.0)))
    if shape.get("p") is not None:
        from ..rotations import A_from_p
        p = np.asarray(shape["p"], dtype=float)
        return A_from_p(p / np.linalg.norm(p))
    return np.eye(3)


def shape_mass_properties(shape: dict, density: float) -> MassProperties:
    """Mass properties of one shape dict (see the module docstring) at ``density`` (kg/m^3),
    in the axes the shape is described in."""
    kind = shape.get("type")
    if not (math.isfinite(float(density)) and float(density) > 0):
        raise ModelError(f"density must be a positive number (kg/m^3), got {density!r}")
    if kind == "box":
        local = box(density, shape["size"])
    elif kind == "cylinder":
        local = cylinder(density, float(shape["radius"]), float(shape["length"]))
    elif kind == "sphere":
        local = sphere(density, float(shape["radius"]))
    elif kind == "capsule":
        local = capsule(density, float(shape["radius"]), float(shape["length"]))
    elif kind == "mesh":
        local = mesh(density, shape.get("vertices"), shape.get("faces"), shape.get("file"),
                     shape.get("scale", 1.0))
    else:
        raise ModelError(f"no mass properties for shape type {kind!r}; use box, cylinder, "
                         "sphere, capsule or mesh")
    R = _rotation_of(shape)
    center = np.asarray(shape.get("center", (0.0, 0.0, 0.0)), dtype=float)
    return MassProperties(local.mass, center + R @ local.com, R @ local.inertia @ R.T)


def combine(parts) -> MassProperties:
    """Sum of several parts, all in the same axes (parallel-axis theorem)."""
    parts = list(parts)
    mass = sum(p.mass for p in parts)
    if not mass > 0:
        raise ModelError("the parts have no mass")
    com = sum(p.mass * np.asarray(p.com) for p in parts) / mass
    inertia = np.zeros((3, 3))
    for p in parts:
        d = np.asarray(p.com) - com
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return MassProperties(float(mass), com, 0.5 * (inertia + inertia.T))


def body_mass_properties(shapes, density: float, what: str = "body",
                         tolerance: float = 1e-9) -> tuple:
    """(mass kg, inertia (3, 3) kg m^2) of a body made of ``shapes`` (body axes) at ``density``
    (kg/m^3, one number, or one per shape), for ``ModelBuilder.add_body`` and model files.

    The body's reference point is its centre of mass, so the shapes' centre of mass must be at
    the body origin (within ``tolerance`` times their size): otherwise a ModelError says by how
    much to move them.
    """
    shapes = list(shapes or [])
    if not shapes:
        raise ModelError(f"{what}: a density needs shapes to compute the mass properties from")
    densities = np.broadcast_to(np.asarray(density, dtype=float), (len(shapes),))
    parts = [shape_mass_properties(s, float(rho)) for s, rho in zip(shapes, densities)]
    total = combine(parts)
    size = max(1e-300, max(float(np.linalg.norm(np.asarray(s.get("center", (0, 0, 0)),
                                                            dtype=float))) for s in shapes),
               max(float(np.max(np.diag(p.inertia))) / p.mass for p in parts) ** 0.5)
    if np.linalg.norm(total.com) > tolerance * size:
        c = [float(f"{x:.6g}") + 0.0 for x in total.com]
        raise ModelError(f"{what}: the centre of mass of its shapes is at {c} m in body axes, "
                         "not at the body origin (a body's position is its centre of mass); "
                         f"move every shape centre by {[0.0 - x for x in c]} and its position by "
                         f"{c} in body axes")
    return total.mass, total.inertia
