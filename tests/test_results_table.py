"""The tables of a result (reactions, constraint violation, to_dataframe) evaluate the constraint
rows over all outputs at once -- the drivers' laws for every time in one array call, then one
compiled loop -- and must give what the run's per-output evaluation gives (System.evaluate at
each output, the laws set time by time), for every kind of driver and motion law."""
import numpy as np
import pytest

from spatialmbd import models
from spatialmbd.dynamics.system import System
from spatialmbd.motion import (Constant, Harmonic, Polynomial, SmoothStep, TimeSeries,
                               UserFunction)
from spatialmbd.results import Results

SAMPLES = dict(times=[0.0, 0.25, 0.5, 1.0], values=[0.1, -0.2, 0.3, 0.05])


def _every_law_model():
    """The driven slider-crank (angle driver, constant velocity) and further bodies driven by
    every other law kind through angle, translation and coordinate drivers."""
    b = models.slider_crank(driven=True)
    b.add_body("probe", 1.0, (0.1, 0.2, 0.3), r=(1.0, 0.0, 0.0))
    b.add_driver("coordinate", "px", Constant(0.4), body="probe", coordinate="x")
    b.add_driver("coordinate", "py", Polynomial([0.1, -0.3, 0.7, 0.2]), body="probe",
                 coordinate="y")
    b.add_driver("coordinate", "pz", TimeSeries(**SAMPLES), body="probe", coordinate="z")
    b.add_driver("coordinate", "pe1", UserFunction(np.sin, np.cos, lambda t: -np.sin(t)),
                 body="probe", coordinate="e1")
    b.add_body("slide", 1.0, (0.1, 0.1, 0.1), r=(0.0, 1.0, 0.0))
    b.add_joint("translational", "T", "ground", "slide", point=(0, 1, 0), axis=(0, 1, 0))
    b.add_driver("translation", "ts", TimeSeries(**SAMPLES, interpolation="zoh"), joint="T")
    b.add_body("wheel", 1.0, (0.1, 0.1, 0.1), r=(0.0, 0.0, 1.0))
    b.add_joint("cylindrical", "W", "ground", "wheel", point=(0, 0, 1), axis=(0, 0, 1))
    b.add_driver("angle", "wa", SmoothStep(t0=0.2, t1=0.7, f0=0.0, f1=2.5), joint="W")
    b.add_driver("translation", "wt", Harmonic(amplitude=0.2, frequency=7.0, phase=0.3),
                 joint="W")
    return b.compile()


def _results(model, nt, seed=0):
    """A Results at arbitrary states (the rows are evaluated wherever the bodies are) and
    times covering the laws' pieces: before, between and exactly at the samples, after."""
    rng = np.random.default_rng(seed)
    nb = model.nb
    t = np.sort(np.concatenate([np.linspace(-0.1, 1.3, nt - 6), [0.0, 0.2, 0.25, 0.5, 0.7,
                                                                 1.0]]))
    q = rng.normal(size=(nt, nb, 7))
    q[:, :, 3:] /= np.linalg.norm(q[:, :, 3:], axis=2, keepdims=True)
    v = rng.normal(size=(nt, nb, 6))
    return Results(model=model, t=t, q=q, v=v, vdot=np.zeros((nt, nb, 6)),
                   lam=rng.normal(size=(nt, model.n_eq)), work=np.zeros(nt), status="success",
                   message="", counters={}, wall_time=0.0)


def _per_output(res):
    """The rows as the run evaluates them: System.evaluate at each output (laws set per time)."""
    system = System.for_model(res.model)
    nt, m = len(res.t), res.model.n_eq
    D, phi, nu = np.empty((nt, m, 12)), np.empty((nt, m)), np.empty((nt, m))
    for k in range(nt):
        system.evaluate(float(res.t[k]), np.concatenate([res.q[k].ravel(), res.v[k].ravel()]),
                        False)
        D[k], phi[k], nu[k] = system.D, system.phi, system.nu
    return D, phi, nu


def _all_rows(res):
    blocks = list(res._constraint_rows())
    assert blocks[0][0] == 0 and blocks[-1][1] == len(res.t)
    return tuple(np.concatenate([blk[i] for blk in blocks]) for i in (2, 3, 4))


@pytest.mark.parametrize("build", [lambda: models.slider_crank(driven=True).compile(),
                                   _every_law_model], ids=["slider_crank", "every_law"])
def test_rows_over_all_outputs_equal_the_per_output_evaluation(build, monkeypatch):
    model = build()
    res = _results(model, 300)
    monkeypatch.setattr(Results, "_ROWS_PER_BLOCK", 128)      # several blocks, a short last
    new, old = _all_rows(res), _per_output(res)
    for name, a, b in zip(("D", "phi", "nu"), new, old):
        scale = max(1.0, np.abs(b).max())
        np.testing.assert_allclose(a, b, rtol=0, atol=4e-16 * scale, err_msg=name)
    assert np.abs(old[2]).max() > 1.0                          # the drivers' rates are in nu


def test_law_history_equals_the_laws_time_by_time():
    model = _every_law_model()
    res = _results(model, 60)
    system = System.for_model(model)
    table = system.table
    history = table.law_history(res.t)
    for k, t in enumerate(res.t):
        table.set_time(float(t))
        np.testing.assert_allclose(history[k], table.law, rtol=0, atol=1e-15, err_msg=str(t))
    drivers = [sl for sl, _ in table._drivers]
    assert len(drivers) == 3 and np.ptp(history[:, :, 0], axis=0).max() > 1.0


def test_tables_of_a_driven_run_keep_their_physics():
    """Reactions from the new rows still balance the driven slider-crank's D^T lam; the
    violation of an actual run is at the integration tolerance."""
    from spatialmbd.simulate import simulate
    res = simulate(models.slider_crank(driven=True).compile(), 0.5, output_step=0.01)
    viol = res.constraint_violation()
    assert viol["position"].max() < 1e-6 and viol["velocity"].max() < 1e-6
    df = res.to_dataframe()
    assert len(df) == len(res.t) and np.isfinite(df.to_numpy()).all()


@pytest.mark.parametrize("build", [lambda: models.slider_crank(driven=True).compile(),
                                   _every_law_model], ids=["slider_crank", "every_law"])
def test_compiled_reduction_equals_the_rows_reduced_in_numpy(build, monkeypatch):
    """Reactions (D^T lam per instance) and the violation summed as the rows are evaluated
    equal those from the materialised rows (einsum over the blocks)."""
    res = _results(build(), 300, seed=1)
    monkeypatch.setattr(Results, "_ROWS_PER_BLOCK", 128)
    gens, (sq, vel) = res._row_pass(True, True)
    gens_np, (sq_np, vel_np) = res._row_pass(True, True, compiled=False)
    for a, b in zip(gens, gens_np):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-14 * np.abs(b).max())
    np.testing.assert_allclose(sq, sq_np, rtol=1e-14)
    np.testing.assert_allclose(vel, vel_np, rtol=1e-14)
    assert np.abs(vel).min() > 0 and len(gens) == len(res.model.constraint_groups)
    reactions, viol = res._reactions_and_violation()
    assert set(reactions) == set(res.model.joint_names) | set(res.model.driver_names)
    np.testing.assert_array_equal(viol["position"], np.sqrt(sq))


def test_joint_reactions_equal_their_numpy_form():
    """Forces, moments about the joint points and their joint-frame components, compiled, equal
    the same formulas in NumPy (P = A s, m - P x f, T^T x with T = A_i R_i)."""
    from spatialmbd.rotations import A_from_p
    model = _every_law_model()
    res = _results(model, 200, seed=2)
    gens = res._row_pass(True, False)[0]
    reactions = res.reactions()
    nb = model.nb
    A = np.concatenate([A_from_p(res.q[:, :, 3:]), np.broadcast_to(np.eye(3), (200, 1, 3, 3))],
                       axis=1)
    for g, gen in zip(model.constraint_groups, gens):
        Pi = np.einsum("tnij,nj->tni", A[:, g.body_i], g.geometry.s_i)
        Pj = np.einsum("tnij,nj->tni", A[:, g.body_j], g.geometry.s_j)
        Ti = np.einsum("tnij,njk->tnik", A[:, g.body_i], g.geometry.R_i)
        for n, name in enumerate(g.names):
            fi, fj = gen[:, n, :3], gen[:, n, 6:9]
            mi = gen[:, n, 3:6] - np.cross(Pi[:, n], fi)
            mj = gen[:, n, 9:12] - np.cross(Pj[:, n], fj)
            r = reactions[name]
            for got, want in ((r.force_i, fi), (r.moment_i, mi), (r.force_j, fj),
                              (r.moment_j, mj)):
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())
            for got, want in ((r.force_i_joint, fi), (r.moment_i_joint, mi),
                              (r.force_j_joint, fj), (r.moment_j_joint, mj)):
                want = np.einsum("tji,tj->ti", Ti[:, n], want)
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())
    assert nb == 6 and np.abs(reactions["W"].moment_i).max() > 0
