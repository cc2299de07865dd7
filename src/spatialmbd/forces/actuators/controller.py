"""Sampled controllers: a Python function of time and joint coordinates, sampled at a fixed
rate, whose commands the actuators hold between samples (zero-order hold).

    SampledController(function, actuators=["m1", "m2"], rate=1000.0)
    function(t, y) -> commands (n_actuators,)

y is a read-only array [q (n_in), q' (n_in)] of the coordinates of the ``inputs`` (actuator
names, default the controlled actuators: the joint angle or translation each acts on, angles
continuous over turns). The function runs at t0, t0 + 1/rate, t0 + 2/rate, ...; each command
replaces the actuator's own command (or reference) law and stays constant until the next
sample. The integrator steps exactly onto the sample times and restarts there
(``ODEProblem.breaks``, :mod:`spatialmbd.integrators.driver`), so no step with error control
spans a jump of the command. A function that raises, or returns commands of the wrong shape or
not finite, stops the run with status "failed", the controller named and the results up to
the sample kept.

:class:`ControlRun` is the per-run part (built by ``simulate``): it writes the held commands
into the run's own force table (law column 0 of the actuators; nothing is stored on the Model)
and logs them: ``results.control_log`` maps every controlled actuator to its samples [t,
command], so outputs and accelerations can be evaluated at any output time afterwards.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import ModelError, SimulationError


class SampledController:
    """A Python controller sampled every 1/rate s (module docstring). name: for messages."""

    def __init__(self, function, actuators, rate: float, inputs=None, name=None):
        self.name = name or getattr(function, "__name__", "controller")
        if not callable(function):
            raise ModelError(f"controller {self.name!r}: function must be a callable "
                             f"(t, y) -> commands, got {function!r}")
        try:
            rate = float(rate)
        except (TypeError, ValueError):
            rate = math.nan
        if not (math.isfinite(rate) and rate > 0):
            raise ModelError(f"controller {self.name!r}: rate must be a positive number of "
                             f"samples per second, got {rate!r}")
        if isinstance(actuators, str) or not len(actuators):
            raise ModelError(f"controller {self.name!r}: actuators must be a non-empty list of "
                             f"actuator names, got {actuators!r}")
        self.function = function
        self.rate = rate
        self.actuators = tuple(actuators)
        self.inputs = self.actuators if inputs is None else tuple(inputs)


def _actuator_rows(model, system, names, who):
    """{name: (group, index, row in the run's force table)} of actuator names."""
    from .common import ActuatorType
    rows, start = {}, 0
    for g in system.force_table.groups:
        if isinstance(g, ActuatorType):
            for k, n in enumerate(g.names):
                rows[n] = (g, k, start + k)
        start += g.n
    for n in names:
        if n not in rows:
            raise ModelError(f"controller {who!r}: {n!r} is not an actuator of the model "
                             f"(actuators: {', '.join(rows) or 'none'})")
    return rows


class ControlRun:
    """The controllers and time-series breakpoints of one run on ``system`` (module
    docstring): ``times`` (the breakpoints), ``action(t, y)``, ``start(t0, y0)``, ``log``."""

    def __init__(self, model, system, controllers, t0: float, t_end: float):
        self.model, self.system, self.nb = model, system, model.nb
        self.controllers = list(controllers or ())
        for c in self.controllers:
            if not isinstance(c, SampledController):
                raise ModelError(f"controllers: expected SampledController objects, got {c!r}")
        names = [n for c in self.controllers for n in c.actuators + c.inputs]
        self.rows = _actuator_rows(model, system, names, self.controllers[0].name
                                   if self.controllers else "")
        owner = {}
        for c in self.controllers:
            for n in c.actuators:
                if n in owner:
                    raise ModelError(f"actuator {n!r} is commanded by two controllers "
                                     f"({owner[n]!r} and {c.name!r})")
                owner[n] = c.name
        self.held_rows = np.array([self.rows[n][2] for c in self.controllers
                                   for n in c.actuators], dtype=np.int64)
        self.held = np.zeros(self.held_rows.size)
        span = t_end - t0
        tol = 1e-12 * max(1.0, abs(t0), abs(t_end))
        self.samples = []                  # per controller: its sample times
        for c in self.controllers:
            n = int(math.floor(span * c.rate * (1.0 + 1e-12))) if span > 0 else 0
            self.samples.append(t0 + np.arange(n + 1) / c.rate)
        series = [g.breakpoints() for g in system.force_table.groups
                  if hasattr(g, "breakpoints") and callable(g.breakpoints)]
        allt = np.concatenate(self.samples + series) if self.samples or series else \
            np.zeros(0)
        allt = np.unique(allt[(allt > t0 + tol) & (allt < t_end - tol)])
        if allt.size:                      # merge times closer than the tolerance
            allt = allt[np.concatenate([[True], np.diff(allt) > tol])]
        self.times = allt
        self._tol = tol
        self._next = [0] * len(self.controllers)
        self._last_q = {}
        self.log: list = []                # (t, held commands (n_held,))
        # the held commands survive every setting of the time-dependent laws
        table = system.table
        flaw, rows, run = system.flaw, self.held_rows, self
        if rows.size:
            def rewrite(t):
                flaw[rows, 0] = run.held
                flaw[rows, 1:3] = 0.0
            table.also_set = tuple(table.also_set) + (rewrite,)
            table.has_drivers = True

    @property
    def active(self) -> bool:
        return bool(self.controllers) or bool(self.times.size)

    # ---------------------------------------------------------------- sampling
    def _inputs(self, c, t, y):
        from ...rotations import normalize_p
        from ...state import BodyState
        from .common import ANGLE
        from ...constraints.drivers import wrap_angle
        nb = self.nb
        q = y[:7 * nb].reshape(nb, 7).copy()
        q[:, 3:] = normalize_p(q[:, 3:])
        state = BodyState.from_qv(q, y[7 * nb:13 * nb].reshape(nb, 6), t)
        out = np.empty(2 * len(c.inputs))
        for m, n in enumerate(c.inputs):
            g, k, _ = self.rows[n]
            d = g.details(state, t)[k]
            value = d[0]
            if g.param[k, 0] == ANGLE:            # continuous over turns
                last = self._last_q.get(n)
                if last is not None:
                    value = last + float(wrap_angle(value - last))
                self._last_q[n] = value
            out[m], out[len(c.inputs) + m] = value, d[1]
        out.flags.writeable = False
        return out

    def _sample(self, ic, t, y):
        c = self.controllers[ic]
        try:
            raw = c.function(t, self._inputs(c, t, y))
            u = np.asarray(raw, dtype=float).reshape(-1)
        except Exception as exc:  # noqa: BLE001 - any failure of user code stops the run
            err = SimulationError(f"t = {t:.6g} s: controller {c.name!r} raised "
                                  f"{type(exc).__name__}: {exc}")
            err.t = t
            raise err from exc
        if u.size != len(c.actuators):
            err = SimulationError(f"t = {t:.6g} s: controller {c.name!r} returned {u.size} "
                                  f"command(s); expected {len(c.actuators)} (one per actuator: "
                                  f"{', '.join(c.actuators)})")
            err.t = t
            raise err
        if not np.all(np.isfinite(u)):
            err = SimulationError(f"t = {t:.6g} s: controller {c.name!r} returned a command "
                                  f"that is not finite: {u.tolist()}")
            err.t = t
            raise err
        first = sum(len(d.actuators) for d in self.controllers[:ic])
        self.held[first:first + u.size] = u

    def action(self, t, y) -> None:
        """Sample every controller due at t; write and log the held commands."""
        due = False
        for ic, times in enumerate(self.samples):
            k = self._next[ic]
            if k < times.size and abs(times[k] - t) <= self._tol:
                self._sample(ic, t, y)
                self._next[ic] = k + 1
                due = True
        if due:
            self._write()
            self.log.append((float(t), self.held.copy()))

    def start(self, t0, y0) -> None:
        """The first samples, at t0."""
        self.action(t0, np.asarray(y0, dtype=float))

    def _write(self):
        if self.held_rows.size:
            self.system.flaw[self.held_rows, 0] = self.held
            self.system.flaw[self.held_rows, 1:3] = 0.0

    def restore(self, t) -> None:
        """The commands held at time t (the last sample at or before t)."""
        held = None
        for tl, values in self.log:
            if tl <= t:
                held = values
            else:
                break
        if held is not None:
            self.held[:] = held
            self._write()

    def commands(self) -> dict:
        """{actuator name: (n_samples, 2) array of [t, command]} of the samples so far (plain
        data for ``results.control_log``)."""
        names = [n for c in self.controllers for n in c.actuators]
        t = np.array([tl for tl, _ in self.log])
        values = np.array([v for _, v in self.log]).reshape(len(self.log), len(names))
        return {n: np.column_stack([t, values[:, m]]) for m, n in enumerate(names)}


def control_run(model, system, controllers, t0, t_end, method):
    """The :class:`ControlRun` of a simulation (sampled controllers and time-series
    breakpoints), or None without either."""
    if not controllers and not any(hasattr(g, "breakpoints") for g in model.force_groups):
        return None
    run = ControlRun(model, system, controllers, t0, t_end)
    if not run.active:
        return None
    if run.controllers and getattr(method, "joint_coordinates", False):
        raise ModelError("method 'recursive' does not run sampled controllers yet; use "
                         "method 'projection' or 'standard'")
    return run
