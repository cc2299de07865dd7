"""Tests of spatialmbd.rotations against the text's chapters 4-5 (with ERRATA.md)."""
from __future__ import annotations

import numpy as np
import pytest

from spatialmbd import rotations as R

# ----------------------------------------------------------------------------------------------
# Test helpers (deliberately not in the package)
# ----------------------------------------------------------------------------------------------


def random_p(n, rng):
    """Uniformly distributed unit Euler parameters (normalised Gaussian 4-vectors)."""
    p = rng.standard_normal((n, 4))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def random_rotations(n, rng):
    return R.A_from_p(random_p(n, rng))


def Rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def zxz_product(psi, theta, sigma):
    """A = D C B with D, C, B written out from (4.1)."""
    D = np.array([[np.cos(psi), -np.sin(psi), 0], [np.sin(psi), np.cos(psi), 0], [0, 0, 1]])
    C = np.array([[1, 0, 0], [0, np.cos(theta), -np.sin(theta)], [0, np.sin(theta), np.cos(theta)]])
    B = np.array([[np.cos(sigma), -np.sin(sigma), 0], [np.sin(sigma), np.cos(sigma), 0], [0, 0, 1]])
    return D @ C @ B


def bryant_product(f1, f2, f3):
    """A = D C B with D, C, B written out from (4.4)."""
    D = np.array([[1, 0, 0], [0, np.cos(f1), -np.sin(f1)], [0, np.sin(f1), np.cos(f1)]])
    C = np.array([[np.cos(f2), 0, np.sin(f2)], [0, 1, 0], [-np.sin(f2), 0, np.cos(f2)]])
    B = np.array([[np.cos(f3), -np.sin(f3), 0], [np.sin(f3), np.cos(f3), 0], [0, 0, 1]])
    return D @ C @ B


def vee(S):
    """Axial vector of a (nearly) skew-symmetric matrix."""
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0],
                           S[..., 1, 0] - S[..., 0, 1]], axis=-1)


def max_err(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))))


def same_up_to_sign(p, q):
    s = np.where(np.sum(p * q, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return max_err(p, s * q)


# Smooth unit-quaternion trajectory and high-order central differences.
_P0 = np.array([0.4, -0.3, 0.7, 0.5])
_V1 = np.array([0.3, 0.8, -0.5, 0.2])
_V2 = np.array([-0.6, 0.1, 0.4, 0.9])
_V3 = np.array([0.2, -0.7, 0.3, -0.4])


def p_path(t):
    t = np.asarray(t, dtype=float)[..., None]
    q = _P0 + t * _V1 + t**2 * _V2 + 0.5 * np.sin(2.0 * t) * _V3
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def d1(f, t, h=1e-3):
    """4th-order central first derivative."""
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


def d2(f, t, h=1e-3):
    """4th-order central second derivative."""
    return (-f(t + 2 * h) + 16 * f(t + h) - 30 * f(t) + 16 * f(t - h) - f(t - 2 * h)) / (12 * h * h)


TIMES = np.linspace(-1.0, 1.5, 11)


@pytest.fixture
def rng():
    return np.random.default_rng(20240601)


# ----------------------------------------------------------------------------------------------
# Chapter 4: A(p), p(A)
# ----------------------------------------------------------------------------------------------


def test_A_orthogonal_det_one(rng):
    A = R.A_from_p(random_p(5000, rng))
    assert max_err(A @ np.swapaxes(A, -1, -2), np.eye(3)) < 1e-14
    assert max_err(np.linalg.det(A), 1.0) < 1e-14


def test_A_matches_compact_form_and_skew(rng):
    p = random_p(200, rng)
    e0, e = p[:, 0], p[:, 1:]
    A = ((2 * e0**2 - 1)[:, None, None] * np.eye(3)
         + 2 * (e[:, :, None] * e[:, None, :] + e0[:, None, None] * R.skew(e)))
    assert max_err(R.A_from_p(p), A) < 1e-15
    a, b = rng.standard_normal((2, 200, 3))
    assert max_err(R.skew(a) @ b[..., None], np.cross(a, b)[..., None]) < 1e-14
    # the axis u is invariant: A u = u; special cases (4.17)-(4.19)
    assert max_err(R.A_from_p(p) @ e[..., None], e[..., None]) < 1e-14
    ang = 0.7
    for k, Rk in zip(range(1, 4), (Rx, Ry, Rz)):
        q = np.zeros(4)
        q[0], q[k] = np.cos(ang / 2), np.sin(ang / 2)
        assert max_err(R.A_from_p(q), Rk(ang)) < 1e-15


def test_p_A_p_round_trip(rng):
    p = random_p(5000, rng)
    q = R.p_from_A(R.A_from_p(p))
    assert same_up_to_sign(p, q) < 1e-14
    assert np.all(q[:, 0] >= 0)
    assert max_err(np.linalg.norm(q, axis=1), 1.0) < 1e-15


def test_p_from_A_180_degrees_and_identity(rng):
    e = rng.standard_normal((1000, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    e[:3] = np.eye(3)  # rotations by pi about the coordinate axes
    p = np.concatenate([np.zeros((1000, 1)), e], axis=1)
    assert same_up_to_sign(p, R.p_from_A(R.A_from_p(p))) < 1e-14
    # nearly 180 degrees
    p2 = R.p_from_axis_angle(e, np.pi - 1e-9)
    assert same_up_to_sign(p2, R.p_from_A(R.A_from_p(p2))) < 1e-14
    assert max_err(R.p_from_A(np.eye(3)), [1, 0, 0, 0]) == 0.0
    assert R.p_from_A(np.eye(3)[None, None]).shape == (1, 1, 4)


# ----------------------------------------------------------------------------------------------
# Chapter 4: zxz Euler angles
# ----------------------------------------------------------------------------------------------


def test_zxz_matches_elementary_product(rng):
    ang = rng.uniform(-4, 4, (50, 3))
    A = R.A_from_euler_zxz(ang)
    for a, Ai in zip(ang, A):
        assert max_err(Ai, zxz_product(*a)) < 1e-15
        assert max_err(Ai, Rz(a[0]) @ Rx(a[1]) @ Rz(a[2])) < 1e-15
    assert max_err(R.A_from_p(R.p_from_euler_zxz(ang)), A) < 1e-14


def test_zxz_round_trip_random(rng):
    A = random_rotations(5000, rng)
    ang = R.euler_zxz_from_A(A)
    assert max_err(R.A_from_euler_zxz(ang), A) < 1e-14
    assert np.all((ang[:, 1] >= 0) & (ang[:, 1] <= np.pi))
    assert np.all(np.abs(ang[:, [0, 2]]) <= np.pi)
    # angles in the canonical range are recovered
    ang0 = np.column_stack([rng.uniform(-3, 3, 2000), rng.uniform(0.1, 3.0, 2000),
                            rng.uniform(-3, 3, 2000)])
    assert max_err(R.euler_zxz_from_A(R.A_from_euler_zxz(ang0)), ang0) < 1e-12
    assert max_err(R.euler_zxz_from_p(R.p_from_euler_zxz(ang0)), ang0) < 1e-12
    p = random_p(2000, rng)
    assert same_up_to_sign(R.p_from_euler_zxz(R.euler_zxz_from_p(p)), p) < 1e-14
    assert max_err(R.euler_zxz_from_p(-p), R.euler_zxz_from_p(p)) < 1e-12


@pytest.mark.parametrize("theta", [0.0, np.pi])
def test_zxz_exactly_singular(rng, theta):
    n = 500
    ang = np.column_stack([rng.uniform(-3, 3, n), np.full(n, theta), rng.uniform(-3, 3, n)])
    A = R.A_from_euler_zxz(ang)
    out = R.euler_zxz_from_A(A)
    assert max_err(R.A_from_euler_zxz(out), A) < 1e-14
    # convention: sigma = 0, psi = psi + sigma (theta = 0) or psi - sigma (theta = pi)
    assert np.all(out[:, 2] == 0.0)
    combined = ang[:, 0] + ang[:, 2] if theta == 0.0 else ang[:, 0] - ang[:, 2]
    assert max_err(np.angle(np.exp(1j * (out[:, 0] - combined))), 0.0) < 1e-13
    assert max_err(out[:, 1], theta) < 1e-15
    # from Euler parameters too, and from (4.3)
    outp = R.euler_zxz_from_p(R.p_from_euler_zxz(ang))
    assert max_err(R.A_from_euler_zxz(outp), A) < 1e-14
    assert np.all(outp[:, 2] == 0.0)
    if theta == 0.0:
        s = ang[:, 0] + ang[:, 2]
        A43 = np.zeros((n, 3, 3))
        A43[:, 0, 0] = A43[:, 1, 1] = np.cos(s)
        A43[:, 0, 1], A43[:, 1, 0] = -np.sin(s), np.sin(s)
        A43[:, 2, 2] = 1.0
        assert max_err(A43, A) < 1e-15


@pytest.mark.parametrize("theta", [1e-9, 1e-12, 1e-13, 2e-14, np.pi - 1e-9, np.pi - 1e-12,
                                   np.pi - 1e-13, 3e-16])
def test_zxz_near_singular(rng, theta):
    n = 500
    ang = np.column_stack([rng.uniform(-3, 3, n), np.full(n, theta), rng.uniform(-3, 3, n)])
    A = R.A_from_euler_zxz(ang)
    out = R.euler_zxz_from_A(A)
    assert max_err(R.A_from_euler_zxz(out), A) < 1e-14
    assert max_err(out[:, 1], theta) < 1e-15
    p = R.p_from_euler_zxz(ang)
    assert same_up_to_sign(R.p_from_euler_zxz(R.euler_zxz_from_p(p)), p) < 1e-15


# ----------------------------------------------------------------------------------------------
# Chapter 4: Bryant angles
# ----------------------------------------------------------------------------------------------


def test_bryant_matches_elementary_product(rng):
    ang = rng.uniform(-4, 4, (50, 3))
    A = R.A_from_bryant(ang)
    for a, Ai in zip(ang, A):
        assert max_err(Ai, bryant_product(*a)) < 1e-15
        assert max_err(Ai, Rx(a[0]) @ Ry(a[1]) @ Rz(a[2])) < 1e-15
    assert max_err(R.A_from_p(R.p_from_bryant(ang)), A) < 1e-14


def test_bryant_round_trip_random(rng):
    A = random_rotations(5000, rng)
    ang = R.bryant_from_A(A)
    assert max_err(R.A_from_bryant(ang), A) < 1e-14
    assert np.all(np.abs(ang[:, 1]) <= np.pi / 2)
    assert np.all(np.abs(ang[:, [0, 2]]) <= np.pi)
    ang0 = np.column_stack([rng.uniform(-3, 3, 2000), rng.uniform(-1.5, 1.5, 2000),
                            rng.uniform(-3, 3, 2000)])
    assert max_err(R.bryant_from_A(R.A_from_bryant(ang0)), ang0) < 1e-12
    assert max_err(R.bryant_from_p(R.p_from_bryant(ang0)), ang0) < 1e-12
    p = random_p(2000, rng)
    assert same_up_to_sign(R.p_from_bryant(R.bryant_from_p(p)), p) < 1e-14
    assert max_err(R.bryant_from_p(-p), R.bryant_from_p(p)) < 1e-12


@pytest.mark.parametrize("phi2", [np.pi / 2, -np.pi / 2])
def test_bryant_exactly_singular(rng, phi2):
    n = 500
    ang = np.column_stack([rng.uniform(-3, 3, n), np.full(n, phi2), rng.uniform(-3, 3, n)])
    A = R.A_from_bryant(ang)
    out = R.bryant_from_A(A)
    assert max_err(R.A_from_bryant(out), A) < 1e-14
    assert np.all(out[:, 2] == 0.0)
    combined = ang[:, 0] + ang[:, 2] if phi2 > 0 else ang[:, 0] - ang[:, 2]
    assert max_err(np.angle(np.exp(1j * (out[:, 0] - combined))), 0.0) < 1e-13
    assert max_err(out[:, 1], phi2) < 1e-15
    outp = R.bryant_from_p(R.p_from_bryant(ang))
    assert max_err(R.A_from_bryant(outp), A) < 1e-14
    assert np.all(outp[:, 2] == 0.0)
    if phi2 > 0:  # Eq. (4.6)
        s = ang[:, 0] + ang[:, 2]
        A46 = np.zeros((n, 3, 3))
        A46[:, 0, 2] = 1.0
        A46[:, 1, 0], A46[:, 1, 1] = np.sin(s), np.cos(s)
        A46[:, 2, 0], A46[:, 2, 1] = -np.cos(s), np.sin(s)
        assert max_err(A46, A) < 1e-15


@pytest.mark.parametrize("phi2", [np.pi / 2 - 1e-9, -np.pi / 2 + 1e-9, np.pi / 2 - 1e-12,
                                  -np.pi / 2 + 1e-12, np.pi / 2 - 1e-13, -np.pi / 2 + 3e-14,
                                  1e-300])
def test_bryant_near_singular(rng, phi2):
    n = 500
    ang = np.column_stack([rng.uniform(-3, 3, n), np.full(n, phi2), rng.uniform(-3, 3, n)])
    A = R.A_from_bryant(ang)
    out = R.bryant_from_A(A)
    assert max_err(R.A_from_bryant(out), A) < 1e-14
    assert max_err(out[:, 1], phi2) < 1e-15
    p = R.p_from_bryant(ang)
    assert same_up_to_sign(R.p_from_bryant(R.bryant_from_p(p)), p) < 1e-15


def test_angle_batch_shapes(rng):
    ang = rng.uniform(-1, 1, (2, 3, 3))
    assert R.A_from_euler_zxz(ang).shape == (2, 3, 3, 3)
    assert R.euler_zxz_from_A(R.A_from_euler_zxz(ang)).shape == (2, 3, 3)
    assert R.bryant_from_p(R.p_from_bryant(ang)).shape == (2, 3, 3)
    assert R.euler_zxz_from_p([1.0, 0, 0, 0]).shape == (3,)
    assert max_err(R.bryant_from_A(np.eye(3)), 0.0) == 0.0
    assert max_err(R.euler_zxz_from_A(np.eye(3)), 0.0) == 0.0


# ----------------------------------------------------------------------------------------------
# Chapter 4: axis and angle
# ----------------------------------------------------------------------------------------------


def test_axis_angle_round_trip(rng):
    u = rng.standard_normal((3000, 3))
    ang = rng.uniform(0, np.pi, 3000)
    p = R.p_from_axis_angle(3.7 * u, ang)  # non-unit axis
    assert max_err(np.linalg.norm(p, axis=1), 1.0) < 1e-15
    unit = u / np.linalg.norm(u, axis=1, keepdims=True)
    assert max_err(p, R.p_from_rotation_vector(ang[:, None] * unit)) < 1e-15
    ax, a = R.axis_angle_from_p(p)
    assert max_err(a, ang) < 1e-14
    assert max_err(ax, u / np.linalg.norm(u, axis=1, keepdims=True)) < 1e-14
    ax2, a2 = R.axis_angle_from_p(-p)
    assert max_err(a2, ang) < 1e-14 and max_err(ax2, ax) < 1e-14
    # rotation angles in (pi, 2 pi) are reported as 2 pi - angle about -u
    ax3, a3 = R.axis_angle_from_p(R.p_from_axis_angle(u, 2 * np.pi - ang))
    assert max_err(a3, ang) < 1e-13 and max_err(ax3, -ax) < 1e-13


@pytest.mark.parametrize("angle", [1e-300, 1e-12, 1e-8, np.pi - 1e-8, np.pi - 1e-12, np.pi])
def test_axis_angle_extreme_angles(angle):
    u = np.array([0.2, -0.6, 0.5])
    u /= np.linalg.norm(u)
    ax, a = R.axis_angle_from_p(R.p_from_axis_angle(u, angle))
    assert abs(a - angle) <= 4e-16 * angle  # relative accuracy, also for tiny angles
    assert max_err(ax, u) < 1e-15


def test_axis_angle_zero_and_errors():
    ax, a = R.axis_angle_from_p([1.0, 0, 0, 0])
    assert a == 0.0 and max_err(ax, [1, 0, 0]) == 0.0
    ax, a = R.axis_angle_from_p([-1.0, 0, 0, 0])
    assert a == 0.0 and max_err(ax, [1, 0, 0]) == 0.0
    with pytest.raises(ValueError):
        R.p_from_axis_angle([0.0, 0.0, 0.0], 1.0)
    with pytest.raises(ValueError):
        R.p_from_axis_angle([[1.0, 0, 0], [0, 0, 0]], [1.0, 2.0])
    # tiny and huge (but non-zero) axes are fine
    for scale in (1e-200, 1e200):
        assert max_err(R.p_from_axis_angle([0, 0, scale], np.pi / 2),
                       [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]) < 1e-16
    assert max_err(R.p_from_axis_angle([0, 0, 2.0], 0.0), [1, 0, 0, 0]) == 0.0
    # broadcasting: one axis, several angles
    assert R.p_from_axis_angle([0, 1.0, 0], np.zeros((2, 5))).shape == (2, 5, 4)
    ax, a = R.axis_angle_from_p(np.tile([1.0, 0, 0, 0], (2, 3, 1)))
    assert ax.shape == (2, 3, 3) and a.shape == (2, 3)


# ----------------------------------------------------------------------------------------------
# Chapter 5: G, L identities
# ----------------------------------------------------------------------------------------------


def test_G_L_identities(rng):
    p = random_p(3000, rng)
    G, L = R.G_matrix(p), R.L_matrix(p)
    GT, LT = np.swapaxes(G, -1, -2), np.swapaxes(L, -1, -2)
    assert max_err(G @ p[..., None], 0.0) < 1e-15
    assert max_err(L @ p[..., None], 0.0) < 1e-15
    assert max_err(G @ GT, np.eye(3)) < 1e-14
    assert max_err(L @ LT, np.eye(3)) < 1e-14
    assert max_err(GT @ G + p[:, :, None] * p[:, None, :], np.eye(4)) < 1e-14
    assert max_err(G @ LT, R.A_from_p(p)) < 1e-14
    # G = [-e, e~ + e0 I], L = [-e, -e~ + e0 I]
    e0, e = p[:, 0, None, None], p[:, 1:]
    assert max_err(G[:, :, 1:], R.skew(e) + e0 * np.eye(3)) == 0.0
    assert max_err(L[:, :, 1:], -R.skew(e) + e0 * np.eye(3)) == 0.0
    assert max_err(G[:, :, 0], -e) == 0.0 and max_err(L[:, :, 0], -e) == 0.0


def test_omega_pdot_maps(rng):
    p = random_p(3000, rng)
    w = rng.standard_normal((3000, 3))
    pd = R.pdot_from_omega(p, w)
    assert max_err(np.sum(p * pd, axis=1), 0.0) < 1e-15  # p^T pdot = 0
    assert max_err(R.omega_from_pdot(p, pd), w) < 1e-14
    assert max_err(pd, 0.5 * np.einsum("nji,nj->ni", R.G_matrix(p), w)) < 1e-15
    wl = np.einsum("nji,nj->ni", R.A_from_p(p), w)  # omega' = A^T omega
    assert max_err(R.omega_local_from_pdot(p, pd), wl) < 1e-14
    assert max_err(R.pdot_from_omega_local(p, wl), pd) < 1e-14
    LTw = 0.5 * np.einsum("nji,nj->ni", R.L_matrix(p), wl)
    assert max_err(R.pdot_from_omega_local(p, wl), LTw) < 1e-15
    # Gdot pdot = 0 and Ldot pdot = 0, identically in pdot
    pd_any = rng.standard_normal((3000, 4))
    for q in (pd, pd_any):
        assert max_err(np.einsum("nij,nj->ni", R.G_dot(q), q), 0.0) < 1e-15
        assert max_err(np.einsum("nij,nj->ni", R.L_dot(q), q), 0.0) < 1e-15
    # pdot^T pdot = omega^T omega / 4
    assert max_err(np.sum(pd * pd, axis=1), 0.25 * np.sum(w * w, axis=1)) < 1e-14


def test_batch_shapes_chapter5(rng):
    p = random_p(6, rng).reshape(2, 3, 4)
    w = rng.standard_normal((2, 3, 3))
    pd = R.pdot_from_omega_local(p, w)
    assert pd.shape == (2, 3, 4)
    assert R.omega_local_from_pdot(p, pd).shape == (2, 3, 3)
    assert R.pddot_from_omegadot(p, pd, w).shape == (2, 3, 4)
    assert R.pddot_from_omegadot_local(p, pd, w).shape == (2, 3, 4)
    assert R.omegadot_from_pddot(p, pd, pd).shape == (2, 3, 3)
    assert R.omegadot_local_from_pddot(p, pd, pd).shape == (2, 3, 3)


# ----------------------------------------------------------------------------------------------
# Chapter 5: finite differences along a smooth path p(t)
# ----------------------------------------------------------------------------------------------


def test_Adot_omega_finite_differences():
    t = TIMES
    p = p_path(t)
    pd = d1(p_path, t)
    assert max_err(np.sum(p * pd, axis=1), 0.0) < 1e-10  # p^T pdot = 0 along the motion
    A = R.A_from_p(p)
    Ad = d1(lambda s: R.A_from_p(p_path(s)), t)
    w = R.omega_from_pdot(p, pd)
    wl = R.omega_local_from_pdot(p, pd)
    scale = np.max(np.abs(Ad))
    assert scale > 0.5
    # (5.2): Adot = omega~ A = A omega'~
    assert max_err(Ad, R.skew(w) @ A) < 1e-9
    assert max_err(Ad, A @ R.skew(wl)) < 1e-9
    # (5.3): omega~ = Adot A^T, omega'~ = A^T Adot
    AT = np.swapaxes(A, -1, -2)
    assert max_err(vee(Ad @ AT), w) < 1e-9
    assert max_err(vee(AT @ Ad), wl) < 1e-9
    # omega' = A^T omega
    assert max_err(np.einsum("nji,nj->ni", A, w), wl) < 1e-13
    # pdot recovered from omega (5.12), (5.16)
    assert max_err(R.pdot_from_omega(p, w), pd) < 1e-10
    assert max_err(R.pdot_from_omega_local(p, wl), pd) < 1e-10


def test_angular_acceleration_finite_differences():
    t = TIMES
    p = p_path(t)
    pd = d1(p_path, t)
    pdd = d2(p_path, t)

    def w_of(s):
        return R.omega_from_pdot(p_path(s), d1(p_path, s))

    def wl_of(s):
        return R.omega_local_from_pdot(p_path(s), d1(p_path, s))

    wd = d1(w_of, t, h=2e-3)
    wld = d1(wl_of, t, h=2e-3)
    assert np.max(np.abs(wd)) > 0.5
    # (5.19), (5.20)
    assert max_err(R.omegadot_from_pddot(p, pd, pdd), wd) < 1e-7
    assert max_err(R.omegadot_local_from_pddot(p, pd, pdd), wld) < 1e-7
    # omegadot' = A^T omegadot
    assert max_err(np.einsum("nji,nj->ni", R.A_from_p(p), wd), wld) < 1e-7
    # (5.21), (5.22)
    assert max_err(R.pddot_from_omegadot(p, pd, wd), pdd) < 1e-7
    assert max_err(R.pddot_from_omegadot_local(p, pd, wld), pdd) < 1e-7
    # the printed forms with -1/4 (omega^T omega) p agree
    w = R.omega_from_pdot(p, pd)
    G = R.G_matrix(p)
    printed = 0.5 * np.einsum("nji,nj->ni", G, wd) - 0.25 * np.sum(w * w, axis=1)[:, None] * p
    assert max_err(printed, pdd) < 1e-7
    # (5.18) with the Gdot pdot term (null) and d2(p^T p)/dt^2 = 0
    assert max_err(2 * np.einsum("nij,nj->ni", R.G_dot(pd), pd), 0.0) < 1e-15
    out = R.pddot_from_omegadot(p, pd, wd)
    assert max_err(np.sum(p * out, axis=1) + np.sum(pd * pd, axis=1), 0.0) < 1e-14


def test_pddot_omegadot_inverse(rng):
    p = random_p(2000, rng)
    pd = R.pdot_from_omega(p, rng.standard_normal((2000, 3)))
    wd = rng.standard_normal((2000, 3))
    pdd = R.pddot_from_omegadot(p, pd, wd)
    assert max_err(R.omegadot_from_pddot(p, pd, pdd), wd) < 1e-14
    pdd_l = R.pddot_from_omegadot_local(p, pd, wd)
    assert max_err(R.omegadot_local_from_pddot(p, pd, pdd_l), wd) < 1e-14
