"""BDF4 step control: the retry exponent and the quadratures (docs/integrators.md)."""
from __future__ import annotations

import numpy as np
import pytest

from spatialmbd.integrators import ODEProblem, get_integrator


def test_bdf4_retry_exponent_is_what_a_shorter_step_from_the_same_history_gives():
    """y' = 5 t^4 from a history exactly on y = t^5 (spacing H): the history quartic misses
    y by prod (t - t_k), so a step of size h has the error estimate ~ h p'(h) and shrinking
    only the new step from h to h/2 lowers it by 2^-k with k = retry_exponent(h, H) (2.38 at
    h = H) -- not 2^-5, the exponent of a step whose history is re-spaced too."""
    from spatialmbd.integrators.base import Counters
    from spatialmbd.integrators.gear import GearBDF4, retry_exponent
    integ = GearBDF4(rtol=1e-9, atol=1.0)      # the error scale: atol, the same for both
    problem = ODEProblem(lambda t, y: np.array([5.0 * t ** 4]))
    for H, h in ((0.1, 0.1), (0.1, 0.05), (0.05, 0.1)):
        t = 1.0
        errs = []
        for hs in (h, 0.5 * h):
            st = integ.make_stepper()
            st.start(problem, t, np.array([t ** 5]), 10.0, Counters())
            st.Y[:] = np.array([[(t - k * H) ** 5] for k in range(5)])
            st.n_hist, st.hY, st.h_nodes = 5, H, H
            errs.append(st.step(t, np.array([t ** 5]), t + hs).err)
        measured = np.log2(errs[0] / errs[1])
        assert measured == pytest.approx(retry_exponent(h, H), abs=0.02), (H, h, measured)
    assert retry_exponent(0.1, 0.1) == pytest.approx(2.376, abs=1e-3)


def test_bdf4_quadrature_of_a_stiff_quadratic_power_follows_the_tolerance():
    """A stiff component y' = -1e4 (y - sin t) + cos t (on y = sin t) and the quadrature
    W' = c (y - sin t + 1e-3)^2 with c = 1e4 (a damper's power on a stiff velocity): W is the
    integral of the derivative at the converged states, so its error follows rtol. Taking it
    from the iterate before the last Newton correction left c dy^2 per step in W."""
    c = 1e4

    def f(t, y):
        d = y[0] - np.sin(t)
        return np.array([-1e4 * d + np.cos(t), c * (d + 1e-3) ** 2])

    T = 2.0
    exact = c * 1e-6 * T            # d = 0 on the solution
    errors = []
    for rtol in (1e-3, 1e-5, 1e-7):
        res = get_integrator("bdf4", rtol=rtol, atol=rtol * 1e-2).integrate(
            ODEProblem(f, n_quadrature=1), 0.0, [0.0, 0.0], np.array([T]))
        assert res.success, res.message
        errors.append(abs(res.y[-1, 1] - exact) / exact)
    assert errors[0] < 1e-2 and errors[1] < 1e-4 and errors[2] < 1e-6, errors
