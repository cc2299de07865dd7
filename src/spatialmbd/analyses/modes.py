"""Vibration modes of a linear model: natural frequencies, damping ratios and mode shapes."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .common import COMPONENTS, describe_direction, results_object
from .linear_model import LinearModel
from .linearize import linearize


@dataclass
class ModalResults:
    """Natural frequencies, damping ratios and mode shapes.

    table: DataFrame, one row per mode: eigenvalue (real, imag; 1/s), omega_n (rad/s),
    frequency_hz, damped_frequency_hz, damping_ratio, kind ("rigid-body", "oscillatory",
    "non-oscillatory", "unstable"), oscillatory (a complex pair), time_constant_s (1/|Re s|),
    whirl ("forward" / "backward" about a spinning body's axis, or ""), motion. A real
    eigenvalue is a decay or a divergence: its omega_n, frequencies and damping ratio are NaN.
    Rigid-body modes: s = 0, omega_n = 0. shapes (6 nb, k) complex: body tangent coordinates
    [dx, dy, dz (m), rx, ry, rz (rad)] per body, largest entry 1. linear: the LinearModel.
    """

    linear: LinearModel
    eigenvalues: np.ndarray
    shapes: np.ndarray
    table: object

    @property
    def model(self):
        return self.linear.model

    @property
    def frequencies_hz(self) -> np.ndarray:
        return self.table["frequency_hz"].to_numpy()

    @property
    def stable(self) -> bool:
        return not (self.table["kind"] == "unstable").any()

    def shapes_table(self):
        """Real parts of the shapes, rows "<body>.<x|y|z|rx|ry|rz>", one column per mode."""
        import pandas as pd
        labels = [f"{name}.{c}" for name in self.model.body_names for c in COMPONENTS]
        return pd.DataFrame(self.shapes.real, index=labels,
                            columns=[f"mode{k}" for k in range(self.shapes.shape[1])])

    def to_dataframe(self):
        """One row per mode: the table and the real parts of the shapes (columns
        "shape.<body>.<x|y|z|rx|ry|rz>")."""
        import pandas as pd
        shapes = self.shapes_table().T.add_prefix("shape.").reset_index(drop=True)
        return pd.concat([self.table.reset_index(drop=True), shapes], axis=1)

    def motion(self, mode: int, amplitude: float = 0.1, cycles: float = 2.0,
               points_per_cycle: int = 40):
        """A Results object animating one mode: q(t) = q* moved by amplitude * Re(shape
        e^{i omega t}) (amplitude in m or rad of the largest entry); rigid-body and overdamped
        modes move as amplitude * shape * sin(2 pi t) over 1 s cycles."""
        from ..kinematics import apply_correction
        s = self.eigenvalues[mode]
        omega = abs(s.imag)
        period = 2 * np.pi / omega if omega > 1e-9 else 1.0
        t = np.linspace(0.0, cycles * period, int(cycles * points_per_cycle) + 1)
        phi = self.shapes[:, mode]
        q0 = self.linear.q
        nb = q0.shape[0]
        Q = np.empty((t.size, nb, 7))
        V = np.zeros((t.size, nb, 6))
        for k, tk in enumerate(t):
            if omega > 1e-9:
                dx = amplitude * np.real(phi * np.exp(1j * omega * tk))
                dv = amplitude * np.real(1j * omega * phi * np.exp(1j * omega * tk))
            else:
                dx = amplitude * np.real(phi) * np.sin(2 * np.pi * tk / period)
                dv = amplitude * np.real(phi) * np.cos(2 * np.pi * tk / period) * 2 * np.pi
            Q[k] = apply_correction(q0, dx)
            V[k] = dv.reshape(nb, 6)
        return results_object(self.model, t, Q, V, np.zeros_like(V),
                              np.zeros((t.size, self.model.n_eq)),
                              settings={"analysis": "mode", "mode": mode})

    def summary(self) -> str:
        lines = [f"modes: {len(self.eigenvalues)} ({'stable' if self.stable else 'UNSTABLE'})"]
        for k, row in self.table.iterrows():
            if row["kind"] == "rigid-body":
                text = "rigid-body"
            elif row["oscillatory"]:
                text = (f"{'unstable oscillatory' if row['kind'] == 'unstable' else 'oscillatory'}"
                        f" f = {row['frequency_hz']:.6g} Hz (omega_n {row['omega_n']:.6g} rad/s),"
                        f" damping ratio {row['damping_ratio']:.4g}")
            else:
                unstable = row["kind"] == "unstable"
                text = (f"{'unstable (divergence)' if unstable else 'non-oscillatory'}"
                        f" s = {row['real']:.6g} 1/s, no frequency")
                if np.isfinite(row["time_constant_s"]):
                    text += f" (time constant {row['time_constant_s']:.4g} s)"
            lines.append(f"  mode {k}: {text}; {row['motion']}")
        return "\n".join(lines)


def modes(model_or_linear, *args, zero_tol: float = 1e-8, **kwargs) -> ModalResults:
    """Vibration modes of a LinearModel, or of ``linearize(model, *args, **kwargs)``.

    Undamped, non-gyroscopic systems (C = 0): the symmetric problem K phi = omega^2 M phi
    (real shapes; omega^2 < 0 is an unstable, divergent direction). Otherwise the eigenvalues
    s of A: omega_n = |s|, damping ratio -Re(s)/|s|, damped frequency |Im s|. Eigenvalues with
    |s|^2 below zero_tol times the largest |s|^2 (a stiffness 1e-8 of the largest: the accuracy
    of the differenced stiffness), or |s| < 1e-6 rad/s, are rigid-body modes.
    """
    import pandas as pd
    lin = model_or_linear if isinstance(model_or_linear, LinearModel) else \
        linearize(model_or_linear, *args, **kwargs)
    n = lin.n
    if lin.nonholonomic:
        symmetric = False
    else:
        Ms, Ks = 0.5 * (lin.M + lin.M.T), 0.5 * (lin.K + lin.K.T)
        scale_c = np.abs(lin.C).max() if lin.C.size else 0.0
        ref = max(np.abs(lin.K).max() if n else 0.0, 1e-300)
        symmetric = scale_c <= 1e-10 * np.sqrt(ref * max(np.abs(Ms).max(), 1e-300))
    if n == 0:
        s_vals, Z = np.zeros(0, complex), np.zeros((0, 0), complex)
    elif symmetric:
        import scipy.linalg as sla
        lam2, Z = sla.eigh(Ks, Ms)
        s_vals = np.where(lam2 >= 0, 1j * np.sqrt(np.abs(lam2)), np.sqrt(np.abs(lam2)) + 0j)
        Z = Z.astype(complex)
    else:
        ev, X, rigid = _eigenpairs(lin)
        # one of each complex-conjugate pair (Im >= 0), all real ones
        pick = [k for k in range(ev.size) if ev[k].imag > 1e-12 * max(1, abs(ev[k]))]
        reals = [k for k in range(ev.size) if abs(ev[k].imag) <= 1e-12 * max(1, abs(ev[k]))]
        idx = pick + reals
        s_vals, Z = ev[idx], X[:n, idx]
        s_vals[len(pick):] = s_vals[len(pick):].real
    mag = np.abs(s_vals)
    big = mag.max() if mag.size else 0.0
    zero = mag <= max(np.sqrt(zero_tol) * big, 1e-6)
    if symmetric and zero.sum() > 1:
        # keep one mode per independent zero-frequency shape
        U, sv, _ = np.linalg.svd(Z[:, zero])
        r = int(np.sum(np.asarray(sv) > 1e-6 * max(sv[0], 1e-300))) if sv[0] > 0 else 0
        s_vals = np.concatenate([np.zeros(r, complex), s_vals[~zero]])
        Z = np.hstack([U[:, :r].astype(complex), Z[:, ~zero]])
        mag = np.abs(s_vals)
    elif not symmetric and (rigid.shape[1] or zero.sum() > 1):
        # the deflated ignorable positions are rigid-body modes (one per independent shape);
        # zeros left in the reduced system (a mechanism without stiffness that no symmetry
        # explains) are defective too: their shapes are the positions of its null space
        red = lin.reduced()
        shapes0 = [rigid]
        if zero.any() and red.A.size:
            _, sa, Vt = np.linalg.svd(red.A)
            k = min(int(zero.sum()), int(np.sum(sa <= np.sqrt(zero_tol) * max(sa[0], 1e-300))))
            if k:
                shapes0.append((red.basis @ Vt[Vt.shape[0] - k:].T)[:n])
        W = np.hstack(shapes0)
        U, sv, _ = np.linalg.svd(W) if W.size else (None, np.zeros(1), None)
        r = int(np.sum(sv > 1e-6 * sv[0])) if sv[0] > 0 else 0
        s_vals = np.concatenate([np.zeros(r, complex), s_vals[~zero]])
        Z = np.hstack([U[:, :r].astype(complex) if r else np.zeros((n, 0), complex),
                       Z[:, ~zero]])
        mag = np.abs(s_vals)
    shapes = lin.basis @ Z if n else np.zeros((6 * lin.model.nb, 0))
    r = int(np.sum(mag <= max(np.sqrt(zero_tol) * big, 1e-6)))
    if r > 1:
        # any basis of the rigid-body motions is one; show the one in which each mode moves a
        # single body coordinate of its own (QR with column pivoting picks r independent
        # coordinates; mode i is 1 in the i-th, 0 in the others): a free body's six modes are
        # then the three translations and three rotations, not mixtures of them
        import scipy.linalg as sla
        rigid = np.real(shapes[:, :r])
        piv = sla.qr(rigid.T, pivoting=True, mode="r")[1][:r]
        square = rigid[piv]
        if np.linalg.cond(square) < 1e8:
            shapes[:, :r] = rigid @ np.linalg.inv(square)
    for k in range(shapes.shape[1]):
        j = int(np.argmax(np.abs(shapes[:, k])))
        if abs(shapes[j, k]) > 0:
            shapes[:, k] = shapes[:, k] / shapes[j, k]
    kinds = []
    for s in s_vals:
        if abs(s) <= max(np.sqrt(zero_tol) * big, 1e-6):
            kinds.append("rigid-body")
        elif s.real > 1e-9 * max(abs(s), 1.0):
            kinds.append("unstable")
        elif abs(s.imag) > 0:
            kinds.append("oscillatory")
        else:
            kinds.append("non-oscillatory")
    order = np.lexsort((mag, [k != "rigid-body" for k in kinds]))
    s_vals, shapes = s_vals[order], shapes[:, order]
    kinds = [kinds[k] for k in order]
    rigid_mode = np.array(kinds) == "rigid-body"
    # a real eigenvalue is a decay or a divergence, not an oscillation: no frequency, no
    # damping ratio (its time constant instead); a complex pair has both
    oscillating = (np.abs(s_vals.imag) > 0) & ~rigid_mode
    mag = np.abs(s_vals)
    omega_n = np.where(rigid_mode, 0.0, np.where(oscillating, mag, np.nan))
    zeta = np.where(oscillating, -s_vals.real / np.where(mag > 0, mag, 1), np.nan)
    zeta[np.abs(zeta) < 1e-12] = 0.0                       # round-off of undamped systems
    damped = np.where(rigid_mode, 0.0, np.where(oscillating, np.abs(s_vals.imag), np.nan))
    tau = np.full(s_vals.size, np.nan)
    decays = ~rigid_mode & (np.abs(s_vals.real) > 1e-12 * np.maximum(mag, 1.0))
    tau[decays] = 1.0 / np.abs(s_vals.real[decays])
    whirls = [_whirl(lin, shapes[:, k]) if oscillating[k] else ""
              for k in range(shapes.shape[1])]
    motion = []
    for k in range(shapes.shape[1]):
        x = shapes[:, k].real if np.abs(shapes[:, k].real).max() > 1e-9 else shapes[:, k].imag
        text = describe_direction(lin.model, x)
        motion.append(f"{whirls[k]}; {text}" if whirls[k] else text)
    table = pd.DataFrame(dict(
        real=s_vals.real, imag=s_vals.imag, omega_n=omega_n, frequency_hz=omega_n / (2 * np.pi),
        damped_frequency_hz=damped / (2 * np.pi), damping_ratio=zeta, kind=kinds,
        oscillatory=oscillating, time_constant_s=tau,
        whirl=[w.split(" whirl")[0] for w in whirls],
        motion=motion))
    return ModalResults(linear=lin, eigenvalues=s_vals, shapes=shapes, table=table)


def _eigenpairs(lin):
    """(eigenvalues (m,), eigenvectors (n_x, m), rigid (n, r)) of A from its reduced system:
    the reduced matrix's eigenpairs lifted to the full state and the ignorable block's
    non-zero ones; rigid: the deflated ignorable positions (rigid-body mode shapes in z)."""
    red = lin.reduced()
    n_x = lin.A.shape[0]
    if red.A.size:
        ev, Y = np.linalg.eig(red.A)
        X = np.column_stack([red.lift(ev[k], Y[:, k]) for k in range(ev.size)])
    else:
        ev, X = np.zeros(0, complex), np.zeros((n_x, 0), complex)
    if red.k:
        evG, VG = np.linalg.eig(red.G)
        keep = red.deflated_eigenvalues() != 0
        ev = np.concatenate([ev, evG[keep]])
        X = np.hstack([X, red.deflated @ VG[:, keep]])
    return ev.astype(complex), X.astype(complex), red.positions


def _whirl(lin, shape: np.ndarray) -> str:
    """"forward whirl" / "backward whirl" of an oscillatory mode shape (6 nb,) complex: the
    body with the largest rotation whose spin axis (its reference angular velocity) the
    rotation vector circles about, in the sense of the spin or against it; "" when no
    spinning body moves on a near-circular path (|Re x Im| below 0.1 of (|Re|^2 + |Im|^2)/2).
    x(t) = Re(phi e^{i w t}) (w > 0) turns about -(Re phi x Im phi)."""
    nb = lin.model.nb
    phi = np.asarray(shape).reshape(nb, 6)[:, 3:]
    omega = np.asarray(lin.v, dtype=float).reshape(nb, 6)[:, 3:]
    if lin.frame_rate is not None:
        omega = omega - np.asarray(lin.frame_rate, dtype=float)    # spin seen in the frame
    b = int(np.argmax(np.linalg.norm(phi, axis=1)))
    re, im = phi[b].real, phi[b].imag
    axis = -np.cross(re, im)
    size = 0.5 * (re @ re + im @ im)
    spin = float(np.linalg.norm(omega[b]))
    if size == 0 or spin == 0 or np.linalg.norm(axis) < 0.1 * size:
        return ""
    along = float(axis @ omega[b]) / (np.linalg.norm(axis) * spin)
    if abs(along) < 0.5:
        return ""
    return ("forward" if along > 0 else "backward") + f" whirl of {lin.model.body_names[b]}"
