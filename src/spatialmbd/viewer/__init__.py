"""Offline 3-D animation of multibody motions as one self-contained HTML file.

>>> from spatialmbd.viewer import write_animation_html, default_shapes
>>> write_animation_html("out.html", scene)  # doctest: +SKIP

See :mod:`spatialmbd.viewer.animation` for the scene dictionary.
"""
from __future__ import annotations

from .animation import animation_html, decode_float32, default_shapes, write_animation_html

__all__ = ["animation_html", "write_animation_html", "default_shapes", "decode_float32"]
