"""Every constraint kernel against finite differences at many random states (ERRATA-aware)."""
import zlib

import numpy as np
import pytest

from spatialmbd.constraints import CONSTRAINT_TYPES, JOINT_TYPES
from spatialmbd.constraints.base import ConstraintEval
from spatialmbd.constraints import primitives as prim
from spatialmbd.constraints.spherical import Spherical
from spatialmbd.constraints.spherical_spherical import SphericalSpherical
from spatialmbd.motion import ConstantVelocity, Harmonic, SmoothStep, Polynomial
from spatialmbd.rotations import skew

from fd_check import WrapJump, derivative_errors, random_geometry, random_state

NB = 3
# body pairs (i, j), ground = NB, in both orders
PAIRS = np.array([(0, 1), (1, 0), (NB, 2), (2, NB), (1, 2), (2, 0)])


def make_group(name, rng):
    cls = CONSTRAINT_TYPES[name]
    n = len(PAIRS)
    geom = random_geometry(rng, n, len(cls.parameters))
    names = [f"{name}{k}" for k in range(n)]
    if name in ("angle", "translation"):
        laws = [Harmonic(0.7, 2.0, 0.3, 0.1), ConstantVelocity(3.0, 0.2), SmoothStep(0.0, 2.0, 0, 1),
                Polynomial([0.1, 0.2, -0.3]), Harmonic(1.0, 5.0), ConstantVelocity(-1.0)]
        return cls(names, PAIRS[:, 0], PAIRS[:, 1], geom, laws=laws)
    if name == "coordinate":
        laws = [Harmonic(0.2, 3.0, 0.0, 0.5)] * 7
        bodies = np.array([0, 1, 2, 0, 1, 2, 0])
        geom = random_geometry(rng, 7)
        return cls([f"c{k}" for k in range(7)], bodies, np.full(7, NB), geom, laws=laws,
                   coordinate=np.arange(7))
    return cls(names, PAIRS[:, 0], PAIRS[:, 1], geom)


def angle_well_defined(group, q0):
    """The angle atan2(b_i.a_j, a_i.a_j) is defined only while a_j is not along the axis u_i;
    keep random states where x^2 + y^2 > 0.1 (else the angle itself is ill-conditioned)."""
    from spatialmbd.state import BodyState
    s = BodyState.from_qv(q0, None, 0.0)
    a_j = np.einsum("nij,nj->ni", s.A[group.body_j], group.geometry.R_j[:, :, 1])
    a_i = np.einsum("nij,nj->ni", s.A[group.body_i], group.geometry.R_i[:, :, 1])
    b_i = np.einsum("nij,nj->ni", s.A[group.body_i], group.geometry.R_i[:, :, 2])
    r2 = np.sum(a_i * a_j, axis=1) ** 2 + np.sum(b_i * a_j, axis=1) ** 2
    return r2.min() > 0.1


@pytest.mark.parametrize("name", sorted(CONSTRAINT_TYPES))
def test_jacobian_and_gamma_match_finite_differences(name):
    if any(par.size > 1 for par in CONSTRAINT_TYPES[name].parameters):
        pytest.skip("list parameters (spline values) need consistent derived columns: checked "
                    "by the type's own test (test_point_curve.py)")
    if CONSTRAINT_TYPES[name].velocity_rows:
        pytest.skip("rows without Phi (nonholonomic): d(D v)/dt = -gamma is checked by the "
                    "type's own test (test_rolling.py)")
    if getattr(CONSTRAINT_TYPES[name], "coupler", False):
        pytest.skip("a coupler's block holds two joints' geometry: checked by "
                    "test_couplers.py on coupled joints")
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    for trial in range(20):
        group = make_group(name, rng)
        q0, v = random_state(rng, NB)
        while CONSTRAINT_TYPES[name].angle_based and not angle_well_defined(group, q0):
            q0, v = random_state(rng, NB)
        while True:
            try:
                e1, e2, scale = derivative_errors(group, q0, v, t0=rng.uniform(0, 1.5))
                break
            except WrapJump:
                q0, v = random_state(rng, NB)
        assert e1 < 1e-8 * scale, f"{name}: D v - nu differs from dPhi/dt by {e1:.3g}"
        assert e2 < 1e-6 * scale, f"{name}: -gamma differs from d2Phi/dt2 by {e2:.3g}"


def test_every_joint_type_is_tested():
    expected = {"spherical", "revolute", "spherical_spherical", "translational", "cylindrical",
                "universal", "fixed", "planar", "spherical_revolute", "n1", "n2", "p1", "p2"}
    assert expected <= set(JOINT_TYPES)


# ---- the same check must reject the printed typos of ERRATA.md ----------------------------
class PrintedSpherical(Spherical):
    """gamma as printed in (9.8): -s~_i omega_i + s~_j omega_j (a velocity term)."""

    def evaluate(self, state, t):
        ev = super().evaluate(state, t)
        g = self.geometry
        s_i = np.einsum("nij,nj->ni", state.A[self.body_i], g.s_i)
        s_j = np.einsum("nij,nj->ni", state.A[self.body_j], g.s_j)
        gamma = (-np.einsum("nij,nj->ni", skew(s_i), state.omega[self.body_i])
                 + np.einsum("nij,nj->ni", skew(s_j), state.omega[self.body_j]))
        return ConstraintEval(ev.phi, ev.D, ev.nu, gamma)


class PrintedDistanceD(SphericalSpherical):
    """Jacobian with the signs printed in (9.25): [2d^T, -2d^T s~_i, 2d^T, 2d^T s~_j]."""

    def evaluate(self, state, t):
        ev = super().evaluate(state, t)
        D = ev.D.copy()
        D[:, :, 0:3] *= -1
        D[:, :, 3:6] *= -1
        D[:, :, 9:12] *= -1
        return ConstraintEval(ev.phi, D, ev.nu, ev.gamma)


class PrintedDistanceGamma(SphericalSpherical):
    """gamma with the brackets printed in (9.26): 2 d^T({w~_i sd_i - w~_j sd_j} - 2 dd^T dd)."""

    def evaluate(self, state, t):
        ev = super().evaluate(state, t)
        g = self.geometry
        P_i = prim.body_point(state, self.body_i, g.s_i, 0)
        P_j = prim.body_point(state, self.body_j, g.s_j, 1)
        d = P_j.value - P_i.value
        dd = P_j.vel - P_i.vel
        term = P_i.acc - P_j.acc          # w~_i sdot_i - w~_j sdot_j
        gamma = 2 * np.einsum("ni,ni->n", d, term - 2 * np.einsum("ni,ni->n", dd, dd)[:, None])
        return ConstraintEval(ev.phi, ev.D, ev.nu, gamma[:, None])


@pytest.mark.parametrize("cls,which", [(PrintedSpherical, 2), (PrintedDistanceD, 1),
                                       (PrintedDistanceGamma, 2)])
def test_finite_difference_check_rejects_printed_typos(cls, which):
    rng = np.random.default_rng(7)
    geom = random_geometry(rng, len(PAIRS))
    group = cls([f"j{k}" for k in range(len(PAIRS))], PAIRS[:, 0], PAIRS[:, 1], geom)
    q0, v = random_state(rng, NB)
    e1, e2, scale = derivative_errors(group, q0, v, 0.3)
    err = e1 if which == 1 else e2
    assert err > 1e-2 * scale
