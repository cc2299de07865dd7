"""Helpers shared by the analyses: tangent-space perturbations, finite-difference Jacobians,
null spaces, energies and plain-language descriptions of motion directions.

Perturbations of the positions live in the 6-per-body tangent space x = [dr, dpi] per body
(dpi a small global rotation vector, applied as p <- quat(dpi) (x) p by
:func:`spatialmbd.kinematics.apply_correction`), the same space as v and the columns of D.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..rank import left_null_space as _left_null_space
from ..rank import nonunique_rows, row_rank
from ..rank import null_space as _null_space
import scipy.sparse as sp

from ..kinematics import apply_correction
from ..results import Results
from ..state import BodyState

COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")


class FiniteDifferenceWarning(UserWarning):
    """A central-difference Jacobian changed more than expected when the step was halved."""


def dense(D) -> np.ndarray:
    return D.toarray() if sp.issparse(D) else np.asarray(D, dtype=float)


def perturb(q: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """q (nb, 7) moved by dx (6 nb,) in the tangent space."""
    return apply_correction(np.asarray(q, dtype=float).reshape(-1, 7), np.asarray(dx))


def default_step(scale: float = 1.0) -> float:
    """Central-difference step: eps^(1/3) (balances truncation h^2 and rounding eps/h)."""
    return float(np.cbrt(np.finfo(float).eps) * max(scale, 1.0))


def central_jacobian(fun, n: int, step: float, check: bool = True, what: str = "Jacobian",
                     rtol: float = 1e-4):
    """d fun / d x at x = 0 by central differences with the given step, (m, n).

    check: also with step/2; the two differ by about 3/4 of the truncation error of the first.
    Returns (J, estimated error); warns (FiniteDifferenceWarning) when the estimate exceeds
    rtol relative to the largest entry.
    """
    def at(h):
        cols = []
        for k in range(n):
            e = np.zeros(n)
            e[k] = h
            cols.append((np.asarray(fun(e)) - np.asarray(fun(-e))) / (2.0 * h))
        return np.column_stack(cols) if cols else np.zeros((0, 0))

    J = at(step)
    if not check or n == 0:
        return J, 0.0
    J2 = at(0.5 * step)
    err = float(np.abs(J - J2).max()) if J.size else 0.0
    scale = float(np.abs(J2).max()) if J.size else 0.0
    if err > rtol * max(scale, 1e-300) and err > 1e-8:
        warnings.warn(f"{what}: central differences with steps {step:.3g} and {step / 2:.3g} "
                      f"differ by {err:.3g} (largest entry {scale:.3g}); the derivative may be "
                      "inaccurate (a non-smooth force element?)", FiniteDifferenceWarning,
                      stacklevel=3)
    return J2 + (J2 - J) / 3.0, err                            # Richardson extrapolation


def null_space(D: np.ndarray, rtol: float = 1e-9):
    """(orthonormal basis N (n, n - rank) of the null space of D, rank), with the project's one
    rank decision (:func:`spatialmbd.rank.row_rank`, relative row distance ``rtol``)."""
    if D.shape[0] == 0:
        return np.eye(D.shape[1]), 0
    return _null_space(D, row_rank(D, rtol))


def left_null_space(D: np.ndarray):
    """Orthonormal basis (m, m - rank) of the vectors w with D^T w = 0 (the self-stresses of
    redundant constraint rows), with the project's one rank decision (:mod:`spatialmbd.rank`)."""
    if D.shape[0] == 0:
        return np.zeros((0, 0))
    return _left_null_space(D)


def nonunique_joints(model, q, t: float = 0.0, exclude_rows=(), rows=None) -> list:
    """The elements whose reactions are not unique at q: every element with an equation that a
    self-stress of D reaches (all the joints of a redundant loop), by the project's one rank
    decision (:mod:`spatialmbd.rank`). exclude_rows: rows not to name (drivers, whose
    uniqueness is reported separately); rows: those rows if already known
    (:func:`spatialmbd.rank.nonunique_rows` of D at q)."""
    if not model.n_eq:
        return []
    if rows is None:
        D = dense(model.assembler.evaluate(np.asarray(q, dtype=float).reshape(model.nb, 7),
                                           None, t).D)
        rows = nonunique_rows(D)
    skip = set(int(r) for r in exclude_rows)
    labels = model.equation_labels
    return sorted({labels[r][0] for r in rows if int(r) not in skip})


def potential_energy(model, q: np.ndarray, t: float, state=None) -> float:
    """Gravitational plus elastic potential energy at q (J)."""
    q = np.asarray(q, dtype=float).reshape(-1, 7)
    value = -float(np.sum(model.mass * (q[:, :3] @ model.gravity)))
    if model.force_groups:
        state = BodyState.from_qv(q, None, t) if state is None else state
        value += sum(g.potential_energy(state, t) for g in model.force_groups)
    return value


def kinetic_energy(model, q: np.ndarray, v: np.ndarray) -> float:
    """1/2 v^T M v (J), omega global, plus the rotors' (armature) 1/2 J theta'^2."""
    from ..rotations import A_from_p
    q = np.asarray(q, dtype=float).reshape(-1, 7)
    v = np.asarray(v, dtype=float).reshape(-1, 6)
    A = A_from_p(q[:, 3:])
    J = A @ model.inertia @ np.swapaxes(A, 1, 2)
    w = v[:, 3:]
    value = float(0.5 * np.sum(model.mass * np.sum(v[:, :3] ** 2, axis=1))
                  + 0.5 * np.einsum("ni,nij,nj->", w, J, w))
    if model.force_groups:
        state = BodyState.from_qv(q, v)
        value += sum(g.kinetic_energy(state) for g in model.force_groups)
    return value


def conservative_forces_only(model) -> bool:
    """True when every force element derives from a potential (springs), so that a static
    equilibrium is a stationary point of the potential energy."""
    return all(g.name in ("spring_damper", "rotational_spring_damper")
               for g in model.force_groups)


def describe_direction(model, x: np.ndarray, count: int = 2) -> str:
    """A short description of a tangent direction x (6 nb,): the bodies that move most, each
    with its dominant motion (translation along / rotation about a global direction)."""
    x = np.asarray(x, dtype=float).reshape(-1, 6)
    size = np.linalg.norm(x, axis=1)
    if size.max() == 0:
        return "no motion"
    parts = []
    # a rotation whose axis lies 1e4 model sizes away is a translation (round-off of a
    # computed shape, e.g. a rigid-body mode from a defective eigenvalue)
    far = 1e4 * max(1.0, float(np.ptp(np.asarray(model.q0)[:, :3], axis=0).max()))
    for b in np.argsort(-size)[:count]:
        if size[b] < 0.2 * size.max():
            break
        dr, dth = x[b, :3], x[b, 3:]
        name = model.body_names[b]
        if np.linalg.norm(dth) > max(1e-9, np.linalg.norm(dr) / far):
            axis = _clean(dth / np.linalg.norm(dth))
            # the point of the body that does not move: r + (dth x dr)/|dth|^2 (screw axis)
            along = float(axis @ dr)
            point = np.cross(dth, dr) / float(dth @ dth)   # on the screw axis, from the CoM
            text = (f"{name}: rotation about axis ({axis[0]:.3g}, {axis[1]:.3g}, "
                    f"{axis[2]:.3g})")
            if np.linalg.norm(point) > 1e-9:
                text += f" through the point {_fmt(point)} from its centre of mass"
            if abs(along) > 1e-6 * np.linalg.norm(dth):
                text += f" with translation {along / np.linalg.norm(dth):.3g} m/rad along it"
            parts.append(text)
        else:
            d = _clean(dr / np.linalg.norm(dr))
            parts.append(f"{name}: translation along ({d[0]:.3g}, {d[1]:.3g}, {d[2]:.3g})")
    return "; ".join(parts)


def _clean(v, scale: float = 1.0):
    """Components below 1e-9 of the scale shown as 0 (round-off in the directions)."""
    v = np.array(v, dtype=float)
    v[np.abs(v) < 1e-9 * max(scale, 1e-300)] = 0.0
    return v + 0.0


def _fmt(v) -> str:
    return "(" + ", ".join(f"{c:.3g}" for c in _clean(v)) + ") m"


def results_object(model, t, q, v, vdot, lam, *, work=None, redundant_joints=(),
                   messages=(), settings=None, status="success", message="") -> Results:
    """A :class:`~spatialmbd.results.Results` holding analysis output, so that reactions,
    energies, tables, files and the animation work on it as on a simulation."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    return Results(model=model, t=t, q=np.asarray(q, dtype=float), v=np.asarray(v, dtype=float),
                   vdot=np.asarray(vdot, dtype=float), lam=np.asarray(lam, dtype=float),
                   work=np.zeros(t.size) if work is None else np.asarray(work, dtype=float),
                   status=status, message=message, counters={}, wall_time=0.0,
                   redundant_joints=list(redundant_joints), messages=list(messages),
                   settings=dict(settings or {}))


def reactions_frame(reactions: dict, t: np.ndarray):
    """The joint reactions (force and moment on each body of every joint, global axes, moment
    about the joint point) as a DataFrame, one row per time."""
    import pandas as pd
    cols = {"t": np.asarray(t)}
    for name, r in reactions.items():
        for body, f, mom in ((r.body_i, r.force_i, r.moment_i), (r.body_j, r.force_j, r.moment_j)):
            for j, c in enumerate("xyz"):
                cols[f"{name}.{body}.f{c}"] = f[:, j]
            for j, c in enumerate("xyz"):
                cols[f"{name}.{body}.m{c}"] = mom[:, j]
    return pd.DataFrame(cols)


def driver_rows(model) -> dict:
    """Driver name -> its row in Phi."""
    out = {}
    for g, off in zip(model.constraint_groups, model.group_offsets):
        if g.rheonomic:
            for k, name in enumerate(g.names):
                out[name] = int(off + k * g.n_eq)
    return out


def driver_units(model) -> dict:
    """Driver name -> unit of its effort (N m for angles, N for translations and x, y, z)."""
    out = {}
    for g in model.constraint_groups:
        if not g.rheonomic:
            continue
        for k, name in enumerate(g.names):
            if g.name == "angle":
                out[name] = "N m"
            elif g.name == "translation":
                out[name] = "N"
            else:
                coord = getattr(g, "coordinate", None)
                out[name] = "N" if coord is not None and coord[k] < 3 else "N m (per unit e)"
    return out
