"""Point on a curve or a surface of another body: a follower on a cam, a bead on a wire, a
ball on a height field.

The text's ch. 7 names the "sliding joint", a point of body j moving along a curve (or surface)
of body i, which brings the curve coordinate as an extra unknown (Adams' PTCV). Here the curve
coordinate is eliminated: the curve lies in the plane of the joint triad of body i (origin: the
joint point; x along a, y along b; u the plane's normal) and is given implicitly by f(x, y) = 0,
so the joint is two ordinary holonomic equations of the local coordinates of the point P of
body j,

    x = a_i . d,  y = b_i . d,  z = u_i . d,   d = r_j^P - r_i^O       (8.4)
    Phi_0 = f(x, y)                            (on the curve)
    Phi_1 = z                                  (in its plane)

with, by the chain rule and the product rule of :mod:`.primitives` (Kins of a_i, b_i, u_i, d),

    D_0     = f_x D_x + f_y D_y
    gamma_0 = -(f_x x''_quad + f_y y''_quad + [x' y'] H [x' y']^T),   H = the Hessian of f,

exact at every state (not only on the curve). One degree of freedom remains between the two
bodies' points (the motion along the curve) plus the rotations of body j, which a follower's
own joints remove.

Two curves, each a C2 cubic spline of values the user gives at equal steps (second derivatives
M computed once, when the model is compiled, and stored after the values in the parameter
block):

* ``point_on_curve``: the graph y = h(x) of a natural cubic spline through ``heights`` at
  x = x_start + k x_step (k = 0 .. N - 1), continued by its end tangents outside (M = 0 there,
  so the continuation is C2 too); f = y - h(x), f_x = -h', H_xx = -h''.
* ``point_on_cam``: the closed star-shaped profile rho = r(theta) of a periodic cubic spline
  through ``radii`` at theta = 2 pi k / N from the axis a towards b; f = rho - r(theta) with
  rho = sqrt(x^2 + y^2), theta = atan2(y, x):
      f_x = x / rho + r' y / rho^2,                f_y = y / rho - r' x / rho^2,
      H_xx = y^2 / rho^3 - r'' y^2 / rho^4 - 2 r' x y / rho^4,
      H_yy = x^2 / rho^3 - r'' x^2 / rho^4 + 2 r' x y / rho^4,
      H_xy = -x y / rho^3 + r'' x y / rho^4 - r' (y^2 - x^2) / rho^4.
  One radius is a circle. The point must stay away from the profile's centre (rho > 0).

The same construction gives a point on a surface, ``point_on_surface`` (Adams' PTSF), with one
equation Phi = z - h(x, y), h a natural bicubic spline through ``heights`` on a regular grid
(``nx`` values per row, rows at increasing y), in its moment form: the splines of the rows
along x (of the heights and of their second derivatives in y), then along y. With the gradient
(-h_x, -h_y, 1) and the Hessian -[h_ab]:

    D = D_z - h_x D_x - h_y D_y,
    gamma = -(z''_quad - h_x x''_quad - h_y y''_quad - [x' y'] [h_ab] [x' y']^T).

``point_on_curve`` has both equations (a bead on a wire). ``point_on_cam`` has only Phi_0: the
point lies on the cam's flank, the profile swept along u (a point on that surface), because
the follower's own joints already keep it in the cam's plane in every cam mechanism (with
Phi_1 too, the plane would be imposed twice, a redundant equation).

The joint is bilateral: the follower is held on the curve whatever the sign of the normal
reaction. Whether a real follower would lift off is read from that sign (the reaction along the
curve's normal, :func:`normal_force`, or ``Results.reactions``): a negative value is a pull that
a contact could not give.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..jit import njit
from .base import ConstraintType, Param, register
from .primitives import add_dot_row, clear_row, dot_gamma, dot_rate, dot_value, kin_sub, \
    point, put_dot, vector

#: the largest number of spline values of one curve
MAX_KNOTS = 64


# ------------------------------------------------------------------------------ splines
def natural_spline_moments(y: np.ndarray, h: float) -> np.ndarray:
    """Second derivatives M_k of the natural cubic spline through y at step h (M = 0 at both
    ends): M_{k-1} + 4 M_k + M_{k+1} = 6 (y_{k-1} - 2 y_k + y_{k+1}) / h^2."""
    n = y.size
    M = np.zeros(n)
    if n > 2:
        A = np.diag(np.full(n - 2, 4.0)) + np.diag(np.ones(n - 3), 1) + np.diag(np.ones(n - 3), -1)
        M[1:-1] = np.linalg.solve(A, 6.0 * (y[:-2] - 2.0 * y[1:-1] + y[2:]) / h**2)
    return M


def periodic_spline_moments(y: np.ndarray, h: float) -> np.ndarray:
    """Second derivatives of the periodic cubic spline through y (the same equations, indices
    modulo n)."""
    n = y.size
    A = np.zeros((n, n))
    rhs = np.empty(n)
    for k in range(n):
        for off, c in ((-1, 1.0), (0, 4.0), (1, 1.0)):
            A[k, (k + off) % n] += c
        rhs[k] = 6.0 * (y[(k - 1) % n] - 2.0 * y[k] + y[(k + 1) % n]) / h**2
    return np.linalg.solve(A, rhs)


@njit
def spline_eval(vals, moms, x0, h, x):
    """Value, first and second derivative at x of the natural cubic spline with values
    ``vals`` and second derivatives ``moms`` (1-D arrays of n >= 2) at x0 + k h, continued along
    its end tangents outside [x0, x0 + (n - 1) h]."""
    n = vals.size
    u = (x - x0) / h
    if u <= 0.0 or u >= n - 1:
        k = 0 if u <= 0.0 else n - 2
        t = 0.0 if u <= 0.0 else h
        val, d1, d2 = _cubic(vals[k], vals[k + 1], moms[k], moms[k + 1], t, h)
        end = x0 + (0.0 if u <= 0.0 else (n - 1) * h)
        # beyond the ends: value and slope continued; the curvature term of the moment there
        # (zero for a natural spline's values, not for derived arrays) is kept as well
        dx = x - end
        return val + d1 * dx + 0.5 * d2 * dx * dx, d1 + d2 * dx, d2
    k = min(int(u), n - 2)
    return _cubic(vals[k], vals[k + 1], moms[k], moms[k + 1], x - x0 - k * h, h)


@njit
def _cubic(y0, y1, M0, M1, t, h):
    s = h - t
    val = (M0 * s**3 + M1 * t**3) / (6.0 * h) + (y0 / h - M0 * h / 6.0) * s \
        + (y1 / h - M1 * h / 6.0) * t
    d1 = (-M0 * s * s + M1 * t * t) / (2.0 * h) - (y0 / h - M0 * h / 6.0) \
        + (y1 / h - M1 * h / 6.0)
    d2 = (M0 * s + M1 * t) / h
    return val, d1, d2


@njit
def graph_eval(P, x):
    """h(x), h'(x), h''(x) of the point_on_curve spline (P: the parameter row)."""
    n = int(P[2])
    v0, m0 = 3, 3 + MAX_KNOTS
    return spline_eval(P[v0:v0 + n], P[m0:m0 + n], P[0], P[1], x)


@njit
def cam_eval(P, theta):
    """r(theta), r', r'' of the point_on_cam periodic spline."""
    n = int(P[0])
    v0, m0 = 1, 1 + MAX_KNOTS
    if n == 1:
        return P[v0], 0.0, 0.0
    h = 2.0 * math.pi / n
    u = theta / h
    u -= n * math.floor(u / n)                    # into [0, n)
    k = min(int(u), n - 1)
    k1 = (k + 1) % n
    return _cubic(P[v0 + k], P[v0 + k1], P[m0 + k], P[m0 + k1], (u - k) * h, h)


# ------------------------------------------------------------------------------ kernels
@njit
def _plane_coordinates(S, G, k):
    """Kins of d, a_i, b_i, u_i, and x = a.d, y = b.d with their rates and quadratic parts."""
    i, j = G.bi[k], G.bj[k]
    d = kin_sub(point(S, j, G.s_j, k, 1), point(S, i, G.s_i, k, 0))
    u = vector(S, i, G.R_i, k, 0, 0)
    a = vector(S, i, G.R_i, k, 1, 0)
    b = vector(S, i, G.R_i, k, 2, 0)
    return d, u, a, b


@njit
def _curve_row(d, a, b, f, fx, fy, hxx, hxy, hyy, row, out):
    """Row of Phi = f(x, y) given f and its derivatives at (x, y)."""
    phi, D, nu, gamma = out
    xd, yd = dot_rate(a, d), dot_rate(b, d)
    qx, qy = -dot_gamma(a, d), -dot_gamma(b, d)
    phi[row] = f
    clear_row(D, row)
    add_dot_row(a, d, fx, D, row)
    add_dot_row(b, d, fy, D, row)
    nu[row] = 0.0
    gamma[row] = -(fx * qx + fy * qy + hxx * xd * xd + 2.0 * hxy * xd * yd + hyy * yd * yd)


@njit
def graph_kernel(S, G, k, row, out):
    d, u, a, b = _plane_coordinates(S, G, k)
    x, y = dot_value(a, d), dot_value(b, d)
    hv, h1, h2 = graph_eval(G.param[k], x)
    _curve_row(d, a, b, y - hv, -h1, 1.0, -h2, 0.0, 0.0, row, out)
    put_dot(u, d, out, row + 1)


@njit
def cam_kernel(S, G, k, row, out):
    d, u, a, b = _plane_coordinates(S, G, k)
    x, y = dot_value(a, d), dot_value(b, d)
    rho2 = x * x + y * y
    rho = math.sqrt(rho2)
    r, r1, r2 = cam_eval(G.param[k], math.atan2(y, x))
    rho3, rho4 = rho2 * rho, rho2 * rho2
    fx = x / rho + r1 * y / rho2
    fy = y / rho - r1 * x / rho2
    hxx = y * y / rho3 - r2 * y * y / rho4 - 2.0 * r1 * x * y / rho4
    hyy = x * x / rho3 - r2 * x * x / rho4 + 2.0 * r1 * x * y / rho4
    hxy = -x * y / rho3 + r2 * x * y / rho4 - r1 * (y * y - x * x) / rho4
    _curve_row(d, a, b, rho - r, fx, fy, hxx, hxy, hyy, row, out)


@njit
def surface_eval(P, x, y):
    """h, h_x, h_y, h_xx, h_xy, h_yy of the point_on_surface bicubic spline at (x, y): splines
    along x of every row (values and their y-moments), then along y (the tensor-product natural
    spline in its moment form)."""
    x0, hx, y0, hy, nx = P[0], P[1], P[2], P[3], int(P[4])
    n = int(P[5])
    ny = n // nx
    v0 = 6
    mx0, my0, mxy0 = v0 + MAX_KNOTS, v0 + 2 * MAX_KNOTS, v0 + 3 * MAX_KNOTS
    G, G1, G2 = np.empty(ny), np.empty(ny), np.empty(ny)
    H, H1, H2 = np.empty(ny), np.empty(ny), np.empty(ny)
    for j in range(ny):
        a, b = j * nx, (j + 1) * nx
        G[j], G1[j], G2[j] = spline_eval(P[v0 + a:v0 + b], P[mx0 + a:mx0 + b], x0, hx, x)
        H[j], H1[j], H2[j] = spline_eval(P[my0 + a:my0 + b], P[mxy0 + a:mxy0 + b], x0, hx, x)
    h, hy_, hyy = spline_eval(G, H, y0, hy, y)
    hx_, hxy, _ = spline_eval(G1, H1, y0, hy, y)
    hxx, _, _ = spline_eval(G2, H2, y0, hy, y)
    return h, hx_, hy_, hxx, hxy, hyy


@njit
def surface_kernel(S, G, k, row, out):
    """Phi = z - h(x, y): D = D_z - h_x D_x - h_y D_y, gamma with the Hessian -[h_ab]."""
    phi, D, nu, gamma = out
    d, u, a, b = _plane_coordinates(S, G, k)
    x, y, z = dot_value(a, d), dot_value(b, d), dot_value(u, d)
    h, hx, hy, hxx, hxy, hyy = surface_eval(G.param[k], x, y)
    xd, yd = dot_rate(a, d), dot_rate(b, d)
    qx, qy, qz = -dot_gamma(a, d), -dot_gamma(b, d), -dot_gamma(u, d)
    phi[row] = z - h
    clear_row(D, row)
    add_dot_row(u, d, 1.0, D, row)
    add_dot_row(a, d, -hx, D, row)
    add_dot_row(b, d, -hy, D, row)
    nu[row] = 0.0
    gamma[row] = -(qz - hx * qx - hy * qy
                   - (hxx * xd * xd + 2.0 * hxy * xd * yd + hyy * yd * yd))


# ------------------------------------------------------------------------------ types
class _PlanarCurve(ConstraintType):
    n_eq = 2
    eq_labels = ("curve", "plane")
    inputs = frozenset({"point", "axis", "point2"})

    @classmethod
    def param_columns(cls) -> int:
        return super().param_columns() + MAX_KNOTS    # + the spline's second derivatives


@register
class PointOnCurve(_PlanarCurve):
    """Point of body j on a planar curve y = h(x) of body i (a cubic spline through heights at
    equal steps), in the plane of body i's joint triad (x along its reference, u its normal)."""

    name = "point_on_curve"
    aliases = ("ptcv", "point_curve")
    parameters = (Param("x_start", "m", "x of the first height (along the reference)", 0.0),
                  Param("x_step", "m", "x step between the heights", positive=True),
                  Param("heights", "m", f"heights y of the curve (2 to {MAX_KNOTS} values, a "
                        "natural cubic spline; straight continuation beyond its ends)",
                        size=MAX_KNOTS))
    kernel = staticmethod(graph_kernel)

    @classmethod
    def resolve_parameters(cls, given, P_i, P_j, what):
        out = super().resolve_parameters(given, P_i, P_j, what)
        n = int(out[2])
        if n < 2:
            raise ModelError(f"{what}.heights: a curve needs at least 2 heights, got {n}")
        m0 = 3 + MAX_KNOTS
        out[m0:m0 + n] = natural_spline_moments(out[3:3 + n], out[1])
        return out


@register
class PointOnCam(_PlanarCurve):
    """Point of body j on the flank of a cam of body i: the closed profile rho = r(theta) (a
    periodic cubic spline through radii at equal angles from the reference) swept along the
    axis, one equation."""

    name = "point_on_cam"
    aliases = ("cam", "cam_follower")
    n_eq = 1
    eq_labels = ("profile",)
    parameters = (Param("radii", "m", f"profile radii at theta = 2 pi k / N, k = 0..N-1 (1 to "
                        f"{MAX_KNOTS} values; one value: a circle)", positive=True,
                        size=MAX_KNOTS),)
    kernel = staticmethod(cam_kernel)

    @classmethod
    def resolve_parameters(cls, given, P_i, P_j, what):
        out = super().resolve_parameters(given, P_i, P_j, what)
        n = int(out[0])
        m0 = 1 + MAX_KNOTS
        out[m0:m0 + n] = periodic_spline_moments(out[1:1 + n], 2.0 * math.pi / n)
        return out


@register
class PointOnSurface(ConstraintType):
    """Point of body j on a surface z = h(x, y) of body i (a bicubic spline through heights on
    a regular grid), in the axes of body i's joint triad (x along the reference, z along the
    axis)."""

    name = "point_on_surface"
    aliases = ("ptsf", "point_surface")
    n_eq = 1
    eq_labels = ("surface",)
    inputs = frozenset({"point", "axis", "point2"})
    parameters = (Param("x_start", "m", "x of the first grid column", 0.0),
                  Param("x_step", "m", "grid step along x", positive=True),
                  Param("y_start", "m", "y of the first grid row", 0.0),
                  Param("y_step", "m", "grid step along y", positive=True),
                  Param("nx", "-", "grid points along x (the heights are given row by row, nx "
                        "per row, rows at increasing y; at least 2 rows and columns)",
                        positive=True),
                  Param("heights", "m", f"heights z on the grid, row by row (at most "
                        f"{MAX_KNOTS} values: a natural bicubic spline, continued along its "
                        "edge tangent planes outside)", size=MAX_KNOTS))
    kernel = staticmethod(surface_kernel)

    @classmethod
    def param_columns(cls) -> int:
        return super().param_columns() + 3 * MAX_KNOTS   # moments in x, y and xy

    @classmethod
    def resolve_parameters(cls, given, P_i, P_j, what):
        out = super().resolve_parameters(given, P_i, P_j, what)
        nx, n = out[4], int(out[5])
        if nx != int(nx) or nx < 2 or n % int(nx) or n // int(nx) < 2:
            raise ModelError(f"{what}: {n} heights do not make a grid of nx = {nx:g} columns "
                             "and at least 2 rows; give nx (an integer >= 2) dividing the "
                             "number of heights")
        nx = int(nx)
        Z = out[6:6 + n].reshape(-1, nx)
        Mx = np.array([natural_spline_moments(row, out[1]) for row in Z])
        My = np.array([natural_spline_moments(col, out[3]) for col in Z.T]).T
        Mxy = np.array([natural_spline_moments(row, out[1]) for row in My])
        for k, M in enumerate((Mx, My, Mxy)):
            start = 6 + (k + 1) * MAX_KNOTS
            out[start:start + n] = M.ravel()
        return out


def curve_normal(group_or_model, joint: str, q: np.ndarray):
    """Unit normal (global axes) of the curve (or surface) of a point_on_curve / point_on_cam /
    point_on_surface joint at the follower point, for the state q (nb, 7) of a compiled model:
    the direction in which a positive normal force pushes body j away from the curve's inside
    (the side f > 0: above the graph or the height field, outside the cam)."""
    from ..rotations import A_from_p
    model = group_or_model
    kinds = ("point_on_curve", "point_on_cam", "point_on_surface")
    for g in model.constraint_groups:
        if joint in getattr(g, "names", ()) and g.name in kinds:
            k = g.names.index(joint)
            break
    else:
        raise ModelError(f"curve_normal: no {', '.join(kinds)} joint named {joint!r}")
    nb = model.nb
    bi, bj = int(g.body_i[k]), int(g.body_j[k])
    geo = g.geometry
    pose = (lambda b: (np.zeros(3), np.eye(3)) if b >= nb else
            (q[b, :3], A_from_p(q[b, 3:])))
    r_i, A_i = pose(bi)
    r_j, A_j = pose(bj)
    d = r_j + A_j @ geo.s_j[k] - r_i - A_i @ geo.s_i[k]
    T = A_i @ geo.R_i[k]                          # columns u, a, b in global axes
    x, y = T[:, 1] @ d, T[:, 2] @ d
    P = geo.param[k]
    if g.name == "point_on_surface":              # grad (z - h) = (-h_x, -h_y, 1)
        _, hx, hy, _, _, _ = surface_eval(P, x, y)
        n = T[:, 0] - hx * T[:, 1] - hy * T[:, 2]
        return n / np.linalg.norm(n)
    if g.name == "point_on_curve":
        _, h1, _ = graph_eval(P, x)
        fx, fy = -h1, 1.0
    else:
        rho2 = x * x + y * y
        rho = math.sqrt(rho2)
        _, r1, _ = cam_eval(P, math.atan2(y, x))
        fx, fy = x / rho + r1 * y / rho2, y / rho - r1 * x / rho2
    n = fx * T[:, 1] + fy * T[:, 2]
    return n / np.linalg.norm(n)


def normal_force(results, joint: str) -> np.ndarray:
    """(nt,) force (N) the curve of a point_on_curve / point_on_cam / point_on_surface joint
    exerts on the
    follower point along the curve's outward normal (:func:`curve_normal`): positive pushes the
    follower out of the profile (a contact can do that), negative pulls it in (a real follower
    would lift off there). ``results``: the Results of a run of the model."""
    reaction = results.reactions()[joint]
    n = np.array([curve_normal(results.model, joint, q) for q in results.q])
    return np.einsum("ti,ti->t", reaction.force_j, n)


def lift_off_intervals(t: np.ndarray, force: np.ndarray) -> list:
    """[(t_start, t_end), ...] where ``force`` (from :func:`normal_force`) is negative, the
    ends located by linear interpolation between the samples."""
    t, force = np.asarray(t, dtype=float), np.asarray(force, dtype=float)
    out, start = [], None
    for k in range(len(t)):
        neg = force[k] < 0
        if neg and start is None:
            start = t[0] if k == 0 else t[k - 1] + (t[k] - t[k - 1]) * force[k - 1] / (
                force[k - 1] - force[k])
        elif not neg and start is not None:
            out.append((start, t[k - 1] + (t[k] - t[k - 1]) * force[k - 1] / (
                force[k - 1] - force[k])))
            start = None
    if start is not None:
        out.append((start, t[-1]))
    return out
