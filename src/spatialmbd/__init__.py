"""spatialmbd: kinematics and dynamics of spatial rigid multibody systems.

Body coordinates (absolute Cartesian, centre of mass + Euler parameters) after P. Flores,
*Concepts and Formulations for Spatial Multibody Dynamics* (2015) and Nikravesh (1988).
"""
from .errors import ConvergenceError, ModelError, SimulationError, SingularMatrixError, SpatialMBDError
from .model import Model, ModelBuilder
from . import motion

__version__ = "0.1.0"

__all__ = ["ModelBuilder", "Model", "motion", "SpatialMBDError", "ModelError", "ConvergenceError",
           "SingularMatrixError", "SimulationError", "__version__"]
