"""Self-contained offline HTML animation of a multibody motion.

The page is one HTML file that loads nothing from the network: the scene is embedded as JSON,
per-frame arrays as base64 strings of little-endian Float32 values (7 numbers per body and
frame).  It is drawn with WebGL by three.js (a minified bundle shipped as package data,
``three.min.js``, MIT licence in ``THREE_LICENSE``, embedded inline; ``webgl.js`` draws with
one instanced mesh per primitive type), and by our own Canvas-2D software renderer
(``viewer.js``, painter's algorithm) where WebGL 2 is unavailable or fails, or with
``renderer="canvas"`` (a much smaller page) or the URL hash ``#renderer=canvas``.

This module only knows plain dictionaries and arrays; it does not depend on the model classes.

Scene dictionary
----------------
``t``        (n_frames,) times in s, non-decreasing.
``bodies``   list of ``{"name", "r": (n_frames, 3), "p": (n_frames, 4), "shapes": [...],
             "color": "#rrggbb" (optional)}``; r is the centre of mass in global axes, p the Euler
             parameters [e0, e1, e2, e3] with A = (2 e0^2 - 1) I + 2 (e e^T + e0 e~) mapping body to
             global components.  A static body may give r as (3,) and p as (4,).
shapes       in body axes: ``{"type": "box", "size": [lx, ly, lz], "center": [x, y, z],
             "p": [e0, e1, e2, e3] (optional)}``, ``{"type": "cylinder", "radius", "length",
             "center", "axis"}``, ``{"type": "sphere", "radius", "center"}``, ``{"type":
             "capsule", "radius", "length" (between the caps' centres), "center", "axis"}`` (drawn
             as a cylinder and two spheres), ``{"type": "mesh", "vertices": (n, 3), "faces":
             (m, 3)}`` or ``{"type": "mesh", "file": path}`` (optional "scale", "center", "p";
             :mod:`spatialmbd.meshes`; embedded as flat vertex and index lists); each may carry
             its own ``"color"``; a shape with ``"role": "collision"`` is not drawn when its
             body has shapes with ``"role": "visual"``.
``joints``   optional list of ``{"name", "type", "body": index or -1 (ground), "point_local"}``.
``springs``  optional list of force elements drawn between two attachment points:
             ``{"name", "kind": "spring" | "damper" | "spring_damper" | "link", "body_i",
             "point_i", "body_j", "point_j", "radius" (m, coil radius, optional), "turns"
             (optional), "color" (optional)}``; body -1 is the ground (points then global, m),
             otherwise points are in body axes.  "link" is a massless rod.
``arrows``   optional list of time-varying vectors drawn as arrows: ``{"name", "kind" (e.g.
             "force", "reaction", "torque"), "body", "point_local", "vectors": (n_frames, 3)
             in global axes (N or N m), "scale": m per unit (optional: the largest arrow then
             spans 30 % of the scene), "color"}``.
``points``   optional list of moving points, e.g. contact points: ``{"name", "positions":
             (n_frames, 3) global (m), "radius" (m, optional), "color"}``.
``ground``   optional list of shapes fixed in global axes.
``gravity``  optional [gx, gy, gz]; the initial camera uses up = -gravity (default up = +z).

The camera frames the box of the moving bodies' trajectories with their shapes, grown by the
static bodies, ground shapes and origin within three times its size (a dummy body parked far
away is not framed); with no static body, or none moving, the whole scene.

The page exposes ``window.spatialmbdViewer`` (``setTime(t)``, ``getTime()``, ``nFrames``,
``ready``, ``play()``, ``pause()``, ``isPlaying()``, ``fit()``, ``setFollow(on)``,
``isFollowing()``, ``cameraTarget()``) and honours a URL hash ``#t=1.25`` (show that time,
paused), ``#speed=2``, ``#play=1``, ``#renderer=canvas``, ``#follow=0|1`` (the camera follows
the bodies; on by default when they travel more than 4 times their own size);
``spatialmbdViewer.renderer()`` says which renderer draws ("webgl" or "canvas").
"""
from __future__ import annotations

import base64
import html
import json
import math
import pathlib
import re
from importlib import resources
from typing import Any

import numpy as np

__all__ = ["animation_html", "write_animation_html", "default_shapes", "decode_float32"]

#: significant digits of every number embedded in the page
SIGNIFICANT_DIGITS = 6

_COLOR_RE = re.compile(r"^#[0-9a-fA-F]{6}$")
_PLACEHOLDER_RE = re.compile(r"\{\{(TITLE|SCENE_JSON|VIEWER_JS|THREE_JS|WEBGL_JS)\}\}")
RENDERERS = ("auto", "canvas")
_DEGENERATE_SIDE = 1e-3
_PALETTE = ("#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#76b7b2", "#edc948", "#b07aa1",
            "#ff9da7", "#9c755f", "#bab0ac")


# ----------------------------------------------------------------------------------------------
# number formatting
# ----------------------------------------------------------------------------------------------
def _rounded(values: Any, what: str, sig: int = SIGNIFICANT_DIGITS) -> list:
    """Flatten to a list of floats rounded to ``sig`` significant digits (ints where exact)."""
    a = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"{what}: non-finite value {a[bad]!r} at flat index {bad}")
    out = []
    for s in np.char.mod(f"%.{sig - 1}e", a):
        x = float(s) + 0.0  # + 0.0 turns -0.0 into 0.0
        out.append(int(x) if x.is_integer() and abs(x) < 1e15 else x)
    return out


def _float32_base64(a: np.ndarray, what: str) -> str:
    """Base64 of the values as little-endian float32 (finite values only)."""
    a = np.asarray(a, dtype=float)
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a.ravel()))[0])
        raise ValueError(f"{what}: non-finite value {a.ravel()[bad]!r} at flat index {bad}")
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def decode_float32(text: str) -> np.ndarray:
    """Inverse of the page's per-frame encoding: base64 little-endian float32 -> 1-D array."""
    return np.frombuffer(base64.b64decode(text), dtype="<f4").astype(float)


def _vec(value: Any, n: int, what: str) -> list:
    a = np.asarray(value, dtype=float)
    if a.shape != (n,):
        raise ValueError(f"{what}: expected {n} numbers, got shape {a.shape}")
    return _rounded(a, what)


def _positive(value: Any, what: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected a positive number, got {value!r}") from None
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"{what}: expected a positive number, got {value!r}")
    return _rounded([x], what)[0]


def _unit(value: Any, n: int, what: str) -> list:
    a = np.asarray(value, dtype=float)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: expected {n} finite numbers, got {value!r}")
    norm = float(np.linalg.norm(a))
    if norm < 1e-12:
        raise ValueError(f"{what}: zero-length vector {value!r}")
    return _rounded(a / norm, what)


def _color(value: Any, what: str) -> str:
    if not isinstance(value, str) or not _COLOR_RE.match(value):
        raise ValueError(f"{what}: expected a colour '#rrggbb', got {value!r}")
    return value.lower()


# ----------------------------------------------------------------------------------------------
# scene normalisation
# ----------------------------------------------------------------------------------------------
def _shape(shape: Any, what: str) -> dict:
    if not isinstance(shape, dict):
        raise ValueError(f"{what}: a shape must be a dict, got {type(shape).__name__}")
    kind = shape.get("type")
    out: dict = {"type": kind}
    if kind == "box":
        size = np.asarray(shape.get("size"), dtype=float)
        if size.shape != (3,) or not np.all(np.isfinite(size)) or np.any(size <= 0):
            raise ValueError(f"{what}: box 'size' must be 3 positive numbers, got "
                             f"{shape.get('size')!r}")
        out["size"] = _rounded(size, what + ".size")
        if shape.get("p") is not None:
            out["p"] = _unit(shape["p"], 4, what + ".p")
    elif kind == "cylinder":
        out["radius"] = _positive(shape.get("radius"), what + ".radius")
        out["length"] = _positive(shape.get("length"), what + ".length")
        out["axis"] = _unit(shape.get("axis", (0.0, 0.0, 1.0)), 3, what + ".axis")
    elif kind == "sphere":
        out["radius"] = _positive(shape.get("radius"), what + ".radius")
    elif kind == "mesh":
        from ..meshes import mesh_arrays
        V, F = mesh_arrays(shape, what)           # scaled vertices, checked faces
        out["vertices"] = _rounded(V, what + ".vertices")
        out["faces"] = [int(i) for i in F.ravel()]
        if shape.get("p") is not None:
            out["p"] = _unit(shape["p"], 4, what + ".p")
    else:
        raise ValueError(f"{what}: unknown shape type {kind!r} (use 'box', 'cylinder', "
                         "'sphere', 'capsule' or 'mesh')")
    out["center"] = _vec(shape.get("center", (0.0, 0.0, 0.0)), 3, what + ".center")
    if shape.get("color") is not None:
        out["color"] = _color(shape["color"], what + ".color")
    return out


def _capsule(shape: dict, what: str) -> list:
    """A capsule (cylinder of ``length`` between two hemispherical caps of ``radius``) as a
    cylinder and two spheres."""
    radius = _positive(shape.get("radius"), what + ".radius")
    length = _positive(shape.get("length"), what + ".length")
    axis = np.asarray(_unit(shape.get("axis", (0.0, 0.0, 1.0)), 3, what + ".axis"))
    center = np.asarray(_vec(shape.get("center", (0.0, 0.0, 0.0)), 3, what + ".center"))
    extra = {"color": shape["color"]} if shape.get("color") is not None else {}
    return ([dict(type="cylinder", radius=radius, length=length, axis=axis, center=center,
                  **extra)]
            + [dict(type="sphere", radius=radius, center=center + s * 0.5 * length * axis,
                    **extra) for s in (-1.0, 1.0)])


def _shapes(shapes: Any, what: str) -> list:
    """Normalised shapes; a body with shapes of ``role: visual`` is drawn with those only (its
    collision shapes would be drawn over them)."""
    if shapes is None:
        return []
    if isinstance(shapes, dict):
        shapes = [shapes]
    if any(isinstance(s, dict) and s.get("role") == "visual" for s in shapes):
        shapes = [s for s in shapes if not (isinstance(s, dict) and s.get("role") == "collision")]
    out = []
    for i, s in enumerate(shapes):
        parts = _capsule(s, f"{what}[{i}]") if isinstance(s, dict) and s.get("type") == \
            "capsule" else [s]
        out += [_shape(part, f"{what}[{i}]") for part in parts]
    return out


def _trajectory(value: Any, n_frames: int, width: int, what: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape == (width,):
        a = a[None, :]
    elif a.shape != (n_frames, width):
        raise ValueError(f"{what}: expected shape ({n_frames}, {width}) (or ({width},) for a "
                         f"static body), got {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.isfinite(a.ravel()))[0])
        raise ValueError(f"{what}: non-finite value {a.ravel()[bad]!r} at flat index {bad}")
    return a


def _body_index(value: Any, n_bodies: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not (
            -1 <= int(value) < n_bodies):
        raise ValueError(f"{what}: must be -1 (ground) or a body index < {n_bodies}, got "
                         f"{value!r}")
    return int(value)


_SPRING_KINDS = ("spring", "damper", "spring_damper", "link")


def _springs(items: Any, n_bodies: int) -> list:
    out = []
    for k, sp in enumerate(items or []):
        what = f"scene['springs'][{k}]"
        if not isinstance(sp, dict):
            raise ValueError(f"{what}: a spring must be a dict")
        kind = sp.get("kind", "spring")
        if kind not in _SPRING_KINDS:
            raise ValueError(f"{what}: unknown kind {kind!r}; use one of {_SPRING_KINDS}")
        entry = {"name": str(sp.get("name", f"spring{k}")), "kind": kind,
                 "body_i": _body_index(sp.get("body_i", -1), n_bodies, what + "['body_i']"),
                 "point_i": _vec(sp.get("point_i", (0, 0, 0)), 3, what + "['point_i']"),
                 "body_j": _body_index(sp.get("body_j", -1), n_bodies, what + "['body_j']"),
                 "point_j": _vec(sp.get("point_j", (0, 0, 0)), 3, what + "['point_j']")}
        for key in ("radius", "turns"):
            if sp.get(key) is not None:
                entry[key] = _positive(sp[key], f"{what}['{key}']")
        if sp.get("color") is not None:
            entry["color"] = _color(sp["color"], what + ".color")
        out.append(entry)
    return out


def _arrows(items: Any, n_frames: int, n_bodies: int) -> list:
    out = []
    for k, ar in enumerate(items or []):
        what = f"scene['arrows'][{k}]"
        if not isinstance(ar, dict):
            raise ValueError(f"{what}: an arrow must be a dict")
        vectors = _trajectory(ar.get("vectors"), n_frames, 3, what + "['vectors']")
        entry = {"name": str(ar.get("name", f"arrow{k}")), "kind": str(ar.get("kind", "force")),
                 "body": _body_index(ar.get("body", -1), n_bodies, what + "['body']"),
                 "point": _vec(ar.get("point_local", (0, 0, 0)), 3, what + "['point_local']"),
                 "vectors": _float32_base64(vectors, what + "['vectors']")}
        if ar.get("scale") is not None:
            entry["scale"] = _positive(ar["scale"], what + "['scale']")
        if ar.get("color") is not None:
            entry["color"] = _color(ar["color"], what + ".color")
        out.append(entry)
    return out


def _points(items: Any, n_frames: int) -> list:
    out = []
    for k, pt in enumerate(items or []):
        what = f"scene['points'][{k}]"
        if not isinstance(pt, dict):
            raise ValueError(f"{what}: a point must be a dict")
        positions = _trajectory(pt.get("positions"), n_frames, 3, what + "['positions']")
        entry = {"name": str(pt.get("name", f"point{k}")),
                 "positions": _float32_base64(positions, what + "['positions']")}
        if pt.get("radius") is not None:
            entry["radius"] = _positive(pt["radius"], what + "['radius']")
        if pt.get("color") is not None:
            entry["color"] = _color(pt["color"], what + ".color")
        out.append(entry)
    return out


def _moves(r: np.ndarray, p: np.ndarray) -> bool:
    """Whether a body's trajectory (frames, 3) and (frames, 4) changes beyond float32 round-off
    of the embedded data (what the viewer shows)."""
    if len(r) < 2:
        return False
    size = 1.0 + float(np.abs(r).max())
    return bool(np.ptp(r, axis=0).max() > 1e-6 * size or np.ptp(p, axis=0).max() > 1e-6)


def _prepare_scene(scene: dict, title: str) -> dict:
    """Validate the scene and convert it to the compact JSON-ready form read by viewer.js."""
    if not isinstance(scene, dict):
        raise ValueError(f"scene must be a dict, got {type(scene).__name__}")
    t = np.asarray(scene.get("t"), dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"scene['t'] must be a 1-D array with at least one time, got shape "
                         f"{t.shape}")
    if np.any(np.diff(t) < 0):
        raise ValueError("scene['t'] must be non-decreasing")
    n = int(t.size)
    out: dict = {"title": str(title), "t": _rounded(t, "scene['t']"), "bodies": [],
                 "joints": [], "ground": []}

    bodies = scene.get("bodies") or []
    for i, body in enumerate(bodies):
        what = f"scene['bodies'][{i}]"
        if not isinstance(body, dict):
            raise ValueError(f"{what}: a body must be a dict")
        r = _trajectory(body.get("r"), n, 3, what + "['r']")
        p = _trajectory(body.get("p"), n, 4, what + "['p']")
        if len(r) != len(p):
            raise ValueError(f"{what}: 'r' and 'p' must both be static or both have "
                             f"{n} frames")
        b = {"name": str(body.get("name", f"body{i}")),
             "color": _color(body["color"], what + ".color") if body.get("color") is not None
             else _PALETTE[i % len(_PALETTE)],
             # (n_samples, 7): r then p per frame, float32 (viewing precision, ~1e-7 relative)
             "q": _float32_base64(np.concatenate([r, p], axis=1), what),
             "shapes": _shapes(body.get("shapes"),
                               f"{what}['shapes'] (body {body.get('name', i)!r})"),
             # the camera frames the bodies that move (a dummy body far away is left out)
             "moving": _moves(r, p)}
        out["bodies"].append(b)

    for j, joint in enumerate(scene.get("joints") or []):
        what = f"scene['joints'][{j}]"
        if not isinstance(joint, dict):
            raise ValueError(f"{what}: a joint must be a dict")
        body = joint.get("body", -1)
        if isinstance(body, bool) or not isinstance(body, (int, np.integer)) or not (
                -1 <= int(body) < len(bodies)):
            raise ValueError(f"{what}: 'body' must be -1 (ground) or an index < {len(bodies)}, "
                             f"got {body!r}")
        out["joints"].append({"name": str(joint.get("name", f"joint{j}")),
                              "type": str(joint.get("type", "")),
                              "body": int(body),
                              "point": _vec(joint.get("point_local", (0.0, 0.0, 0.0)), 3,
                                            what + "['point_local']")})

    out["springs"] = _springs(scene.get("springs"), len(bodies))
    out["arrows"] = _arrows(scene.get("arrows"), n, len(bodies))
    out["points"] = _points(scene.get("points"), n)
    out["ground"] = _shapes(scene.get("ground"), "scene['ground']")
    gravity = scene.get("gravity")
    if gravity is not None:
        g = np.asarray(gravity, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"scene['gravity'] must be 3 finite numbers, got {gravity!r}")
        if np.linalg.norm(g) > 0:
            out["up"] = _unit(-g, 3, "scene['gravity']")
    out.setdefault("up", [0, 0, 1])
    return out


# ----------------------------------------------------------------------------------------------
# page assembly
# ----------------------------------------------------------------------------------------------
def _resource(name: str) -> str:
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def _scene_json(data: dict) -> str:
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    # safe inside <script type="application/json">: no "</script>", no "<!--"
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def animation_html(scene: dict, *, title: str = "spatialmbd animation",
                   renderer: str = "auto") -> str:
    """Return the complete offline HTML page animating ``scene`` (see the module docstring).

    renderer: "auto" (WebGL through the embedded three.js bundle, ~0.55 MB, with the Canvas
    renderer as automatic fallback) or "canvas" (Canvas-2D only, no bundle: a page of ~50 kB
    plus the data).
    """
    if renderer not in RENDERERS:
        raise ValueError(f"renderer must be one of {RENDERERS}, got {renderer!r}")
    data = _prepare_scene(scene, title)
    scripts = {"VIEWER_JS": "viewer.js", "THREE_JS": "three.min.js", "WEBGL_JS": "webgl.js"}
    if renderer == "canvas":
        scripts = {"VIEWER_JS": "viewer.js"}
    values = {"TITLE": html.escape(str(title)), "SCENE_JSON": _scene_json(data),
              "THREE_JS": "", "WEBGL_JS": ""}
    for key, name in scripts.items():
        js = _resource(name)
        if "</script" in js.lower():
            raise RuntimeError(f"{name} must not contain '</script'")
        values[key] = js
    # one pass, so user text that looks like a placeholder is never expanded
    return _PLACEHOLDER_RE.sub(lambda m: values[m.group(1)], _resource("template.html"))


def write_animation_html(path, scene: dict, *, title: str = "spatialmbd animation",
                         renderer: str = "auto") -> pathlib.Path:
    """Write the offline HTML animation of ``scene`` to ``path``; return the path."""
    path = pathlib.Path(path)
    text = animation_html(scene, title=title, renderer=renderer)
    from ..atomic import atomic_write
    if path.parent != pathlib.Path(""):
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OSError(exc.errno, f"cannot write {path}: cannot create its directory "
                                     f"{path.parent}: {exc.strerror or exc}") from exc
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


# ----------------------------------------------------------------------------------------------
# default display geometry
# ----------------------------------------------------------------------------------------------
def default_shapes(mass, inertia_principal, *, min_fraction: float = 0.05,
                   fallback_size: float = 0.1) -> list[dict]:
    """Display geometry for a body without any: one box with the body's inertia.

    A uniform box of mass m and sides (lx, ly, lz) has principal moments
    Ix = m (ly^2 + lz^2) / 12 etc., so lx^2 = 6 (Iy + Iz - Ix) / m and cyclically.  When the
    moments violate the triangle inequality (Iy + Iz <= Ix, e.g. a thin rod or a point mass) the
    side would be imaginary or zero: it is clamped to ``min_fraction`` times the largest side
    (so is a side below 1e-3 times the largest one, i.e. zero up to round-off); otherwise the
    box reproduces the moments exactly.
    When every side is zero (zero inertia) a cube of side ``fallback_size`` is returned.

    ``inertia_principal`` is the 3 principal moments (a 3x3 inertia matrix is accepted too: its
    eigenvalues are used).  Returns a list with one box shape dict, centred at the body origin,
    ready for ``body["shapes"]``.
    """
    m = float(mass)
    if not (math.isfinite(m) and m > 0.0):
        raise ValueError(f"default_shapes: mass must be a positive number, got {mass!r}")
    inertia = np.asarray(inertia_principal, dtype=float)
    if inertia.shape == (3, 3):
        inertia = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    if inertia.shape != (3,) or not np.all(np.isfinite(inertia)):
        raise ValueError("default_shapes: inertia_principal must be 3 principal moments, got "
                         f"{inertia_principal!r}")
    if np.any(inertia < -1e-12 * max(1.0, float(np.max(np.abs(inertia))))):
        raise ValueError(f"default_shapes: negative principal moment in {inertia.tolist()}")
    ix, iy, iz = np.maximum(inertia, 0.0)
    sq = 6.0 / m * np.array([iy + iz - ix, iz + ix - iy, ix + iy - iz])
    sides = np.sqrt(np.maximum(sq, 0.0))
    largest = float(np.max(sides))
    if largest <= 0.0:
        sides = np.full(3, float(fallback_size))
    else:
        # imaginary, zero or numerically-zero sides only: real thin sides are kept exact
        degenerate = sides <= _DEGENERATE_SIDE * largest
        sides = np.where(degenerate, float(min_fraction) * largest, sides)
    return [{"type": "box", "size": [float(s) for s in sides], "center": [0.0, 0.0, 0.0]}]
