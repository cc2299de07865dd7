"""Checks around a run: arguments before work starts, plausibility warnings, and the diagnosis
of a run that stopped at a singular position.

Every check raises :class:`~spatialmbd.errors.ModelError` naming the argument, the value and
the fix (valid choices closest match first), or warns with :class:`PlausibilityWarning`.
Nothing here changes a value silently.
"""
from __future__ import annotations

import functools
import inspect
import math
import warnings
from typing import Optional

import numpy as np

from .errors import ModelError
from .checks import check_time, check_times  # noqa: F401  (re-exported)
from .suggest import closest_first, suggest, unknown

#: an initial-condition correction moving a body by more than this fraction of the model's
#: size (or rotating it by more than this many radians) warns
CORRECTION_WARN_FRACTION = 0.05
#: implied densities (mass / volume of the display shapes) outside this range warn (kg/m^3);
#: the densest element is about 22,600 kg/m^3, a mm-for-m mix-up is a factor 1e9
DENSITY_RANGE = (1.0, 1.0e5)
#: radius of gyration sqrt(I_max / m) more than this factor larger than the display shapes
#: (or smaller than 1 / this factor) warns
GYRATION_FACTOR = 30.0


class PlausibilityWarning(UserWarning):
    """A value that is allowed but looks wrong (units, a large initial correction)."""


# ---------------------------------------------------------------------------- names, options
@functools.lru_cache(maxsize=None)
def _signature_options(cls) -> tuple:
    """The keyword options of cls.__init__ (cached: inspect.signature is slow, and every
    simulate() call checks its method's and integrator's options)."""
    return tuple(k for k, p in inspect.signature(cls.__init__).parameters.items()
                 if k != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD))


def check_options(kind: str, name: str, cls, options) -> dict:
    """``options`` (a dict) with every key an option of ``cls``; ModelError otherwise."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ModelError(f"{kind}_options: expected a dict of options, got "
                         f"{type(options).__name__}")
    valid = _signature_options(cls)
    for key in options:
        if key not in valid:
            order = closest_first(key, valid)
            raise ModelError(f"{kind} {name!r} takes no option {key!r}{suggest(key, valid)}; "
                             f"its options are {', '.join(order) or 'none'}")
    return dict(options)


def make_method(spec, options):
    """A Method from a name or instance with options; ModelError for unknown names, misspelt
    options and bad values (never a bare TypeError / ValueError)."""
    from .dynamics.base import ALIASES, METHODS, Method, get_method
    if isinstance(spec, Method):
        if options:
            raise ModelError("method_options cannot be combined with a Method instance; set "
                             "them on the instance")
        return spec
    if not isinstance(spec, str):
        raise ModelError(f"method: expected a method name or a Method, got "
                         f"{type(spec).__name__} {spec!r}; "
                         f"valid names: {', '.join(sorted(METHODS))}")
    key = ALIASES.get(spec.lower(), spec.lower())
    if key not in METHODS:
        raise ModelError(unknown("method", spec, sorted(METHODS) + sorted(ALIASES)))
    options = check_options("method", key, METHODS[key], options)
    try:
        return get_method(key, **options)
    except ModelError:
        raise
    except (TypeError, ValueError, OverflowError) as exc:
        raise ModelError(f"method {key!r}: {exc}") from None


def check_integrator_name(spec) -> None:
    from .integrators import INTEGRATORS, Integrator
    if isinstance(spec, Integrator):
        return
    if not isinstance(spec, str):
        raise ModelError(f"integrator: expected an integrator name or an Integrator, got "
                         f"{type(spec).__name__} {spec!r}; "
                         f"valid names: {', '.join(sorted(INTEGRATORS))}")
    if spec.lower() not in INTEGRATORS:
        raise ModelError(unknown("integrator", spec, sorted(INTEGRATORS)))


def compiled_model(model):
    """The Model to run: a Model as is, a ModelBuilder compiled; ModelError otherwise."""
    from .model import Model, ModelBuilder
    if isinstance(model, Model):
        return model
    if isinstance(model, ModelBuilder):
        return model.compile()
    raise ModelError(f"model: expected a Model (ModelBuilder.compile() or io.load_model()), "
                     f"got {type(model).__name__}")


def check_hold(model, hold):
    """``hold`` as {body: [coordinates]} (a single coordinate may be a string); ModelError
    naming the valid bodies and coordinates otherwise."""
    from .dynamics.correction import HOLD_NAMES
    if hold is None:
        return None
    if not isinstance(hold, dict):
        raise ModelError(f"hold: expected a mapping {{body: [coordinates]}} with coordinates "
                         f"from {', '.join(HOLD_NAMES)}, got {type(hold).__name__}")
    out = {}
    for body, coords in hold.items():
        if not isinstance(body, str) or body not in model.body_names:
            raise ModelError("hold: " + unknown("body", body, list(model.body_names)))
        coords = [coords] if isinstance(coords, str) else coords
        if not isinstance(coords, (list, tuple)):
            raise ModelError(f"hold[{body!r}]: expected a list of coordinates from "
                             f"{', '.join(HOLD_NAMES)}, got {coords!r}")
        for c in coords:
            if not isinstance(c, str) or c not in HOLD_NAMES:
                raise ModelError(f"hold[{body!r}]: " + unknown("coordinate", c, HOLD_NAMES))
        out[body] = list(coords)
    return out


# ---------------------------------------------------------------------------- initial state
def initial_state(model, q0, v0):
    """(q (nb, 7), v (nb, 6)) checked: shapes, finite values, non-zero Euler parameters."""
    nb = model.nb
    out = []
    for name, value, width, default in (("q0", q0, 7, model.q0), ("v0", v0, 6, model.v0)):
        if value is None:
            out.append(np.array(default, dtype=float).reshape(nb, width))
            continue
        try:
            arr = np.array(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{name}: expected an array of numbers ({nb}, {width}), got "
                             f"{type(value).__name__}") from None
        if arr.size != nb * width:
            raise ModelError(f"{name}: expected {nb} x {width} = {nb * width} numbers "
                             f"(shape ({nb}, {width})), got shape {arr.shape}")
        arr = arr.reshape(nb, width)
        bad = np.argwhere(~np.isfinite(arr))
        if bad.size:
            k, j = bad[0]
            raise ModelError(f"{name}[{k}, {j}] (body {model.body_names[k]!r}): expected a "
                             f"finite number, got {arr[k, j]!r}")
        out.append(arr)
    q = out[0]
    norms = np.linalg.norm(q[:, 3:], axis=1)
    for k in np.flatnonzero(~(norms > 1e-8)):
        raise ModelError(f"q0[{k}, 3:7] (body {model.body_names[k]!r}): the Euler parameters "
                         f"{q[k, 3:].tolist()} have zero length; give unit Euler parameters "
                         "(e.g. [1, 0, 0, 0] for the global orientation)")
    return out[0], out[1]


# ---------------------------------------------------------------------------- plausibility
def model_size(model, q) -> float:
    """A length scale of the model (m): the extent of its bodies' positions, points and
    shapes (at least 1e-3 m)."""
    pts = [np.asarray(q[:, :3])]
    for spec in model.builder_state["bodies"].values():
        for local in spec.points.values():
            pts.append(np.asarray(spec.r, dtype=float)[None] + np.linalg.norm(local))
    P = np.concatenate([p.reshape(-1, 3) for p in pts])
    P = P[np.all(np.isfinite(P), axis=1)]
    extent = float(np.ptp(P, axis=0).max()) if len(P) else 0.0
    shapes = [_shape_extent(s) for spec in model.builder_state["bodies"].values()
              for s in spec.shapes]
    return max([extent, 1e-3] + [x for x in shapes if x])


def guard_length(model, q) -> float:
    """The length scale L of the singular-position guard (:mod:`.dynamics.singular_guard`):
    the model's extent (:func:`model_size`) or, if larger, its longest lever arm -- the ratio
    of the rotation to the translation part of a constraint row of D at q (a single link
    swinging about a joint has no extent of body positions, but a lever arm)."""
    L = model_size(model, q)
    if model.n_eq:
        D = model.assembler.evaluate(np.asarray(q, dtype=float).reshape(model.nb, 7), None,
                                     0.0).D
        D = D.toarray() if hasattr(D, "toarray") else np.asarray(D)
        blocks = D.reshape(D.shape[0], model.nb, 6)
        trans = np.linalg.norm(blocks[:, :, :3], axis=2)
        rot = np.linalg.norm(blocks[:, :, 3:], axis=2)
        arms = rot[trans > 1e-12] / trans[trans > 1e-12]
        if arms.size and np.all(np.isfinite(arms)):
            L = max(L, float(arms.max()))
    return L


def _shape_extent(shape) -> float:
    try:
        kind = shape.get("type")
        if kind == "box":
            return float(np.linalg.norm(shape["size"]))
        if kind == "cylinder":
            return float(math.hypot(2 * shape["radius"], shape["length"]))
        if kind == "sphere":
            return float(2 * shape["radius"])
    except (KeyError, TypeError, ValueError, AttributeError):
        pass
    return 0.0


#: the shape types whose volume and extent the unit check measures; a body with any other
#: shape (a mesh: an imported robot's foot has four marker spheres beside its mesh) is not
#: judged, since the part measured says nothing of the mass
_MEASURED = ("box", "cylinder", "sphere")


def _shape_volume(shape) -> float:
    kind = shape.get("type")
    if kind == "box":
        return float(np.prod(shape["size"]))
    if kind == "cylinder":
        return float(math.pi * shape["radius"] ** 2 * shape["length"])
    if kind == "sphere":
        return float(4.0 / 3.0 * math.pi * shape["radius"] ** 3)
    return 0.0


def correction_warning(model, correction, q) -> Optional[str]:
    """Text of a warning when the initial-condition correction moved a body by more than
    CORRECTION_WARN_FRACTION of the model's size (or rotated it by more than that in rad)."""
    if correction is None or not correction.dr.size:
        return None
    size = model_size(model, q)
    moves = np.linalg.norm(correction.dr, axis=1)
    turns = np.linalg.norm(correction.dtheta, axis=1)
    limit = CORRECTION_WARN_FRACTION * size
    big = [k for k in range(model.nb)
           if moves[k] > limit or turns[k] > CORRECTION_WARN_FRACTION]
    if not big:
        return None
    parts = [f"{model.body_names[k]} moved {moves[k]:.3g} m and turned {turns[k]:.3g} rad"
             for k in big[:5]]
    more = f" (and {len(big) - 5} more)" if len(big) > 5 else ""
    return ("the initial-condition correction moved bodies by more than "
            f"{CORRECTION_WARN_FRACTION:.0%} of the model's size ({size:.3g} m): "
            + "; ".join(parts) + more + "; check the initial positions (the given ones do not "
            "satisfy the joints), or keep coordinates with hold={body: [...]}")


def unit_warnings(model) -> list:
    """Texts of warnings for bodies whose mass and inertia are inconsistent with their display
    shapes by orders of magnitude (a sign of mixed units, e.g. mm and m, g and kg)."""
    out = []
    for k, (name, spec) in enumerate(model.builder_state["bodies"].items()):
        if not spec.shapes:
            continue
        if any(s.get("type") not in _MEASURED for s in spec.shapes):
            continue        # a mesh or another shape without a volume here: no verdict
        try:
            volume = sum(_shape_volume(s) for s in spec.shapes)
            extent = max(_shape_extent(s) for s in spec.shapes)
        except (KeyError, TypeError, ValueError):
            continue
        m = float(model.mass[k])
        if volume > 0 and m > 0:
            density = m / volume
            if not DENSITY_RANGE[0] <= density <= DENSITY_RANGE[1]:
                out.append(f"body {name!r}: mass {m:.3g} kg in display shapes of "
                           f"{volume:.3g} m^3 means a density of {density:.3g} kg/m^3 "
                           f"(expected {DENSITY_RANGE[0]:g} .. {DENSITY_RANGE[1]:g}); check "
                           "the units (SI: kg, m) of the mass and of the shapes")
                continue
        I_max = float(np.linalg.eigvalsh(model.inertia[k]).max())
        if extent > 0 and m > 0 and I_max > 0:
            gyration = math.sqrt(I_max / m)
            half = 0.5 * extent
            if gyration > GYRATION_FACTOR * half or gyration < half / GYRATION_FACTOR ** 2:
                out.append(f"body {name!r}: inertia {I_max:.3g} kg m^2 and mass {m:.3g} kg "
                           f"give a radius of gyration of {gyration:.3g} m, but its shapes "
                           f"are {extent:.3g} m across; check the units (SI: kg m^2)")
    return out


def warn(texts, stacklevel=3) -> None:
    for text in texts:
        if text:
            warnings.warn(text, PlausibilityWarning, stacklevel=stacklevel)


# ---------------------------------------------------------------------------- singular positions
#: a constraint Jacobian whose smallest (non-redundant) singular value fell below this
#: fraction of its largest one, or below SINGULAR_DROP times its ratio at the start, is
#: called (near-)singular
SINGULAR_RATIO = 1e-5
SINGULAR_DROP = 1e-3


class LastState:
    """Wraps a right-hand side to remember the last state it was called with (a reference,
    no copy): where a run failed, for the diagnosis of singular positions."""

    def __init__(self):
        self.t = None
        self.y = None

    def wrap(self, rhs):
        def remembered(t, y):
            self.t, self.y = t, y
            return rhs(t, y)
        return remembered

    def wrap_stages(self, stages):
        """The compiled ``ODEProblem.stages`` hook (t, y, h, ...): remembers its step start."""
        if stages is None:
            return None

        def remembered(t, y, *args):
            self.t, self.y = t, y
            return stages(t, y, *args)
        return remembered


def conditioning(model, q, t, rank0=None):
    """(singular values of D at (q, t), rank0 used): for the singularity diagnosis."""
    D = model.assembler.evaluate(np.asarray(q, dtype=float).reshape(model.nb, 7), None, t).D
    D = D.toarray() if hasattr(D, "toarray") else np.asarray(D)
    if D.size > 4_000_000:
        return None
    return np.linalg.svd(D, compute_uv=False), D


#: a failed run whose bodies move this many times faster than the start and free fall explain
#: is taken for an unstable integration, not a singular position
BLOW_UP_FACTOR = 1e3


def blow_up_diagnosis(model, v0, v_last, t0: float, t: float) -> Optional[str]:
    """Why a run stopped, if its velocities had grown without bound first (an explicit
    integrator unstable with its step, e.g. on a stiff spring): the bodies then reach
    arbitrary positions, where the constraint Jacobian may look singular although the
    mechanism is not. None when the speeds are plausible: at most BLOW_UP_FACTOR times
    the start's speed plus what gravity gives over the elapsed time (plus 1 m/s)."""
    if v_last is None:
        return None
    v_last = np.asarray(v_last, dtype=float).reshape(-1, 6)
    speed = float(np.abs(v_last[:, :3]).max(initial=0.0)) if np.all(np.isfinite(v_last)) \
        else math.inf
    start = float(np.abs(np.asarray(v0, dtype=float).reshape(-1, 6)[:, :3]).max(initial=0.0))
    scale = start + float(np.linalg.norm(model.gravity)) * abs(t - t0) + 1.0
    if speed <= BLOW_UP_FACTOR * scale:
        return None
    return (f"the speeds grew from {start:.3g} m/s to {speed:.3g} m/s before t = {t:.6g} s: "
            "the integration became unstable (a step too large for the stiffest element, "
            "e.g. a stiff spring or a fast rotation); use a smaller step, the adaptive rk45, "
            "or an implicit integrator (bdf4)")


def singular_diagnosis(model, q, t, rank0: Optional[int], ratio0: Optional[float] = None,
                       t_fail=None) -> Optional[str]:
    """Why a run stopped, if it stopped at (or near) a singular position: the rank of D at
    (q, t) against its rank at the start, the joints whose equations became dependent, and the
    methods that handle it. None when D is far from singular (or cannot be evaluated).

    q, t: the state where the run failed (or the last output); rank0: the rank of D at the
    start; ratio0: sigma_rank0 / sigma_1 of D at the start."""
    found = _dependency(model, q, t, rank0, ratio0)
    if found is None:
        return None
    strict, rank0, m, ratio, joints, drivers = found
    when = f"t = {t:.6g} s" if t_fail is None or abs(t_fail - t) < 1e-9 else \
        f"t = {t:.6g} s (failure reported at t = {t_fail:.6g} s)"
    state = (f"rank {strict} of {m} equations, rank deficiency {rank0 - strict}"
             if strict < rank0 else
             f"near rank deficiency 1 (sigma_min / sigma_max = {ratio:.2g}"
             + (f", {ratio0:.2g} at the start" if ratio0 is not None else "") + ")")
    head = (f"singular position near {when}: the constraint Jacobian D has {state} "
            f"(rank {rank0} at the start); dependent equations in joint(s) "
            f"{', '.join(joints)}, whose multipliers are not unique there. ")
    if drivers:
        return head + (f"The driver(s) {', '.join(drivers)} take part in the dependency: they "
                       "prescribe a motion the mechanism cannot continue here (a dead point, "
                       "e.g. a slider driven past the dead centre of its crank, where the "
                       "crank would need an infinite rate); drive another joint, change the "
                       "driver's motion law so that it stops or reverses there, or check the "
                       "geometry of these joints")
    return head + ("Ways on: a "
            "looser rtol (the step control stalls when a step ends within round-off of the "
            "singular position; the IFToMM N-four-bar passes its flat positions with "
            "projection and rk45 at rtol 1e-6 to 1e-10), the projection method (the default "
            "for closed loops: it returns to Phi = 0 after every step and so passes singular "
            "positions straight), or check the geometry of these joints")


def branch_diagnosis(model, method: str, q, t, rank0: Optional[int]) -> str:
    """Why a run of a method that follows its drift stopped at a singular position
    (:mod:`.dynamics.singular_guard`): the joints of the dependency and the ways on."""
    found = _dependency(model, q, t, rank0, None, force=True)
    where = ""
    if found is not None:
        joints, drivers = found[4], found[5]
        where = (f" (sigma_min / sigma_max of D = {found[3]:.2g}; the near-dependent "
                 f"equations are in joint(s) {', '.join(joints)})")
        if drivers:
            return (f"the mechanism reaches a singular position near t = {t:.6g} s{where}, "
                    f"and the driver(s) {', '.join(drivers)} take part in the dependency: "
                    "they prescribe a motion the mechanism cannot continue here; drive another "
                    "joint or change the driver's motion law")
    return (f"the mechanism reaches a singular position near t = {t:.6g} s{where}, where two "
            f"branches of its motion meet. The {method} method keeps the state on Phi = eps "
            "(its drift or compliance) instead of Phi = 0, and that manifold is split there: "
            "which branch the run continues on depends on eps, not on the mechanics "
            "(docs/choosing.md, 'The other methods at singular positions'). Use the projection "
            "method (the default for closed loops), which returns to Phi = 0 after every step "
            "and passes straight; or set method option singular='continue' (a model file's "
            "analysis: method_options) to go on regardless and check the branch yourself")


def _dependency(model, q, t, rank0, ratio0, force=False):
    """(numerical rank, rank0, equations, sigma_rank0 / sigma_1, joints, drivers) of the
    dependency of D at (q, t), or None where D is far from singular (unless ``force``: the
    equations of its smallest singular value) or cannot be evaluated."""
    if not model.n_eq or q is None or not np.all(np.isfinite(q)):
        return None
    try:
        out = conditioning(model, q, t)
        if out is None:
            return None
        s, D = out
        m = D.shape[0]
        rank0 = m if rank0 is None else rank0
        if rank0 < 1 or s[0] == 0:
            return None
        ratio = s[rank0 - 1] / s[0]
        strict = int(np.sum(s > max(D.shape) * np.finfo(float).eps * s[0] * 1e3))
        near = force or ratio < SINGULAR_RATIO or (ratio0 is not None
                                                   and ratio < SINGULAR_DROP * ratio0)
        if strict >= rank0 and not near:
            return None
        # the equations in the new dependency: the weights of the left singular vectors
        # that lost their singular value (rank0 - 1 ... , or strict ...)
        U = np.linalg.svd(D, full_matrices=False)[0]
        lost = range(min(strict, rank0 - 1), min(rank0, U.shape[1]))
        weight = np.max(np.abs(U[:, list(lost)]), axis=1)
        rows = np.flatnonzero(weight > 0.1 * weight.max())
        joints = sorted({model.equation_labels[r][0] for r in rows})
        drivers = sorted({model.equation_labels[r][0] for r in rows
                          for g, off in zip(model.constraint_groups, model.group_offsets)
                          if g.rheonomic and off <= r < off + g.size})
    except Exception:  # noqa: BLE001 - a diagnosis must never hide the original failure
        return None
    return strict, rank0, m, ratio, joints, drivers
