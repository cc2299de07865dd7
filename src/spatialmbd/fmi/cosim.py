"""Co-simulation stepping: a model advanced from one communication point to the next.

    sim = CoSimulation(model, inputs=["drive"], outputs=["A.angle", "slider.x"],
                       rtol=1e-8, atol=1e-10)
    sim.set_input("drive", 0.2)          # held constant over the next step (zero-order hold)
    sim.do_step(0.0, 0.01)               # the project's integrator, with error control, 0 -> 0.01
    sim.output("A.angle")

This is what an exported FMU's ``doStep`` runs (:mod:`.slave`). The system, the method and the
compiled right-hand side are built once (the same pieces as :func:`spatialmbd.simulate.simulate`);
each step restarts the integrator at the communication point t and integrates to t + h, so an
input's jump is never inside a step with error control. Breakpoints of time-series laws inside
a communication step are landed on as in a simulation.

Inputs (element names): the magnitude of a ``point_force`` or ``torque`` element, or the command
(reference) of an actuator (``motor``, ``position_servo``, ``velocity_servo``, ``general``).
The held value replaces the element's own law (column 0 of its law row; its rates are zero).

Outputs (result column names, :mod:`spatialmbd.outputs`): ``<body>.x|y|z|e0..e3|vx..vz|wx..wz``
and ``<joint>.<coordinate>`` of a joint (``A.angle``, ``A.angle_rate``, ``D.translation``, ...;
angles continuous over turns across steps) from the state; ``<body>.ax..alphaz`` and the
reactions ``<joint>.<body>.fx..mz`` of the results table through the method's solve at the
communication point (with the inputs held over the step that ends there).
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import ModelError, SimulationError
from ..outputs.vocabulary import BODY_ACCELERATION, BODY_POSITION, BODY_VELOCITY, REACTION
from .joint_kernel import axis_joint_coordinates

BODY_COLUMNS = BODY_POSITION + BODY_VELOCITY
#: accelerations and reactions need the method's solve at the communication point (slower)
ACCELERATION_COLUMNS = BODY_ACCELERATION
REACTION_COLUMNS = REACTION
#: force-element types whose law column 0 an input may hold (besides every actuator type)
INPUT_TYPES = ("point_force", "torque")


class _OneState:
    """The one-sample result :mod:`spatialmbd.outputs` evaluates joint coordinates on."""

    def __init__(self, model, t, q, v):
        self.model, self.t = model, np.array([t])
        self.q, self.v, self.vdot = q[None], v[None], None


class _Breaks:
    """Time-series breakpoints of the model's force laws (:class:`ODEProblem.breaks`)."""

    def __init__(self, times):
        self.times = np.asarray(times, dtype=float)

    def action(self, t, y):                # the laws are functions of time: nothing to do
        return None


def input_rows(model, system, names, who="co-simulation"):
    """{input name: row of the run's force table} (element names of point_force, torque or
    actuator elements); a name that is none of these is a ModelError listing the choices."""
    from ..forces.actuators.common import ActuatorType
    rows, start = {}, 0
    for g in system.force_table.groups:
        if isinstance(g, ActuatorType) or getattr(g, "name", "") in INPUT_TYPES:
            for k, n in enumerate(g.names):
                rows[n] = start + k
        start += g.n
    for n in names:
        if n not in rows:
            raise ModelError(f"{who}: input {n!r} is not a point_force, torque or actuator "
                             f"element of the model (inputs it can take: "
                             f"{', '.join(rows) or 'none'})")
    return {n: rows[n] for n in names}


def check_outputs(model, names, who="co-simulation"):
    """The output names as (kind, target, quantity); unknown ones are a ModelError."""
    from ..outputs import JOINT_COORDINATES, GENERIC_COORDINATES
    bodies = list(model.body_names)
    out = []
    for name in names:
        target, _, quantity = str(name).rpartition(".")
        if target in bodies and quantity in BODY_COLUMNS:
            out.append(("body", bodies.index(target), quantity))
            continue
        if target in bodies and quantity in ACCELERATION_COLUMNS:
            out.append(("acceleration", bodies.index(target), quantity))
            continue
        reaction = _reaction(model, str(name), who)
        if reaction is not None:
            out.append(reaction)
            continue
        force = _force_column(model, target, quantity, str(name), who)
        if force is not None:                     # <force element>.<quantity>
            out.append(force)
            continue
        if target.endswith(".imu"):               # <body>.<point>.imu.<quantity>
            from ..outputs import QUANTITIES
            point = target[:-len(".imu")]
            if point not in model.points:
                raise ModelError(f"{who}: output {name!r}: no named point {point!r} for an "
                                 f"IMU (points: {', '.join(model.points) or 'none'})")
            if quantity not in QUANTITIES["imu"]:
                raise ModelError(f"{who}: output {name!r}: an IMU measures "
                                 f"{', '.join(QUANTITIES['imu'])}")
            out.append(("imu", point, quantity))
            continue
        try:
            g, _, _ = model.element(target) if target else (None, None, None)
        except (ModelError, KeyError, ValueError):
            g = None
        if g is not None and hasattr(g, "rheonomic") and not g.rheonomic:
            coords = JOINT_COORDINATES.get(g.name, GENERIC_COORDINATES)
            base = quantity[:-5] if quantity.endswith("_rate") else quantity
            if base in coords:
                out.append(("joint", target, quantity))
                continue
            raise ModelError(f"{who}: output {name!r}: joint {target!r} ({g.name}) has the "
                             f"coordinates {', '.join(coords)} (and their _rate)")
        raise ModelError(f"{who}: output {name!r} is not a result column of the model (body "
                         f"columns <body>.{'|'.join(BODY_COLUMNS[:3])}|..., <body>.ax|..., "
                         f"joint columns <joint>.angle, <joint>.angle_rate, ..., reactions "
                         f"<joint>.<body>.fx|...|mz, IMUs <body>.<point>.imu.ax|sfx|wx|...; "
                         f"bodies: {', '.join(bodies)})")
    return out


def _force_column(model, target: str, quantity: str, name: str, who):
    """("force", element, quantity) of a force element's output column (spring force,
    actuator effort, ...: spatialmbd.outputs.force_outputs), None when ``target`` is not a
    force element."""
    groups = [g for g in model.force_groups if target in g.names]
    if not groups:
        return None
    from ..outputs.vocabulary import QUANTITIES, _force_kind
    g = groups[0]
    kind = _force_kind(g)
    if kind is None:
        raise ModelError(f"{who}: output {name!r}: the elements of type {g.name} have no "
                         "output columns of their own")
    allowed = list(g.output_units(g.names.index(target)) if kind == "own" else
                   QUANTITIES[kind])
    if quantity not in allowed:
        raise ModelError(f"{who}: output {name!r}: the {g.name} element {target!r} has the "
                         f"outputs {', '.join(allowed)}")
    return ("force", target, quantity)


def _reaction(model, name: str, who):
    """("reaction", joint, body, quantity) of a column <joint>.<body>.<fx..mz> (the reaction
    on that body of the joint, global axes, moment about the joint point, as in the results
    table), None when the name is not of that form."""
    parts = name.split(".")
    if len(parts) != 3 or parts[2] not in REACTION_COLUMNS:
        return None
    try:
        g, k, _ = model.element(parts[0])
    except ModelError:
        return None
    names = list(model.body_names) + ["ground"]
    ends = (names[int(g.body_i[k])], names[int(g.body_j[k])])
    if parts[1] not in ends:
        raise ModelError(f"{who}: output {name!r}: joint {parts[0]!r} joins {ends[0]!r} and "
                         f"{ends[1]!r}; its reactions are <joint>.<one of them>.fx ... mz")
    return ("reaction", parts[0], parts[1], parts[2])


def check_step(h, who="co-simulation") -> float:
    """A communication step (s): positive and finite, else a ModelError naming it."""
    try:
        h = float(h)
    except (TypeError, ValueError):
        h = math.nan
    if not (math.isfinite(h) and h > 0):
        raise ModelError(f"{who}: the communication step must be a positive number of "
                         f"seconds, got {h!r}")
    return h


class CoSimulation:
    """A model stepped between communication points (module docstring).

    model: a Model; inputs, outputs: names (module docstring); t0: start time (s);
    method: a body-coordinate method (default "projection"); integrator: one of the package's
    (default "rk45") with rtol, atol (adaptive) or step (fixed; in integrator_options).
    ``integration_time``: wall time (s) spent inside the integrator, for overhead figures."""

    def __init__(self, model, inputs=(), outputs=(), *, t0: float = 0.0, method="projection",
                 integrator="rk45", rtol=1e-8, atol=1e-10, integrator_options=None,
                 name="co-simulation"):
        from .. import guards
        from ..dynamics import EquationsOfMotion
        from ..dynamics import system as cs
        from ..dynamics.correction import correct_initial_conditions, hold_mask
        from ..integrators.base import ODEProblem
        from ..state import normalize_q
        # the simulation's own building blocks (one run, built once)
        from ..simulate.assembly import _contact_memory
        from ..simulate.rhs import _compiled_rhs, _driver_rows, _python_rhs
        from ..simulate.setup import _make_integrator, _start_mobility
        model = guards.compiled_model(model)
        self.model, self.name, nb = model, name, model.nb
        self.t = float(t0)
        meth = guards.make_method(method, None)
        if getattr(meth, "joint_coordinates", False):
            raise ModelError(f"{name}: method {meth.name!r} does not co-simulate; use "
                             "'projection' or 'standard'")
        opts = dict(integrator_options or {})
        guards.check_integrator_name(integrator)
        from ..integrators import INTEGRATORS
        cls = INTEGRATORS.get(str(integrator).lower())
        if cls is not None and getattr(cls, "adaptive", False):
            opts.setdefault("rtol", rtol)
            opts.setdefault("atol", atol)
        self.integrator = _make_integrator(integrator, opts)
        self.outputs = list(outputs)
        self._out = check_outputs(model, self.outputs, name)
        eom = EquationsOfMotion(model)
        system = eom.system
        q, v = guards.initial_state(model, None, None)
        q = normalize_q(q)
        if model.n_eq:
            q, v, _ = correct_initial_conditions(model, q, v, self.t, hold_mask(model, None),
                                                 system=system)
        mob = _start_mobility(model, eom, q, v, self.t)
        redundant = np.array([r[0] for r in mob.redundant], dtype=int) if mob else None
        meth.setup(eom, redundant)
        from ..dynamics.reaction_friction import install
        meth = install(meth, eom)              # joint friction from the joints' reactions
        self._eom, self._method = eom, meth
        self._redundant_joints = sorted({r[1] for r in mob.redundant}) if mob else []
        # inputs: held values in law column 0, rewritten after every setting of the laws
        self.inputs = list(inputs)
        rows = input_rows(model, system, self.inputs, name)
        self._rows = np.array([rows[n] for n in self.inputs], dtype=np.int64)
        self._index = {n: i for i, n in enumerate(self.inputs)}
        table, flaw = system.table, system.flaw
        self._laws = flaw                     # held inputs and contact memories live here
        if table.has_drivers:
            table.set_time(self.t)
        self.held = flaw[self._rows, 0].copy()
        if self._rows.size:
            held, rows_ = self.held, self._rows

            def rewrite(t):
                flaw[rows_, 0] = held
                flaw[rows_, 1:3] = 0.0
            table.also_set = tuple(table.also_set) + (rewrite,)
            table.has_drivers = True
            rewrite(self.t)
        track_work = bool(model.force_groups) or _driver_rows(model).size > 0
        rhs = _compiled_rhs(model, eom, meth, track_work)
        compiled = rhs is not None
        if rhs is None:
            rhs = _python_rhs(model, eom, meth, track_work, _driver_rows(model))
        n_z = system.force_table.n_states
        n_q = 7 * nb

        def project(t, y):
            y = y.copy()
            cs.normalize_y(y, nb)
            if meth.projects and hasattr(meth, "project_y"):
                y = meth.project_y(system, t, y)
            return y
        series = [g.breakpoints() for g in system.force_table.groups
                  if hasattr(g, "breakpoints") and callable(g.breakpoints)]
        breaks = _Breaks(np.unique(np.concatenate(series))) if series and \
            sum(s.size for s in series) else None
        self._problem = ODEProblem(rhs=rhs, project=project,
                                   project_keeps_rhs=not meth.projects,
                                   stages=meth.stages(system) if compiled else None,
                                   n_quadrature=1, breaks=breaks)
        self.y = np.concatenate([q.reshape(-1), v.reshape(-1), np.zeros(n_z), [0.0]])
        # contacts: the impact-velocity memory restarts the steps at every first touch, as in
        # a simulation (the located touches are the integrator's events within a step)
        memory = _contact_memory(model, eom, compiled, self.t, self.y)
        self._events = None
        if memory is not None:
            from ..integrators import Event
            self._events = [Event(gap, direction=-1.0, name=touch_name, restart=touch,
                                  record=False) for touch_name, gap, touch in memory.triggers()]
        self._nq = n_q
        self.integration_time = 0.0
        self.steps = 0
        self._values = self._evaluate()

    # ------------------------------------------------------------------ inputs
    def set_input(self, name: str, value: float) -> None:
        """Hold ``value`` on input ``name`` from now on (N, N m, or the actuator's command)."""
        i = self._index.get(name)
        if i is None:
            raise ModelError(f"{self.name}: {name!r} is not an input (inputs: "
                             f"{', '.join(self.inputs) or 'none'})")
        self.held[i] = value

    def get_input(self, name: str) -> float:
        return float(self.held[self._index[name]])

    # ------------------------------------------------------------------ stepping
    def do_step(self, t: float, h: float) -> None:
        """Integrate from the communication point t (the current state's time) to t + h,
        inputs held; a failure is a SimulationError naming the time."""
        try:
            valid = 0.0 < h < math.inf                # NaN fails too
        except TypeError:
            valid = False
        if not valid:
            h = check_step(h, self.name)
        if abs(t - self.t) > 1e-9 * max(1.0, abs(t)):
            raise ModelError(f"{self.name}: doStep at t = {t!r} s, but the state is at "
                             f"t = {self.t!r} s (steps must follow one another)")
        t_end = t + h
        start = time.perf_counter()
        res = self.integrator.integrate(self._problem, t, self.y, np.array([t, t_end]),
                                        events=self._events)
        self.integration_time += time.perf_counter() - start
        if res.status != "success" or len(res.t) < 2:
            err = SimulationError(f"{self.name}: the step from t = {t:.9g} s to "
                                  f"{t_end:.9g} s failed: {res.message}")
            err.t = t
            raise err
        self.y = np.asarray(res.y[-1], dtype=float)
        self.t = t_end
        self.steps += 1
        self._values = self._evaluate()

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict:
        """Everything a later :meth:`set_state` needs to go on from here, as plain numbers
        (FMI fmi2GetFMUstate): the time, the state vector, the held inputs and the law table
        (the contacts' impact memories)."""
        return {"t": float(self.t), "y": [float(x) for x in self.y],
                "held": [float(x) for x in self.held],
                "laws": [[float(x) for x in row] for row in self._laws],
                "steps": int(self.steps)}

    def set_state(self, state: dict) -> None:
        """Back to a state of :meth:`get_state` (FMI fmi2SetFMUstate)."""
        y = np.asarray(state["y"], dtype=float)
        laws = np.asarray(state["laws"], dtype=float)
        if y.shape != self.y.shape or laws.shape != self._laws.shape or \
                len(state["held"]) != self.held.size:
            raise ModelError(f"{self.name}: the FMU state does not belong to this model "
                             f"(state vector {y.shape} against {self.y.shape})")
        self.t = float(state["t"])
        self.y = y.copy()
        self.held[:] = state["held"]
        self._laws[:] = laws
        self.steps = int(state.get("steps", 0))
        self._values = self._evaluate()

    # ------------------------------------------------------------------ outputs
    def _plan_outputs(self):
        """Index arrays of the outputs: body columns straight from y, axis joints through the
        compiled kernel (:mod:`.joint_kernel`), any other joint through spatialmbd.outputs."""
        from .joint_kernel import AXIS_JOINTS
        model, nb = self.model, self.model.nb
        body_pos, body_idx, joints, slow = [], [], [], []
        self._solved = [(m, item) for m, item in enumerate(self._out)
                        if item[0] in ("acceleration", "reaction", "imu", "force")]
        for m, (kind, target, quantity, *_) in enumerate(self._out):
            if kind == "body":
                c = BODY_COLUMNS.index(quantity)
                body_pos.append(m)
                body_idx.append(7 * target + c if c < 7 else 7 * nb + 6 * target + c - 7)
                continue
            if kind != "joint":
                continue
            g, k, _ = model.element(target)
            if g.name in AXIS_JOINTS:
                if target not in joints:
                    joints.append(target)
                col = {"angle": 0, "angle_rate": 1, "translation": 2,
                       "translation_rate": 3}[quantity]
                slow.append((m, None, joints.index(target) * 4 + col))
            else:
                slow.append((m, target, quantity))
        self._body_pos = np.array(body_pos, dtype=np.int64)
        self._body_idx = np.array(body_idx, dtype=np.int64)
        geo = [(model.element(n)[0], model.element(n)[1]) for n in joints]
        self._jb_i = np.array([int(g.body_i[k]) for g, k in geo], dtype=np.int64)
        self._jb_j = np.array([int(g.body_j[k]) for g, k in geo], dtype=np.int64)
        self._jR_i = np.array([g.geometry.R_i[k] for g, k in geo], dtype=float).reshape(-1, 3, 3)
        self._jR_j = np.array([g.geometry.R_j[k] for g, k in geo], dtype=float).reshape(-1, 3, 3)
        self._js_i = np.array([g.geometry.s_i[k] for g, k in geo], dtype=float).reshape(-1, 3)
        self._js_j = np.array([g.geometry.s_j[k] for g, k in geo], dtype=float).reshape(-1, 3)
        self._jout = np.zeros((len(joints), 4))
        self._jlast = np.full(len(joints), np.nan)
        fast = [(m, c) for m, t, c in slow if t is None]
        self._fast_pos = np.array([m for m, _ in fast], dtype=np.int64)
        self._fast_col = np.array([c for _, c in fast], dtype=np.int64)
        self._generic = [(m, t, q) for m, t, q in slow if t is not None]
        generic = {m for m, _, _ in self._generic}
        angles = [m for m, (kind, _, q, *_) in enumerate(self._out)
                  if m in generic and (q in ("rx", "rz") or
                                       ("angle" in q and not q.endswith("_rate")))]
        self._angle_pos = np.array(angles, dtype=np.int64)
        self._last_angles = None

    def _evaluate(self) -> np.ndarray:
        if not hasattr(self, "_body_pos"):
            self._plan_outputs()
        y, nb = self.y, self.model.nb
        values = np.empty(len(self._out))
        values[self._body_pos] = y[self._body_idx]
        if self._fast_pos.size:
            axis_joint_coordinates(y, nb, self._jb_i, self._jb_j, self._jR_i, self._jR_j,
                                   self._js_i, self._js_j, self._jlast, self._jout)
            values[self._fast_pos] = self._jout.reshape(-1)[self._fast_col]
        if self._generic:
            from ..outputs import _Track, _joint
            track = _Track(_OneState(self.model, self.t, y[:7 * nb].reshape(nb, 7),
                                     y[7 * nb:13 * nb].reshape(nb, 6)))
            done = {}
            for m, target, quantity in self._generic:
                if target not in done:
                    done[target] = _joint(track, self.model, target)
                values[m] = done[target][quantity][0]
        if self._solved:
            self._solve(values)
        if self._angle_pos.size:                    # other joints' angles, likewise
            a = values[self._angle_pos]
            if self._last_angles is not None:
                last = self._last_angles
                a = last + np.remainder(a - last + math.pi, 2.0 * math.pi) - math.pi
                values[self._angle_pos] = a
            self._last_angles = a
        return values

    def _solve(self, values) -> None:
        """Accelerations and reactions at the current state: the method's solve, through the
        one-sample :class:`spatialmbd.results.Results` (its reaction columns)."""
        from ..results import Results
        res = Results.from_integration(
            model=self.model, eom=self._eom, method=self._method, integrator=self.integrator,
            t=np.array([self.t]), y=self.y[None, :], status="success", message="",
            counters={}, wall_time=0.0, correction=None,
            redundant_joints=self._redundant_joints, messages=[], settings={})
        reactions, cache = None, {}
        for m, (kind, target, *rest) in self._solved:
            if kind == "acceleration":
                values[m] = res.vdot[0, target, ACCELERATION_COLUMNS.index(rest[0])]
                continue
            if kind == "force":                    # spatialmbd.outputs.force_outputs, likewise
                if ("force", target) not in cache:
                    from ..outputs import force_outputs
                    cache[("force", target)] = force_outputs(res, target)
                values[m] = cache[("force", target)][rest[0]][0]
                continue
            if kind == "imu":                      # spatialmbd.outputs.imu at this sample
                if target not in cache:
                    from ..outputs import imu
                    cache[target] = imu(res, target)
                values[m] = cache[target][rest[0]][0]
                continue
            if reactions is None:
                reactions = res.reactions()
            body, quantity = rest
            r = reactions[target]
            side = "i" if body == r.body_i else "j"
            vector = getattr(r, ("force_" if quantity[0] == "f" else "moment_") + side)
            values[m] = vector[0, "xyz".index(quantity[1])]

    def output(self, name: str) -> float:
        """The value of output ``name`` at the current time."""
        try:
            return float(self._values[self.outputs.index(name)])
        except ValueError:
            raise ModelError(f"{self.name}: {name!r} is not an output (outputs: "
                             f"{', '.join(self.outputs) or 'none'})") from None

    def output_values(self) -> np.ndarray:
        """(n_outputs,) the outputs at the current time, in the order given."""
        return self._values.copy()
