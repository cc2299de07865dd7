"""Closed-form reference solutions used by the validation suite and the chapter 15 study.

Everything here is independent of the multibody code (plain NumPy/SciPy), so it can serve as
a reference for it. SciPy's ``ellipk(m)`` and ``ellipj(u, m)`` take the *parameter* m = k^2,
not the modulus k.

* :class:`PhysicalPendulum` - a rigid body turning about a fixed axis under uniform gravity,
  released from rest (large amplitude, Jacobi elliptic functions), with the full body motion
  (centre of mass, orientation, angular velocity and acceleration) and the joint reaction
  force and moment recovered from Newton-Euler.
* :class:`AxialMotion` - a rigid body guided along a fixed line (translational joint: sliding
  only; cylindrical joint: sliding and the physical pendulum about the line), released at rest.
* :class:`DistancePendulum` - a body held at its centre of mass by a massless link of fixed
  length to a fixed point (point-mass pendulum, the body not turning).
* :func:`symmetric_free_body` - torque-free axisymmetric body (body-axis angular velocity
  precessing at lambda = (I3 - I1)/I1 w3, orientation A(t) = R_h(|H|/I1 t) A0 R_3(-lambda t)).
* :class:`EulerFreeBody` - torque-free asymmetric body (Jacobi's solution of Euler's
  equations; intermediate-axis flips).
* :func:`heavy_top_steady_precession` - precession rate of a heavy symmetric top.
* :func:`rotating_pendulum` - I phi'' = K sin phi over the top (IFToMM A02 parallelogram).
* :func:`bicycle_eigenvalues` - eigenvalues of the lean and steer equations of the Whipple
  bicycle benchmark, M q'' + v C1 q' + (g K0 + v^2 K2) q = 0.
* :class:`NutatingTop` - the heavy symmetric top in general motion (nutation between the roots
  of the cubic of u = cos theta, Jacobi elliptic functions).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ellipj, ellipk


def rotation_matrix(axis, angle) -> np.ndarray:
    """Rodrigues: rotation by ``angle`` (rad, array (n,) or scalar) about the unit ``axis``."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
    ux = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return c * np.eye(3) + s * ux + (1 - c) * np.outer(u, u)


def quat_from_matrix(A: np.ndarray) -> np.ndarray:
    """Unit quaternion (e0, e1, e2, e3) of rotation matrices (..., 3, 3), e0 >= 0 (Shepperd)."""
    A = np.asarray(A, dtype=float)
    shape = A.shape[:-2]
    A = A.reshape(-1, 3, 3)
    out = np.empty((A.shape[0], 4))
    for n, R in enumerate(A):
        tr = np.trace(R)
        cand = np.array([tr, R[0, 0], R[1, 1], R[2, 2]])
        k = int(np.argmax(cand))
        if k == 0:
            e0 = 0.5 * np.sqrt(1 + tr)
            q = [e0, (R[2, 1] - R[1, 2]) / (4 * e0), (R[0, 2] - R[2, 0]) / (4 * e0),
                 (R[1, 0] - R[0, 1]) / (4 * e0)]
        else:
            i = k - 1
            j, l = (i + 1) % 3, (i + 2) % 3
            ei = 0.5 * np.sqrt(1 + 2 * R[i, i] - tr)
            q = [0.0] * 4
            q[1 + i] = ei
            q[0] = (R[l, j] - R[j, l]) / (4 * ei)
            q[1 + j] = (R[j, i] + R[i, j]) / (4 * ei)
            q[1 + l] = (R[l, i] + R[i, l]) / (4 * ei)
        q = np.array(q)
        out[n] = q if q[0] >= 0 else -q
    return out.reshape(shape + (4,))


def align_quaternion_sign(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """q (n, 4) with each row's sign flipped where it points away from ref (q and -q are the
    same rotation)."""
    s = np.sign(np.sum(q * ref, axis=-1))
    s[s == 0] = 1.0
    return q * s[..., None]


# --------------------------------------------------------------------------- physical pendulum
@dataclass
class PendulumMotion:
    """Exact motion at times t (arrays (nt,) or (nt, 3) / (nt, 3, 3), global axes)."""

    t: np.ndarray
    theta: np.ndarray          # angle from the downward direction (of g normal to the axis), rad
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    r: np.ndarray              # centre of mass
    rdot: np.ndarray
    rddot: np.ndarray
    A: np.ndarray              # body orientation (body -> global)
    omega: np.ndarray          # angular velocity
    omegadot: np.ndarray
    force_on_body: np.ndarray  # joint reaction force on the pendulum (R = m a - m g)
    moment_on_body: np.ndarray  # joint reaction moment on the pendulum about the pivot


def _body_data(obj, mass, inertia, r0, A0, point, g, axis=None) -> None:
    """The data of a body held at a fixed point P (or guided by the line through it along
    ``axis``) under gravity g, set on ``obj``: m, Jc (centroidal tensor), r0, A0, P, g, and
    with an axis its unit vector n."""
    obj.m = float(mass)
    J = np.asarray(inertia, dtype=float)
    obj.Jc = np.diag(J) if J.shape == (3,) else J
    obj.r0 = np.asarray(r0, dtype=float)
    obj.A0 = np.asarray(A0, dtype=float)
    obj.P = np.asarray(point, dtype=float)
    obj.g = np.asarray(g, dtype=float)
    if axis is not None:
        n = np.asarray(axis, dtype=float)
        obj.n = n / np.linalg.norm(n)


class PhysicalPendulum:
    """A rigid body turning about a fixed axis through ``pivot`` under uniform gravity ``g``,
    released from rest at t = 0 (exact large-amplitude solution).

    mass (kg), inertia: 3x3 centroidal tensor in body axes; r0, A0: initial centre of mass and
    orientation; axis: the fixed rotation axis (global). With n the unit axis, g_n = g - (g.n) n
    the gravity component normal to it, d the distance of the centre of mass from the axis and
    I_O = n^T J_O n the moment of inertia about the axis,
        I_O theta'' = -m |g_n| d sin theta,   omega0^2 = m |g_n| d / I_O,
    theta = the angle of the centre of mass from the direction of g_n, measured about
    w = g_hat x e_hat (e_hat completes the plane towards the initial position). From rest at
    theta0 with k = sin(theta0 / 2) (elliptic parameter m = k^2):
        sin(theta / 2) = k sn(K(m) - omega0 t | m),   theta' = -2 k omega0 cn(K - omega0 t | m),
        period T = 4 K(m) / omega0.
    The joint reaction on the body is R = m a_c - m g and, about the pivot,
    M = dH_O/dt - (r_c - P) x m g with H_O = J_O omega (Newton-Euler about a fixed point).
    """

    def __init__(self, mass, inertia, r0, A0, pivot, axis, g):
        _body_data(self, mass, inertia, r0, A0, pivot, g, axis)
        gn = self.g - (self.g @ self.n) * self.n
        self.gn = float(np.linalg.norm(gn))
        self.g_hat = gn / self.gn
        c0 = self.r0 - self.P
        self.axial = (c0 @ self.n) * self.n            # offset of the centre along the axis
        c0p = c0 - self.axial
        self.d = float(np.linalg.norm(c0p))
        e = c0p - (c0p @ self.g_hat) * self.g_hat
        if np.linalg.norm(e) < 1e-12 * self.d:
            raise ValueError("released at an equilibrium: no motion")
        self.e_hat = e / np.linalg.norm(e)
        self.w = np.cross(self.g_hat, self.e_hat)       # rotation from g_hat towards e_hat
        self.theta0 = float(np.arctan2(c0p @ self.e_hat, c0p @ self.g_hat))
        JO0 = self.A0 @ self.Jc @ self.A0.T + self.m * ((c0 @ c0) * np.eye(3) - np.outer(c0, c0))
        self.I_O = float(self.n @ JO0 @ self.n)
        self.omega0 = np.sqrt(self.m * self.gn * self.d / self.I_O)
        self.k = np.sin(self.theta0 / 2)
        self.m_ell = self.k**2
        self.K = float(ellipk(self.m_ell))

    @property
    def period(self) -> float:
        """T = 4 sqrt(I_O / (m |g_n| d)) K(sin^2(theta0 / 2))."""
        return 4.0 * self.K / self.omega0

    def angle_of(self, A) -> np.ndarray:
        """The angle theta of orientations A (nt, 3, 3): the body-fixed direction from the axis
        to the centre of mass, measured from g_hat towards e_hat."""
        u_body = self.A0.T @ (np.cos(self.theta0) * self.g_hat + np.sin(self.theta0) * self.e_hat)
        u = np.einsum("nij,j->ni", np.asarray(A), u_body)
        return np.arctan2(u @ self.e_hat, u @ self.g_hat)

    def angle(self, t, theta0=None):
        """theta, theta', theta'' at t (released from rest at theta0, default the model's)."""
        t = np.asarray(t, dtype=float)
        theta0 = self.theta0 if theta0 is None else float(theta0)
        k = np.sin(theta0 / 2)
        K = float(ellipk(k * k))
        sn, cn, dn, _ = ellipj(K - self.omega0 * t, k * k)
        theta = 2.0 * np.arcsin(np.clip(k * sn, -1.0, 1.0))
        theta_dot = -2.0 * k * self.omega0 * cn
        theta_ddot = -self.omega0**2 * np.sin(theta)
        return theta, theta_dot, theta_ddot

    def amplification(self, t, h: float = 1e-6) -> float:
        """Largest growth of a perturbation of the motion up to t: max over [0, t] of
        |d theta / d theta0|, |d theta' / d theta0| / omega0 and 1 (central differences of the
        exact solution). A change of the release amplitude (energy) changes the period, so a
        phase error grows linearly with time; a time shift does not grow."""
        tt = np.linspace(0.0, float(np.max(t)), 2001)
        a = self.angle(tt, self.theta0 + h)
        b = self.angle(tt, self.theta0 - h)
        dth = np.abs(a[0] - b[0]) / (2 * h)
        dthd = np.abs(a[1] - b[1]) / (2 * h) / self.omega0
        return float(max(1.0, dth.max(), dthd.max()))

    def crossing_times(self, t_end: float) -> np.ndarray:
        """Times in (0, t_end] at which theta = 0 (the centre of mass passes below the axis):
        (2 j + 1) K / omega0 = (2 j + 1) T / 4."""
        n = int(np.floor(t_end * self.omega0 / self.K + 1) // 2 + 1)
        tc = (2 * np.arange(n) + 1) * self.K / self.omega0
        return tc[tc <= t_end]

    def motion(self, t) -> PendulumMotion:
        """The exact motion at the times t."""
        t = np.asarray(t, dtype=float)
        return self.motion_at(t, *self.angle(t))

    def motion_at(self, t, th, thd, thdd=None) -> PendulumMotion:
        """Body motion and joint reaction for given angle, rate and (default: from the equation
        of motion) angular acceleration - e.g. the reaction that belongs to a simulated state."""
        t = np.asarray(t, dtype=float)
        th = np.asarray(th, dtype=float)
        thd = np.asarray(thd, dtype=float)
        if thdd is None:
            thdd = -self.omega0**2 * np.sin(th)
        g_hat, e_hat, w = self.g_hat, self.e_hat, self.w
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        rad = self.d * (c * g_hat + s * e_hat)                    # pivot -> centre, normal part
        tang = self.d * (-s * g_hat + c * e_hat)                  # d rad / d theta
        r = self.P + self.axial + rad
        rdot = thd[:, None] * tang
        rddot = thdd[:, None] * tang - (thd**2)[:, None] * rad
        R = rotation_matrix(w, th - self.theta0)
        A = R @ self.A0
        omega = thd[:, None] * w
        omegadot = thdd[:, None] * w
        force = self.m * rddot - self.m * self.g
        cvec = r - self.P
        JO = (A @ self.Jc @ np.swapaxes(A, 1, 2)
              + self.m * (np.einsum("ni,ni->n", cvec, cvec)[:, None, None] * np.eye(3)
                          - np.einsum("ni,nj->nij", cvec, cvec)))
        Jw = np.einsum("nij,nj->ni", JO, omega)
        Hdot = np.einsum("nij,nj->ni", JO, omegadot) + np.cross(omega, Jw)
        moment = Hdot - np.cross(cvec, self.m * self.g)
        return PendulumMotion(t=t, theta=th, theta_dot=thd, theta_ddot=thdd, r=r, rdot=rdot,
                              rddot=rddot, A=A, omega=omega, omegadot=omegadot,
                              force_on_body=force, moment_on_body=moment)


# --------------------------------------------------------------------------- guided bodies
def _newton_euler(m, Jc, g, pivot, r, rddot, A, omega, omegadot):
    """Joint reaction on a body moving as given: force R = m a_c - m g and the moment about the
    fixed point ``pivot`` M_P = J w' + w x J w + (r_c - P) x R (J = A Jc A^T: Euler's equation
    about the centre of mass, where gravity has no moment, moved to P)."""
    force = m * rddot - m * np.asarray(g, dtype=float)
    J = A @ Jc @ np.swapaxes(A, 1, 2)
    Jw = np.einsum("nij,nj->ni", J, omega)
    moment = (np.einsum("nij,nj->ni", J, omegadot) + np.cross(omega, Jw)
              + np.cross(r - np.asarray(pivot, dtype=float), force))
    return force, moment


class AxialMotion:
    """A rigid body guided along a fixed line (through ``point``, unit direction n = ``axis``)
    under uniform gravity g, released at rest at t = 0.

    The joint forces are normal to the line and the joint moments normal to it (a translational
    joint adds the moment about it), so along the line the body falls freely,
        s(t) = (g . n) t^2 / 2,
    and about it (``rotates``: a cylindrical joint) it turns as the physical pendulum about the
    line (I_O theta'' = -m |g_n| d sin theta; :class:`PhysicalPendulum`, whose moment of
    inertia about the line does not depend on the axial offset): the axial momentum and the
    angular momentum about the line decouple, u . H_P = I_O theta' for P on the line. Without
    rotation (a translational joint, or gravity with no moment about the line: the centre of
    mass in the vertical plane through the line, or g along the line) the orientation stays
    A0. The reaction follows from Newton-Euler (:func:`_newton_euler`) about the fixed point.
    """

    def __init__(self, mass, inertia, r0, A0, point, axis, g, rotates: bool):
        _body_data(self, mass, inertia, r0, A0, point, g, axis)
        self.g_axial = float(self.g @ self.n)            # acceleration along the line
        torque = self.n @ np.cross(self.r0 - self.P, self.g)
        scale = np.linalg.norm(self.r0 - self.P) * np.linalg.norm(self.g)
        self.pendulum = None
        if rotates and abs(torque) > 1e-12 * scale:
            self.pendulum = PhysicalPendulum(mass, self.Jc, self.r0, self.A0, self.P, self.n,
                                             self.g)

    def motion(self, t) -> PendulumMotion:
        t = np.asarray(t, dtype=float)
        nt = len(t)
        if self.pendulum is not None:
            p = self.pendulum.motion(t)
            th, thd, thdd = p.theta, p.theta_dot, p.theta_ddot
            r, rdot, rddot, A, omega, omegadot = p.r, p.rdot, p.rddot, p.A, p.omega, p.omegadot
        else:
            th = thd = thdd = np.zeros(nt)
            r = np.repeat(self.r0[None], nt, 0)
            rdot, rddot, omega, omegadot = (np.zeros((nt, 3)) for _ in range(4))
            A = np.repeat(self.A0[None], nt, 0)
        a = self.g_axial * self.n
        r = r + 0.5 * t[:, None] ** 2 * a
        rdot = rdot + t[:, None] * a
        rddot = rddot + a
        force, moment = _newton_euler(self.m, self.Jc, self.g, self.P, r, rddot, A, omega,
                                      omegadot)
        return PendulumMotion(t=t, theta=th, theta_dot=thd, theta_ddot=thdd, r=r, rdot=rdot,
                              rddot=rddot, A=A, omega=omega, omegadot=omegadot,
                              force_on_body=force, moment_on_body=moment)


class DistancePendulum:
    """A rigid body whose centre of mass is held at the fixed distance L = |r0 - P| from the
    fixed point P (a massless link with ball joints at both ends, or a distance constraint),
    under uniform gravity, released at rest.

    The link force acts along the link through the centre of mass: the centre moves as a
    point-mass pendulum of length L, released at rest and so staying in the vertical plane
    through P and r0 (:class:`PhysicalPendulum` with zero centroidal inertia, axis
    (r0 - P) x g), and the body, torque-free about its centre and at rest, keeps its
    orientation A0 (omega = 0). Reaction on the body: R = m a_c - m g, along the link, so its
    moment about P is zero.
    """

    def __init__(self, mass, inertia, r0, A0, point, g):
        _body_data(self, mass, inertia, r0, A0, point, g)
        self.L = float(np.linalg.norm(self.r0 - self.P))
        self.pendulum = PhysicalPendulum(mass, np.zeros((3, 3)), self.r0, np.eye(3), self.P,
                                         np.cross(self.r0 - self.P, self.g), self.g)

    @property
    def period(self) -> float:
        return self.pendulum.period

    def motion(self, t) -> PendulumMotion:
        t = np.asarray(t, dtype=float)
        p = self.pendulum.motion(t)
        nt = len(t)
        A = np.repeat(self.A0[None], nt, 0)
        zero = np.zeros((nt, 3))
        force, moment = _newton_euler(self.m, self.Jc, self.g, self.P, p.r, p.rddot, A, zero,
                                      zero)
        return PendulumMotion(t=t, theta=p.theta, theta_dot=p.theta_dot,
                              theta_ddot=p.theta_ddot, r=p.r, rdot=p.rdot, rddot=p.rddot, A=A,
                              omega=zero, omegadot=zero, force_on_body=force,
                              moment_on_body=moment)


# --------------------------------------------------------------------------- free rigid bodies
def symmetric_free_body(t, I1: float, I3: float, A0, omega_local0):
    """Torque-free axisymmetric body (I1 = I2 about the centre of mass, symmetry axis body 3).

    Returns (omega_local (nt, 3), A (nt, 3, 3)). Euler's equations give
        w1 + i w2 = (w1 + i w2)(0) exp(i lambda t),  lambda = (I3 - I1) / I1 w3,  w3 const,
    and with H = A0 J w(0) (constant in space), h = H / |H|:
        A(t) = R_h(|H| / I1 t) A0 R_3(-lambda t).
    """
    t = np.asarray(t, dtype=float)
    A0 = np.asarray(A0, dtype=float)
    w0 = np.asarray(omega_local0, dtype=float)
    lam = (I3 - I1) / I1 * w0[2]
    c, s = np.cos(lam * t), np.sin(lam * t)
    w = np.column_stack([c * w0[0] - s * w0[1], s * w0[0] + c * w0[1],
                         np.full_like(t, w0[2])])
    H = A0 @ (np.array([I1, I1, I3]) * w0)
    Hn = np.linalg.norm(H)
    A = rotation_matrix(H / Hn, Hn / I1 * t) @ A0 @ rotation_matrix([0, 0, 1], -lam * t)
    return w, A


class EulerFreeBody:
    """Jacobi's closed-form solution of Euler's equations for a torque-free body with principal
    moments I = (I1, I2, I3), I1 < I2 < I3, started with the intermediate-axis component at
    its extreme: omega_local(0) = (0, w2, w3) with |H|^2 > 2 T I2 (motion about axis 3).

    With 2T = sum I_i w_i^2 and L^2 = sum I_i^2 w_i^2,
        w1 = a1 cn(u | m), w2 = a2 sn(u | m), w3 = a3 dn(u | m),  u = lambda t + K(m),
        lambda^2 = (I3 - I2)(L^2 - 2T I1) / (I1 I2 I3),
        m = (I2 - I1)(2T I3 - L^2) / ((I3 - I2)(L^2 - 2T I1)),
        a1^2 = (2T I3 - L^2) / (I1 (I3 - I1)), a2^2 = (2T I3 - L^2) / (I2 (I3 - I2)),
        a3^2 = (L^2 - 2T I1) / (I3 (I3 - I1)),
    signs from I1 w1' = (I2 - I3) w2 w3 (w2, w3 > 0 at u = K). w2 changes sign every
    2 K(m) / lambda (the flip of the intermediate axis); the full period is 4 K(m) / lambda.
    """

    def __init__(self, inertia, w2: float, w3: float):
        self.I = np.asarray(inertia, dtype=float)
        I1, I2, I3 = self.I
        if not (I1 < I2 < I3):
            raise ValueError("needs I1 < I2 < I3")
        w = np.array([0.0, w2, w3])
        self.T2 = float(self.I @ w**2)
        self.L2 = float((self.I**2) @ w**2)
        if not self.L2 > self.T2 * I2:
            raise ValueError("needs L^2 > 2T I2 (choose |w3| larger)")
        self.lam = np.sqrt((I3 - I2) * (self.L2 - self.T2 * I1) / (I1 * I2 * I3))
        self.m = (I2 - I1) * (self.T2 * I3 - self.L2) / ((I3 - I2) * (self.L2 - self.T2 * I1))
        self.a1 = np.sqrt((self.T2 * I3 - self.L2) / (I1 * (I3 - I1)))
        self.a2 = np.sqrt((self.T2 * I3 - self.L2) / (I2 * (I3 - I2)))
        self.a3 = np.sqrt((self.L2 - self.T2 * I1) / (I3 * (I3 - I1)))
        self.K = float(ellipk(self.m))

    @property
    def flip_time(self) -> float:
        """Time between successive sign changes of w2: 2 K(m) / lambda."""
        return 2.0 * self.K / self.lam

    def amplification(self, t_end: float, h: float = 1e-7) -> float:
        """Largest growth of a perturbation of the initial angular velocity up to t_end:
        max over [0, t_end] of |w(t; w0 + h e_i) - w(t; w0)| / h for perturbations of w2 and
        w3 (central differences of the closed form), at least 1."""
        tt = np.linspace(0.0, float(t_end), 2001)
        w2, w3 = self.a2, self.a3 * np.sqrt(1.0 - self.m)
        g = 1.0
        for d2, d3 in ((h, 0.0), (0.0, h)):
            plus = EulerFreeBody(self.I, w2 + d2, w3 + d3).omega_local(tt)
            minus = EulerFreeBody(self.I, w2 - d2, w3 - d3).omega_local(tt)
            g = max(g, float(np.abs(plus - minus).max() / (2 * h)))
        return g

    def omega_local(self, t) -> np.ndarray:
        sn, cn, dn, _ = ellipj(self.lam * np.asarray(t, dtype=float) + self.K, self.m)
        return np.column_stack([self.a1 * cn, self.a2 * sn, self.a3 * dn])


# --------------------------------------------------------------------------- heavy top
def heavy_top_steady_precession(mass, l, I1, I3, g, theta, spin_w3, slow=True) -> float:
    """Precession rate Omega (rad/s about the upward vertical) of a heavy symmetric top in
    steady precession: symmetry axis at angle theta from the upward vertical, centre of mass
    at distance l from the fixed tip, centroidal moments I1 (transverse), I3 (axial), axial
    component of the angular velocity w3. From the Euler-angle equation of theta,
        A Omega^2 cos(theta) - C w3 Omega + m g l = 0,  A = I1 + m l^2, C = I3,
    the slow root (slow=True) or the fast one."""
    A = I1 + mass * l * l
    C = I3
    a = A * np.cos(theta)
    b = -C * spin_w3
    c = mass * g * l
    disc = b * b - 4 * a * c
    if disc < 0:
        raise ValueError("no steady precession for this spin (spin faster)")
    roots = sorted([(-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)],
                   key=abs)
    return float(roots[0] if slow else roots[1])


# --------------------------------------------------------------------------- A02 parallelogram
def rotating_pendulum(t, I: float, K: float, phi_dot0: float):
    """phi(t), phi'(t) of I phi'' = K sin phi from phi(0) = 0 (the top) with phi'(0) = phi_dot0
    != 0: the motion goes over the top. psi = phi + pi obeys psi'' = -w0^2 sin psi,
    w0^2 = K / I, with energy h = psi'^2 / 2 - w0^2 cos psi = phi_dot0^2 / 2 + w0^2 and
    parameter m = k^2 = 2 w0^2 / (h + w0^2) < 1; the rotating solution is
    psi = 2 am(u | m), u = w0 t / k + K(m), so with s = sign(phi_dot0)
        phi(t) = s (2 am(u | m) - pi),   phi'(t) = s 2 w0 / k dn(u | m).
    """
    t = np.asarray(t, dtype=float)
    w0 = np.sqrt(K / I)
    h = 0.5 * phi_dot0**2 + w0**2          # at psi = -pi: cos psi = -1
    m = 2 * w0**2 / (h + w0**2)
    k = np.sqrt(m)
    Km = float(ellipk(m))
    s = np.sign(phi_dot0)
    sn, cn, dn, ph = ellipj(w0 * t / k + Km, m)
    phi = s * (2 * ph - np.pi)
    phi_dot = s * 2 * w0 / k * dn
    return phi, phi_dot


def bicycle_eigenvalues(v: float, M, C1, K0, K2, g: float = 9.81) -> np.ndarray:
    """The four eigenvalues s (1/s) of M q'' + v C1 q' + (g K0 + v^2 K2) q = 0 (2 x 2
    matrices; Meijaard et al. 2007, the linearized Whipple bicycle at forward speed v, q =
    (lean, steer)), from the first-order form [[0, I], [-M^-1 K, -M^-1 v C1]], sorted by
    real part then imaginary part."""
    M, C1, K0, K2 = (np.asarray(a, dtype=float) for a in (M, C1, K0, K2))
    K = g * K0 + v * v * K2
    A = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, v * C1)]])
    return np.sort_complex(np.linalg.eigvals(A))


@dataclass
class NutatingTop:
    """Heavy symmetric top with its tip fixed: mass m, centre of mass l from the tip on the
    symmetry axis, moments I1 (centroidal, transverse) and I3 (axial), gravity g; started at
    the nutation angle theta0 from the upward vertical with theta' = 0, precession rate
    phidot0 and axial spin w3 (Goldstein, Classical Mechanics, sec. 5.7).

    With A = I1 + m l^2 about the tip, C = I3 and u = cos(theta), the conserved w3, p_phi =
    A phi' sin^2 theta + C w3 u and energy give u'^2 = f(u) = (1 - u^2)(alpha - beta u) -
    (b - a u)^2, alpha = phidot0^2 sin^2 theta0 + beta u0, beta = 2 m g l / A, a = C w3 / A,
    b = p_phi / A: a cubic beta (u - u1)(u - u2)(u - u3), u1 <= u2 <= 1 < u3, between whose
    first two roots u oscillates:

        u(t) = u1 + (u2 - u1) sn^2(lam t + t0, m),  lam = sqrt(beta (u3 - u1)) / 2,
        m = (u2 - u1) / (u3 - u1)

    (substituting gives u'^2 = 4 lam^2 (u2 - u1)^2 sn^2 cn^2 dn^2 = f(u)), t0 = K(m) when it
    starts at the upper turning point u2, 0 at the lower one u1; nutation period 2 K(m) / lam."""

    m: float
    l: float
    I1: float
    I3: float
    g: float
    theta0: float
    w3: float
    phidot0: float = 0.0

    def __post_init__(self):
        A = self.I1 + self.m * self.l ** 2
        self.A = A
        u0 = float(np.cos(self.theta0))
        s2 = 1.0 - u0 * u0
        self.beta = 2 * self.m * self.g * self.l / A
        self.a = self.I3 * self.w3 / A
        self.b = self.phidot0 * s2 + self.a * u0
        self.alpha = self.phidot0 ** 2 * s2 + self.beta * u0
        roots = np.sort(np.roots([self.beta, -(self.alpha + self.a ** 2),
                                  2 * self.a * self.b - self.beta,
                                  self.alpha - self.b ** 2]).real)
        self.u1, self.u2, self.u3 = (float(r) for r in roots)
        self.u0 = u0
        self.from_top = abs(u0 - self.u2) <= abs(u0 - self.u1)
        self.lam = float(np.sqrt(self.beta * (self.u3 - self.u1))) / 2.0
        self.m_ell = (self.u2 - self.u1) / (self.u3 - self.u1)
        self.K = float(ellipk(self.m_ell))

    @property
    def period(self) -> float:
        """Nutation period (s): u returns to its start."""
        return 2.0 * self.K / self.lam

    def u(self, t) -> np.ndarray:
        """cos(theta(t)) = u1 + (u2 - u1) sn^2(lam t + t0 | m)."""
        t = np.asarray(t, dtype=float)
        shift = self.K if self.from_top else 0.0
        sn = ellipj(self.lam * t + shift, self.m_ell)[0]
        return self.u1 + (self.u2 - self.u1) * sn * sn

    def p_phi(self) -> float:
        """Angular momentum about the vertical (kg m^2/s), conserved."""
        return self.A * self.b
