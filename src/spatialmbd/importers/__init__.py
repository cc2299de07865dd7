"""Model importers: MJCF and URDF through MuJoCo's compiler (:mod:`.mjcf`, optional extra
``spatialmbd[mjcf]``) and mass properties of shapes (:mod:`.massprops`)."""
from __future__ import annotations

from .massprops import MassProperties, combine, shape_mass_properties

__all__ = ["import_mjcf", "read_mjcf", "MassProperties", "combine", "shape_mass_properties"]


def import_mjcf(source, *, strict: bool = False, name=None, keyframe=None,
                contacts: bool = False):
    """The ModelBuilder of an MJCF (.xml) or URDF (.urdf) file; see :mod:`.mjcf`."""
    from .mjcf import import_mjcf as _import
    return _import(source, strict=strict, name=name, keyframe=keyframe, contacts=contacts)


def read_mjcf(source, *, strict: bool = False, name=None, keyframe=None,
              contacts: bool = False):
    """Like :func:`import_mjcf`, with the weld groups and the list of what was left out."""
    from .mjcf import read_mjcf as _read
    return _read(source, strict=strict, name=name, keyframe=keyframe, contacts=contacts)
