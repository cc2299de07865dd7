"""The packed layout is declared once: every compiled view equals its declared field."""
import numpy as np

from spatialmbd import models
from spatialmbd.dynamics import layout
from spatialmbd.dynamics.eom import EquationsOfMotion


def test_every_compiled_view_is_its_declared_field():
    system = EquationsOfMotion(models.flyball_governor().compile()).system   # forces too
    F, I, W = system.F, system.I, system.W
    KI, KW = system.penalty_pack()
    packs = {"unpack_k": (KI, KW)}
    seen = set()
    for fname, _, fields, _, _ in layout.VIEWS:
        views = getattr(layout, fname)(*packs.get(fname, (F, I, W)))
        assert views._fields == tuple(f[0] for f in fields)
        all_fields = layout.KFIELDS if fname == "unpack_k" else layout.FIELDS
        bufs = (np.zeros(0), KI, KW) if fname == "unpack_k" else (F, I, W)
        for name, buf, ndim in fields:
            expected = layout.field_view(all_fields, *bufs, name)
            got = getattr(views, name)
            assert got.shape == expected.shape and got.ndim == ndim, name
            assert np.array_equal(got, expected), name
            assert got.size == 0 or np.shares_memory(got, expected), name
            seen.add((fname, name))
    assert len(seen) == len(layout.FIELDS) + len(layout.KFIELDS)
    assert layout.field_view(layout.FIELDS, F, I, W, "fkind").size == 2     # two springs


def test_the_compile_cache_key_covers_subpackages():
    """The cache directory is named after a hash of every hot-path source, subpackages
    included: an edit to forces/contact/ must compile afresh, not load stale machine code."""
    import os
    from spatialmbd import jit
    files = set(jit.hot_path_files())
    assert os.path.join("forces", "contact", "element.py") in files
    assert os.path.join("constraints", "point_curve.py") in files
    pkg = os.path.dirname(jit.__file__)
    for entry in ("constraints", "forces", "dynamics", "integrators"):
        for root, _, names in os.walk(os.path.join(pkg, entry)):
            for f in names:
                if f.endswith(".py"):
                    assert os.path.relpath(os.path.join(root, f), pkg) in files


def test_the_compile_cache_key_covers_every_compiled_module():
    """The cache locator stamps every compiled function of the package with the hash of the
    hot-path sources only: a module that compiles a function (``njit``) but is not listed
    would load stale machine code after an edit (design/adjoint_kernels.py, rank.py, ... were
    missing)."""
    import os
    import re
    from spatialmbd import jit
    files = set(jit.hot_path_files())
    pkg = os.path.dirname(jit.__file__)
    compiled = set()
    for root, dirs, names in os.walk(pkg):
        dirs[:] = [d for d in dirs if d != "__pycache__"]     # the generated dispatches
        for f in names:
            if f.endswith(".py"):
                with open(os.path.join(root, f), encoding="utf-8") as fh:
                    if re.search(r"\bnjit\b", fh.read()):
                        compiled.add(os.path.relpath(os.path.join(root, f), pkg))
    assert os.path.join("design", "adjoint_kernels.py") in compiled   # the scan finds them
    assert compiled - files == set()


def test_cache_is_warm_looks_where_the_cache_will_be(tmp_path, monkeypatch):
    """With NUMBA_CACHE_DIR set, the compiled code goes there: an empty one is a cold cache
    (the first run says it is compiling) even when the package's own cache is warm."""
    from spatialmbd import jit
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not jit.cache_is_warm()
    root = tmp_path / f"spatialmbd-{jit._stamp()}"
    root.mkdir()
    (root / "system.stage_state-1.py311.nbi").write_bytes(b"")
    assert not jit.cache_is_warm()          # some kernels are not the whole hot path
    assert jit.cache_is_warm(complete=False)  # but the core is there (no compile notice)
    jit.mark_warm()                         # what a completed `spatialmbd warmup` leaves
    assert (root / jit.COMPLETE).exists() and jit.cache_is_warm()
