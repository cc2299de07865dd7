"""Geoms -> display shapes: primitives, meshes (each MuJoCo mesh once, vertices without
repeats), colours (geom rgba, else its material's), and their role: ``visual`` for geoms that
never collide (MJCF ``contype = conaffinity = 0``: Menagerie's visual class), else
``collision``."""
from __future__ import annotations

import re
from typing import Optional

import numpy as np

from ...meshes import compact
from ...rotations import p_from_A

_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)          # MuJoCo's geom default


def clean(values, scale: float = 1.0) -> list:
    """Plain floats with round-off (below 1e-12 of the scale) set to zero."""
    a = np.asarray(values, dtype=float)
    a = np.where(np.abs(a) < 1e-12 * max(scale, float(np.max(np.abs(a), initial=0.0))), 0.0, a)
    return [float(x) + 0.0 for x in a]


def _hex(rgba) -> Optional[str]:
    r, g, b = (float(x) for x in rgba[:3])
    if np.allclose((r, g, b), _DEFAULT_RGBA[:3]):
        return None                       # MuJoCo's default grey: let the viewer pick colours
    return "#" + "".join(f"{int(round(255 * min(max(c, 0.0), 1.0))):02x}" for c in (r, g, b))


def geom_rgba(m, g) -> np.ndarray:
    """The colour MuJoCo draws geom g with: its rgba, or its material's when the geom keeps
    the default rgba."""
    rgba = np.asarray(m.geom_rgba[g], dtype=float)
    mat = int(m.geom_matid[g]) if hasattr(m, "geom_matid") else -1
    if mat >= 0 and np.allclose(rgba, _DEFAULT_RGBA):
        rgba = np.asarray(m.mat_rgba[mat], dtype=float)
    return rgba


def role(m, g) -> str:
    """``visual`` (never collides: contype = conaffinity = 0) or ``collision``."""
    return "visual" if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0 else "collision"


class GeomShapes:
    """Shapes of the geoms of a compiled model; meshes are compacted once per MuJoCo mesh and
    the same arrays are shared by every geom that uses them."""

    def __init__(self, mujoco, m, d):
        self.mujoco, self.m, self.d = mujoco, m, d
        self._meshes: dict = {}

    def visible(self, g) -> bool:
        return geom_rgba(self.m, g)[3] > 0

    def mesh(self, k) -> tuple:
        """(name, vertices (n, 3) float32 without repeats, faces (f, 3) int32) of mesh k."""
        if k not in self._meshes:
            m = self.m
            v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
            f0, nf = int(m.mesh_faceadr[k]), int(m.mesh_facenum[k])
            V, F = compact(np.asarray(m.mesh_vert[v0:v0 + nv]),
                           np.asarray(m.mesh_face[f0:f0 + nf], dtype=np.int32))
            name = self.mujoco.mj_id2name(m, self.mujoco.mjtObj.mjOBJ_MESH, k) or f"mesh{k}"
            name = re.sub(r"[^A-Za-z0-9_\-]", "_", name)
            self._meshes[k] = (name, V.astype(np.float32), F.astype(np.int32))
        return self._meshes[k]

    def shapes(self, g, R, c) -> list:
        """Display shapes of geom g in the frame (origin c, axes R: body -> global)."""
        mujoco, m, d = self.mujoco, self.m, self.d
        G = mujoco.mjtGeom
        kind = int(m.geom_type[g])
        size = np.asarray(m.geom_size[g], dtype=float)
        Rg = R.T @ np.asarray(d.geom_xmat[g], dtype=float).reshape(3, 3)
        center = R.T @ (np.asarray(d.geom_xpos[g], dtype=float) - c)
        color = _hex(geom_rgba(m, g))
        extra = {"color": color, "role": role(m, g)} if color else {"role": role(m, g)}
        zaxis = Rg[:, 2]
        if kind == G.mjGEOM_PLANE:
            return []                      # an infinite plane: the viewer draws its own floor
        if kind == G.mjGEOM_SPHERE:
            return [dict(type="sphere", radius=float(size[0]), center=clean(center), **extra)]
        if kind == G.mjGEOM_CYLINDER:
            return [dict(type="cylinder", radius=float(size[0]), length=float(2 * size[1]),
                         center=clean(center), axis=clean(zaxis), **extra)]
        if kind == G.mjGEOM_CAPSULE:
            return [dict(type="capsule", radius=float(size[0]), length=float(2 * size[1]),
                         center=clean(center), axis=clean(zaxis), **extra)]
        if kind == G.mjGEOM_BOX or kind == G.mjGEOM_ELLIPSOID:
            return [dict(type="box", size=(2 * size[:3]).tolist(), center=clean(center),
                         p=clean(p_from_A(Rg)), **extra)]
        if kind == G.mjGEOM_MESH and int(m.geom_dataid[g]) >= 0:
            # the compiled mesh, in the geom frame (MuJoCo re-centres it on the geom's pos/quat)
            name, V, F = self.mesh(int(m.geom_dataid[g]))
            return [dict(type="mesh", mesh=name, vertices=V, faces=F, center=clean(center),
                         p=clean(p_from_A(Rg)), **extra)]
        # hfields, sdf: their bounding box in the geom frame
        aabb = np.asarray(m.geom_aabb[g], dtype=float)
        half = np.maximum(aabb[3:], 1e-6)
        return [dict(type="box", size=(2 * half).tolist(), center=clean(center + Rg @ aabb[:3]),
                     p=clean(p_from_A(Rg)), **extra)]
