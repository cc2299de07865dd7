"""Forward dynamics: equations of motion and the methods to solve them (text ch. 10, 12, 14)."""
from . import augmented_lagrangian, baumgarte, penalty, projection, recursive, standard  # noqa: F401
from .base import METHODS, Method, MethodOutput, get_method
from .eom import EquationsOfMotion

__all__ = ["METHODS", "Method", "MethodOutput", "get_method", "EquationsOfMotion"]
