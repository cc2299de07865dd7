"""Every code name in docs/notation.md resolves: modules, functions, classes, their attributes
and fields, and the source files it names."""
import dataclasses
import importlib
import pkgutil
import re
from pathlib import Path

import spatialmbd

ROOT = Path(__file__).resolve().parents[1]
PKG = Path(spatialmbd.__file__).resolve().parent


def _modules():
    mods = {"spatialmbd": spatialmbd}
    for info in pkgutil.walk_packages(spatialmbd.__path__, "spatialmbd."):
        if "._generated" in info.name or info.name.endswith("__main__"):
            continue
        try:
            mods[info.name] = importlib.import_module(info.name)
        except ImportError:            # an optional extra that is not installed
            pass
    return mods


def _has(obj, attr) -> bool:
    if hasattr(obj, attr):
        return True
    if isinstance(obj, type) and "__getattr__" in vars(obj):      # lazy fields by name
        import inspect
        if f'name == "{attr}"' in inspect.getsource(obj):
            return True
    if dataclasses.is_dataclass(obj) and attr in {f.name for f in dataclasses.fields(obj)}:
        return True
    return attr in getattr(obj, "__annotations__", {}) or \
        attr in getattr(getattr(obj, "__init__", None), "__code__", type("", (), {
            "co_varnames": ()})).co_varnames


def resolve(name: str, mods) -> bool:
    parts = name.split(".")
    # a module path (possibly shortened: rotations.A_from_p, dynamics.eom.MassMatrix)
    for cut in range(len(parts), 0, -1):
        suffix = ".".join(parts[:cut])
        for modname, mod in mods.items():
            if modname == "spatialmbd." + suffix or modname.endswith("." + suffix):
                obj = mod
                if all(_has(obj, p) and (obj := getattr(obj, p, obj)) is not None
                       for p in parts[cut:]):
                    return True
    # a class or function defined in some module, then its attributes
    for mod in mods.values():
        if hasattr(mod, parts[0]):
            obj = getattr(mod, parts[0])
            ok = True
            for p in parts[1:]:
                if not _has(obj, p):
                    ok = False
                    break
                obj = getattr(obj, p, None)
            if ok:
                return True
    return False


def test_every_code_name_in_the_notation_page_resolves():
    text = (ROOT / "docs" / "notation.md").read_text()
    mods = _modules()
    names, files = set(), set()
    for token in re.findall(r"`([^`]+)`", text):
        token = token.strip()
        if re.fullmatch(r"[\w/]+\.py", token):
            files.add(token)
        elif re.fullmatch(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)+", token):
            names.add(token)
    assert len(names) > 20
    missing = sorted(n for n in names if not resolve(n, mods))
    assert not missing, f"docs/notation.md names code that does not exist: {missing}"
    gone = sorted(f for f in files if not (PKG / f).is_file())
    assert not gone, f"docs/notation.md names files that do not exist: {gone}"
