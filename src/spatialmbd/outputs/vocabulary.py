"""The output vocabulary: the kinds of output, the quantities (and units) of each, the
:class:`Output` requests, their parsing and checks, and the unit of every column."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Optional

import numpy as np

from ..errors import ModelError
from ..state import POSITION_NAMES, VELOCITY_NAMES


# ============================================================================ standard columns
#: the columns of every body in a result table (global axes, SI): position and Euler
#: parameters (q), velocity and angular velocity (v), acceleration and angular acceleration
#: (vdot), in the order of their arrays' last axis
BODY_POSITION = POSITION_NAMES
BODY_VELOCITY = VELOCITY_NAMES
BODY_ACCELERATION = ("ax", "ay", "az", "alphax", "alphay", "alphaz")
#: of every named point "body.point": position, velocity, acceleration (global axes)
POINT = ("x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az")
#: of the reaction of a joint on each of its bodies, "<joint>.<body>.<fx..mz>" (global axes)
REACTION = ("fx", "fy", "fz", "mx", "my", "mz")
#: "energy.<...>" and "violation.<...>" of a dynamic result
ENERGY = ("kinetic", "gravitational", "elastic", "work_nonconservative", "total", "error")
VIOLATION = ("position", "velocity")
#: (what, unit) of the standard columns by their last part
STANDARD = {**{c: ("position", "m") for c in ("x", "y", "z")},
            **{c: ("Euler parameters", "1") for c in ("e0", "e1", "e2", "e3")},
            **{c: ("velocity", "m/s") for c in ("vx", "vy", "vz")},
            **{c: ("angular velocity", "rad/s") for c in ("wx", "wy", "wz")},
            **{c: ("acceleration", "m/s^2") for c in ("ax", "ay", "az")},
            **{c: ("angular acceleration", "rad/s^2") for c in ("alphax", "alphay", "alphaz")},
            **{c: ("force", "N") for c in ("fx", "fy", "fz")},
            **{c: ("moment", "N m") for c in ("mx", "my", "mz")}}
#: (what, unit) of the columns of a result table named in full
NAMED = {"t": ("time", "s"),
         **{f"energy.{c}": ("energy", "J") for c in ENERGY},
         "violation.position": ("|Φ| (position violation)", "1"),
         "violation.velocity": ("|D v − ν| (velocity violation)", "1"),
         "violation.phi_squared": ("ΦᵀΦ", "1"),
         "newton.iterations": ("Newton iterations", "1")}


def body_columns(body_names, q, v, vdot) -> dict:
    """{"<body>.<column>": (nt,) array} of the standard body columns; q (nt, nb, 7), v and
    vdot (nt, nb, 6) (vdot None: no acceleration columns)."""
    cols = {}
    for k, name in enumerate(body_names):
        for arr, names in ((q, BODY_POSITION), (v, BODY_VELOCITY), (vdot, BODY_ACCELERATION)):
            if arr is not None:
                for j, c in enumerate(names):
                    cols[f"{name}.{c}"] = arr[:, k, j]
    return cols


def describe_column(column: str, units: Optional[dict] = None):
    """(what, unit) of a column of a result table (``units``: the table's units of its
    requested outputs, ``attrs["units"]``), or None when the vocabulary does not know it."""
    if column in NAMED:
        return NAMED[column]
    last = column.rsplit(".", 1)[-1]
    if units and column in units and not (last in STANDARD and ".imu." not in column):
        return ("output", units[column])
    if "." in column and last in STANDARD and ".imu." not in column:
        return STANDARD[last]
    unit = column_units([column], units).get(column)
    return None if unit is None else ("output", unit)


KINDS = ("joint", "force", "driver", "momentum", "energy", "imu")
SHORTHANDS = {"joints": "joint", "forces": "force", "drivers": "driver"}

#: unit of every quantity (last part of a column name) by output kind
QUANTITIES = {
    "joint": {"angle": "rad", "translation": "m", "translation_a": "m", "translation_b": "m",
              "angle_i": "rad", "angle_j": "rad", "rx": "rad", "ry": "rad", "rz": "rad",
              "dx": "m", "dy": "m", "dz": "m"},
    "spring_damper": {"length": "m", "length_rate": "m/s", "deflection": "m", "force": "N",
                      "power": "W", "energy": "J"},
    "rotational_spring_damper": {"angle": "rad", "angle_rate": "rad/s", "deflection": "rad",
                                 "torque": "N m", "power": "W", "energy": "J"},
    "point_force": {"fx": "N", "fy": "N", "fz": "N", "power": "W"},
    "torque": {"mx": "N m", "my": "N m", "mz": "N m", "power": "W"},
    "user": {"power": "W"},
    #: actuators (spatialmbd.forces.actuators): the joint coordinate q and rate, the command
    #: used (clipped to ctrlrange), the effort gear * f on the joint and its power effort * q'
    "actuator": {"coordinate": "m | rad", "coordinate_rate": "m/s | rad/s", "command": "-",
                 "effort": "N | N m", "power": "W"},
    "bushing": {"dx": "m", "dy": "m", "dz": "m", "rx": "rad", "ry": "rad", "rz": "rad",
                "fx": "N", "fy": "N", "fz": "N", "mx": "N m", "my": "N m", "mz": "N m",
                "power": "W", "energy": "J"},
    #: contact instances (spatialmbd.forces.contact): the pair's state at the contact
    "contact": {"gap": "m", "penetration": "m", "gap_rate": "m/s", "impact_velocity": "m/s",
                "normal_force": "N", "friction_x": "N", "friction_y": "N", "friction_z": "N",
                "slip_x": "m/s", "slip_y": "m/s", "slip_z": "m/s", "slip_speed": "m/s",
                "point_x": "m", "point_y": "m", "point_z": "m", "active": "-",
                "power_normal": "W", "power_friction": "W", "dissipated_normal": "J",
                "dissipated_friction": "J", "damping": "N s/m"},
    #: any other force type (one element of its type in the model): power and energy
    "*": {"power": "W", "energy": "J"},
    "driver": {"coordinate": "m | rad", "coordinate_rate": "m/s | rad/s",
               "effort": "N | N m", "power": "W"},
    "momentum": {"px": "N s", "py": "N s", "pz": "N s",
                 "hx": "N m s", "hy": "N m s", "hz": "N m s"},
    "energy": {"kinetic": "J", "potential": "J"},
    "imu": {"ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2", "sfx": "m/s^2", "sfy": "m/s^2",
            "sfz": "m/s^2", "wx": "rad/s", "wy": "rad/s", "wz": "rad/s"},
}

#: joint coordinates of each joint type (the rest get the generic relative pose)
JOINT_COORDINATES = {
    "revolute": ("angle",),
    "translational": ("translation",),
    "cylindrical": ("angle", "translation"),
    "screw": ("angle", "translation"),
    "planar": ("angle", "translation_a", "translation_b"),
    "universal": ("angle_i", "angle_j"),
    "spherical": ("rx", "ry", "rz"),
}
GENERIC_COORDINATES = ("dx", "dy", "dz", "rx", "ry", "rz")
_ANGLES = {"angle", "angle_i", "angle_j", "rx", "ry", "rz"}


# ============================================================================ requests
@dataclass(frozen=True)
class Output:
    """One output request.

    kind: "joint", "force", "driver", "momentum", "energy" or "imu".
    of: the joint, force element or driver name; the body ("momentum", "energy": None = the
        whole system); the named point "body.point" ("imu"). None for joint/force/driver: every
        element of that kind.
    name: column prefix (default: ``of``; "system" for the system; "<point>.imu" for an IMU).
    about: momentum only -- angular momentum about this fixed point (global axes, m) instead
        of about the centre of mass (of the body, or of the system).
    """

    kind: str
    of: Optional[str] = None
    name: Optional[str] = None
    about: Optional[tuple] = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ModelError(f"output kind {self.kind!r} is not one of {', '.join(KINDS)} "
                             "(or the shorthands joints, drivers, forces, bodies, all)")
        if self.about is not None:
            if self.kind != "momentum":
                raise ModelError(f"output {self.label}: 'about' is for momentum outputs only")
            about = np.asarray(self.about, dtype=float).reshape(-1)
            if about.size != 3 or not np.all(np.isfinite(about)):
                raise ModelError(f"output {self.label}: 'about' must be 3 finite numbers "
                                 f"(a point in global axes, m), got {self.about!r}")
            object.__setattr__(self, "about", tuple(float(x) for x in about))
        if self.kind == "imu" and not self.of:
            raise ModelError("an imu output needs the point it sits at: of='body.point'")

    @property
    def label(self) -> str:
        return f"{self.kind}" + (f" {self.of!r}" if self.of else "")

    @property
    def prefix(self) -> str:
        if self.name:
            return self.name
        if self.kind == "imu":
            return f"{self.of}.imu"
        return self.of or "system"

    def to_dict(self) -> dict:
        out = {"type": self.kind}
        if self.of is not None:
            out["of"] = self.of
        if self.name is not None:
            out["name"] = self.name
        if self.about is not None:
            out["about"] = list(self.about)
        return out

    @classmethod
    def from_dict(cls, d) -> "Output":
        if isinstance(d, Output):
            return d
        if not isinstance(d, dict):
            raise ModelError(f"an output request is a mapping like {{type: joint, of: pivot}} "
                             f"or one of joints, drivers, forces, bodies, all; got {d!r}")
        extra = set(d) - {"type", "of", "name", "about"}
        if extra:
            raise ModelError(f"output {d!r}: unknown key(s) {sorted(extra)}; allowed: type, "
                             "of, name, about")
        if "type" not in d:
            raise ModelError(f"output {d!r}: missing 'type' (one of {', '.join(KINDS)})")
        return cls(str(d["type"]), d.get("of"), d.get("name"), d.get("about"))


def parse_outputs(model, requests) -> list:
    """The list of :class:`Output` named by ``requests`` (Output objects, dicts or the
    shorthands "joints", "drivers", "forces", "bodies", "all"), checked against ``model``
    (unknown names and duplicate column prefixes raise ModelError naming them)."""
    if requests is None:
        return []
    if isinstance(requests, (str, dict, Output)):
        requests = [requests]
    out: list = []
    for item in requests:
        if isinstance(item, str):
            out.extend(_expand(model, item))
        else:
            req = Output.from_dict(item)
            if req.of is None and req.kind in ("joint", "force", "driver"):
                out.extend(_expand(model, req.kind + "s"))
            else:
                out.append(req)
    seen: dict = {}
    for req in out:
        _check_target(model, req)
        key = (req.prefix, req.kind)
        if key in seen and seen[key] != req:
            raise ModelError(f"outputs {seen[key].label} and {req.label} would both write "
                             f"columns {req.prefix}.*; give one of them a 'name'")
        seen[key] = req
    unique = []
    for req in out:
        if req not in unique:
            unique.append(req)
    return unique


def _expand(model, word: str) -> list:
    if word in SHORTHANDS:
        kind = SHORTHANDS[word]
        if kind == "joint":
            return [Output("joint", n) for n in model.joint_names]
        if kind == "driver":
            return [Output("driver", n) for n in model.driver_names]
        return [Output("force", n) for g in model.force_groups if _force_kind(g) is not None
                for n in g.names]
    if word == "bodies":
        return [Output(k, b) for b in model.body_names for k in ("momentum", "energy")]
    if word == "all":
        return (_expand(model, "joints") + _expand(model, "drivers") + _expand(model, "forces")
                + [Output("momentum"), Output("energy")] + _expand(model, "bodies"))
    if word in ("momentum", "energy"):
        return [Output(word)]
    raise ModelError(f"unknown output {word!r}: use joints, drivers, forces, bodies, all, "
                     "momentum, energy or a mapping like {type: joint, of: pivot}")


def _check_target(model, req: Output) -> None:
    def unknown(what, name, valid):
        import difflib
        close = difflib.get_close_matches(str(name), list(valid), n=1)
        raise ModelError(f"output {req.label}: no {what} named {name!r}"
                         + (f" (did you mean {close[0]!r}?)" if close else "")
                         + f"; {what}s: {', '.join(valid) or 'none'}")
    if req.kind == "joint" and req.of not in model.joint_names:
        unknown("joint", req.of, model.joint_names)
    if req.kind == "driver" and req.of not in model.driver_names:
        unknown("driver", req.of, model.driver_names)
    if req.kind == "force":
        names = [n for g in model.force_groups for n in g.names]
        if req.of not in names:
            unknown("force element", req.of, names)
    if req.kind in ("momentum", "energy") and req.of is not None and \
            req.of not in model.body_names:
        unknown("body", req.of, model.body_names)
    if req.kind == "imu" and req.of not in model.points:
        unknown("point", req.of, list(model.points))


# ============================================================================ states over time
def _force_group(model, element):
    for g in model.force_groups:
        if element in g.names:
            return g, g.names.index(element)
    names = [n for g in model.force_groups for n in g.names]
    raise ModelError(f"no force element named {element!r}; force elements: "
                     f"{', '.join(names) or 'none'}")


def _force_kind(g):
    """The QUANTITIES key of a force group: its type, "*" (another type, one element), or
    None (another type with several elements: they cannot be told apart)."""
    if hasattr(g, "output_columns"):       # a type with outputs of its own (limits, actuators)
        return "own"
    if g.name in QUANTITIES:
        return g.name
    return "*" if g.n == 1 else None


def output_units(results, requests=None) -> dict:
    """{column: unit} of the requested outputs (units of drivers from their kind)."""
    model = results.model
    reqs = parse_outputs(model, getattr(results, "output_requests", None)
                         if requests is None else requests)
    units: dict = {}
    for req in reqs:
        if req.kind == "joint":
            g, _, _ = model.element(req.of)
            names = JOINT_COORDINATES.get(g.name, GENERIC_COORDINATES)
            for n in names:
                u = QUANTITIES["joint"][n]
                units[f"{req.prefix}.{n}"] = u
                units[f"{req.prefix}.{n}_rate"] = u + "/s"
        elif req.kind == "force":
            g, i = _force_group(model, req.of)
            own = g.output_units(i) if _force_kind(g) == "own" else None
            for n, u in (own or QUANTITIES[_force_kind(g) or "*"]).items():
                units[f"{req.prefix}.{n}"] = u
        elif req.kind == "driver":
            g, _, _ = model.element(req.of)
            rad = g.name == "angle"
            lin = g.name == "translation" or (g.coordinate is not None and
                                              int(g.coordinate[model.element(req.of)[1]]) < 3)
            base = "rad" if rad else ("m" if lin else "1")
            eff = "N m" if rad else ("N" if lin else "N m")
            units.update({f"{req.prefix}.coordinate": base,
                          f"{req.prefix}.coordinate_rate": base + "/s",
                          f"{req.prefix}.effort": eff, f"{req.prefix}.power": "W"})
        else:
            for n, u in QUANTITIES[req.kind].items():
                units[f"{req.prefix}.{n}"] = u
    return units


def column_units(columns: Iterable[str], units: Optional[dict] = None) -> dict:
    """Unit of every column name that has a known one: from ``units`` (e.g. a table's
    ``attrs["units"]``), else from the standard columns' suffixes."""
    units = dict(units or {})
    std = {c: u for c, (_, u) in STANDARD.items()}
    # the output quantities whose unit does not depend on the element type
    by_quantity: dict = {}
    for table in QUANTITIES.values():
        for q, u in table.items():
            by_quantity.setdefault(q, set()).add(u)
            if u in ("rad", "m"):
                by_quantity.setdefault(q + "_rate", set()).add(u + "/s")
    known = {q: next(iter(u)) for q, u in by_quantity.items() if len(u) == 1 and "|" not in
             next(iter(u))}
    out = {}
    for c in columns:
        last = c.rsplit(".", 1)[-1]
        if c in units:
            out[c] = units[c]
        elif c == "t":
            out[c] = "s"
        elif c.startswith("energy."):
            out[c] = "J"
        elif c.startswith(("violation.", "newton.")):
            continue
        elif ".imu." in c and last in QUANTITIES["imu"]:
            out[c] = QUANTITIES["imu"][last]
        elif last in std:
            out[c] = std[last]
        elif last in known and "." in c:
            out[c] = known[last]
    return out
