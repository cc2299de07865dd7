"""Method "recursive" (dynamics.recursive): joint coordinates of open trees, articulated-body
accelerations, against the body-coordinate methods and closed forms."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from spatialmbd import ModelBuilder, models
from spatialmbd.dynamics import get_method
from spatialmbd.dynamics.eom import EquationsOfMotion
from spatialmbd.dynamics.recursive import (JointTree, body_rows, joint_kinematics,
                                           joint_right_hand_side, rhs_joint)
from spatialmbd.errors import ModelError
from spatialmbd.simulate import simulate

def _floating():
    """A free body carrying a pendulum on a spherical joint and a revolute link: a floating
    base (free joint) with a spherical and a revolute child."""
    b = ModelBuilder("floating", gravity=(0.0, 0.0, -9.81))
    b.add_body("base", 4.0, (0.2, 0.3, 0.4), r=(0, 0, 1), omega=(0.3, -0.2, 1.0),
               rdot=(0.5, 0, 2.0))
    b.add_body("ball", 1.0, (0.02, 0.03, 0.01), r=(0.5, 0, 0.6), omega=(1.0, 0.5, -0.3))
    b.add_body("arm", 0.5, (0.001, 0.04, 0.04), r=(-0.4, 0, 1.0))
    b.add_joint("spherical", "hip", "base", "ball", point=(0.3, 0, 0.8))
    b.add_joint("revolute", "elbow", "base", "arm", point=(-0.2, 0, 1.0), axis=(0, 1, 0))
    return b


TREES = {
    "pendulum": models.pendulum_ch15,
    "revolute chain": lambda: models.chain(5, "revolute"),
    "spherical chain": lambda: models.chain(4, "spherical"),
    "flyball governor (revolute, translational, springs)": models.flyball_governor,
    "robot arm (joint springs and dampers)": models.robot_arm,
    "double pendulum": models.double_pendulum,
    "heavy top (spherical)": models.heavy_top,
    "floating base (free, spherical, revolute)": _floating,
}


@pytest.mark.parametrize("name", list(TREES))
def test_joint_accelerations_equal_the_standard_method(name):
    """At random joint coordinates and rates: the bodies placed by the joints satisfy every
    constraint (Phi, D v - nu at round-off), and the articulated-body accelerations are the
    standard method's (12.3) at that body state."""
    model = TREES[name]().compile()
    tree = JointTree(model, model.q0, model.v0)
    nb, nq, nv = model.nb, tree.nq, tree.nv
    rng = np.random.default_rng(11)
    x = np.concatenate([tree.x0[:nq] + 0.7 * rng.normal(size=nq), rng.normal(size=nv), [0.0]])
    eom = EquationsOfMotion(model)
    meth = get_method("standard")
    meth.setup(eom)
    s = eom.system
    y = np.zeros(13 * nb + 1)
    xd = np.empty_like(x)
    assert rhs_joint(0.2, x, xd, y, tree.arrays(), s.F, s.I, s.W)
    vdot = s.fields(s.W, "vdot").copy()
    ev = eom.evaluate(0.2, y[:7 * nb].reshape(nb, 7), y[7 * nb:13 * nb])
    assert np.abs(ev.cv.phi).max() < 1e-12
    assert np.abs(ev.cv.D @ y[7 * nb:13 * nb] - ev.cv.nu).max() < 1e-12
    ref = meth.accelerations(ev, 0.2).vdot
    assert np.abs(vdot - ref).max() <= 1e-9 * max(1.0, np.abs(ref).max())
    # zdot: the rates, and 1/2 G^T omega for the Euler parameters (whose length the
    # kinematics ignore: the rates are tangent to the unit sphere)
    for k in range(tree.n):
        oq, ov = tree.qo[k], tree.vo[k]
        if tree.kind[k] in (0, 1):
            assert xd[oq] == x[nq + ov]
        else:
            o = oq + (3 if tree.kind[k] == 3 else 0)
            pq = x[o:o + 4] / np.linalg.norm(x[o:o + 4])
            assert abs(pq @ xd[o:o + 4]) < 1e-12


def test_initial_state_and_rates():
    model = models.flyball_governor().compile()
    tree = JointTree(model, model.q0, model.v0)
    assert tree.check_initial(model.q0) < 1e-12
    y = np.zeros(13 * model.nb)
    joint_kinematics(tree.x0[:tree.nq], tree.x0[tree.nq:-1], tree.arrays(), model.nb, y)
    assert np.allclose(y[7 * model.nb:], np.asarray(model.v0).ravel(), atol=1e-12)
    names = dict(zip(tree.names, tree.x0[tree.nq:-1]))
    assert names["shaft_pivot"] == pytest.approx(2 * np.pi)      # the spin about z
    assert names["slider_guide"] == pytest.approx(0.0, abs=1e-12)
    f, x0 = joint_right_hand_side(model)
    assert f(0.0, x0).shape == x0.shape


@pytest.mark.parametrize("name", ["revolute chain", "flyball governor (revolute, "
                                  "translational, springs)", "heavy top (spherical)",
                                  "floating base (free, spherical, revolute)"])
def test_runs_agree_with_the_projection_method(name):
    model = TREES[name]().compile()
    kw = dict(t_end=0.5, rtol=1e-10, atol=1e-12, output_step=0.05)
    a = simulate(model, method="recursive", **kw)
    b = simulate(model, method="projection", **kw)
    assert a.status == b.status == "success"
    assert a.settings["method"] == "recursive"
    assert np.abs(a.q - b.q).max() < 1e-8
    assert np.abs(a.v - b.v).max() < 1e-7
    assert np.abs(a.lam - b.lam).max() < 1e-6 * np.abs(b.lam).max()
    viol = a.constraint_violation()
    assert viol["position"].max() < 1e-13 and viol["velocity"].max() < 1e-12   # no drift
    assert np.abs(a.energy()["error"]).max() < 1e-7 * np.abs(a.energy()["kinetic"]).max()


@pytest.mark.parametrize("name", ["revolute chain", "floating base (free, spherical, "
                                  "revolute)"])
def test_dop853_runs_agree_with_the_projection_method_and_keep_max_step(name):
    """The compiled driver with the DOP853 pair: the projection method's result (the Python
    stepper's arithmetic there), fewer evaluations than rk45 at rtol 1e-10, and max_step
    held on every step (not only the first)."""
    model = TREES[name]().compile()
    kw = dict(t_end=0.5, rtol=1e-10, atol=1e-12, output_step=0.05)
    a = simulate(model, method="recursive", integrator="dop853", **kw)
    b = simulate(model, method="projection", integrator="dop853", **kw)
    c = simulate(model, method="recursive", **kw)
    assert a.status == b.status == "success"
    assert a.settings["integrator"] == "dop853"
    assert np.abs(a.q - b.q).max() < 1e-8 and np.abs(a.v - b.v).max() < 1e-7
    assert a.counters["nfev"] < 0.7 * c.counters["nfev"], (a.counters, c.counters)
    auto = simulate(model, method="auto", integrator="dop853", **kw)
    assert auto.settings["method"] == "recursive"
    assert np.array_equal(auto.q, a.q)
    short = simulate(model, method="recursive", integrator="dop853",
                     integrator_options=dict(max_step=0.01), **kw)
    assert short.counters["steps"] >= 50


@pytest.mark.parametrize("integrator", ["rk45", "dop853"])
def test_joint_coordinates_take_the_python_drivers_steps(integrator):
    """The joint coordinates through the one compiled driver take the steps of the Python
    driver (its stepper, PIController and starting step) on the same right-hand side: a
    revolute chain has no Euler parameters to renormalise, so both integrate the same ODE."""
    from spatialmbd.integrators import ODEProblem, get_integrator
    model = models.chain(3, "revolute").compile()
    kw = dict(rtol=1e-9, atol=1e-11)
    t_eval = np.linspace(0.0, 1.0, 21)
    a = simulate(model, 1.0, method="recursive", integrator=integrator, output_step=0.05, **kw)
    f, x0 = joint_right_hand_side(model)
    b = get_integrator(integrator, **kw).integrate(ODEProblem(f), 0.0, x0, t_eval)
    assert a.status == "success" and b.success
    for key in ("nfev", "steps", "rejected"):
        assert a.counters[key] == getattr(b.counters, key), key
    tree = JointTree(model, model.q0, model.v0)
    y = np.empty((t_eval.size, 13 * model.nb + 1))
    body_rows(np.asarray(b.y), tree.arrays(), model.nb, tree.nq, y)
    assert np.abs(a.q.reshape(t_eval.size, -1) - y[:, :7 * model.nb]).max() <= 1e-12


def test_driver_error_follows_the_tolerance():
    """The compiled Dormand-Prince driver of the joint coordinates: the final error against a
    1e-12 run falls with the tolerance, about in proportion (the pendulum reaction against
    its closed form, in joint coordinates too, is in test_dynamics.py)."""
    model = models.chain(3, "revolute").compile()
    ref = simulate(model, 1.0, method="recursive", rtol=1e-12, atol=1e-14, output_step=1.0)
    errors = []
    for rtol in (1e-5, 1e-7, 1e-9):
        res = simulate(model, 1.0, method="recursive", rtol=rtol, atol=rtol * 1e-2,
                       output_step=1.0)
        errors.append(np.abs(res.q[-1] - ref.q[-1]).max())
        assert errors[-1] < 100 * rtol
    assert errors[0] > 10 * errors[1] > 100 * errors[2]


def test_what_it_cannot_represent_is_refused_by_name():
    b = ModelBuilder("cylinder")
    b.add_body("sleeve", 1.0, (0.1, 0.1, 0.1))
    b.add_joint("cylindrical", "guide", "ground", "sleeve", point=(0, 0, 0), axis=(0, 0, 1))
    with pytest.raises(ModelError, match="cylindrical guide cannot be written"):
        simulate(b.compile(), 0.1, method="recursive")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                       # redundant rows of these two
        with pytest.raises(ModelError, match="closes a loop"):
            simulate(models.bricard().compile(), 0.1, method="recursive")
        with pytest.raises(ModelError, match="drivers"):
            simulate(models.slider_crank(driven=True).compile(), 0.1, method="recursive")
    chain = models.chain(2, "revolute").compile()
    with pytest.raises(ModelError, match="rk45"):
        simulate(chain, 0.1, method="recursive", integrator="rk4", step=1e-3)
    with pytest.raises(ModelError, match="events"):
        simulate(chain, 0.1, method="recursive", events=[lambda t, s: s.r[0, 2]])


def test_progress_and_streamed_chunks(tmp_path):
    from spatialmbd.io.stream import simulate_to_file
    model = models.chain(3, "revolute").compile()
    seen = []
    full = simulate(model, 0.3, method="recursive", output_step=0.01, progress=seen.append)
    assert seen and seen[-1] == pytest.approx(0.3)
    last, written = simulate_to_file(model, 0.3, tmp_path / "run.csv", chunk_rows=8,
                                     method="recursive", output_step=0.01)
    assert last.status == "success" and written[tmp_path / "run.csv"][0] == full.t.size
    assert np.array_equal(last.q, full.q[-last.t.size:])


def test_auto_takes_the_recursive_method_for_trees_and_projection_otherwise():
    chain = models.chain(3, "revolute").compile()
    assert simulate(chain, 0.1).settings["method"] == "recursive"
    assert simulate(chain, 0.1, integrator="rk4", step=1e-3).settings["method"] == "projection"
    assert simulate(chain, 0.1, events=[lambda t, s: 1.0]).settings["method"] == "projection"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert simulate(models.bricard().compile(), 0.1).settings["method"] == "projection"
    # an unassembled start without the correction: the projection method projects it
    q = np.array(chain.q0, dtype=float).reshape(chain.nb, 7)
    q[1, 2] += 1e-3
    res = simulate(chain, 0.1, q0=q, correct_initial=False)
    assert res.settings["method"] == "projection" and res.status == "success"
    with pytest.raises(ModelError, match="do not satisfy the joints"):
        simulate(chain, 0.1, q0=q, correct_initial=False, method="recursive")


def test_auto_takes_trees_with_spherical_joints_but_not_bare_free_bodies():
    """Spherical joints too (faster than projection since their closed-form 3 x 3 path); a
    model of free bodies without any joint keeps the projection method (nothing to save)."""
    assert simulate(models.chain(2, "spherical").compile(), 0.05).settings["method"] == \
        "recursive"
    assert simulate(_floating().compile(), 0.05).settings["method"] == "recursive"
    b = ModelBuilder("free bodies", gravity=(0.0, 0.0, -9.81))
    b.add_body("a", 1.0, (0.1, 0.2, 0.3), omega=(1.0, 0.0, 0.5))
    b.add_body("b", 2.0, (0.2, 0.2, 0.3), r=(1.0, 0, 0))
    assert simulate(b.compile(), 0.05).settings["method"] == "projection"
