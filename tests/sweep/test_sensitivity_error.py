"""The error estimate of the finite-difference sensitivities bounds the true error: on the
compound pendulum released at 30 and 90 degrees, d(period)/d(amplitude) and d(period)/d(I_cm)
against the closed form (the period through the complete elliptic integral), with the
default adaptive integration (rk45, rtol 1e-6), whose error dominates."""
import numpy as np
import pytest
from scipy.special import ellipk

from spatialmbd import ModelBuilder
from spatialmbd.sweep import sensitivities

pytest.importorskip("xarray")

MASS, I_CM, D, G = 7.02, 0.5855265, 0.5, 9.81


def pendulum(amplitude_deg, inertia):
    th = np.radians(amplitude_deg)
    a = th - np.pi / 2                        # rotation about x taking body y to the rod line
    A = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    b = ModelBuilder("pendulum", gravity=(0, 0, -G))
    b.add_body("rod", mass=MASS, inertia=(inertia, 0.001053, inertia),
               r=D * np.array([0.0, np.sin(th), -np.cos(th)]), A=A)
    b.add_joint("revolute", "pivot", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    return b.compile()


def period(amplitude_deg, inertia):
    """T = 4 sqrt(L / g) K(sin^2(theta0 / 2)), L = (I_cm + m d^2) / (m d)."""
    L = (inertia + MASS * D * D) / (MASS * D)
    return 4 * np.sqrt(L / G) * ellipk(np.sin(np.radians(amplitude_deg) / 2) ** 2)


@pytest.mark.parametrize("amplitude", [30.0, 90.0])
def test_the_error_estimate_bounds_the_true_error(amplitude):
    fd = sensitivities(pendulum, {"amplitude_deg": amplitude, "inertia": I_CM},
                       ["period(rod.wx)"], dict(type="dynamic", t_end=5.0, output_step=0.01))
    assert (fd["status"] == "success").all()
    h = 1e-6                                   # the closed form, centrally differenced
    exact = np.array([period(amplitude + h, I_CM) - period(amplitude - h, I_CM),
                      period(amplitude, I_CM + h) - period(amplitude, I_CM - h)]) / (2 * h)
    derivative, error = fd["derivative"].values[0], fd["error"].values[0]
    true_error = np.abs(derivative - exact)
    assert np.all(true_error <= error), (true_error, error)
    # an estimate, not a blanket: within a factor 20 of the true error
    assert np.all(error < 20 * true_error), (true_error, error)
    assert np.all(fd["truncation"].values[0] + fd["integration"].values[0] == error)
    assert np.all(fd["integration"].values[0] > 0)
    if amplitude == 30.0:     # the truncation part alone (the estimate before) misses it
        assert fd["truncation"].values[0, 1] < 0.1 * true_error[1]


def test_forward_sensitivities_with_error_control_on_the_sensitivities():
    """A near point mass (I_cm 1e-3 kg m^2 against m d^2 = 1.755 kg m^2) released at 150
    degrees, the sensitivities integrated with the state by rk45 at rtol 1e-9 with the
    sensitivities in its error norm, against the Richardson-extrapolated central differences
    of runs at rtol 1e-11: d/d(amplitude) agrees to 1e-8 (measured 4.9e-9 and 6.7e-10);
    d/d(I_cm) is closer than the RK4 sensitivities with step 1e-3 (the default before), but
    still 1.4e-4 (2e-5 relative) off: not an integration error (it does not shrink with
    rtol), an open issue."""
    from spatialmbd.sweep import forward_sensitivities
    an = dict(type="dynamic", t_end=2.0, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk45", rtol=1e-9, atol=1e-12))
    params = {"amplitude_deg": 150.0, "inertia": 1e-3}
    outs = ["final(rod.wx)", "final(rod.z)"]
    fw = forward_sensitivities(pendulum, params, outs, an)
    assert "error norm" in fw.attrs["method"]
    tight = dict(an, integrator=dict(name="rk45", rtol=1e-11, atol=1e-14))
    fd = sensitivities(pendulum, params, outs, tight, relative_steps=(1e-3, 1e-4))
    assert (fd["status"] == "success").all()
    ref = fd["richardson"].values
    off = np.abs(fw["derivative"].values - ref)
    assert np.all(off[:, 0] < 1e-8), off
    rk4 = forward_sensitivities(pendulum, params, outs, an, scheme="rk4")
    assert np.all(off[:, 1] < np.abs(rk4["derivative"].values - ref)[:, 1]), off
