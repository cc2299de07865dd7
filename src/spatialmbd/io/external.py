"""Files a model file refers to outside its own folder (mesh files, mesh sidecars, time series).

A model file may name any file (``file: ../meshes/arm.stl``, ``file: /data/motion.csv``):
they are allowed, listed by ``spatialmbd info``, and refused before anything is read when the
model is not trusted (``load_model(path, external_files=False)``; ``--no-external-files`` of
run, info, animate and plot). A file is outside the folder when its real path (symbolic links
followed) is not inside the real path of the model file's folder; for a model given as a dict
the folder is the working directory.
"""
from __future__ import annotations

import os
from typing import Optional

__all__ = ["scan", "external_files", "refusal"]


def _render(path: tuple) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _inside(path: str, folder: str) -> bool:
    try:
        return os.path.commonpath([path, folder]) == folder
    except ValueError:                              # other drive (Windows)
        return False


def scan(data, base_dir: Optional[str]) -> list:
    """[(path, real path)] of every ``file:`` value of ``data`` (a model-file dict) that
    lies outside ``base_dir`` (default: the working directory); path: the keys and indices
    leading to it. Nothing is read."""
    folder = os.path.realpath(base_dir or os.getcwd())
    found = []

    def walk(node, path):
        if isinstance(node, dict):
            for key, value in node.items():
                if key == "file" and isinstance(value, str) and value:
                    full = os.path.expanduser(value)
                    if not os.path.isabs(full):
                        full = os.path.join(folder, full)
                    real = os.path.realpath(full)
                    if not _inside(real, folder):
                        found.append((path + (key,), real))
                else:
                    walk(value, path + (key,))
        elif isinstance(node, list):
            for k, value in enumerate(node):
                walk(value, path + (k,))

    walk(data, ())
    return found


def external_files(path) -> list:
    """[(place, real path)] of the files a model file refers to outside its folder."""
    from .source import _read
    data, source, *_ = _read(path)
    base = None if source is None else os.path.dirname(os.path.realpath(str(source)))
    return [(_render(path), real) for path, real in scan(data, base)]


def refusal(real: str, base_dir: Optional[str]) -> str:
    """The problem text of a refused external file."""
    folder = os.path.realpath(base_dir or os.getcwd())
    return (f"{real} is outside the model's folder {folder}; refused because the model is "
            "not trusted (external_files=False, --no-external-files): copy the file next to "
            "the model, or allow external files")
