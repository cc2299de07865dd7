"""Restart events of the driver: the accepted step ends at the located crossing, the action
changes the right-hand side from there, the stepper restarts (integrators/driver.py)."""
import numpy as np
import pytest

from spatialmbd.integrators import Event, ODEProblem, get_integrator


def switched(name, **options):
    """y' = s, s = 1 until y crosses 0 (from y0 = -0.5 at t = 0.5), then s = 3 (set by the
    action): exactly y = t - 0.5, then 3 (t - 0.5)."""
    slope = [1.0]
    calls = []

    def action(t, y):
        calls.append((t, y[0]))
        slope[0] = 3.0
    ev = Event(lambda t, y: y[0], direction=1.0, name="switch", restart=action)
    problem = ODEProblem(rhs=lambda t, y: np.array([slope[0]]))
    t_eval = np.linspace(0.0, 1.0, 11)
    res = get_integrator(name, **options).integrate(problem, 0.0, np.array([-0.5]), t_eval,
                                                    events=[ev], event_tol=1e-13)
    return res, calls


@pytest.mark.parametrize("name, options", [("rk45", dict(rtol=1e-8, atol=1e-10)),
                                           ("rk4", dict(step=0.3)), ("abm4", dict(step=0.03)),
                                           ("bdf4", dict(step=0.03))])
def test_restart_lands_on_the_crossing(name, options):
    res, calls = switched(name, **options)
    assert res.status == "success"
    assert len(calls) == 1                            # fired once, not again after the restart
    t_switch, y_switch = calls[0]
    assert t_switch == pytest.approx(0.5, abs=1e-12) and y_switch >= 0.0
    exact = np.where(res.t <= 0.5, res.t - 0.5, 3.0 * (res.t - 0.5))
    assert np.allclose(res.y[:, 0], exact, atol=1e-10)
    assert [(e.t, e.y[0]) for e in res.events] == [(t_switch, y_switch)]


def test_without_restart_the_kink_is_smeared():
    """The same switch done inside the right-hand side (no restart): rk4 with step 0.3
    steps over the kink and misses the exact solution, which the restart keeps."""
    problem = ODEProblem(rhs=lambda t, y: np.array([1.0 if y[0] < 0 else 3.0]))
    res = get_integrator("rk4", step=0.3).integrate(problem, 0.0, np.array([-0.5]),
                                                    np.linspace(0, 1, 11))
    assert abs(res.y[-1, 0] - 1.5) > 1e-3
