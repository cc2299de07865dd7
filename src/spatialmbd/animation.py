"""From results to the offline HTML animation (:mod:`spatialmbd.viewer`).

:func:`static_scene` describes what does not move with time: each body's display shapes (the
``shapes`` given to ``ModelBuilder.add_body``, or, when there are none, a box with the body's
inertia, :func:`spatialmbd.viewer.default_shapes`, turned onto the principal axes when the
inertia tensor is not diagonal), joint markers at each joint point on body i, the ground
shapes and gravity (the camera's "down"). :func:`animation_scene` adds the time series r, p of
every body; :func:`write_animation` writes the page.

Works with dynamic Results, KinematicResults and LoadedResults (the static scene is stored in
HDF5 results files, so no model is needed to animate one).
"""
from __future__ import annotations

import pathlib
from typing import Optional

import numpy as np

from .viewer import default_shapes, write_animation_html

__all__ = ["static_scene", "animation_scene", "write_animation", "body_shapes"]

#: default upper limit on the number of frames embedded in a page
MAX_FRAMES = 1000


def body_shapes(mass: float, inertia: np.ndarray) -> list:
    """A box with the inertia of the body (mass kg, inertia (3, 3) kg m^2 in body axes),
    oriented along the principal axes."""
    from .rotations import p_from_A
    inertia = 0.5 * (np.asarray(inertia, dtype=float) + np.asarray(inertia, dtype=float).T)
    moments, axes = np.linalg.eigh(inertia)                      # columns: principal axes
    shapes = default_shapes(mass, moments)
    off = np.abs(inertia - np.diag(np.diag(inertia))).max()
    if off > 1e-12 * max(np.abs(inertia).max(), 1e-300):
        if np.linalg.det(axes) < 0:
            axes[:, 2] = -axes[:, 2]
        shapes[0]["p"] = [float(x) for x in p_from_A(axes)]     # box axes -> body axes
    else:
        # diagonal tensor: keep the box on the body axes (sides in x, y, z order)
        shapes = default_shapes(mass, np.diag(inertia))
    return shapes


def static_scene(model) -> dict:
    """The time-independent part of the scene (JSON-compatible): bodies with names, colours
    and shapes; joint markers; ground shapes; gravity."""
    state = getattr(model, "builder_state", None) or {}
    specs = state.get("bodies", {})
    bodies = []
    for k, name in enumerate(model.body_names):
        spec = specs.get(name)
        shapes = list(getattr(spec, "shapes", None) or [])
        if not shapes:
            shapes = body_shapes(float(model.mass[k]), model.inertia[k])
        body = {"name": name, "shapes": _plain(shapes)}
        color = getattr(spec, "color", None)
        if color:
            body["color"] = color
        bodies.append(body)
    joints = []
    for g in model.constraint_groups:
        if g.rheonomic:                      # drivers act on joints that are already shown
            continue
        for n, name in enumerate(g.names):
            bi = int(g.body_i[n])
            joints.append({"name": name, "type": g.name,
                           "body": -1 if bi >= model.nb else bi,
                           "point_local": [float(x) for x in g.geometry.s_i[n]]})
    return {"bodies": bodies, "joints": joints,
            "ground": _plain(list(state.get("ground_shapes", []) or [])),
            "gravity": [float(x) for x in np.asarray(model.gravity, dtype=float)]}


def _plain(value):
    """Shapes as plain JSON-compatible values (numpy arrays -> lists)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _frames(t: np.ndarray, q: np.ndarray, max_frames: Optional[int]) -> np.ndarray:
    """Indices of the frames to show: finite states only, at most max_frames evenly spread."""
    finite = np.all(np.isfinite(q.reshape(len(t), -1)), axis=1) & np.isfinite(t)
    idx = np.flatnonzero(finite)
    if max_frames and idx.size > max_frames:
        pick = np.unique(np.round(np.linspace(0, idx.size - 1, max_frames)).astype(int))
        idx = idx[pick]
    return idx


def animation_scene(results, *, model=None, max_frames: Optional[int] = MAX_FRAMES) -> dict:
    """The viewer scene dict of a motion (see spatialmbd.viewer.animation for its keys).

    results: Results, KinematicResults or LoadedResults (an HDF5 file's contents).
    model: the Model, when the results do not carry it. max_frames: at most this many frames
    (evenly spread; None for all). Non-finite states (after a failure) are left out.
    """
    model = model if model is not None else getattr(results, "model", None)
    if model is not None:
        base = static_scene(model)
    else:
        base = getattr(results, "scene", None)
        if not base:
            raise ValueError("these results carry no model or scene description; animate an "
                             "HDF5 results file written by spatialmbd, or give the model")
    if results.q is None:
        raise ValueError("these results hold no body positions (q) to animate")
    t = np.asarray(results.t, dtype=float)
    q = np.asarray(results.q, dtype=float)
    idx = _frames(t, q, max_frames)
    if idx.size == 0:
        raise ValueError("no finite state to animate (the analysis failed at its first time)")
    scene = {"t": t[idx], "bodies": [], "joints": base.get("joints", []),
             "ground": base.get("ground", []), "gravity": base.get("gravity")}
    for k, body in enumerate(base["bodies"]):
        entry = dict(body)
        entry["r"] = q[idx, k, :3]
        entry["p"] = q[idx, k, 3:]
        scene["bodies"].append(entry)
    return scene


def write_animation(results, path, *, model=None, title: Optional[str] = None,
                    max_frames: Optional[int] = MAX_FRAMES) -> pathlib.Path:
    """Write the offline HTML animation of ``results`` to ``path`` (atomically)."""
    from .io.results_io import atomic_write
    from .viewer.animation import animation_html
    scene = animation_scene(results, model=model, max_frames=max_frames)
    if title is None:
        m = model if model is not None else getattr(results, "model", None)
        stored = getattr(results, "model_dict", None)
        name = m.name if m is not None else (stored or {}).get("name")
        title = f"spatialmbd: {name}" if name else "spatialmbd animation"
    text = animation_html(scene, title=title)
    path = pathlib.Path(path)
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


# keep the viewer's writer importable from here too
write_animation_html = write_animation_html
