"""Model description: the mutable builder, the frozen compiled model and its workspaces."""
from .builder import ModelBuilder
from .data import Data, make_data
from .model import Model

__all__ = ["ModelBuilder", "Model", "Data", "make_data"]
