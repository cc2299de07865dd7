"""Workspaces of a Model: everything an evaluation computes or writes lives here, never in the
frozen :class:`~spatialmbd.model.Model` (MuJoCo's mjModel / mjData, Pinocchio's Model / Data).

A :class:`Data` holds the constraint assembler with its law buffers and the compiled systems
(their static, symbolic part built once per Data; every run clones its own work arrays).
:func:`make_data` gives a new, explicit workspace; the library's functions that are not handed
one use :func:`thread_data`, one workspace per model and thread, so that two threads running
one Model never share a buffer.
"""
from __future__ import annotations

import threading
import weakref


class Data:
    """The workspace of one model: ``assembler`` (constraint values, Jacobian assembly) and
    ``systems`` (compiled equations of motion by kept constraint rows)."""

    def __init__(self, model):
        from ..assembly import Assembler
        self.model = model
        self.assembler = Assembler(model)
        self.systems: dict = {}


def make_data(model) -> Data:
    """A new workspace for ``model`` (for example one per worker of a custom parallel loop)."""
    return Data(model)


_local = threading.local()


def thread_data(model) -> Data:
    """The workspace of ``model`` for the calling thread (made on first use)."""
    registry = getattr(_local, "registry", None)
    if registry is None:
        registry = _local.registry = weakref.WeakKeyDictionary()
    data = registry.get(model)
    if data is None:
        data = registry[model] = Data(model)
    return data
