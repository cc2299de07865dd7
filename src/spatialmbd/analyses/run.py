"""Running an analysis described by a model file's ``analysis`` section
(:class:`spatialmbd.io.modelfile.Analysis`): dynamic, kinematic and the engineering types."""
from __future__ import annotations

import numpy as np

from ..errors import ModelError

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
                    outputs=list(a.outputs), budget=budget, stream=stream)


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
