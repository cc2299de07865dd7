"""Robust defaults on hard but valid mechanisms (issue 16): redundant rows in the augmented
Lagrangian, its adaptation before failing, singular positions (diagnosis, start at dead
centre). The timing side lives in bench/robustness.py."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from spatialmbd import ModelBuilder, models
from spatialmbd.dynamics import get_method
from spatialmbd.simulate import RedundantConstraintsWarning, simulate


def max_violation(model, res, k=-1):
    q = res.q[k]
    return float(np.abs(model.assembler.evaluate(q, None, res.t[k]).phi).max())


def test_augmented_lagrangian_leaves_redundant_rows_out():
    """Bricard: D's redundant direction has a tiny non-zero singular value, along which
    M + alpha D^T D barely contracts; with the redundant rows left out the defaults converge
    (before: 'did not converge in 50' at t ~ 0.05 s)."""
    model = models.bricard().compile()
    meth = get_method("augmented_lagrangian")
    with pytest.warns(RedundantConstraintsWarning):
        res = simulate(model, 0.2, method=meth, integrator="rk45", output_step=0.05)
    assert res.status == "success", res.message
    assert meth.adaptations == []                       # the defaults sufficed
    assert max_violation(model, res) < 1e-6
    # same motion as the standard method (which drops the same rows)
    with pytest.warns(RedundantConstraintsWarning):
        ref = simulate(model, 0.2, method="standard", integrator="rk45", rtol=1e-9, atol=1e-11,
                       output_step=0.05)
    np.testing.assert_allclose(res.q, ref.q, atol=1e-5)


def mass_ratio_chain(masses, L=0.5):
    b = ModelBuilder("mass_ratio_chain", gravity=(0.0, 0.0, -9.81))
    prev, x = "ground", 0.0
    for k, m in enumerate(masses):
        b.add_body(f"l{k}", m, (1e-4 * m, m * L * L / 12, m * L * L / 12), r=(x + L / 2, 0, 0))
        b.add_joint("revolute", f"j{k}", prev, f"l{k}", point=(x, 0, 0), axis=(0, 1, 0))
        prev, x = f"l{k}", x + L
    return b.compile()


def test_augmented_lagrangian_adapts_before_failing():
    """Masses 1e3 / 1e-3 alternating: with alpha = 1e7 the round-off floor of (12.17) stays
    above the tolerance; the method lowers alpha, continues, and says so."""
    model = mass_ratio_chain([1e3, 1e-3, 1e3, 1e-3])
    meth = get_method("augmented_lagrangian")
    res = simulate(model, 0.1, method=meth, integrator="rk45", output_step=0.05)
    assert res.status == "success", res.message
    assert len(meth.adaptations) >= 1 and meth.alpha != 1e7
    assert any("continued with alpha" in m for m in res.messages)
    assert res.settings["method_options"]["alpha"] == meth.alpha
    ref = simulate(model, 0.1, method="standard", integrator="rk45", rtol=1e-10, atol=1e-12,
                   output_step=0.05)
    np.testing.assert_allclose(res.q, ref.q, atol=1e-6)


def test_augmented_lagrangian_failure_names_the_settings():
    model = mass_ratio_chain([1e3, 1e-3, 1e3, 1e-3])
    res = simulate(model, 0.1, method="augmented_lagrangian", integrator="rk45",
                   method_options=dict(max_iterations=1, tolerance=1e-15, floor=1e-300))
    assert res.status == "failed"
    for text in ("alpha (now", "max_iterations (now 1)", "tolerance (now", "nor with"):
        assert text in res.message


def flat_time(n):
    """Closed form of models.n_four_bar: I phi'' = K sin phi, phi(0) = 0, phi'(0) = -1; the
    time when phi = -pi/2 (the cranks horizontal: the flat, singular position)."""
    I, K = (n + 1) / 3 + n, 9.81 * ((n + 1) / 2 + n)

    def flat(t, y):
        return y[0] + math.pi / 2
    flat.terminal = True
    sol = solve_ivp(lambda t, y: [y[1], K / I * math.sin(y[0])], (0.0, 2.0), [0.0, -1.0],
                    events=flat, rtol=1e-12, atol=1e-12)
    return float(sol.t_events[0][0])


def test_singular_position_failure_is_diagnosed():
    """A driver that tears the mechanism: the slider of a slider-crank pushed at constant speed
    past the dead centre of its crank (where the crank would need an infinite rate). The run
    stops there with its outputs up to the failure, and the message names the time, the rank
    deficiency, the joints and the driver, and what to change. (This test used the N-four-bar
    at rk45 rtol 1e-10, which stalled at its flat position; it passes it now -- B0 within
    6.8e-6 m of the exact path after 1 s -- so it no longer serves as a failing case.) At
    rtol 1e-9 (tests/dynamics/test_fused.py's run): the same stall at t = 0.18032 s and the
    same diagnosis as at 1e-10, whose crawl into the dead centre took 4 times as many steps."""
    from spatialmbd.motion import ConstantVelocity
    b = models.slider_crank(driven=False)
    b.add_driver("translation", "push", ConstantVelocity(rate=0.5), joint="D")
    model = b.compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        res = simulate(model, 1.0, method="projection", integrator="rk45", rtol=1e-9,
                       atol=1e-11, output_step=0.01)
    assert res.status == "failed"
    t_fail = float(res.message.split("t = ")[1].split(" s")[0])
    assert 0.17 < t_fail < 0.19 and res.t[-1] <= t_fail < res.t[-1] + 0.01
    msg = res.message
    # one diagnosis for every failing run (spatialmbd.guards.singular_diagnosis)
    assert "near rank deficiency 1" in msg and "rank 18 at the start" in msg
    assert "joint(s) A, B, C, D, push" in msg
    assert "The driver(s) push take part in the dependency" in msg and "penalty" not in msg
    t_diag = float(msg.split("singular position near t = ")[1].split(" s")[0])
    assert abs(t_diag - t_fail) < 1e-3


def test_n_four_bar_passes_its_first_flat_position_at_tight_tolerance():
    """The N-four-bar with projection and rk45 at rtol 1e-10 passes the flat position of
    t = 0.714 s on the parallelogram branch (it used to stall there)."""
    model = models.n_four_bar(2).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RedundantConstraintsWarning)
        res = simulate(model, 1.0, method="projection", integrator="rk45", rtol=1e-10,
                       atol=1e-12, output_step=0.01)
    assert res.status == "success" and res.t[-1] == 1.0, res.message
    assert flat_time(2) < 1.0
    k = model.body_index("crank0")
    phi = np.unwrap(2 * np.arctan2(res.q[:, k, 6], res.q[:, k, 3]))
    n, a = 2, 0.02                                  # the exact 1-DoF motion of the branch
    inertia = (n + 1) * ((1 + a * a) / 12 + 0.25) + n
    K = 9.81 * ((n + 1) / 2 + n)
    exact = solve_ivp(lambda t, y: [y[1], K / inertia * math.sin(y[0])], (0.0, 1.0),
                      [0.0, -1.0], rtol=1e-12, atol=1e-12)
    assert phi[-1] < -np.pi / 2 and abs(phi[-1] - exact.y[0, -1]) < 1e-5


def dead_centre_four_bar(n=1):
    """models.n_four_bar_flat: the N-four-bar started in its flat (singular) position."""
    return models.n_four_bar_flat(n).compile()


@pytest.mark.parametrize("integrator", ["bdf4", "rk45"])
def test_start_at_dead_centre(integrator):
    """Rows dependent only at the start are kept (the redundancy is analysed a moment along
    the motion), so the constraints hold after the linkage leaves the flat position; the
    projection falls back to least squares where its Newton iteration stalls."""
    model = dead_centre_four_bar(1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = simulate(model, 0.1, method="projection", integrator=integrator,
                       output_step=0.05)
    assert res.status == "success", res.message
    assert max_violation(model, res) < 1e-8
    assert res.counters["steps"] < 200
    # the structural redundancy of a planar loop of spatial revolute joints: 3 rows
    texts = [str(w.message) for w in caught if issubclass(w.category,
                                                          RedundantConstraintsWarning)]
    assert texts and texts[0].startswith("3 redundant")
    # the cranks follow the parallelogram branch: crank angles equal
    p0, p1 = res.q[-1, model.body_index("crank0"), 3:], res.q[-1, model.body_index("crank1"), 3:]
    assert abs(2 * math.atan2(p0[3], p0[0]) - 2 * math.atan2(p1[3], p1[0])) < 1e-6
