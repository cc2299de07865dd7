"""Layers import one way only: the import-linter contract of pyproject.toml holds, and every
top-level module of the package is placed in it."""
import pkgutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import spatialmbd

ROOT = Path(__file__).resolve().parents[1]


def contract_layers():
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return data["tool"]["importlinter"]["contracts"][0]["layers"]


def test_every_module_has_a_layer():
    listed = {m.strip() for layer in contract_layers() for m in layer.split("|")}
    modules = {f"spatialmbd.{m.name}" for m in pkgutil.iter_modules(spatialmbd.__path__)
               if m.name != "__main__"}
    assert modules <= listed, f"place these in the layer contract: {sorted(modules - listed)}"


def test_import_layers_hold():
    pytest.importorskip("importlinter")
    out = subprocess.run([sys.executable, "-c", "from importlinter.cli import lint_imports_command;"
                          "lint_imports_command()"], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
