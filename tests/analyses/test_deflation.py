"""The reduced system (ignorable modes deflated) and the modal table's reporting of real
eigenvalues: the bicycle's critical speeds under several OpenBLAS kernels, the structure of
the deflation, non-oscillatory real modes and whirling tops."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spatialmbd import ModelBuilder
from spatialmbd.analyses import linearize, modes
from spatialmbd.models import HEAVY_TOP, heavy_top, whipple_bicycle

G = 9.81
WEAVE, CAPSIZE = 4.29238253634111, 6.02426201538837    # Meijaard et al. (2007)
SRC = Path(__file__).resolve().parents[2] / "src"

ROOTS = """
import numpy as np
from scipy.optimize import brentq
from spatialmbd.analyses import linearize
from spatialmbd.models import whipple_bicycle
def ev(v):
    return linearize(whipple_bicycle(v).compile(), steady=v > 0).reduced().eigenvalues
def weave(v):
    e = ev(v)
    return float(e[np.abs(e.imag) > 1e-6].real.max())
def capsize(v):
    e = ev(v)
    re = e[e.imag == 0].real
    return float(re[np.argmin(np.abs(re))])
print(repr(brentq(weave, 4.2, 4.4, xtol=1e-13)), repr(brentq(capsize, 5.9, 6.1, xtol=1e-13)))
"""


def test_bicycle_critical_speeds_agree_with_the_benchmark_under_each_blas_kernel():
    """OpenBLAS picks its kernels when it loads, so each runs in its own process. On the
    full A the capsize root moved by 4e-4 m/s between kernels (it crosses zero among six
    defective zero eigenvalues); on the reduced system it is a simple root."""
    procs = {}
    for kernel in ("Haswell", "Prescott"):
        env = dict(os.environ, OPENBLAS_CORETYPE=kernel,
                   PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]))
        procs[kernel] = subprocess.Popen([sys.executable, "-c", ROOTS], env=env, text=True,
                                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    for kernel, proc in procs.items():
        out, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, err
        weave, capsize = (float(x) for x in out.split())
        assert abs(weave - WEAVE) < 1e-9, (kernel, weave)
        assert abs(capsize - CAPSIZE) < 1e-9, (kernel, capsize)


def test_bicycle_reduced_system_deflates_position_heading_wheel_angles_and_speed():
    """Five ignorable positions (x, y, heading, two wheel angles) and the forward speed: the
    reduced matrix keeps the four lean and steer eigenvalues, the same as the full A's
    largest four away from the capsize speed, and A is block triangular in [U Q]."""
    lin = linearize(whipple_bicycle(3.0).compile(), steady=True)
    red = lin.reduced()
    assert red.k == 6 and red.positions.shape == (7, 5) and red.A.shape == (4, 4)
    assert red.residual < 1e-10 * np.abs(lin.A).max()
    assert not red.deflated_eigenvalues().any()
    full = np.linalg.eigvals(lin.A)
    big = np.sort_complex(full[np.argsort(np.abs(full))[-4:]])
    assert np.abs(np.sort_complex(red.eigenvalues) - big).max() < 1e-9
    # the deflated states are those the lean and steer motion does not depend on
    U, Q = red.deflated, red.basis
    assert np.abs(Q.T @ lin.A @ U).max() <= red.residual
    assert np.allclose(np.hstack([U, Q]).T @ np.hstack([U, Q]), np.eye(10), atol=1e-12)
    lifted = red.lift(red.eigenvalues[0], np.linalg.eig(red.A)[1][:, 0])
    s = np.linalg.eig(red.A)[0][0]
    assert np.abs(lin.A @ lifted - s * lifted).max() < 1e-10 * np.abs(lifted).max() * abs(s)


def test_free_body_and_pendulum_deflation():
    """A free body: its six positions and six rates are ignorable, nothing is left. A
    pendulum under gravity: its angle is not (gravity depends on it), nothing is deflated."""
    b = ModelBuilder("free", gravity=(0, 0, 0))
    b.add_body("box", 2.0, (0.1, 0.2, 0.25))
    red = linearize(b.compile()).reduced()
    assert red.k == 12 and red.A.shape == (0, 0) and red.positions.shape == (6, 6)
    p = ModelBuilder("pendulum", gravity=(0, 0, -G))
    p.add_body("rod", 1.0, (1 / 12, 1 / 12, 1e-6), r=(0, 0, -0.5))
    p.add_joint("revolute", "pin", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    lin = linearize(p.compile())
    assert lin.reduced().k == 0 and lin.reduced().A.shape == (2, 2)


def test_sleeping_top_spin_is_deflated_and_its_gyroscopic_modes_are_forward_whirls():
    """Sleeping top: the spin angle and spin rate are ignorable; the two tilt modes (roots w
    of A w^2 - C Omega w + m g l = 0, both positive above the threshold) make the axis circle
    in the sense of the spin: forward whirls."""
    p = HEAVY_TOP
    m, l, I1, C = p["mass"], p["l"], p["I1"], p["I3"]
    A = I1 + m * l**2
    spin = 50.0
    lin = linearize(heavy_top(theta=0.0, spin=spin, precession=0.0).compile(), steady=True)
    assert lin.reduced().k == 2
    w = np.sort(np.roots([A, -C * spin, m * G * l]).real)
    assert np.allclose(np.sort(np.abs(lin.reduced().eigenvalues.imag))[::2], w, rtol=1e-7)
    md = modes(lin)
    osc = md.table[md.table["oscillatory"]]
    assert list(osc["whirl"]) == ["forward", "forward"]
    assert all("forward whirl of top" in text for text in osc["motion"])
    spun_back = modes(heavy_top(theta=0.0, spin=-spin, precession=0.0).compile(), steady=True)
    assert list(spun_back.table[spun_back.table["oscillatory"]]["whirl"]) == ["forward"] * 2


def test_real_eigenvalues_are_non_oscillatory_without_frequency_or_damping_ratio():
    """Bicycle at 5 m/s: capsize (-0.323 1/s) and caster (-14.08 1/s) are real: no
    frequency, no damping ratio, a time constant 1/|s|; the weave pair is oscillatory with
    both. A rod with a strong damper (overdamped, two real eigenvalues): the same."""
    md = modes(whipple_bicycle(5.0).compile(), steady=True)
    t = md.table
    assert (t["kind"] == "rigid-body").sum() == 5 and md.stable
    real = t[t["kind"] == "non-oscillatory"]
    assert len(real) == 2 and (real["imag"] == 0).all() and not real["oscillatory"].any()
    assert real[["omega_n", "frequency_hz", "damped_frequency_hz", "damping_ratio"]].isna() \
        .all().all()
    assert np.allclose(real["time_constant_s"], 1 / np.abs(real["real"]), rtol=1e-12)
    assert np.allclose(np.sort(real["real"]), [-14.0784, -0.322866], rtol=1e-5)
    weave = t[t["oscillatory"]]
    assert len(weave) == 1 and weave["kind"].iloc[0] == "oscillatory"
    assert weave["damping_ratio"].iloc[0] == pytest.approx(
        -weave["real"].iloc[0] / np.hypot(weave["real"].iloc[0], weave["imag"].iloc[0]))
    assert "non-oscillatory s = -0.322866 1/s, no frequency" in md.summary()

    b = ModelBuilder("damped", gravity=(0, 0, -G))
    b.add_body("rod", 1.0, (1 / 12, 1 / 12, 1e-6), r=(0, 0, -0.5))
    b.add_joint("revolute", "pin", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("rotational_spring_damper", "damper", joint="pin", stiffness=0.0, damping=5.0)
    md = modes(b.compile())
    # I_O th'' + c th' + m g L/2 th = 0 with c^2 > 4 I_O m g L/2: two real roots
    I_O, c, k = 1 / 3, 5.0, G / 2
    roots = np.sort(np.roots([I_O, c, k]).real)
    assert list(md.table["kind"]) == ["non-oscillatory"] * 2
    assert np.allclose(np.sort(md.table["real"]), roots, rtol=1e-7)
    assert md.table["damping_ratio"].isna().all() and md.table["frequency_hz"].isna().all()


def test_unstable_real_mode_is_a_divergence():
    """An inverted pendulum: s = +-sqrt(m g L/2 / I_O); the positive root is unstable and
    non-oscillatory (a divergence), no frequency."""
    b = ModelBuilder("inverted", gravity=(0, 0, -G))
    b.add_body("rod", 1.0, (1 / 12, 1 / 12, 1e-6), r=(0, 0, 0.5))
    b.add_joint("revolute", "pin", "ground", "rod", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_force("rotational_spring_damper", "damper", joint="pin", stiffness=0.0, damping=0.1)
    md = modes(b.compile())
    unstable = md.table[md.table["kind"] == "unstable"]
    assert len(unstable) == 1 and not md.stable and not unstable["oscillatory"].any()
    assert np.isnan(unstable["frequency_hz"].iloc[0])
    I_O, c, k = 1 / 3, 0.1, -G / 2
    assert unstable["real"].iloc[0] == pytest.approx(np.roots([I_O, c, k]).real.max(), rel=1e-7)
    assert "unstable (divergence)" in md.summary()
