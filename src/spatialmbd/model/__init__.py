"""Model description: the mutable builder and the frozen compiled model."""
from .builder import ModelBuilder
from .model import Model

__all__ = ["ModelBuilder", "Model"]
