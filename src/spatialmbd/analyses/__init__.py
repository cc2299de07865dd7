"""Engineering analyses next to :func:`spatialmbd.simulate.simulate`.

    inverse_dynamics   driver efforts and joint reactions of a kinematically driven mechanism
    static_equilibrium Q(q) + D^T lam = 0, Phi = 0 with stability of the equilibrium
    quasi_static       a sequence of equilibria along rheonomic drivers
    linearize          M, C, K and A, B, C, D in independent coordinates
    modes              natural frequencies, damping ratios and mode shapes

Sign convention (dynamics/eom.py): M vdot = g + D^T lam, D^T lam are the reactions on the
bodies. The effort of a driver k (force or torque along its coordinate) is lam_k: its power
on the mechanism is lam_k * d(coordinate)/dt, so a positive effort does positive work when the
driven coordinate increases.
"""
from .inverse import InverseDynamicsResults, inverse_dynamics, prescribed_motion_model
from .statics import QuasiStaticResults, StaticResults, quasi_static, static_equilibrium
from .linearize import LinearModel, linearize
from .modes import ModalResults, modes

__all__ = ["inverse_dynamics", "InverseDynamicsResults", "prescribed_motion_model",
           "static_equilibrium", "StaticResults", "quasi_static", "QuasiStaticResults",
           "linearize", "LinearModel", "modes", "ModalResults"]
