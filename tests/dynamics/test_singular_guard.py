"""The singular-position guard of the methods that follow their drift (standard, Baumgarte,
penalty, augmented Lagrangian; dynamics/singular_guard.py) on the IFToMM N-four-bar, whose flat
positions are bifurcations of the parallelogram and the crossed branch.

Before the guard these methods went on through the flat positions and mostly ended on the
crossed branch, 0.4-1.9 m off the exact path, reporting success (bench/results/singular.md).
Now a run either ends on the parallelogram branch within 1e-4 m of the exact path, or stops
with the diagnosis before it has left it -- on every kernel, since the guard's decision is
compiled arithmetic without BLAS."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from spatialmbd import guards, models
from spatialmbd.dynamics.singular_guard import GUARD_FACTOR, singular_ratio
from spatialmbd.dynamics.system import System
from spatialmbd.errors import ModelError
from spatialmbd.kinematics import mobility
from spatialmbd.simulate import simulate

from test_singular_passage import branch_error  # noqa: E402 (the closed-form branch)

STOP = "stopped at a singular position"


def b0_error(model, res, n):
    """Largest distance of crank 1's tip from the exact parallelogram-branch path (m)."""
    return branch_error(model, res, n)[0]


#: the augmented Lagrangian follows its drift only without its projection (project: false);
#: with it (its default) it passes the flat positions as the projection method does
#: (test_singular_passage)
DRIFT_OPTIONS = {"augmented_lagrangian": {"project": False}}


def run(model, method, integrator, rtol, **kw):
    kw.setdefault("method_options", DRIFT_OPTIONS.get(method))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(model, 10.0, method=method, integrator=integrator, rtol=rtol,
                        atol=1e-2 * rtol, output_step=0.05, **kw)


@pytest.mark.parametrize("method", ["standard", "baumgarte", "penalty", "augmented_lagrangian"])
@pytest.mark.parametrize("integrator", ["rk45", "dop853"])
def test_drift_methods_never_end_on_the_crossed_branch(method, integrator):
    """N = 2 through its flat positions (every 0.5 s or so), rtol 1e-6, 1e-8, 1e-10: each run
    passes (success, within 1e-4 m of the exact path all along the 10 s) or stops with the
    diagnosis still on the parallelogram branch (within 1e-3 m) -- never success elsewhere."""
    model = models.n_four_bar(2).compile()
    for rtol in (1e-6, 1e-8, 1e-10):
        res = run(model, method, integrator, rtol)
        err = b0_error(model, res, 2)
        if res.status == "success":
            assert res.t[-1] == 10.0 and err < 1e-4, (rtol, err)
        else:
            assert res.status == "failed" and STOP in res.message, (rtol, res.message)
            assert "joint(s) A0, A1, B0, B1" in res.message, res.message
            assert err < 1e-3, (rtol, res.t[-1], err)


def test_without_the_guard_the_penalty_method_ends_on_the_crossed_branch():
    """What the guard prevents (singular='continue', the behaviour before it): the penalty
    method's compliance (max |Phi| ~ 1e-6 m) is far above the gap of the flat positions, so it
    turns onto the crossed branch and reports success 1.6 m off the exact path."""
    model = models.n_four_bar(2).compile()
    res = run(model, "penalty", "rk45", 1e-8, method_options={"singular": "continue"})
    assert res.status == "success" and b0_error(model, res, 2) > 0.5


def test_the_compiled_and_python_drivers_stop_at_the_same_step():
    """The whole-run compiled driver (dynamics/fused.py) and the Python driver (taken with a
    wall-time budget) apply the same rule at the same accepted steps."""
    model = models.n_four_bar(2).compile()
    fused = run(model, "standard", "rk45", 1e-6)
    python = run(model, "standard", "rk45", 1e-6, max_wall_time=600.0)
    assert STOP in fused.message and STOP in python.message
    assert fused.counters["steps"] == python.counters["steps"]
    t_fused = float(fused.message.split("s:")[0].split("=")[1])
    t_python = float(python.message.split("s:")[0].split("=")[1])
    assert t_fused == pytest.approx(t_python, rel=1e-12, abs=0.0)


def test_eight_loops_stop_or_pass_on_the_branch():
    """N = 8 (the loops all flat at once), rk45 at rtol 1e-8, every drift method."""
    model = models.n_four_bar(8).compile()
    for method in ("standard", "baumgarte", "penalty", "augmented_lagrangian"):
        res = run(model, method, "rk45", 1e-8)
        err = b0_error(model, res, 8)
        assert (res.status == "success" and err < 1e-4) or (
            STOP in res.message and err < 1e-3), (method, res.status, res.t[-1], err)


def test_singular_option_is_checked():
    with pytest.raises(ModelError, match="singular: expected one of stop, continue"):
        simulate(models.n_four_bar(2).compile(), 0.1, method="standard",
                 method_options={"singular": "halt"})


def test_ratio_bounds_the_scaled_singular_values():
    """singular_ratio against the SVD of D with the rotation columns scaled by 1 / L and
    every row then scaled to unit length (sigma_max >= 1 then, which the guard takes for it):
    never below the true sigma_min (the inverse iteration bounds it from above), and near a
    flat position -- where the guard decides, and where the two loops' small singular values
    nearly coincide -- between the smallest and the second smallest."""
    model = models.n_four_bar(2).compile()
    mob = mobility(model)
    keep = np.setdiff1d(np.arange(model.n_eq), [r[0] for r in mob.redundant])
    system = System.for_model(model, keep)
    length = guards.guard_length(model, np.asarray(model.q0, float))
    res = run(model, "projection", "rk45", 1e-10)
    scale = np.tile(np.r_[np.ones(3), np.full(3, 1.0 / length)], model.nb)
    checked_near = 0
    for j in range(0, 60):
        y = np.concatenate([res.q[j].ravel(), res.v[j].ravel(), [0.0]])
        r, phi = singular_ratio(res.t[j], y, system.F, system.I, system.W, length)
        D = model.assembler.evaluate(res.q[j], None, res.t[j]).D[keep] * scale
        D /= np.linalg.norm(D, axis=1)[:, None]
        s = np.linalg.svd(D, compute_uv=False)
        assert s[0] >= 1.0 - 1e-12
        true = s[-1]
        assert r >= true * (1 - 1e-9), (res.t[j], r, true)
        if true < 0.01:
            assert r <= s[-2] * (1 + 1e-6), (res.t[j], r, true, s[-2])
            checked_near += 1
        assert phi < 1e-8
    assert checked_near >= 1
    assert GUARD_FACTOR == 1.0


def rssr_parallelogram(crank_mass=1.0):
    """A spatial parallelogram four-bar without redundant equations (RSSR: revolute cranks,
    spherical joints at the coupler, which may spin about its own axis: 2 DoF), started as the
    IFToMM mechanism with one loop: its flat positions are bifurcations of the parallelogram
    and the crossed branch, as in the N-four-bar."""
    from spatialmbd.model import ModelBuilder
    from spatialmbd.models.iftomm import G_TEXT, _slender_inertia
    b = ModelBuilder("rssr_parallelogram", gravity=(0.0, -G_TEXT, 0.0))
    for k in range(2):
        b.add_body(f"crank{k}", crank_mass, _slender_inertia(crank_mass, 1.0, 1),
                   r=(k, 0.5, 0.0), omega=(0.0, 0.0, -1.0), rdot=(0.5, 0.0, 0.0))
        b.add_joint("revolute", f"O{k}", "ground", f"crank{k}", point=(k, 0, 0),
                    axis=(0, 0, 1))
    b.add_body("coupler", 1.0, _slender_inertia(1.0, 1.0, 0), r=(0.5, 1.0, 0.0),
               rdot=(1.0, 0.0, 0.0))
    b.add_joint("spherical", "A", "crank0", "coupler", point=(0, 1, 0))
    b.add_joint("spherical", "B", "coupler", "crank1", point=(1, 1, 0))
    return b


def test_batch_members_are_guarded_as_separate_runs():
    """The compiled batch (sweep/batch) runs the same guard per member (each member its own
    state of it): on the RSSR parallelogram every standard-method member stops where the
    separate run stops, with the guard's status text; the projection method passes."""
    from spatialmbd.io import Analysis
    from spatialmbd.sweep.batch import simulate_batch
    members = [rssr_parallelogram(mass).compile() for mass in (1.0, 1.2)]
    assert not mobility(members[0]).redundant
    an = Analysis(t_end=3.0, output_step=0.05, integrator="rk45", method="standard",
                  rtol=1e-8, atol=1e-10)
    out = simulate_batch(members, an)
    for model, member in zip(members, out):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = an.run(model)
        assert ref.status == member.status == "failed"
        assert STOP in ref.message and STOP in member.message
        assert 0.5 < ref.t[-1] < 3.0
        assert member.message.split(":")[0] == ref.message.split(":")[0]   # "t = ... s"
        k = len(ref.t)                    # a batch member keeps every output row: those
        np.testing.assert_allclose(member.q[:k], ref.q, rtol=0, atol=1e-12)   # reached
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        passed = simulate(members[0], 3.0, method="projection", rtol=1e-8, atol=1e-10)
    assert passed.status == "success"
