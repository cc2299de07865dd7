"""The ``analysis`` section of a model file: what to run (:class:`Analysis`) and its checks."""
from __future__ import annotations

import functools
import inspect
from dataclasses import dataclass, field
from typing import Optional

from ..errors import ModelError
from .schema import (ANALYSIS_KEYS, ANALYSIS_TYPES, _describe, DYNAMIC_ONLY, _list, _mapping,
                     _member, _name, _number, _plain, _Problems, _reference, SINGLE_TIME_TYPES,
                     _string, _suggest, _vector)
from .source import _plain_input

#: the default method: simulate() takes "recursive" for an open tree of revolute,
#: translational and spherical joints, else "projection"
AUTO = "auto"


# ============================================================================ analysis
@dataclass
class Analysis:
    """What to run on a model: a forward-dynamics simulation or a kinematic analysis.

    type: "dynamic" (:func:`spatialmbd.simulate.simulate`) or "kinematic"
    (:func:`spatialmbd.kinematics.kinematic_analysis`). t_end (s); output_step (s, None = 500
    intervals) or t_eval (explicit output times). Dynamic only: method and method_options,
    integrator with step (s), rtol, atol (None = the integrator's default) and
    integrator_options, correct_initial, hold ({"body": ["x", ...]}).
    Engineering analyses (spatialmbd.analyses): "inverse" and "quasi_static" over the output
    times, "static" and "modal" at ``time`` (s); modal: ``steady`` (about the initial state as
    a steady motion) and ``frame_rate`` (rad/s, a turning frame for relative equilibria).
    """

    type: str = "dynamic"
    t_end: float = 1.0
    output_step: Optional[float] = None
    t_eval: Optional[list] = None
    method: str = "auto"
    method_options: dict = field(default_factory=dict)
    integrator: str = "rk45"
    step: Optional[float] = None
    rtol: Optional[float] = None
    atol: Optional[float] = None
    integrator_options: dict = field(default_factory=dict)
    correct_initial: bool = True
    hold: Optional[dict] = None
    #: the model file's top-level ``outputs:`` section: what to record besides the standard
    #: columns (:mod:`spatialmbd.outputs`; list of request dicts or shorthand strings)
    outputs: list = field(default_factory=list)
    steady: bool = False
    time: float = 0.0
    frame_rate: Optional[list] = None
    #: dynamic only: controllers sampled during the run, as given in the file (dicts with a
    #: ``type``; "fmu": an FMU driving actuators, ``file`` resolved against the model file's
    #: folder) -- built by :func:`spatialmbd.analyses.run.build_controllers`
    controllers: list = field(default_factory=list)

    def run(self, model, progress=False, budget=None, stream=None):
        """Run this analysis of ``model`` (:func:`spatialmbd.analyses.run.run_analysis`: the
        IO package only describes analyses; running them belongs to the analyses layer)."""
        from ..analyses.run import run_analysis
        return run_analysis(self, model, progress=progress, budget=budget, stream=stream)

    def to_dict(self) -> dict:
        """The ``analysis`` section of a model file (plain Python types)."""
        out: dict = {"type": self.type}
        if self.type in SINGLE_TIME_TYPES:
            if self.time:
                out["time"] = float(self.time)
            if self.type == "modal" and self.steady:
                out["steady"] = True
                if self.frame_rate is not None:
                    out["frame_rate"] = [float(x) for x in self.frame_rate]
            return out
        if self.t_eval is not None:
            out["t_eval"] = [float(t) for t in self.t_eval]
        else:
            out["t_end"] = float(self.t_end)
            if self.output_step is not None:
                out["output_step"] = float(self.output_step)
        if self.type == "dynamic":
            out["method"] = {"name": self.method, **_plain(self.method_options)}
            integ = {"name": self.integrator}
            for key in ("step", "rtol", "atol"):
                if getattr(self, key) is not None:
                    integ[key] = _plain(getattr(self, key))
            integ.update(_plain(self.integrator_options))
            out["integrator"] = integ
            out["correct_initial"] = bool(self.correct_initial)
            if self.hold is not None:
                out["hold"] = {str(b): ([c] if isinstance(c, str) else list(c))
                               for b, c in self.hold.items()}
            if self.controllers:
                out["controllers"] = [_plain(c) for c in self.controllers]
        return out

    @classmethod
    def from_dict(cls, data, body_names=None) -> "Analysis":
        """An Analysis from an ``analysis`` section; raises ModelFileError listing problems.
        body_names: the model's bodies, to check ``hold`` (None: not checked)."""
        P = _Problems()
        out = _parse_analysis(P, ("analysis",), _plain_input(data), body_names)
        if len(P):
            raise P.error(heading="analysis")
        return out


@functools.lru_cache(maxsize=None)
def _option_parameters(cls) -> dict:
    """The keyword parameters of cls.__init__ (inspect.signature is slow, and a sweep parses
    one analysis per member)."""
    return {k: p for k, p in inspect.signature(cls.__init__).parameters.items()
            if k != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}


def _options(P, path, cls, options: dict, skip=()) -> bool:
    """Check option names and types against the signature of cls.__init__."""
    params = _option_parameters(cls)
    n0 = len(P)
    valid = ["name"] + list(params)
    for key, value in options.items():
        if key in skip:
            continue
        where = tuple(path) + (key,)
        if key not in params:
            P.add(where, f"{cls.name!r} takes no option {key!r}{_suggest(key, params)}; "
                         f"valid keys: {', '.join(valid)}")
            continue
        default = params[key].default
        if isinstance(default, bool):
            if not isinstance(value, bool):
                P.add(where, f"expected true or false, got {_describe(value)}")
        elif isinstance(default, str):
            _string(P, where, value)
        elif isinstance(default, int) and not isinstance(default, float):
            _number(P, where, value, integer=True)
        else:
            _number(P, where, value)
    return len(P) == n0


def _parse_analysis(P, path, d, body_names) -> Optional[Analysis]:
    from ..dynamics import METHODS
    from ..dynamics.base import ALIASES
    from ..dynamics.correction import HOLD_NAMES
    from ..integrators import INTEGRATORS

    if not _mapping(P, path, d, ANALYSIS_KEYS):
        return None
    a = Analysis()
    kind = d.get("type", "dynamic")
    if kind not in ANALYSIS_TYPES:
        P.add(tuple(path) + ("type",), f"unknown analysis type {_name(kind)}; valid: "
                                        + ", ".join(ANALYSIS_TYPES))
        kind = "dynamic"
    a.type = kind
    if "t_eval" in d:
        te = d["t_eval"]
        if _list(P, tuple(path) + ("t_eval",), te, "times (s)"):
            if not te:
                P.add(tuple(path) + ("t_eval",), "expected at least one time")
            elif all(_number(P, tuple(path) + ("t_eval", k), x) for k, x in enumerate(te)):
                if te[0] < 0 or any(b <= a_ for a_, b in zip(te, te[1:])):
                    P.add(tuple(path) + ("t_eval",), "output times must be >= 0 and strictly "
                                                     "increasing")
                else:
                    a.t_eval = [float(x) for x in te]
                    a.t_end = a.t_eval[-1]
        if "output_step" in d:
            P.add(tuple(path) + ("output_step",), "give output_step or t_eval, not both")
        if "t_end" in d and _number(P, tuple(path) + ("t_end",), d["t_end"]) \
                and a.t_eval is not None and float(d["t_end"]) != a.t_eval[-1]:
            P.add(tuple(path) + ("t_end",), f"t_end ({d['t_end']!r}) differs from the last "
                                            f"time of t_eval ({a.t_eval[-1]!r}); leave it out")
    elif "t_end" not in d and kind in SINGLE_TIME_TYPES:
        pass                                    # one time: "time" (s), default 0
    elif "t_end" not in d:
        P.add(path, "missing required key 't_end' (end time, s), or give t_eval")
    elif _number(P, tuple(path) + ("t_end",), d["t_end"], positive=True):
        a.t_end = float(d["t_end"])
    if "output_step" in d and "t_eval" not in d:
        if _number(P, tuple(path) + ("output_step",), d["output_step"], positive=True):
            a.output_step = float(d["output_step"])

    for key, types in (("steady", ("modal",)), ("time", SINGLE_TIME_TYPES)):
        if key in d and kind not in types:
            P.add(tuple(path) + (key,), f"applies to {' and '.join(types)} analyses only "
                                        f"(this analysis is {kind})")
    if kind in SINGLE_TIME_TYPES:
        for key in ("t_end", "output_step", "t_eval"):
            if key in d:
                P.add(tuple(path) + (key,), f"a {kind} analysis is at one time: give 'time' "
                                            "(s) instead")
    if "steady" in d and kind == "modal":
        if isinstance(d["steady"], bool):
            a.steady = d["steady"]
        else:
            P.add(tuple(path) + ("steady",), f"expected true or false, got "
                                             f"{_describe(d['steady'])}")
    if "frame_rate" in d:
        if kind != "modal" or not d.get("steady", False):
            P.add(tuple(path) + ("frame_rate",), "applies to modal analyses with steady: true "
                                                 "only (the rate, rad/s, of the frame turning "
                                                 "with a relative equilibrium)")
        elif _vector(P, tuple(path) + ("frame_rate",), d["frame_rate"]):
            a.frame_rate = [float(x) for x in d["frame_rate"]]
    if "time" in d and kind in SINGLE_TIME_TYPES:
        if _number(P, tuple(path) + ("time",), d["time"], nonneg=True):
            a.time = float(d["time"])

    if kind != "dynamic":
        for key in DYNAMIC_ONLY:
            if key in d:
                P.add(tuple(path) + (key,), "applies to dynamic analyses only (this analysis "
                                            f"is {kind})")
        return a

    if "method" in d:
        m = d["method"]
        mpath = tuple(path) + ("method",)
        name, opts = (m, {}) if isinstance(m, str) else (None, None)
        if isinstance(m, dict):
            if "name" not in m:
                P.add(mpath, "missing required key 'name' (methods: "
                             + ", ".join(sorted(METHODS)) + ")")
            else:
                name = m["name"]
                opts = {k: v for k, v in m.items() if k != "name"}
                mpath = mpath + ("name",)
        elif not isinstance(m, str):
            P.add(mpath, f"expected a method name or a mapping {{name: ..., options}}, got "
                         f"{_describe(m)}")
        if isinstance(name, str) and name.lower() == AUTO:
            a.method = AUTO                     # simulate() chooses (recursive or projection)
            if opts:
                P.add(tuple(path) + ("method",), "method 'auto' takes no options (name a "
                      "method to set its options)")
        elif name is not None:
            key = ALIASES.get(name.lower(), name.lower()) if isinstance(name, str) else None
            if key not in METHODS:
                P.add(mpath, f"unknown method {_name(name)}{_suggest(name, METHODS)}; "
                             "valid names: auto, " + ", ".join(sorted(METHODS)))
            else:
                a.method = key
                if _options(P, tuple(path) + ("method",), METHODS[key], opts):
                    try:
                        METHODS[key](**opts)
                        a.method_options = dict(opts)
                    except (ModelError, ValueError, TypeError) as exc:
                        P.add(tuple(path) + ("method",), str(exc))

    if "integrator" in d:
        m = d["integrator"]
        ipath = tuple(path) + ("integrator",)
        name, opts = (m, {}) if isinstance(m, str) else (None, None)
        if isinstance(m, dict):
            if "name" not in m:
                P.add(ipath, "missing required key 'name' (integrators: "
                             + ", ".join(sorted(INTEGRATORS)) + ")")
            else:
                name = m["name"]
                opts = {k: v for k, v in m.items() if k != "name"}
        elif not isinstance(m, str):
            P.add(ipath, f"expected an integrator name or a mapping {{name: ..., options}}, "
                         f"got {_describe(m)}")
        if name is not None:
            key = name.lower() if isinstance(name, str) else None
            if key not in INTEGRATORS:
                P.add(ipath + (("name",) if isinstance(m, dict) else ()),
                      f"unknown integrator {_name(name)}{_suggest(name, INTEGRATORS)}; "
                      "valid names: " + ", ".join(sorted(INTEGRATORS)))
            else:
                a.integrator = key
                n0 = len(P)
                for opt in ("step", "rtol", "atol"):
                    if opt in opts:
                        _number(P, ipath + (opt,), opts[opt], positive=True)
                if _options(P, ipath, INTEGRATORS[key], opts) and len(P) == n0:
                    try:
                        INTEGRATORS[key](**opts)
                    except (ModelError, ValueError, TypeError) as exc:
                        P.add(ipath, str(exc))
                    else:
                        a.step = opts.get("step")
                        a.rtol = opts.get("rtol")
                        a.atol = opts.get("atol")
                        a.integrator_options = {k: v for k, v in opts.items()
                                                if k not in ("step", "rtol", "atol")}

    if "correct_initial" in d:
        if isinstance(d["correct_initial"], bool):
            a.correct_initial = d["correct_initial"]
        else:
            P.add(tuple(path) + ("correct_initial",),
                  f"expected true or false, got {_describe(d['correct_initial'])}")
    if "hold" in d and d["hold"] is not None:
        hold = d["hold"]
        hpath = tuple(path) + ("hold",)
        if not isinstance(hold, dict):
            P.add(hpath, f"expected a mapping {{body: [x, y, z, rx, ry, rz]}}, got "
                         f"{_describe(hold)}")
        else:
            out, n0 = {}, len(P)
            for body, coords in hold.items():
                if body_names is not None:
                    _reference(P, hpath + (body,), body, body_names, "body")
                coords = [coords] if isinstance(coords, str) else coords
                if not isinstance(coords, list):
                    P.add(hpath + (body,), f"expected a list of coordinates "
                                           f"({', '.join(HOLD_NAMES)}), got {_describe(coords)}")
                    continue
                for k, c in enumerate(coords):
                    if not _member(c, HOLD_NAMES):
                        P.add(hpath + (body, k), f"{_describe(c)} is not one of "
                                                 f"{', '.join(HOLD_NAMES)} (translations x, y, "
                                                 "z; small rotations rx, ry, rz)")
                out[body] = list(coords)
            if len(P) == n0:
                a.hold = out
    if "controllers" in d and d["controllers"] is not None:
        a.controllers = _parse_controllers(P, tuple(path) + ("controllers",), d["controllers"])
    return a


def _parse_controllers(P, path, value) -> list:
    """The ``controllers`` entries (checked as far as the file can tell: the FMU itself is
    opened when the run builds them)."""
    from .schema import FMU_CONTROLLER_KEYS
    out = []
    if not _list(P, path, value, "controllers"):
        return out
    for k, entry in enumerate(value):
        where = path + (k,)
        if not isinstance(entry, dict) or entry.get("type") != "fmu":
            P.add(where, "expected a controller {type: fmu, file, inputs_from, outputs_to, "
                         "step} (the only controller type a model file names), got "
                         + _describe(entry))
            continue
        if not _mapping(P, where, entry, FMU_CONTROLLER_KEYS,
                        required=("file", "outputs_to", "step")):
            continue
        n0 = len(P)
        _string(P, where + ("file",), entry["file"], "the path of the .fmu")
        for key in ("inputs_from", "outputs_to", "parameters"):
            mapping = entry.get(key, {})
            if not isinstance(mapping, dict) or not all(isinstance(x, str)
                                                        for x in mapping):
                P.add(where + (key,), f"expected a mapping {{FMU variable: ...}}, got "
                                      f"{_describe(mapping)}")
        _number(P, where + ("step",), entry["step"], positive=True)
        if len(P) > n0:
            continue
        spec = dict(entry)
        spec["file"] = resolve_controller_file(entry["file"])
        out.append(spec)
    return out


def resolve_controller_file(name: str) -> str:
    """``name`` against the model file's folder (as meshes and time series are)."""
    import os
    from .schema import _BASE_DIR
    base = _BASE_DIR.get()
    full = os.path.expanduser(name)
    return full if os.path.isabs(full) or base is None else os.path.join(base, full)
