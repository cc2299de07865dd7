"""dF/dp and dy0/dp of the adjoint's parameters without model builds where the parameter is a
*direct* entry (:mod:`.adjoint`).

A model build costs about as much as the compiled RK4 run of a small model, so the 2 p builds
of central differences over builds dominated the gradient of many parameters. Most parameters
of an identification or a design study set one entry of the model's masses, inertias, gravity
or initial state -- exactly the parameters the batch engine writes without a build
(:mod:`spatialmbd.sweep.batch.direct`). For those the packed floats F and the corrected
initial state y0 follow from the built model's arrays:

* masses, inertias, gravity: F's body fields (mass, J', J'^-1, weight = m g) rewritten from
  the patched arrays (:func:`body_columns`, vectorised over the parameters); y0 does not move
  (the initial-condition correction is kinematic);
* initial positions and velocities: F does not move; y0 is the corrected initial state of the
  patched model (:func:`state_columns`, about 0.05 ms a call against 10-20 ms a build).

Whether a parameter is direct is decided once, from the builds of the first gradient (one
build pair per parameter anyway): building with only that parameter changed must change
exactly one entry of those arrays, to the parameter's value, leave the model's points as they
are and give the pack a patched model gives (:func:`direct_entry`, the probe of the batch
engine's direct path). Every other parameter (a stiffness, a joint point, a velocity in body
axes) keeps its builds. The decision is taken at the first gradient's values: a rate given in
body axes is direct when the body's orientation is the identity there, and stays so only while
no other parameter turns that body: an initial-velocity entry stays direct only when no
parameter has a derivative of the initial orientations (:func:`keep_valid`).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..sweep.batch.direct import DIRECT_ARRAYS, written_entry

#: the Model arrays a direct parameter may set
#: those that move only F (the others move only y0)
BODY_ARRAYS = ("mass", "inertia", "gravity")


def _patched(model, array: str, index: int, value: float):
    x = np.array(getattr(model, array), dtype=float)
    x.reshape(-1)[index] = value
    return dataclasses.replace(model, **{array: x})


def direct_entry(setup, model0, model_p, F_p, value):
    """(array, flat index) when model_p (built with one parameter set to ``value``) is model0
    with exactly that entry of :data:`DIRECT_ARRAYS` set to ``value``, the same points and
    the pack (F_p) a patched model0 gives; else None (the batch engine's probe,
    :func:`spatialmbd.sweep.batch.direct.written_entry`)."""
    return written_entry(setup, model0, model_p, value, F_p)


def keep_valid(direct: dict, dy0: np.ndarray, nb: int) -> dict:
    """The direct parameters {j: (array, index)} whose decision holds at every later value:
    an initial-velocity entry found direct (it may be a rate in body axes, direct only while
    its body's orientation stays as it was) stays direct only when no parameter turns a body --
    none has a derivative of the initial orientations (dy0, from the first gradient's builds:
    Euler parameters, columns 3-6 of each body's 7 leading entries); otherwise it keeps its
    builds."""
    orientation = np.zeros(dy0.shape[0], dtype=bool)
    orientation[:7 * nb] = (np.arange(7 * nb) % 7) >= 3
    if not np.any(dy0[orientation] != 0.0):
        return direct
    return {j: e for j, e in direct.items() if e[0] != "v0"}


def body_columns(setup, model, F, entries, values, deltas):
    """dF/dp (F.size, len(entries)) of direct body parameters: entries [(array, index)] of
    mass / inertia / gravity, values and deltas (the central-difference steps) per entry.
    F's body fields are those :meth:`spatialmbd.sweep.batch.BatchSetup.pack_F` writes:
    mass, Jl, Jl_inv, weight."""
    k = len(entries)
    B = 2 * k
    mass = np.repeat(np.asarray(model.mass, dtype=float)[None], B, axis=0)
    inertia = np.repeat(np.asarray(model.inertia, dtype=float)[None], B, axis=0)
    gravity = np.repeat(np.asarray(model.gravity, dtype=float)[None], B, axis=0)
    arrays = dict(mass=mass, inertia=inertia, gravity=gravity)
    for c, ((a, i), v, d) in enumerate(zip(entries, values, deltas)):
        arrays[a][2 * c].reshape(-1)[i] = v + d
        arrays[a][2 * c + 1].reshape(-1)[i] = v - d
    fields = dict(mass=mass, Jl=inertia, Jl_inv=np.linalg.inv(inertia),
                  weight=mass[:, :, None] * gravity[:, None, :])
    dF = np.zeros((F.size, k))
    for name, off, shape in setup._slots:
        if name in fields:
            size = math.prod(shape)
            x = fields[name].reshape(B, size)
            dF[off:off + size] = ((x[0::2] - x[1::2]) / (2.0 * np.asarray(deltas))[:, None]).T
    return dF


def state_columns(setup, model, analysis, F, entries, values, deltas):
    """dy0/dp (n, len(entries)) of direct initial-state parameters (entries [(array, index)]
    of q0 / v0): central differences of the corrected initial state of the patched model."""
    cols = []
    for (a, i), v, d in zip(entries, values, deltas):
        plus = setup.initial_state(_patched(model, a, i, v + d), F, analysis)
        minus = setup.initial_state(_patched(model, a, i, v - d), F, analysis)
        cols.append((plus - minus) / (2.0 * d))
    return np.array(cols).T
