"""The packed layout is declared once: every compiled view equals its declared field."""
import numpy as np

from spatialmbd import models
from spatialmbd.dynamics import layout
from spatialmbd.dynamics.eom import EquationsOfMotion


def test_every_compiled_view_is_its_declared_field():
    system = EquationsOfMotion(models.slider_crank().compile()).system
    F, I, W = system.F, system.I, system.W
    KI, KW = system.penalty_pack()
    packs = {"body_views": (F, I, W), "cons_views": (F, I, W), "schur_views": (F, I, W),
             "unpack_k": (KI, KW)}
    seen = set()
    for fname, _, fields, _, _ in layout.VIEWS:
        views = getattr(layout, fname)(*packs[fname])
        assert views._fields == tuple(f[0] for f in fields)
        all_fields = layout.KFIELDS if fname == "unpack_k" else layout.FIELDS
        bufs = (np.zeros(0), KI, KW) if fname == "unpack_k" else (F, I, W)
        for name, buf, ndim in fields:
            expected = layout.field_view(all_fields, *bufs, name)
            got = getattr(views, name)
            assert got.shape == expected.shape and got.ndim == ndim, name
            assert np.shares_memory(got, expected) and np.array_equal(got, expected), name
            seen.add((fname, name))
    assert len(seen) == len(layout.FIELDS) + len(layout.KFIELDS)
