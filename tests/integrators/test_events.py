"""Event location by the integration driver (spatialmbd.integrators.driver) and simulate."""
from __future__ import annotations

import math

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.integrators import Event, ODEProblem, get_integrator
from spatialmbd.simulate import simulate

G = 9.81
OWN = ["euler", "heun", "rk4", "abm4", "bdf4", "rk45", "dop853"]
SCIPY = ["scipy-rk45", "scipy-dop853", "scipy-radau", "scipy-bdf", "scipy-lsoda"]
FIXED = {"euler": dict(step=1e-3), "heun": dict(step=1e-2), "rk4": dict(step=1e-2)}


def ballistic(t, y):
    """y = [z, vz]: free fall, z'' = -g."""
    return np.array([y[1], -G])


def hit_time(z0, v0, level=0.0, rising=False):
    """Closed form: z0 + v0 t - g t^2 / 2 = level; the later root (falling) or earlier."""
    disc = math.sqrt(v0 * v0 + 2.0 * G * (z0 - level))
    return (v0 - disc) / G if rising else (v0 + disc) / G


def ground(t, y):
    return y[0]


ground.terminal = True
ground.direction = -1


@pytest.mark.parametrize("name", OWN + SCIPY)
def test_terminal_event_located_by_every_integrator(name):
    z0, v0 = 2.0, 1.0
    t_hit = hit_time(z0, v0)
    t_eval = np.linspace(0.0, 2.0, 41)
    res = get_integrator(name, **FIXED.get(name, {})).integrate(
        ODEProblem(ballistic), 0.0, [z0, v0], t_eval, events=[ground])
    assert res.status == "event" and res.success, res.message
    assert len(res.events) == 1 and res.events[0].terminal and res.events[0].index == 0
    t_ev = res.events[0].t
    # Euler's own trajectory differs from the parabola by O(h); SciPy's BDF and LSODA start at
    # order 1 (their solution error is of the order of rtol = 1e-6); every other method
    # integrates a quadratic exactly and its interpolant is at least cubic
    tol = {"euler": 5e-3, "scipy-bdf": 1e-6, "scipy-lsoda": 1e-6}.get(name, 1e-8)
    assert abs(t_ev - t_hit) < tol, (t_ev, t_hit)
    # the run stops there: outputs before the event, then the event state
    assert res.t[-1] == t_ev and np.all(res.t[:-1] < t_ev)
    np.testing.assert_array_equal(res.t[:-1], t_eval[t_eval < t_ev])
    assert abs(res.y[-1, 0]) < 10 * tol
    assert f"{t_ev:.9g}" in res.message and "ground" in res.message


def test_event_located_to_tolerance_on_the_dense_output():
    """rk45 with large steps (loose tolerances): the event time is still exact to event_tol,
    because Dormand-Prince is exact on the quadratic and Brent works on its dense output."""
    z0, v0 = 2.0, 1.0
    for tol in (1e-6, 1e-12):
        res = get_integrator("rk45", rtol=1e-3, atol=1e-3).integrate(
            ODEProblem(ballistic), 0.0, [z0, v0], [3.0], events=[ground], event_tol=tol)
        assert res.counters.steps <= 6
        assert abs(res.events[0].t - hit_time(z0, v0)) <= tol + 1e-14


def test_direction_filter_and_non_terminal_events():
    """z crosses 2.5 rising at t1 and falling at t2; a non-terminal event does not stop."""
    z0, v0, level = 2.0, 4.0, 2.5
    t1, t2 = hit_time(z0, v0, level, rising=True), hit_time(z0, v0, level)

    def make(direction):
        return Event(lambda t, y: y[0] - level, direction=direction, name=f"d{direction}")

    res = get_integrator("rk45").integrate(ODEProblem(ballistic), 0.0, [z0, v0],
                                           np.linspace(0.0, 1.0, 11),
                                           events=[make(1), make(-1), make(0)])
    assert res.status == "success"
    np.testing.assert_allclose(res.t, np.linspace(0.0, 1.0, 11))
    by_name = {}
    for e in res.events:
        by_name.setdefault(e.name, []).append(e.t)
    np.testing.assert_allclose(by_name["d1"], [t1], atol=1e-10)
    np.testing.assert_allclose(by_name["d-1"], [t2], atol=1e-10)
    np.testing.assert_allclose(by_name["d0"], [t1, t2], atol=1e-10)
    assert [e.t for e in res.events] == sorted(e.t for e in res.events)


def test_restart_from_a_terminal_event_does_not_fire_at_once():
    """g = 0 at the start is not a crossing (strict sign change), so a restart continues."""
    up = Event(lambda t, y: y[0], terminal=True)      # both directions
    res = get_integrator("rk45").integrate(ODEProblem(ballistic), 0.0, [0.0, 3.0], [1.0],
                                           events=[up])
    assert res.status == "event"
    assert res.events[0].t == pytest.approx(2 * 3.0 / G, abs=1e-9)   # the next zero


def test_bad_event_spec_is_rejected():
    with pytest.raises(ValueError, match="events\\[0\\]"):
        get_integrator("rk45").integrate(ODEProblem(ballistic), 0.0, [1.0, 0.0], [1.0],
                                         events=[42])


def test_simulate_stops_a_falling_body_at_first_touch():
    """A free body dropped from z0 with vz0: touch-down of its lowest point (0.1 m below the
    centre) located to tolerance against the closed form; results record the event."""
    b = ModelBuilder("drop", gravity=(0.0, 0.0, -G))
    b.add_body("ball", 1.0, [0.004, 0.004, 0.004], r=(0.0, 0.0, 1.0), rdot=(0.3, 0.0, 2.0))
    model = b.compile()
    radius = 0.1

    class Touch:
        terminal = True
        direction = -1
        name = "touch"

        @staticmethod
        def function(t, state):
            return state.r[0, 2] - radius

    res = simulate(model, 2.0, integrator="rk45", output_step=0.05, events=[Touch()])
    t_hit = hit_time(1.0, 2.0, level=radius)
    assert res.status == "event" and res.success
    assert res.events == [dict(t=res.t[-1], name="touch", index=0, terminal=True)]
    assert abs(res.t[-1] - t_hit) < 1e-9
    assert abs(res.q[-1, 0, 2] - radius) < 1e-9
    assert res.q[-1, 0, 0] == pytest.approx(0.3 * t_hit, abs=1e-9)


def test_docs_worked_example_runs():
    """The worked example of docs/integrators.md runs and prints what it says."""
    import contextlib
    import io
    from pathlib import Path
    text = (Path(__file__).resolve().parents[2] / "docs" / "integrators.md").read_text()
    code = text.split("```python\n", 1)[1].split("```", 1)[0]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "docs/integrators.md", "exec"), {})
    lines = out.getvalue().splitlines()
    assert lines[0] == "event 0.678269 touch" and lines[1] == "True"


def test_event_states_are_the_located_states():
    """results.event_states holds the state at each event (located, not sampled): a body
    falling from rest reaches z = 0 with the speed sqrt(2 g h) there."""
    import math
    from spatialmbd import ModelBuilder
    from spatialmbd.simulate import simulate
    b = ModelBuilder("fall", gravity=(0, 0, -9.81))
    b.add_body("ball", 1.0, (0.1, 0.1, 0.1), r=(0, 0, 0.8))

    def floor(t, s):
        return s.r[0, 2]
    floor.terminal, floor.direction = True, -1
    res = simulate(b.compile(), 2.0, output_step=0.1, events=[floor], rtol=1e-10, atol=1e-12)
    q, v = res.event_states[0]
    assert abs(q[0, 2]) < 1e-10
    assert v[0, 2] == pytest.approx(-math.sqrt(2 * 9.81 * 0.8), rel=1e-9)
    assert res.events[0]["t"] == pytest.approx(math.sqrt(2 * 0.8 / 9.81), rel=1e-10)
