"""Running an analysis described by a model file's ``analysis`` section
(:class:`spatialmbd.io.modelfile.Analysis`): dynamic, kinematic and the engineering types."""
from __future__ import annotations

import numpy as np

from ..errors import ModelError

#: controller types a model file's ``analysis.controllers`` may name: type -> factory(spec) ->
#: a sampled controller. Registered by the packages that provide them (``"fmu"``:
#: :mod:`spatialmbd.fmi.controller`, which ``spatialmbd run`` imports for such a file).
CONTROLLER_TYPES: dict = {}


def register_controller(name: str, factory) -> None:
    """Make ``analysis.controllers`` entries of ``type: name`` buildable by ``factory(spec)``."""
    CONTROLLER_TYPES[name] = factory


def build_controllers(analysis) -> list:
    """The sampled controllers of ``analysis.controllers`` (ModelError naming an entry whose
    type has no provider loaded: for FMUs, ``import spatialmbd.fmi`` -- the extra
    ``spatialmbd[fmi]`` -- first; the command line does it)."""
    out = []
    for k, spec in enumerate(getattr(analysis, "controllers", None) or []):
        factory = CONTROLLER_TYPES.get(spec.get("type"))
        if factory is None:
            raise ModelError(f"analysis.controllers[{k}]: controllers of type "
                             f"{spec.get('type')!r} need spatialmbd.fmi (pip install "
                             "'spatialmbd[fmi]', then import spatialmbd.fmi before running "
                             "the analysis from Python)")
        out.append(factory(spec))
    return out


def run_analysis(analysis, model, progress=False, budget=None, stream=None):
    """Results (dynamic) or KinematicResults (kinematic) of ``analysis`` on ``model``; the
    result objects of spatialmbd.analyses for the engineering types. budget: a
    :class:`spatialmbd.budget.Budget` (or dict) for dynamic and kinematic runs. stream: a
    :class:`spatialmbd.io.stream.ResultsWriter` receiving a dynamic run's outputs in chunks
    (see ``simulate``)."""
    a = analysis
    if a.type == "kinematic":
        from ..kinematics import kinematic_analysis
        from ..outputs import parse_outputs
        from ..simulate import output_times
        requests = parse_outputs(model, a.outputs)
        res = kinematic_analysis(model, output_times(a.t_end, a.output_step, a.t_eval),
                                 budget=budget)
        res.output_requests = requests
        return res
    if a.type != "dynamic":
        return _run_engineering(a, model)
    from ..simulate import simulate
    return simulate(model, a.t_end, method=a.method, integrator=a.integrator,
                    output_step=a.output_step, t_eval=a.t_eval, step=a.step, rtol=a.rtol,
                    atol=a.atol, method_options=dict(a.method_options),
                    integrator_options=dict(a.integrator_options),
                    correct_initial=a.correct_initial, hold=a.hold, progress=progress,
                    outputs=list(a.outputs), budget=budget, stream=stream,
                    **({"controllers": build_controllers(a)} if a.controllers else {}))


def _run_engineering(a, model):
    """inverse: InverseDynamicsResults; static: StaticResults at ``time``; quasi_static:
    QuasiStaticResults; modal: ModalResults about the static equilibrium at ``time`` (or, with
    ``steady``, about the model's initial state as a steady motion)."""
    from . import inverse_dynamics, modes, quasi_static, static_equilibrium
    from ..simulate import output_times
    if a.type == "static":
        return static_equilibrium(model, t=a.time)
    if a.type == "modal":
        if a.steady:
            return modes(model, t=a.time, steady=True, frame_rate=a.frame_rate)
        sol = static_equilibrium(model, t=a.time)
        return modes(model, sol.q, np.zeros(6 * model.nb), a.time)
    if a.type not in ("inverse", "quasi_static"):
        raise ModelError(f"analysis type {a.type!r} is not one of dynamic, kinematic, "
                         "inverse, static, quasi_static, modal")
    times = output_times(a.t_end, a.output_step, a.t_eval)
    if a.type == "inverse":
        return inverse_dynamics(model, times)
    return quasi_static(model, times)
