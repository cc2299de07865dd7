"""The error estimate of the finite-difference sensitivities bounds the true error: on the
compound pendulum released at 30 and 90 degrees, d(period)/d(amplitude) and d(period)/d(I_cm)
against the closed form (the period through the complete elliptic integral), with the
default adaptive integration (rk45, rtol 1e-6), whose error dominates."""
import numpy as np
import pytest
from scipy.special import ellipk

mp = pytest.importorskip("mpmath")

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


def closed_form_final_state(amplitude_deg, inertia, t):
    """(theta'(t), z(t)) of the pendulum released from rest, to 40 digits (mpmath):
    sin(theta / 2) = k sn(K - w0 t, k^2), theta' = -2 k w0 cn(K - w0 t, k^2), k = sin(theta0 / 2),
    w0^2 = m g d / (I_cm + m d^2); z = -d cos(theta)."""
    th0 = mp.radians(amplitude_deg)
    w0 = mp.sqrt(mp.mpf(MASS) * G * D / (inertia + mp.mpf(MASS) * D * D))
    k = mp.sin(th0 / 2)
    u = mp.ellipk(k * k) - w0 * t
    theta = 2 * mp.asin(k * mp.ellipfun("sn", u, m=k * k))
    return -2 * k * w0 * mp.ellipfun("cn", u, m=k * k), -D * mp.cos(theta)


def closed_form_derivatives(amplitude_deg, inertia, t):
    """d(final wx, final z) / d(amplitude_deg, I_cm): central differences of the closed form
    at 40 digits with a step of 1e-15 (their error is below 1e-25)."""
    with mp.workdps(40):
        x, h = [mp.mpf(amplitude_deg), mp.mpf(inertia)], mp.mpf("1e-15")
        out = np.empty((2, 2))
        for j in range(2):
            plus, minus = list(x), list(x)
            plus[j] += h
            minus[j] -= h
            a, b = closed_form_final_state(*plus, t), closed_form_final_state(*minus, t)
            out[:, j] = [float((a[i] - b[i]) / (2 * h)) for i in range(2)]
    return out


def test_forward_sensitivities_with_error_control_on_the_sensitivities():
    """A near point mass (I_cm 1e-3 kg m^2 against m d^2 = 1.755 kg m^2) released at 150
    degrees, the sensitivities integrated with the state by rk45 with the sensitivities in its
    error norm, against the closed form (Jacobi's elliptic functions) of d final(rod.wx, rod.z)
    / d(amplitude, I_cm). The right-hand side of this model carries round-off of about 1e-12
    relative (the constraint torque cancels the weight's), which a two-point difference of f_p
    at a fixed step of 1e-6 |x0| amplified into a 1.4e-4 error of d/dI_cm; the f_p step now
    chosen per parameter and Richardson-extrapolated, the I_cm column is within 1.5e-7
    relative (measured up to 3.7e-8 at rtol 1e-9, 4e-9 to 5e-8 from 1e-8 to 1e-10, on the
    Haswell, Prescott and SkylakeX kernels) and below the error of the finite differences of
    the same runs (sensitivities(): 1.2e-6 / 3.4e-7); the amplitude column to 2.5e-10.
    Classic RK4 at h = 1e-3 (the discrete adjoint's scheme) within the same bound."""
    from spatialmbd.sweep import forward_sensitivities
    an = dict(type="dynamic", t_end=2.0, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk45", rtol=1e-9, atol=1e-12))
    params = {"amplitude_deg": 150.0, "inertia": 1e-3}
    outs = ["final(rod.wx)", "final(rod.z)"]
    exact = closed_form_derivatives(150.0, 1e-3, 2.0)
    fw = forward_sensitivities(pendulum, params, outs, an)
    assert "error norm" in fw.attrs["method"]
    off = np.abs(fw["derivative"].values - exact)
    assert np.all(off[:, 0] < 1e-8), off
    assert np.all(off[:, 1] < 1.5e-7 * np.abs(exact[:, 1])), off / np.abs(exact)
    fd = sensitivities(pendulum, params, outs, an)      # the same runs, differenced
    assert np.all(off < np.abs(fd["derivative"].values - exact)), (off, fd["derivative"])
    # a tighter tolerance takes more steps (the sensitivities are in the error control); the
    # I_cm column stays at the round-off floor of its differences (4e-9 to 5e-8 relative,
    # depending on the BLAS kernel), the amplitude column follows the tolerance
    fine = forward_sensitivities(pendulum, params, outs,
                                 dict(an, integrator=dict(name="rk45", rtol=1e-10, atol=1e-13)))
    off_fine = np.abs(fine["derivative"].values - exact)
    assert np.all(off_fine[:, 0] < 1e-9), off_fine
    assert np.all(off_fine[:, 1] < 1.5e-7 * np.abs(exact[:, 1])), off_fine / np.abs(exact)
    assert fine.attrs["steps"] > fw.attrs["steps"]
    # classic RK4 at h = 1e-3 (2,000 steps; 2.1e-4 off with the fixed f_p step before)
    rk4 = forward_sensitivities(pendulum, params, outs, an, scheme="rk4")
    assert np.all(np.abs(rk4["derivative"].values - exact) < 1.5e-7 * np.abs(exact)), \
        rk4["derivative"].values - exact


def test_forward_sensitivities_reuse_their_parameter_steps():
    """The f_p steps chosen by the ladder come back in attrs["parameter_steps"] (relative to
    |x0|); passed again (as identification does from one iterate to the next) they give the
    same derivatives without the ladder, also at a moved parameter; a wrong count is refused."""
    from spatialmbd.errors import ModelError
    from spatialmbd.sweep import forward_sensitivities
    an = dict(type="dynamic", t_end=0.5, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk4", step=2e-3))
    params = {"amplitude_deg": 150.0, "inertia": 1e-3}
    outs = ["final(rod.wx)"]
    first = forward_sensitivities(pendulum, params, outs, an)
    steps = first.attrs["parameter_steps"]
    assert steps.shape == (2, 2) and np.all((steps >= 1e-6) & (steps <= 0.27))
    again = forward_sensitivities(pendulum, params, outs, an, parameter_steps=steps)
    np.testing.assert_array_equal(again["derivative"].values, first["derivative"].values)
    moved = {"amplitude_deg": 140.0, "inertia": 1.1e-3}
    ladder = forward_sensitivities(pendulum, moved, outs, an)
    reused = forward_sensitivities(pendulum, moved, outs, an, parameter_steps=steps)
    scale = np.abs(ladder["derivative"].values)
    assert np.all(np.abs(reused["derivative"].values - ladder["derivative"].values)
                  < 1e-6 * scale), (reused["derivative"].values, ladder["derivative"].values)
    with pytest.raises(ModelError, match="parameter_steps"):
        forward_sensitivities(pendulum, params, outs, an, parameter_steps=steps[:, 0])


def test_forward_sensitivity_ladder_ends_below_a_step_the_model_refuses():
    """I_cm 6e-4 kg m^2 with the third moment 1.053e-3: steps above 6.8e-5 break the triangle
    inequality (2 I_cm >= 1.053e-3), so the ladder (up to 0.26 |x0| = 1.6e-4) ends there and
    chooses among the steps the model takes; the derivatives still match the closed form, the
    I_cm column to 1e-6 relative (measured 4e-8 to 2.3e-7 on the Haswell and Prescott kernels:
    a smaller I_cm cancels more, m d^2 / I_cm = 2,900, and the largest steps are cut off)."""
    from spatialmbd.sweep import forward_sensitivities
    an = dict(type="dynamic", t_end=2.0, output_step=0.01, method=dict(name="standard"),
              integrator=dict(name="rk45", rtol=1e-9, atol=1e-12))
    params = {"amplitude_deg": 150.0, "inertia": 6e-4}
    fw = forward_sensitivities(pendulum, params, ["final(rod.wx)", "final(rod.z)"], an)
    exact = closed_form_derivatives(150.0, 6e-4, 2.0)
    assert fw.attrs["parameter_steps"][1, 0] * 6e-4 < 6.8e-5
    off = np.abs(fw["derivative"].values - exact)
    assert np.all(off[:, 1] < 1e-6 * np.abs(exact[:, 1])), off / np.abs(exact)
    assert np.all(off[:, 0] < 1e-8), off
