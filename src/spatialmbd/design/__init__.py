"""Design with gradients: parameter identification from measurements and design optimization
(docs/design.md).

    from spatialmbd.design import identify, optimize
    fit = identify("examples/design/pendulum_damped.yaml", "rig.csv",
                   ["bodies.pendulum.mass", "forces.pivot_damper.damping"])
    best = optimize(model, "peak(crank_drive.crank.mx)", {"counterweight": 0.1})

Parameters are the sweep's paths (:mod:`spatialmbd.sweep.params`), outputs its columns and
reductions (:mod:`spatialmbd.sweep.outputs`); the Jacobians come from its forward
sensitivities, from the adjoint (:mod:`.adjoint`) or from central differences run as members of
one chunk (:mod:`.problem`).
"""
from .adjoint import Adjoint, adjoint_gradients
from .identify import Identification, identify
from .optimize import Optimization, optimize
from .problem import read_data

__all__ = ["adjoint_gradients", "Adjoint", "identify", "Identification", "optimize",
           "Optimization", "read_data"]
