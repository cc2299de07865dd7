"""Members written, not built: parameters that each set one entry of the model's masses,
inertias, gravity or initial state are written into copies of one built model's arrays and
packs."""
from __future__ import annotations

import numpy as np

from ...errors import ModelError
from .reduce import _integrate_reduce
from .setup import BatchSetup, _check_analysis


DIRECT_ARRAYS = ("mass", "inertia", "gravity", "q0", "v0")
#: fewest members of a group for which the direct path is tried (it builds one probe model
#: per parameter)
DIRECT_MIN_MEMBERS = 3


def _direct_entries(job, member0, model0, others, setup):
    """For every model parameter of the sweep, the Model entry (array, flat index) it sets, or
    None if no member changes it -- when building a member with that parameter changed is
    exactly writing its value into that one entry of :data:`DIRECT_ARRAYS`. Probed: the
    model is built with only that parameter set to another member's value and compared with
    model0 entry by entry, point by point and pack by pack. None (the whole dict) when some
    parameter is not of that kind (a joint's axis, a force element's stiffness, a velocity
    given in body axes, ...): those members are built one by one."""
    from ..params import split
    names = list(split(member0, False)[0])
    F0 = setup.pack_F(model0)
    entries = {}
    for name in names:
        other = next((m[name] for m in others if m[name] != member0[name]), None)
        if other is None:
            entries[name] = None
            continue
        probe = dict(member0)
        probe[name] = other
        try:
            model_p, _ = job.build(probe)
        except Exception:
            return None
        entry = written_entry(setup, model0, model_p, other)
        if entry is None:
            return None
        a, i = entry
        patched = _patched(model0, {a: _with(getattr(model0, a), i, other)})
        if np.array_equal(F0, setup.pack_F(patched)) != (a in ("q0", "v0")):
            return None
        entries[name] = (a, i)
    return entries


def written_entry(setup, model0, model_p, value, F_p=None):
    """(array, flat index) when model_p (built with one parameter set to ``value``) is model0
    with exactly one entry of :data:`DIRECT_ARRAYS` set to ``value``, the same points (body,
    local point) and the pack a patched model0 gives (F_p: model_p's, when already packed);
    else None. The probe of the direct path (and of the adjoint's direct parameters)."""
    changed = []
    for a in DIRECT_ARRAYS:
        x0 = np.asarray(getattr(model0, a), dtype=float).ravel()
        x1 = np.asarray(getattr(model_p, a), dtype=float).ravel()
        if x0.shape != x1.shape:
            return None
        changed += [(a, int(i), float(x1[i])) for i in np.flatnonzero(x0 != x1)]
    if len(changed) != 1 or changed[0][2] != float(value):
        return None
    a, i, _ = changed[0]
    p0, p1 = model0.points, model_p.points
    if p1.keys() != p0.keys() or any(p1[k][0] != p0[k][0]
                                     or not np.array_equal(p1[k][1], p0[k][1]) for k in p0):
        return None
    patched = _patched(model0, {a: _with(getattr(model0, a), i, value)})
    if not np.array_equal(setup.pack_F(model_p) if F_p is None else F_p,
                          setup.pack_F(patched)):
        return None
    return a, i


def _with(x, i, value):
    y = np.array(x, dtype=float)
    y.reshape(-1)[i] = value
    return y


def _patched(model, arrays: dict):
    """model with some of DIRECT_ARRAYS replaced (its builder snapshot, used for model files
    and warnings, stays the prototype's: these members live only inside the sweep)."""
    import dataclasses
    return dataclasses.replace(model, **arrays)


def _run_direct(job, members: list, rows: list) -> list:
    """Members whose parameters are all direct (:func:`_direct_entries`), grouped by their
    analysis values: one model built per group (and one probe per parameter); every other
    member's masses, inertias, gravity and initial state are written into copies of its
    arrays and packs, its initial state corrected only when a parameter sets it (the
    correction is kinematic). Fills their rows; returns the indices of the members left to
    the building path."""
    from ...simulate import output_times
    from ..params import split
    if job.factory is not None and not job.analysis:
        return list(range(len(members)))        # the factory's own analysis may vary
    groups: dict = {}
    for k, member in enumerate(members):
        key = tuple(sorted(split(member, False)[1].items()))
        groups.setdefault(key, []).append(k)
    left = []
    for ks in groups.values():
        if len(ks) < DIRECT_MIN_MEMBERS:
            left += ks
            continue
        try:
            model0, analysis = job.build(members[ks[0]])
            _check_analysis(analysis)
            setup = BatchSetup(model0, analysis.method, analysis.method_options,
                               analysis.integrator)
            entries = _direct_entries(job, members[ks[0]], model0,
                                      [members[k] for k in ks[1:]], setup)
        except Exception:
            entries = None
        if entries is None:
            left += ks
            continue
        left += _direct_group(job, setup, model0, analysis, output_times(
            analysis.t_end, analysis.output_step, analysis.t_eval, 0.0),
            [(k, members[k]) for k in ks], entries, rows)
    return sorted(left)


def _direct_valid(arrays, items, entries) -> np.ndarray:
    """Which direct members' values pass the checks a build applies to them (a boolean per
    member): the model file's range checks on each value (by the quantity its path names,
    :func:`..io.schema.range_of`), positive masses, the builder's inertia check and finite
    arrays. (A member that fails is built, so that its error is the build's.)"""
    from ...io.schema import range_of
    from ...model.builder import check_inertia
    B = len(items)
    ok = np.ones(B, dtype=bool)
    for a, x in arrays.items():
        ok &= np.all(np.isfinite(x.reshape(B, -1)), axis=1)
    inertias = set()
    for name, entry in entries.items():
        if entry is None:
            continue
        vals = np.array([member[name] for _, member in items], dtype=float)
        low, high = range_of(tuple(name.split(".")))
        size = np.abs(vals)
        ok &= (size == 0.0) | ((size >= low) & (size <= high))
        a, i = entry
        if a == "mass":
            ok &= vals > 0.0
        elif a == "inertia":
            inertias.add(i // 9)
    for b in np.flatnonzero(ok) if inertias else ():
        try:
            for body in inertias:
                check_inertia(arrays["inertia"][b, body], "inertia")
        except ModelError:
            ok[b] = False
    return ok


def _direct_group(job, setup, model0, analysis, t_out, items, entries, rows) -> list:
    """Run the members items = [(row, member)] of one direct group (see :func:`_run_direct`);
    the rows of members whose values fail a check (:func:`_direct_valid`) are returned, for
    the building path."""
    from ..status import FAILED, _describe
    B = len(items)
    arrays = {a: np.repeat(np.asarray(getattr(model0, a), dtype=float)[None], B, axis=0)
              for a in DIRECT_ARRAYS}
    for name, entry in entries.items():
        if entry is not None:
            a, i = entry
            arrays[a].reshape(B, -1)[:, i] = [member[name] for _, member in items]
    valid = _direct_valid(arrays, items, entries)
    declined = [k for (k, _), ok in zip(items, valid) if not ok]
    items = [it for it, ok in zip(items, valid) if ok]
    arrays = {a: x[valid] for a, x in arrays.items()}
    if not items:
        return declined
    models = [_patched(model0, {a: arrays[a][b] for a in DIRECT_ARRAYS})
              for b in range(len(items))]
    Fs = setup.pack_bodies(arrays["mass"], arrays["inertia"], arrays["gravity"])
    state_set = any(e is not None and e[0] in ("q0", "v0") for e in entries.values())
    good, keep, Y0, starts = [], [], [], []
    y_shared = start_shared = None
    for b, ((k, _), model) in enumerate(zip(items, models)):
        try:
            if state_set or y_shared is None:
                y0 = setup.initial_state(model, Fs[b], analysis)
                start = setup.joint_start(model, y0) if setup.recursive else None
                if not state_set:
                    y_shared, start_shared = y0, start
            else:
                y0, start = y_shared, start_shared
            Y0.append(y0)
            starts.append(start)
            good.append((k, model))
            keep.append(b)
        except Exception as exc:
            rows[k] = (FAILED, _describe(exc), job.empty(), None)
    if good:
        _integrate_reduce(job, setup, analysis, t_out, good, Fs[keep], np.stack(Y0),
                          starts if setup.recursive else None, rows)
    return declined
