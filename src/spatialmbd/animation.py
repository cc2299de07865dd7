"""From results to the offline HTML animation (:mod:`spatialmbd.viewer`).

:func:`static_scene` describes what does not move with time: each body's display shapes (the
``shapes`` given to ``ModelBuilder.add_body``, or, when there are none, a box with the body's
inertia, :func:`spatialmbd.viewer.default_shapes`, turned onto the principal axes when the
inertia tensor is not diagonal), joint markers at each joint point on body i, the ground
shapes, spring-damper elements (drawn as helices / dampers between their attachment points) and
gravity (the camera's "down"). :func:`animation_scene` adds the time series r, p of every body
and, on request, the joint reaction forces as arrows (``reactions=True``, from
``Results.reactions()``); :func:`mode_shape_scene` animates a small-motion mode shape about a
configuration; :func:`write_animation` writes the page.

Works with dynamic Results, KinematicResults and LoadedResults (the static scene is stored in
HDF5 results files, so no model is needed to animate one).
"""
from __future__ import annotations

import pathlib
from typing import Optional

import numpy as np

from .viewer import default_shapes, write_animation_html

__all__ = ["static_scene", "animation_scene", "write_animation", "body_shapes",
           "mode_shape_scene"]

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
    return {"bodies": bodies, "joints": joints, "springs": _springs(model),
            "ground": _plain(list(state.get("ground_shapes", []) or [])),
            "gravity": [float(x) for x in np.asarray(model.gravity, dtype=float)]}


def _springs(model) -> list:
    """Two-point force elements drawn as springs (their type's ``drawn_as``: spring_damper)
    and distance constraints drawn as links (spherical-spherical, spherical-revolute), as
    viewer springs: body -1 is the ground. Contacts, limits, friction and actuators are not
    springs and are not drawn as such."""
    out = []
    for g in getattr(model, "constraint_groups", ()):
        if getattr(type(g), "drawn_as", "") != "link":
            continue
        geo = g.geometry
        for n, name in enumerate(g.names):
            bi, bj = int(g.body_i[n]), int(g.body_j[n])
            out.append({"name": name, "kind": "link",
                        "body_i": -1 if bi >= model.nb else bi,
                        "point_i": [float(x) for x in geo.s_i[n]],
                        "body_j": -1 if bj >= model.nb else bj,
                        "point_j": [float(x) for x in geo.s_j[n]]})
    for g in getattr(model, "force_groups", ()):
        if getattr(type(g), "drawn_as", "") != "spring" or not all(
                hasattr(g, key) for key in ("bi", "bj", "s_i", "s_j")):
            continue
        stiffness = np.broadcast_to(np.asarray(getattr(g, "k", 1.0), dtype=float), (g.n,))
        damping = np.broadcast_to(np.asarray(getattr(g, "c", 0.0), dtype=float), (g.n,))
        for n, name in enumerate(g.names):
            kind = ("spring_damper" if stiffness[n] > 0 and damping[n] > 0 else
                    "damper" if damping[n] > 0 else "spring")
            bi, bj = int(g.bi[n]), int(g.bj[n])
            out.append({"name": name, "kind": kind,
                        "body_i": -1 if bi >= model.nb else bi,
                        "point_i": [float(x) for x in g.s_i[n]],
                        "body_j": -1 if bj >= model.nb else bj,
                        "point_j": [float(x) for x in g.s_j[n]]})
    return out


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


def animation_scene(results, *, model=None, max_frames: Optional[int] = MAX_FRAMES,
                    reactions: bool = False) -> dict:
    """The viewer scene dict of a motion (see spatialmbd.viewer.animation for its keys).

    results: Results, KinematicResults or LoadedResults (an HDF5 file's contents).
    model: the Model, when the results do not carry it. max_frames: at most this many frames
    (evenly spread; None for all). Non-finite states (after a failure) are left out.
    reactions: also draw each joint's reaction force on its body i (N, global axes, at the
    joint point; needs results with multipliers, i.e. dynamic Results).
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
             "springs": base.get("springs", []),
             "ground": base.get("ground", []), "gravity": base.get("gravity")}
    if reactions:
        scene["arrows"] = _reaction_arrows(results, model, idx)
    for k, body in enumerate(base["bodies"]):
        entry = dict(body)
        entry["r"] = q[idx, k, :3]
        entry["p"] = q[idx, k, 3:]
        scene["bodies"].append(entry)
    return scene


def _reaction_arrows(results, model, idx) -> list:
    """Reaction force on body i of every joint, as arrows at the joint point (one scale)."""
    if model is None or not hasattr(results, "reactions") or getattr(results, "lam",
                                                                       None) is None:
        raise ValueError("reaction arrows need the Results of a dynamic analysis with their "
                         "model (from simulate); these results cannot give the joint reactions "
                         "(a results file or a kinematic analysis): animate the model file "
                         "with --reactions instead")
    index = {name: k for k, name in enumerate(model.body_names)}
    arrows = []
    for name, reaction in results.reactions().items():
        force = np.asarray(reaction.force_i, dtype=float)[idx]
        if reaction.body_i in index:
            body, point = index[reaction.body_i], _joint_point_local(model, name)
        else:                                # body i is the ground: draw it on body j
            if reaction.body_j not in index:
                continue
            body, point = index[reaction.body_j], _joint_point_local(model, name, "s_j")
            force = np.asarray(reaction.force_j, dtype=float)[idx]
        arrows.append({"name": name, "kind": "reaction", "body": body, "point_local": point,
                       "vectors": force, "color": "#d62728"})
    big = max([float(np.max(np.linalg.norm(a["vectors"], axis=1))) for a in arrows] + [0.0])
    for a in arrows:                         # one scale for all, so the arrows compare
        if big > 0:
            a["scale"] = _scene_size(model) * 0.3 / big
    return arrows


def _joint_point_local(model, name, which="s_i") -> list:
    for g in model.constraint_groups:
        if name in g.names:
            return [float(x) for x in getattr(g.geometry, which)[list(g.names).index(name)]]
    return [0.0, 0.0, 0.0]


def _scene_size(model) -> float:
    """A length of the scene (m) for arrow scales: the spread of the bodies and joint points."""
    r = np.asarray([b.r for b in (getattr(model, "builder_state", None) or {}).get(
        "bodies", {}).values()] or [[0.0, 0.0, 0.0]], dtype=float)
    size = float(np.max(np.ptp(np.vstack([r, np.zeros((1, 3))]), axis=0)))
    return size if size > 0 else 1.0


def mode_shape_scene(model, q0, shape, *, amplitude: float = 0.1, n_frames: int = 61,
                     frequency: Optional[float] = None) -> dict:
    """A scene that animates one mode shape about the configuration q0.

    q0: (nb, 7) configuration [r, p] per body. shape: (nb, 6) mode in velocity space
    [delta r (m), delta theta (rad, global rotation vector)] per body (e.g. an eigenvector of the
    linearized equations). The bodies move as r0 + s(t) delta r and rotate by s(t) delta theta,
    with s(t) = amplitude sin(2 pi t / T) over one period T = 1 / frequency (frequency in Hz;
    T = 1 s when not given) and amplitude relative to the largest component of ``shape``.
    """
    from .rotations import rotate_p
    q0 = np.asarray(q0, dtype=float).reshape(model.nb, 7)
    shape = np.asarray(shape, dtype=float).reshape(model.nb, 6)
    if not np.all(np.isfinite(shape)) or np.max(np.abs(shape)) == 0:
        raise ValueError("mode_shape_scene: the mode shape must be finite and non-zero")
    period = 1.0 / float(frequency) if frequency else 1.0
    t = np.linspace(0.0, period, int(n_frames))
    s = float(amplitude) / np.max(np.abs(shape)) * np.sin(2 * np.pi * t / period)
    base = static_scene(model)
    scene = {"t": t, "bodies": [], "joints": base["joints"], "springs": base["springs"],
             "ground": base["ground"], "gravity": base["gravity"]}
    for k, body in enumerate(base["bodies"]):
        entry = dict(body)
        entry["r"] = q0[k, :3] + s[:, None] * shape[k, :3]
        entry["p"] = rotate_p(np.broadcast_to(q0[k, 3:], (t.size, 4)),
                              s[:, None] * shape[k, 3:])
        scene["bodies"].append(entry)
    return scene


def write_animation(results, path, *, model=None, title: Optional[str] = None,
                    max_frames: Optional[int] = MAX_FRAMES, reactions: bool = False,
                    renderer: str = "auto") -> pathlib.Path:
    """Write the offline HTML animation of ``results`` to ``path`` (atomically).

    reactions: draw the joint reaction forces (see :func:`animation_scene`). renderer: "auto"
    (WebGL with the Canvas fallback) or "canvas" (no three.js bundle, a smaller page).
    """
    from .atomic import atomic_write
    from .viewer.animation import animation_html
    scene = animation_scene(results, model=model, max_frames=max_frames, reactions=reactions)
    if title is None:
        m = model if model is not None else getattr(results, "model", None)
        stored = getattr(results, "model_dict", None)
        name = m.name if m is not None else (stored or {}).get("name")
        title = f"spatialmbd: {name}" if name else "spatialmbd animation"
    text = animation_html(scene, title=title, renderer=renderer)
    path = pathlib.Path(path)
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


# keep the viewer's writer importable from here too
write_animation_html = write_animation_html
