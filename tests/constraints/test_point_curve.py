"""Point on a curve (constraints.point_curve): the kernels against finite differences, a cam
and its follower against the profile's spline (SciPy's, an independent implementation), the
follower's normal force against Newton's law and its lift-off, a bead on a wire (energy,
small-oscillation frequency), model files and bad input."""
import math
import zlib

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from spatialmbd import ModelBuilder, ModelError, models
from spatialmbd.constraints import JOINT_TYPES, JointGeometry
from spatialmbd.constraints.point_curve import lift_off_intervals, normal_force
from spatialmbd.io.modelfile import ModelFileError, load_model, model_to_dict
from spatialmbd.kinematics import kinematic_analysis
from spatialmbd.rotations import A_from_p
from spatialmbd.simulate import simulate

from fd_check import derivative_errors, random_geometry, random_state

PAIRS = np.array([[0, 1], [1, 2], [3, 0], [2, 3]])      # body 3 = ground


def _group(rng, name):
    cls = JOINT_TYPES[name]
    geom = random_geometry(rng, len(PAIRS), 1)
    params = []
    for _ in PAIRS:
        if name == "point_on_curve":
            n = int(rng.integers(2, 12))
            given = dict(x_start=rng.uniform(-2, 0), x_step=rng.uniform(0.2, 0.6),
                         heights=list(rng.normal(size=n)))
        else:
            given = dict(radii=list(rng.uniform(0.5, 1.5, int(rng.integers(1, 12)))))
        params.append(cls.resolve_parameters(given, None, None, "j"))
    geom = JointGeometry(geom.s_i, geom.s_j, geom.R_i, geom.R_j, np.array(params))
    return cls([f"c{k}" for k in range(len(PAIRS))], PAIRS[:, 0], PAIRS[:, 1], geom)


def _plane_radius(group, q0):
    """Distance of each follower point from its curve frame's origin, in the curve plane."""
    q = np.vstack([q0, [0, 0, 0, 1, 0, 0, 0]])
    out = []
    for k, (i, j) in enumerate(PAIRS):
        g = group.geometry
        d = (q[j, :3] + A_from_p(q[j, 3:]) @ g.s_j[k] - q[i, :3] - A_from_p(q[i, 3:]) @ g.s_i[k])
        T = A_from_p(q[i, 3:]) @ g.R_i[k]
        out.append(math.hypot(T[:, 1] @ d, T[:, 2] @ d))
    return np.array(out)


@pytest.mark.parametrize("name", ["point_on_curve", "point_on_cam"])
def test_kernels_match_finite_differences(name):
    """Random states, on and off the curve. The splines are C2 only: a stencil across a knot
    sees the jump of the third derivative, an error O(h) in the second difference, hence the
    small step h = 1e-4 (with h = 1e-3 a few draws reach 1e-4 relative for that reason)."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    for _ in range(15):
        group = _group(rng, name)
        while True:
            q0, v = random_state(rng, 3)
            if _plane_radius(group, q0).min() > 0.3:      # the cam's rho away from 0
                break
        e1, e2, scale = derivative_errors(group, q0, v, t0=0.0, h=1e-4)
        assert e1 < 1e-8 * scale and e2 < 1e-6 * scale, (e1, e2, scale)


def _profile_spline():
    radii = models.cam_profile()
    theta = 2 * np.pi * np.arange(len(radii) + 1) / len(radii)
    return CubicSpline(theta, radii + radii[:1], bc_type="periodic")


def test_cam_follower_kinematics_follow_the_profile():
    """Drive the follower too (its height from the profile is the only DoF the cam leaves, so
    the kinematic analysis needs the cam driver only): y = r(pi/2 - w t), ydot = -w r',
    yddot = w^2 r'' with SciPy's periodic spline through the same radii."""
    w = 20.0
    model = models.cam_follower(speed=w).compile()
    t = np.linspace(0.0, 2 * np.pi / w, 181)
    kin = kinematic_analysis(model, t)
    r = _profile_spline()
    theta = np.pi / 2 - w * t
    y, ydot, yddot = kin.q[:, 1, 1], kin.v[:, 1, 1], kin.vdot[:, 1, 1]
    assert np.abs(y - r(theta % (2 * np.pi))).max() < 1e-10
    assert np.abs(ydot + w * r(theta % (2 * np.pi), 1)).max() < 1e-8
    assert np.abs(yddot - w * w * r(theta % (2 * np.pi), 2)).max() < 1e-6 * w * w


def _closed_form_normal_force(t, w, m=0.5, k=500.0, preload=10.0):
    """Follower along y: m yddot = F_spring + N n_y (the guide takes no force along y), with
    the outward profile normal n rotated by the cam angle w t."""
    r = _profile_spline()
    th = (np.pi / 2 - w * t) % (2 * np.pi)
    R, R1, R2 = r(th), r(th, 1), r(th, 2)
    yddot = w * w * R2
    r0 = r(np.pi / 2)
    l0 = 0.2 - r0 + preload / k
    spring = k * (0.2 - R - l0)                     # tension k (l - l0) pulls the tip to +y
    # outward normal in cam axes: perpendicular to the tangent (r' c - r s, r' s + r c)
    tx, ty = R1 * np.cos(th) - R * np.sin(th), R1 * np.sin(th) + R * np.cos(th)
    nx, ny = ty, -tx                                # turned -90 deg: outward for rising theta
    norm = np.hypot(nx, ny)
    phi = w * t                                     # cam angle: cam axes -> global
    n_y = (np.sin(phi) * nx + np.cos(phi) * ny) / norm
    return (m * yddot - spring) / n_y


@pytest.mark.parametrize("w", [20.0, 30.0])
def test_normal_force_and_lift_off(w):
    model = models.cam_follower(speed=w).compile()
    res = simulate(model, 2 * np.pi / w, method="projection", rtol=1e-9, atol=1e-11,
                   output_step=np.pi / w / 90)
    assert res.success, res.message
    N = normal_force(res, "contact")
    ref = _closed_form_normal_force(res.t, w)
    assert np.abs(N - ref).max() < 1e-5 * np.abs(ref).max()
    spans = lift_off_intervals(res.t, N)
    if w == 20.0:
        assert N.min() > 0 and spans == []           # held on by the spring all round
    else:
        fine = np.linspace(0, 2 * np.pi / w, 20001)
        expected = lift_off_intervals(fine, _closed_form_normal_force(fine, w))
        assert len(spans) == len(expected) >= 1
        for (a, b), (c, d) in zip(spans, expected):
            assert abs(a - c) < 2e-4 and abs(b - d) < 2e-4


def test_bead_on_wire_conserves_energy_and_oscillates_at_sqrt_g_kappa():
    x0 = -0.05                                       # small amplitude about the bottom
    model = models.bead_on_wire(x0=x0).compile()
    res = simulate(model, 3.0, method="projection", rtol=1e-10, atol=1e-12, output_step=0.001)
    assert res.success, res.message
    assert np.abs(res.energy()["error"]).max() < 1e-9
    xs = np.linspace(-1, 1, 9)
    h2 = CubicSpline(xs, 0.5 * xs ** 2, bc_type="natural")(0.0, 2)
    x = res.q[:, 0, 0]
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))         # upward zero crossings
    tc = res.t[up] - x[up] * (res.t[up + 1] - res.t[up]) / (x[up + 1] - x[up])
    period = np.diff(tc).mean()
    # amplitude 0.05: the period exceeds the linear one by O(amplitude^2) (a few 1e-3 here)
    assert period == pytest.approx(2 * np.pi / np.sqrt(9.81 * h2), rel=5e-3)
    # the bead stays on the wire: y = 0 and z = h(x)
    assert np.abs(res.q[:, 0, 1]).max() < 1e-10
    h = CubicSpline(xs, 0.5 * xs ** 2, bc_type="natural")
    assert np.abs(res.q[:, 0, 2] - h(x)).max() < 1e-9


def test_model_file_round_trip_and_errors(tmp_path):
    from spatialmbd.io.modelfile import save_model
    path = save_model(models.cam_follower(), tmp_path / "cam.yaml")
    model, _ = load_model(path)
    assert model_to_dict(model) == model_to_dict(models.cam_follower().compile())
    text = path.read_text()
    data = model_to_dict(models.bead_on_wire().compile())
    cases = [({"heights": [0.1]}, "at least 2 heights"),
             ({"heights": list(range(70))}, "1 to 64 numbers"),
             ({"heights": "flat"}, "list of 1 to 64"),
             ({"x_step": -0.1}, "must be > 0")]
    for change, match in cases:
        d = {**data, "joints": [dict(data["joints"][0], **change)]}
        with pytest.raises((ModelFileError, ModelError), match=match):
            load_model(d)
    d = {**data, "joints": [dict(data["joints"][0], type="point_on_cam",
                                 radii=[0.1, -0.2, 0.1])]}
    for key in ("x_start", "x_step", "heights"):
        d["joints"][0].pop(key)
    with pytest.raises(ModelFileError, match=r"radii\[1\]|radii.*1.*> 0"):
        load_model(d)
    assert "point_on_cam" in text


def test_builder_rejects_bad_lists():
    b = ModelBuilder("x")
    b.add_body("a", 1.0, (1, 1, 1))
    with pytest.raises(ModelError, match=r"radii\[1\]: must be positive"):
        b.add_joint("point_on_cam", "c", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1),
                    point2=(0.1, 0, 0), radii=[0.1, -0.1])
    with pytest.raises(ModelError, match="1 to 64 numbers"):
        b.add_joint("point_on_cam", "c", "ground", "a", point=(0, 0, 0), axis=(0, 0, 1),
                    point2=(0.1, 0, 0), radii=[0.1] * 65)


# ------------------------------------------------------------------------------ surfaces
def _surface_group(rng):
    cls = JOINT_TYPES["point_on_surface"]
    geom = random_geometry(rng, len(PAIRS), 1)
    params = []
    for _ in PAIRS:
        nx, ny = int(rng.integers(2, 6)), int(rng.integers(2, 6))
        given = dict(x_start=rng.uniform(-2, 0), x_step=rng.uniform(0.3, 0.8),
                     y_start=rng.uniform(-2, 0), y_step=rng.uniform(0.3, 0.8), nx=nx,
                     heights=list(rng.normal(size=nx * ny)))
        params.append(cls.resolve_parameters(given, None, None, "j"))
    geom = JointGeometry(geom.s_i, geom.s_j, geom.R_i, geom.R_j, np.array(params))
    return cls([f"s{k}" for k in range(len(PAIRS))], PAIRS[:, 0], PAIRS[:, 1], geom)


def test_surface_kernel_matches_finite_differences():
    rng = np.random.default_rng(zlib.crc32(b"point_on_surface"))
    for _ in range(15):
        group = _surface_group(rng)
        q0, v = random_state(rng, 3)
        e1, e2, scale = derivative_errors(group, q0, v, t0=0.0, h=1e-4)
        assert e1 < 1e-8 * scale and e2 < 1e-6 * scale, (e1, e2, scale)


def test_surface_spline_equals_scipy_tensor_product():
    """The natural bicubic spline in moment form against nested SciPy natural splines (rows
    along x, then along y), inside the grid and beyond its edges, with derivatives."""
    from spatialmbd.constraints.point_curve import PointOnSurface, surface_eval
    rng = np.random.default_rng(3)
    nx, ny = 5, 4
    xs, ys = -0.5 + 0.4 * np.arange(nx), 0.2 + 0.3 * np.arange(ny)
    Z = rng.normal(size=(ny, nx))
    P = PointOnSurface.resolve_parameters(dict(x_start=-0.5, x_step=0.4, y_start=0.2,
                                               y_step=0.3, nx=nx, heights=list(Z.ravel())),
                                          None, None, "s")
    for x, y in rng.uniform([-0.8, 0.0], [1.5, 1.3], size=(25, 2)):
        def along_y(order_x):
            vals = [CubicSpline(xs, Z[j], bc_type="natural")(x, order_x)
                    if xs[0] <= x <= xs[-1] else _linear(xs, Z[j], x, order_x)
                    for j in range(ny)]
            return vals
        ref = {}
        for ox in (0, 1, 2):
            vals = along_y(ox)
            for oy in (0, 1, 2):
                if ox + oy <= 2:
                    ref[ox, oy] = (CubicSpline(ys, vals, bc_type="natural")(y, oy)
                                   if ys[0] <= y <= ys[-1] else _linear(ys, vals, y, oy))
        h, hx, hy, hxx, hxy, hyy = surface_eval(P, x, y)
        got = {(0, 0): h, (1, 0): hx, (0, 1): hy, (2, 0): hxx, (1, 1): hxy, (0, 2): hyy}
        for key, value in got.items():
            assert value == pytest.approx(ref[key], abs=1e-12), (x, y, key)


def _linear(xs, vals, x, order):
    """A natural spline beyond its ends: the end value and slope continued (order 0, 1, 2)."""
    s = CubicSpline(xs, vals, bc_type="natural")
    end = xs[0] if x < xs[0] else xs[-1]
    return [s(end) + s(end, 1) * (x - end), s(end, 1), 0.0][order]


def test_ball_in_a_bowl_oscillates_at_sqrt_g_h_xx():
    """A particle on z = h(x, y) (h: x^2/2 + y^2 on a 7 x 7 grid) released at rest at
    (0.02, 0): energy conserved, y stays 0 by symmetry, and x oscillates at omega^2 = g h_xx(0,
    0) (the spline's own curvature, checked above against SciPy)."""
    from spatialmbd.constraints.point_curve import PointOnSurface, surface_eval
    g = 9.81
    xs = np.linspace(-1, 1, 7)
    X, Y = np.meshgrid(xs, xs)                         # rows at increasing y
    heights = list((0.5 * X ** 2 + Y ** 2).ravel())
    params = dict(x_start=-1.0, x_step=1 / 3, y_start=-1.0, y_step=1 / 3, nx=7, heights=heights)
    P = PointOnSurface.resolve_parameters(params, None, None, "bowl")
    x0 = 0.02
    z0 = surface_eval(P, x0, 0.0)[0]
    b = ModelBuilder("bowl", gravity=(0, 0, -g))
    b.add_body("ball", 0.1, (1e-5, 1e-5, 1e-5), r=(x0, 0.0, z0))
    b.add_joint("point_on_surface", "bowl", "ground", "ball", point=(0, 0, 0), axis=(0, 0, 1),
                reference=(1, 0, 0), point2=(x0, 0.0, z0), **params)
    res = simulate(b.compile(), 3.0, method="projection", rtol=1e-10, atol=1e-12,
                   output_step=0.001)
    assert res.success, res.message
    assert np.abs(res.energy()["error"]).max() < 1e-9
    assert np.abs(res.q[:, 0, 1]).max() < 1e-9
    x = res.q[:, 0, 0]
    cross = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))     # every half period
    tc = res.t[cross] - x[cross] * (res.t[cross + 1] - res.t[cross]) / (x[cross + 1] - x[cross])
    assert len(tc) >= 3
    hxx = surface_eval(P, 0.0, 0.0)[3]
    assert 2 * np.diff(tc).mean() == pytest.approx(2 * np.pi / np.sqrt(g * hxx), rel=5e-3)


def test_surface_grid_errors():
    b = ModelBuilder("x")
    b.add_body("a", 1.0, (1, 1, 1))
    for nx, match in [(4, "do not make a grid"), (2.5, "do not make a grid"),
                      (6, "at least 2 rows")]:
        with pytest.raises(ModelError, match=match):
            b.add_joint("point_on_surface", f"s{int(10 * nx)}", "ground", "a", point=(0, 0, 0),
                        axis=(0, 0, 1), point2=(0, 0, 0), x_step=0.1, y_step=0.1, nx=nx,
                        heights=[0.0] * 6)


def test_normal_force_on_a_surface_carries_the_weight_at_rest():
    """A particle resting at the bottom of a bowl: the surface pushes up with m g."""
    xs = np.linspace(-1, 1, 5)
    X, Y = np.meshgrid(xs, xs)
    params = dict(x_start=-1.0, x_step=0.5, y_start=-1.0, y_step=0.5, nx=5,
                  heights=list((X ** 2 + Y ** 2).ravel()))
    b = ModelBuilder("rest", gravity=(0, 0, -9.81))
    b.add_body("ball", 0.3, (1e-5, 1e-5, 1e-5), r=(0.0, 0.0, 0.0))
    b.add_joint("point_on_surface", "bowl", "ground", "ball", point=(0, 0, 0), axis=(0, 0, 1),
                reference=(1, 0, 0), point2=(0, 0, 0), **params)
    res = simulate(b.compile(), 0.2, rtol=1e-10, atol=1e-12, output_step=0.05)
    assert np.allclose(normal_force(res, "bowl"), 0.3 * 9.81, rtol=1e-9)
