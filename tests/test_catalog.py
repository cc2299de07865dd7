"""The registries drive everything generated from them: the docs table, the builder's and the
file's keyword checks, and the compiled dispatch -- also for a type defined in user code."""
from pathlib import Path

import numpy as np
import pytest

from spatialmbd import ModelBuilder, ModelError
from spatialmbd.catalog import element_types, markdown
from spatialmbd.constraints import JOINT_TYPES, ConstraintType, Param, register
from spatialmbd.constraints.primitives import kin_sub, point, put_dot, vector
from spatialmbd.io.modelfile import load_model, model_to_dict
from spatialmbd.jit import njit

DOCS = Path(__file__).resolve().parents[1] / "docs" / "elements.md"


def test_docs_table_is_generated_from_the_registry():
    assert DOCS.read_text() == markdown(), \
        "docs/elements.md is stale: run python -m spatialmbd.catalog > docs/elements.md"


def test_every_type_declares_a_summary_and_units():
    for e in element_types():
        assert e.summary.endswith("."), e
        for name, unit, doc in e.parameters:
            assert unit and doc, (e.name, name)


@njit
def _offset_kernel(S, G, k, row, out):
    """x_j^P - x_i^P along u_i equals the parameter 'gap' (a user-written type)."""
    d = kin_sub(point(S, G.bj[k], G.s_j, k, 1), point(S, G.bi[k], G.s_i, k, 0))
    put_dot(vector(S, G.bi[k], G.R_i, k, 0, 0), d, out, row)
    out[0][row] -= G.param[k, 0]


def test_a_type_registered_from_user_code_works_everywhere():
    @register
    class AxialGap(ConstraintType):
        """Axial gap: the joint point of j keeps a given distance along the axis of i."""

        name = "test_axial_gap"
        n_eq = 1
        eq_labels = ("gap",)
        inputs = frozenset({"point", "axis", "point2"})
        parameters = (Param("gap", "m", "distance along the axis", default=0.0),)
        kernel = staticmethod(_offset_kernel)

    assert "test_axial_gap" in JOINT_TYPES                       # live view, no snapshot
    assert any(e.name == "test_axial_gap" for e in element_types())
    b = ModelBuilder("gap", gravity=(0, 0, -9.81))
    b.add_body("slider", 1.0, (0.1, 0.1, 0.1), r=(0, 0, 0))
    b.add_joint("translational", "rail", "ground", "slider", point=(0, 0, 0), axis=(1, 0, 0))
    with pytest.raises(ModelError, match="gap"):
        b.add_joint("test_axial_gap", "g", "ground", "slider", point=(0, 0, 0),
                    axis=(1, 0, 0), point2=(0, 0, 0), gap="wide")
    b.add_joint("test_axial_gap", "g", "ground", "slider", point=(0, 0, 0), axis=(1, 0, 0),
                point2=(0, 0, 0), gap=0.25)
    model = b.compile()
    from spatialmbd.kinematics import solve_positions
    q, _ = solve_positions(model, model.q0.copy())
    assert q[0, 0] == pytest.approx(0.25, abs=1e-10)
    d = model_to_dict(model)
    assert d["joints"][1]["gap"] == 0.25
    again, _ = load_model(d)
    assert np.allclose(again.constraint_groups[1].geometry.param, [[0.25]])
