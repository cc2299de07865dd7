"""Deflation of the ignorable modes of a linear model (analyses.linearize).

A mechanism with ignorable coordinates -- a vehicle's position in the plane and heading, its
wheels' rotation angles, a free body's position, a rotor's angle -- has a linear model x' = A x
in which nothing depends on those coordinates: their columns of A feed only their own rows.
Their zero eigenvalues are defective (the rate of an ignorable coordinate is a second zero of a
Jordan block: x = v t), and floating point resolves a defective zero only to about the square
root of the rounding (a perturbation e of A moves a 2 x 2 Jordan block's eigenvalues by
sqrt(e |A|): 1e-7 1/s on the Whipple bicycle). A real eigenvalue that crosses zero -- the
bicycle's capsize mode -- passes through that cluster, and where it crosses would be decided by
the last bits of the BLAS kernel.

So stability verdicts, critical-speed roots and modal tables use the reduced system:

1. Candidates, from the model's structure, not from the numbers of A: the rigid motions of the
   whole mechanism (translations along and rotations about the global axes: a vehicle's
   position and heading) and the rotation of each body alone about its centre of mass (a
   wheel's spin about its axle). They are fixed by the geometry, so no parameter of the model
   can tune one of them onto an eigenvector whose eigenvalue happens to cross zero.
2. Admissible: the part of their span that moves along the constraints. A configuration
   candidate carries the reference velocities it turns (a heading change of a bicycle rolling
   forward turns its velocities with it): dx = N_h a and dv = P a + N_v b (``lin.basis``,
   ``lin.velocity_map``, ``lin.velocity_basis``; with holonomic constraints only,
   dx = N z, dx' = dv + W dx = N z'). A rate candidate is the motion's velocity alone.
3. Ignorable: the largest subspace U_c of the admissible configurations that A maps into
   itself (a heading feeds only the position; nothing feeds a lean), then the largest
   subspace U_r of the admissible rates that A maps into U_c + U_r (a forward speed feeds
   only the position and the wheel angles): null spaces of (I - U U^T) A U, shrunk until
   they hold. A tilted top's configuration feeds its tilt rates, so it stays.
4. With Q an orthonormal complement of U, [U Q]^T A [U Q] = [[G, U^T A Q], [0, Q^T A Q]] is
   block triangular: the eigenvalues of A are those of G (the ignorable block: zeros, or the
   decay of an ignorable rate under damping) and those of the reduced matrix Q^T A Q, which
   are simple and computed to the rounding of A.

The two rank decisions (admissible, ignorable) compare with ``tol`` (1e-8) times the scale:
admissible candidates leave residuals at the rounding (1e-16), inadmissible ones of order one;
ignorable columns are zero to the rounding of the differenced derivatives (1e-14 of |A| on the
bicycle), the others at least as large as the physics they carry. A coupling below 1e-8 of |A|
is below the accuracy of the differenced linearization itself, so it is treated as none.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class ReducedSystem:
    """A linear model's state matrix with its ignorable modes deflated.

    A: (m, m) the reduced state matrix Q^T A Q; its eigenvalues are those of the linear model
    apart from the ignorable ones. basis: Q (n_x, m), orthonormal, x = Q y. deflated: U (n_x, k),
    orthonormal, the ignorable states (A U = U G). G: (k, k) U^T A U. coupling: (k, m) U^T A Q.
    positions: (n, r) orthonormal, the position directions (in the linear model's z) of the
    ignorable states: the rigid-body modes. residual: largest |(I - U U^T) A U| (the part
    treated as zero); tolerance: the bound it was compared with (tol times max |A|).
    """

    A: np.ndarray
    basis: np.ndarray
    deflated: np.ndarray
    G: np.ndarray
    coupling: np.ndarray
    positions: np.ndarray
    residual: float
    tolerance: float
    tol: float = 1e-8

    @property
    def k(self) -> int:
        """Number of deflated states."""
        return self.deflated.shape[1]

    @property
    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues (1/s) of the reduced matrix: every eigenvalue of the linear model that
        is not an ignorable one."""
        return np.linalg.eigvals(self.A) if self.A.size else np.zeros(0, complex)

    def deflated_eigenvalues(self) -> np.ndarray:
        """Eigenvalues (1/s) of the ignorable block G: zero (the ignorable coordinates and
        their rates), or the decay of an ignorable rate under damping. G holds the Jordan
        blocks, so its zeros come out at about the square root of the rounding: values below
        sqrt(tol) of |G| (1e-4; a rate decaying 1e4 times slower than the fastest) are zero."""
        if not self.k:
            return np.zeros(0, complex)
        ev = np.linalg.eigvals(self.G).astype(complex)
        ev[np.abs(ev) <= np.sqrt(self.tol) * float(np.abs(self.G).max())] = 0.0
        return ev

    def lift(self, s: complex, y: np.ndarray) -> np.ndarray:
        """The eigenvector x = Q y + U c of the full matrix for an eigenpair (s, y) of the
        reduced one: (s I - G) c = U^T A Q y (least squares where s is an eigenvalue of G)."""
        y = np.asarray(y)
        if not self.k:
            return self.basis @ y
        c = np.linalg.lstsq(s * np.eye(self.k) - self.G, self.coupling @ y, rcond=None)[0]
        return self.basis @ y + self.deflated @ c


def _candidates(q: np.ndarray, v: np.ndarray) -> tuple:
    """The structural candidates, (dx, dv) pairs (6 nb, 6 + 3 nb) each in body tangent
    coordinates [dr, dpi] per body: the three translations and three rotations (about the
    global axes through the origin) of the whole mechanism, and the rotation of each body
    alone about its centre of mass; dv is the change of the reference velocities v = [rdot,
    omega] (global) that the motion carries (a rotated motion has rotated velocities)."""
    nb = q.shape[0]
    r, rdot, omega = q[:, :3], v[:, :3], v[:, 3:]
    X = np.zeros((nb, 6, 6 + 3 * nb))
    V = np.zeros_like(X)
    eye = np.eye(3)
    every = np.arange(nb)
    for k in range(3):
        X[:, k, k] = 1.0                                        # translation along e_k
        X[:, :3, 3 + k] = np.cross(eye[k], r)                   # rotation about e_k: e_k x r
        X[:, 3 + k, 3 + k] = 1.0
        V[:, :3, 3 + k] = np.cross(eye[k], rdot)
        V[:, 3:, 3 + k] = np.cross(eye[k], omega)
        X[every, 3 + k, 6 + 3 * every + k] = 1.0                # body b alone about e_k
        V[every, 3:, 6 + 3 * every + k] = np.cross(eye[k], omega)
    X, V = X.reshape(6 * nb, -1), V.reshape(6 * nb, -1)
    size = np.linalg.norm(X, axis=0)
    return X / size, V / size


def _orth(X: np.ndarray, tol: float) -> np.ndarray:
    """Orthonormal basis of the columns of X whose singular values exceed tol times the
    largest (tol times 1 if all are smaller than 1)."""
    if X.size == 0:
        return np.zeros((X.shape[0], 0))
    U, s, _ = np.linalg.svd(X, full_matrices=False)
    return U[:, s > tol * max(s[0] if s.size else 0.0, 1.0)]


def _states(lin, dx: np.ndarray, dv: np.ndarray) -> tuple:
    """(states (n_x, k), residuals (12 nb, k)): the linear model's state x for each pair
    (dx, dv) of tangent position and velocity changes, and the part of the pair it misses
    (zero when the pair moves along the constraints). Nonholonomic: dx = N_h a,
    dv = P a + N_v b. Holonomic: dx = N z, dx' = dv + W dx (W = blockdiag(0, omega*~)) and
    dx' = N z' + Om N z in a frame turning at Om (``frame_rate``)."""
    N = lin.basis
    a = np.linalg.pinv(N) @ dx
    if lin.nonholonomic:
        rest = dv - lin.velocity_map @ a
        b = np.linalg.pinv(lin.velocity_basis) @ rest
        miss = rest - lin.velocity_basis @ b
    else:
        nb = dx.shape[0] // 6
        w = np.asarray(lin.v, dtype=float).reshape(nb, 6)[:, 3:]
        wf = np.zeros(3) if lin.frame_rate is None else np.asarray(lin.frame_rate, float)
        d = dx.reshape(nb, 6, -1)
        rate = dv.reshape(nb, 6, -1).copy()
        rate[:, 3:] += np.cross(w[:, :, None], d[:, 3:], axis=1)          # + W dx
        rate[:, :3] -= np.cross(wf[None, :, None], d[:, :3], axis=1)      # - Om dx
        rate[:, 3:] -= np.cross(wf[None, :, None], d[:, 3:], axis=1)
        rate = rate.reshape(6 * nb, -1)
        b = np.linalg.pinv(N) @ rate
        miss = rate - N @ b
    return np.vstack([a, b]), np.vstack([dx - N @ a, miss])


def _admissible(lin, dx: np.ndarray, dv: np.ndarray, tol: float) -> np.ndarray:
    """Orthonormal basis of the states of the pairs in span([dx; dv]) that move along the
    constraints: null space of the residuals of :func:`_states`. Columns: unit size."""
    n_x = lin.A.shape[0]
    if dx.shape[1] == 0:
        return np.zeros((n_x, 0))
    states, miss = _states(lin, dx, dv)
    _, s, Vt = np.linalg.svd(miss)
    rank = int(np.sum(s > tol))
    return _orth(states @ Vt[rank:].T, tol)


def _complement(U: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the orthogonal complement of the orthonormal columns U."""
    n, k = U.shape
    if k == 0:
        return np.eye(n)
    Qf = np.linalg.qr(U, mode="complete")[0]
    return Qf[:, k:]


def _shrink(A: np.ndarray, U: np.ndarray, fixed: np.ndarray, bound: float) -> np.ndarray:
    """The largest subspace of span(U) (orthonormal, orthogonal to ``fixed``) that A maps into
    itself plus span(fixed): null space of (I - W W^T) A U, W = [fixed, U], shrunk until it
    holds (at most dim U rounds)."""
    while U.shape[1]:
        W = np.hstack([fixed, U])
        R = _complement(W).T @ A @ U
        if R.size == 0:
            break
        _, s, Vt = np.linalg.svd(R)
        rank = int(np.sum(s > bound))
        if rank == 0:
            break
        U = U @ Vt[rank:].T
    return U


def deflate(lin, tol: float = 1e-8) -> ReducedSystem:
    """The reduced system of a LinearModel: its ignorable states (rigid motions of the whole
    mechanism, single bodies spinning about their centres of mass, and the rates of those
    motions that the constraints allow) deflated from A (module docstring)."""
    A = np.asarray(lin.A, dtype=float)
    n_x, n = A.shape[0], lin.n
    scale = max(float(np.abs(A).max()) if A.size else 0.0, 1e-300)
    nb = lin.model.nb
    X, V = _candidates(np.asarray(lin.q, dtype=float).reshape(nb, 7),
                       np.asarray(lin.v, dtype=float).reshape(nb, 6))
    bound = tol * scale
    # configurations: the candidate motions with the velocities they carry; ignorable if A
    # maps them into themselves (a heading feeds only the position, nothing feeds the lean)
    Uc = _shrink(A, _admissible(lin, X, V, tol), np.zeros((n_x, 0)), bound)
    # rates: the candidate motions' velocities; ignorable if A maps them into the ignorable
    # configurations and themselves (a forward speed feeds only the position and wheel angles)
    Ur = np.zeros((n_x, 0))
    rates = _admissible(lin, np.zeros_like(X), X, tol)
    if rates.shape[1]:
        Ur = _shrink(A, _orth(rates - Uc @ (Uc.T @ rates), tol), Uc, bound)
    U = np.hstack([Uc, Ur])
    R = _complement(U).T @ A @ U
    residual = float(np.abs(R).max()) if R.size else 0.0
    Q = _complement(U)
    positions = _orth(Uc[:n], tol)
    return ReducedSystem(A=Q.T @ A @ Q, basis=Q, deflated=U, G=U.T @ A @ U,
                         coupling=U.T @ A @ Q, positions=positions, residual=residual,
                         tolerance=bound, tol=tol)
