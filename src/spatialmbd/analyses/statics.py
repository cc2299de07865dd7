"""Static equilibrium, its stability, and quasi-static analysis along rheonomic drivers.

Equilibrium (v = 0, vdot = 0 in M vdot = g + D^T lam, dynamics/eom.py):

    r(q, lam) = Q(q) + D(q)^T lam = 0,    Phi(q, t) = 0

with Q the applied forces at rest (gravity, force elements; no gyroscopic term). Newton on the
KKT system, in the 6-per-body tangent space x = [dr, dpi] (kinematics.apply_correction):

    [H   D^T] [dx  ]     [r  ]
    [D   0  ] [dlam] = - [Phi],     H = d(Q + D^T lam)/dx  (lam held fixed),

H by central differences (the constraint kernels have no second derivatives). Singular KKT
matrices (zero-stiffness directions such as the spin of a rod between two spherical joints, or
redundant constraints) are solved in the minimum-norm sense, so they do not stop the iteration.
When Newton fails: load stepping (the external loads -- gravity, point forces and torques, user
forces -- scaled by s = 1/n, 2/n, ..., 1, each solution starting the next; springs are internal
and keep their full stiffness), then a damped minimisation of the potential energy on the
constraint manifold (Levenberg-Marquardt steps in the null space of D, each followed by
projection onto Phi = 0).

Stability: the tangent stiffness K = -H reduced to the null space N of D (orthonormal columns),
K_r = N^T K N, is the Hessian of the Lagrangian V - lam^T Phi on the constraint manifold. At an
equilibrium r = 0 it is symmetric (the asymmetry is reported). Its eigenvalues > 0: stable
directions; < 0: unstable; ~0: zero stiffness (neutral, e.g. free spins), each described by the
motion of the bodies. Units of K_r mix N/m and N m/rad; only the signs are basis-independent.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..errors import ConvergenceError, SimulationError, SingularMatrixError
from ..kinematics import solve_positions
from ..outputs.vocabulary import (BODY_ACCELERATION, BODY_POSITION, BODY_VELOCITY,
                                 body_columns)
from ..state import BodyState
from .common import (central_jacobian, conservative_forces_only, default_step, dense,
                     describe_direction, driver_rows, driver_units, null_space, perturb,
                     nonunique_joints, potential_energy, reactions_frame, results_object)

INTERNAL_FORCES = ("spring_damper", "rotational_spring_damper")


class NoEquilibriumError(SimulationError):
    """The applied loads have a component that no stiffness or constraint can balance."""


# ------------------------------------------------------------------------------- forces
class _Loads:
    """Applied forces at rest, Q(q) (6 nb,), with the external part scaled by ``scale``."""

    def __init__(self, model, t: float):
        self.model = model
        self.t = t
        nb = model.nb
        self.gravity = np.zeros((nb, 6))
        self.gravity[:, :3] = model.mass[:, None] * model.gravity[None, :]
        self.internal = [g for g in model.force_groups if g.name in INTERNAL_FORCES]
        self.external = [g for g in model.force_groups if g.name not in INTERNAL_FORCES]

    def __call__(self, q, scale: float = 1.0, t: Optional[float] = None) -> np.ndarray:
        t = self.t if t is None else t
        nb = self.model.nb
        state = BodyState.from_qv(q, None, t)
        ext = np.zeros((nb + 1, 6))
        ext[:nb] = self.gravity
        for g in self.external:
            g.evaluate(state, t, ext)
        out = scale * ext[:nb]
        if self.internal:
            internal = np.zeros((nb + 1, 6))
            for g in self.internal:
                g.evaluate(state, t, internal)
            out = out + internal[:nb]
        return out.reshape(-1)


def _constraints(model, q, t):
    cv = model.assembler.evaluate(q, None, t)
    return cv.phi, dense(cv.D)


def _tangent(model, loads, q, lam, t, scale, step, check=False):
    """H = d(Q + D^T lam)/dx (6 nb, 6 nb) by central differences about q."""
    def fun(dx):
        qq = perturb(q, dx)
        _, D = _constraints(model, qq, t)
        return loads(qq, scale, t) + D.T @ lam
    return central_jacobian(fun, 6 * model.nb, step, check=check,
                            what="tangent stiffness d(Q + D^T lam)/dx")[0]


def _kkt_solve(H, D, r, phi):
    n, m = H.shape[0], D.shape[0]
    K = np.block([[H, D.T], [D, np.zeros((m, m))]])
    rhs = -np.concatenate([r, phi])
    # minimum-norm solution with singular values below 1e-9 of the largest dropped: zero-
    # stiffness directions (known only to the accuracy of the differenced H) and redundant
    # constraint rows do not produce huge steps
    sol = np.linalg.lstsq(K, rhs, rcond=1e-9)[0]
    return sol[:n], sol[n:]


def _scales(model, loads, q):
    force = max(float(np.abs(loads(q)).max()), 1e-12)
    return force


def _newton(model, loads, q, t, scale, tol, max_iter, step, force_scale):
    """Newton on the KKT system; returns (q, lam, iterations) or raises ConvergenceError."""
    q, _ = solve_positions(model, q, t, tol=min(tol, 1e-10))
    phi, D = _constraints(model, q, t)
    Q = loads(q, scale, t)
    lam = np.linalg.lstsq(D.T, -Q, rcond=None)[0] if D.shape[0] else np.zeros(0)
    best = np.inf
    for it in range(max_iter + 1):
        r = Q + D.T @ lam
        err_f = float(np.abs(r).max()) / force_scale
        err_phi = float(np.abs(phi).max()) if phi.size else 0.0
        if err_f <= tol and err_phi <= max(tol, 1e-10):
            return q, lam, it
        if it == max_iter or not np.isfinite(err_f):
            break
        best = min(best, err_f)
        H = _tangent(model, loads, q, lam, t, scale, step)
        dx, dlam = _kkt_solve(H, D, r, phi)
        # limit a step to 0.5 rad of rotation / half the model size of translation
        blocks = dx.reshape(-1, 6)
        limit = max(np.abs(blocks[:, 3:]).max() / 0.5, 1.0)
        dx, dlam = dx / limit, dlam / limit
        q = perturb(q, dx)
        lam = lam + dlam
        phi, D = _constraints(model, q, t)
        Q = loads(q, scale, t)
    raise ConvergenceError(f"static equilibrium (load factor {scale:.3g}): Newton did not "
                           f"converge in {max_iter} iterations (force residual "
                           f"{err_f:.3g} of the load scale {force_scale:.3g} N)")


def _minimise(model, loads, q, t, tol, max_iter, step, force_scale, size_scale):
    """Damped Newton (Levenberg-Marquardt) on the reduced problem: descend the potential
    energy (conservative loads) or |N^T Q|^2 on the constraint manifold. Returns q."""
    conservative = conservative_forces_only(model)
    q, _ = solve_positions(model, q, t)
    q_start = q.copy()

    def reduced(qq):
        phi, D = _constraints(model, qq, t)
        N, _ = null_space(D)
        Q = loads(qq, 1.0, t)
        lam = np.linalg.lstsq(D.T, -Q, rcond=None)[0] if D.shape[0] else np.zeros(0)
        return N, Q, lam

    def merit(qq):
        if conservative:
            return potential_energy(model, qq, t)
        N, Q, _ = reduced(qq)
        return float(np.sum((N.T @ Q) ** 2))

    mu = 1e-3
    f_val = merit(q)
    for _ in range(max_iter):
        N, Q, lam = reduced(q)
        f = N.T @ Q
        if np.abs(f).max() <= tol * force_scale:
            return q
        H = _tangent(model, loads, q, lam, t, 1.0, step)
        K = -N.T @ H @ N
        K = 0.5 * (K + K.T)
        ev = np.linalg.eigvalsh(K) if K.size else np.zeros(1)
        kscale = max(np.abs(ev).max(), force_scale / size_scale)
        accepted = False
        for _ in range(30):
            shift = max(0.0, -ev.min()) + mu * kscale
            dz = np.linalg.solve(K + shift * np.eye(K.shape[0]), f)
            try:
                q_try, _ = solve_positions(model, perturb(q, N @ dz), t)
            except (ConvergenceError, SingularMatrixError):
                mu *= 10.0
                continue
            f_try = merit(q_try)
            if f_try < f_val:
                q, f_val, accepted = q_try, f_try, True
                mu = max(mu / 10.0, 1e-12)
                break
            mu *= 10.0
        if not accepted:
            break
        if np.abs(q[:, :3] - q_start[:, :3]).max() > 1e3 * size_scale:
            break                                           # running away: no equilibrium
    return q


def _diagnose(model, loads, q, t, step, force_scale):
    """NoEquilibriumError when the loads have a component along a zero-stiffness direction."""
    phi, D = _constraints(model, q, t)
    N, _ = null_space(D)
    Q = loads(q, 1.0, t)
    lam = np.linalg.lstsq(D.T, -Q, rcond=None)[0] if D.shape[0] else np.zeros(0)
    f = N.T @ Q
    if N.shape[1] == 0 or np.abs(f).max() <= 1e-6 * force_scale:
        return None
    H = _tangent(model, loads, q, lam, t, 1.0, step)
    K = -N.T @ H @ N
    w, Z = np.linalg.eigh(0.5 * (K + K.T))
    zero = np.abs(w) <= 1e-8 * max(np.abs(w).max(), 1e-300) + 1e-10 * force_scale
    fz = Z[:, zero].T @ f
    if zero.any() and np.abs(fz).max() > 1e-6 * force_scale:
        direction = N @ (Z[:, zero] @ fz)
        return NoEquilibriumError(
            "static equilibrium: no equilibrium exists: the applied loads have an unbalanced "
            f"component of {np.linalg.norm(fz):.4g} (N or N m) along a direction that no "
            f"joint, driver or spring resists -- {describe_direction(model, direction)}. "
            "Support the body (a joint to the ground, a spring) or remove the load.")
    return None


# ------------------------------------------------------------------------------- results
@dataclass
class StaticResults:
    """A static equilibrium and its stability.

    q (nb, 7) positions; lam (m,) multipliers; efforts: driver name -> effort (N m or N);
    reactions: name -> JointReaction (one time); residual: max |Q + D^T lam| (N or N m);
    constraint_residual: max |Phi|; method: "newton", "load stepping" or "energy
    minimisation"; stiffness: eigenvalues of the reduced tangent stiffness (ascending);
    directions (6 nb, k): their tangent directions (translation, rotation vector per body);
    classification: "stable" / "unstable" / "zero" per eigenvalue; asymmetry: relative
    |K_r - K_r^T| (should be small at an equilibrium).
    """

    model: object
    t: float
    q: np.ndarray
    lam: np.ndarray
    efforts: dict
    reactions: dict
    residual: float
    constraint_residual: float
    iterations: int
    method: str
    stiffness: np.ndarray
    directions: np.ndarray
    classification: list
    asymmetry: float
    results: object
    units: dict = field(default_factory=dict)
    messages: list = field(default_factory=list)

    @property
    def stable(self) -> bool:
        """True when no direction has negative stiffness (zero-stiffness ones are neutral)."""
        return "unstable" not in self.classification

    @property
    def unstable_directions(self) -> list:
        return [describe_direction(self.model, self.directions[:, k])
                for k, c in enumerate(self.classification) if c == "unstable"]

    @property
    def zero_stiffness_directions(self) -> list:
        return [describe_direction(self.model, self.directions[:, k])
                for k, c in enumerate(self.classification) if c == "zero"]

    def stability_table(self):
        import pandas as pd
        return pd.DataFrame(dict(
            stiffness=self.stiffness, kind=self.classification,
            motion=[describe_direction(self.model, self.directions[:, k])
                    for k in range(self.directions.shape[1])]))

    def reactions_table(self):
        return reactions_frame(self.reactions, np.array([self.t]))

    def positions_table(self):
        import pandas as pd
        rows = {}
        for k, name in enumerate(self.model.body_names):
            rows[name] = self.q[k]
        return pd.DataFrame.from_dict(rows, orient="index",
                                      columns=list(BODY_POSITION))

    def to_dataframe(self):
        """One row: positions, driver efforts and reactions."""
        import pandas as pd
        df = self.results.to_dataframe()
        rates = BODY_VELOCITY + BODY_ACCELERATION
        keep = [c for c in df.columns if c.rsplit(".", 1)[-1] not in rates
                and not c.startswith(("violation.velocity", "energy.kinetic"))]
        df = df[keep]
        for name, value in self.efforts.items():
            df[f"{name}.effort"] = value
        return pd.DataFrame(df)

    def summary(self) -> str:
        lines = [f"static equilibrium at t = {self.t:.6g} s ({self.method}, {self.iterations} "
                 f"iterations): force residual {self.residual:.3g}, max |Phi| "
                 f"{self.constraint_residual:.3g}"]
        for name, value in self.efforts.items():
            lines.append(f"  driver {name}: effort {value:.6g} {self.units.get(name, '')}")
        n_u = self.classification.count("unstable")
        n_z = self.classification.count("zero")
        lines.append(f"stability: {'STABLE' if self.stable else 'UNSTABLE'} "
                     f"({len(self.classification)} DoF: {n_u} unstable, {n_z} zero-stiffness)")
        for text in self.unstable_directions:
            lines.append(f"  unstable: {text}")
        for text in self.zero_stiffness_directions:
            lines.append(f"  zero stiffness: {text}")
        lines.extend(self.messages)
        return "\n".join(lines)


def _stability(model, loads, q, lam, t, step, zero_tol):
    _, D = _constraints(model, q, t)
    N, _ = null_space(D)
    H = _tangent(model, loads, q, lam, t, 1.0, step, check=True)
    Kr = -N.T @ H @ N
    asym = float(np.abs(Kr - Kr.T).max() / max(np.abs(Kr).max(), 1e-300)) if Kr.size else 0.0
    w, Z = np.linalg.eigh(0.5 * (Kr + Kr.T)) if Kr.size else (np.zeros(0), np.zeros((0, 0)))
    scale = max(np.abs(w).max(), 1e-300) if w.size else 1.0
    kinds = ["zero" if abs(x) <= zero_tol * scale else ("stable" if x > 0 else "unstable")
             for x in w]
    dirs = N @ Z
    zero = np.array([k == "zero" for k in kinds], dtype=bool)
    if zero.sum() > 1:
        dirs[:, zero] = localize(dirs[:, zero])
    return w, dirs, kinds, asym


def localize(Z: np.ndarray) -> np.ndarray:
    """Another basis of span(Z) (n, k) whose vectors each involve as few coordinates as
    possible (reduced echelon form on k pivot coordinates chosen by QR with column pivoting),
    so that degenerate directions read as separate motions (e.g. one spin per rod)."""
    import scipy.linalg as sla
    _, _, piv = sla.qr(Z.T, pivoting=True, mode="economic")
    P = piv[:Z.shape[1]]
    B = Z @ np.linalg.inv(Z[P])
    B[np.abs(B) < 1e-9 * np.abs(B).max()] = 0.0
    return B / np.linalg.norm(B, axis=0)


def static_equilibrium(model, q_guess=None, t: float = 0.0, *, tol: float = 1e-9,
                       max_iter: int = 50, load_steps: Sequence[int] = (4, 16, 64),
                       minimise: bool = True, step: Optional[float] = None,
                       zero_tol: float = 1e-7, seek_stable: bool = False,
                       _loads=None) -> StaticResults:
    """Static equilibrium Q(q) + D^T lam = 0, Phi(q, t) = 0 near q_guess, and its stability.

    q_guess: (nb, 7) starting positions (default the model's q0). t: time (s) of the driver
        laws (drivers hold their value at t). tol: force residual relative to the largest
        applied load. load_steps: numbers of load increments tried, in turn, when Newton at
        full load fails; minimise: then try the energy-minimisation fallback.
    step: central-difference step of the tangent stiffness (default eps^(1/3) ~ 6e-6).
    zero_tol: eigenvalues below zero_tol * max |eigenvalue| count as zero stiffness.
    seek_stable: when the equilibrium found is unstable, push the mechanism off it along each
        unstable direction (both senses), minimise the potential energy from there, and return
        the stable equilibrium of lowest energy found (the unstable one if none is).

    Raises NoEquilibriumError (the loads push along an unsupported direction, e.g. a free body
    under gravity) or ConvergenceError when no equilibrium is found.
    """
    nb = model.nb
    q = np.array(model.q0 if q_guess is None else q_guess, dtype=float).reshape(nb, 7)
    step = default_step() if step is None else float(step)
    loads = _Loads(model, t) if _loads is None else _loads
    force_scale = max(_scales(model, loads, q), 1e-9)
    size_scale = max(float(np.abs(q[:, :3]).max()), 1.0)
    q, _ = solve_positions(model, q, t)
    messages = []
    method, sol = "newton", None
    try:
        sol = _newton(model, loads, q, t, 1.0, tol, max_iter, step, force_scale)
    except (ConvergenceError, SingularMatrixError) as exc:
        messages.append(f"Newton at full load failed ({exc})")
    if sol is None:
        for n in load_steps:
            qq, total = q.copy(), 0
            try:
                for k in range(1, n + 1):
                    qq, lam, it = _newton(model, loads, qq, t, k / n, tol, max_iter, step,
                                          force_scale)
                    total += it
                sol, method = (qq, lam, total), f"load stepping ({n} increments)"
                break
            except (ConvergenceError, SingularMatrixError) as exc:
                messages.append(f"load stepping with {n} increments failed ({exc})")
    if sol is None and minimise:
        qm = _minimise(model, loads, q, t, tol, 200, step, force_scale, size_scale)
        try:
            sol = _newton(model, loads, qm, t, 1.0, tol, max_iter, step, force_scale)
            method = "energy minimisation + Newton"
        except (ConvergenceError, SingularMatrixError) as exc:
            messages.append(f"energy minimisation then Newton failed ({exc})")
            q = qm
    if sol is None:
        err = _diagnose(model, loads, q, t, step, force_scale)
        if err is not None:
            raise err
        raise ConvergenceError("static equilibrium not found: " + "; ".join(messages)
                               + ". Start nearer the expected equilibrium (q_guess).")
    q, lam, iterations = sol
    phi, D = _constraints(model, q, t)
    residual = float(np.abs(loads(q, 1.0, t) + D.T @ lam).max())
    w, dirs, kinds, asym = _stability(model, loads, q, lam, t, step, zero_tol)
    if asym > 1e-3:
        messages.append(f"reduced stiffness asymmetric by {asym:.2g} (relative): non-"
                        "conservative loads (follower forces?) make it non-symmetric; the "
                        "eigenvalues of its symmetric part are reported")
    if seek_stable and "unstable" in kinds:
        best = None
        for k in [k for k, c in enumerate(kinds) if c == "unstable"]:
            d = dirs[:, k] / np.abs(dirs[:, k]).max()
            for sign in (1.0, -1.0):
                try:
                    start, _ = solve_positions(model, perturb(q, 0.05 * sign * d), t)
                    qm = _minimise(model, loads, start, t, tol, 200, step, force_scale,
                                   size_scale)
                    q2, lam2, it2 = _newton(model, loads, qm, t, 1.0, tol, max_iter, step,
                                            force_scale)
                except (ConvergenceError, SingularMatrixError):
                    continue
                w2, dirs2, kinds2, asym2 = _stability(model, loads, q2, lam2, t, step, zero_tol)
                energy = potential_energy(model, q2, t)
                if "unstable" not in kinds2 and (best is None or energy < best[0]):
                    best = (energy, q2, lam2, it2, w2, dirs2, kinds2, asym2)
        if best is None:
            messages.append("no stable equilibrium found near the unstable one")
        else:
            messages.append("the equilibrium first found was unstable; moved off it along "
                            "its unstable direction to a stable one")
            _, q, lam, iterations, w, dirs, kinds, asym = best
            method += " + stable search"
            phi, D = _constraints(model, q, t)
            residual = float(np.abs(loads(q, 1.0, t) + D.T @ lam).max())
    rows = driver_rows(model)
    res = results_object(model, [t], q[None], np.zeros((1, nb, 6)), np.zeros((1, nb, 6)),
                         lam[None], settings={"analysis": "static"},
                         redundant_joints=nonunique_joints(model, q, t))
    return StaticResults(model=model, t=float(t), q=q, lam=lam,
                         efforts={n: float(lam[r]) for n, r in rows.items()},
                         reactions=res.reactions(), residual=residual,
                         constraint_residual=float(np.abs(phi).max()) if phi.size else 0.0,
                         iterations=int(iterations), method=method, stiffness=w,
                         directions=dirs, classification=kinds, asymmetry=asym, results=res,
                         units=driver_units(model), messages=messages)


# ------------------------------------------------------------------------------- quasi-static
@dataclass
class QuasiStaticResults:
    """A sequence of static equilibria along the drivers' motion (inertia neglected).

    t (nt,); efforts: DataFrame (t, one column per driver, N m or N); reactions: name ->
    JointReaction over time; stable (nt,) bool; results: Results (q, lam; v = vdot = 0) for
    tables, files and the animation.
    """

    model: object
    t: np.ndarray
    efforts: object
    reactions: dict
    stable: np.ndarray
    results: object
    units: dict
    min_stiffness: np.ndarray
    messages: list = field(default_factory=list)

    @property
    def q(self):
        return self.results.q

    def reactions_table(self):
        return reactions_frame(self.reactions, self.t)

    def to_dataframe(self):
        import pandas as pd
        pos = {"t": self.t, **body_columns(self.model.body_names, self.results.q, None, None)}
        eff = self.efforts.drop(columns="t").add_suffix(".effort")
        return pd.concat([pd.DataFrame(pos), eff, self.reactions_table().drop(columns="t"),
                          pd.DataFrame({"stable": self.stable})], axis=1)

    def summary(self) -> str:
        lines = [f"quasi-static analysis: {len(self.t)} equilibria from t = {self.t[0]:.6g} to "
                 f"{self.t[-1]:.6g} s; unstable at {int((~self.stable).sum())} of them"]
        for name in self.efforts.columns[1:]:
            e = self.efforts[name].to_numpy()
            lines.append(f"  {name}: effort {e.min():.6g} .. {e.max():.6g} "
                         f"{self.units.get(name, '')}")
        lines.extend(self.messages)
        return "\n".join(lines)


def quasi_static(model, t: Optional[Sequence[float]] = None, *, t_end: Optional[float] = None,
                 output_step: Optional[float] = None, q_guess=None, tol: float = 1e-9,
                 max_iter: int = 50, stability: bool = True) -> QuasiStaticResults:
    """Equilibria at the times t of a model with rheonomic drivers (Adams EQUILIBRIUM along a
    motion / Chrono DoStaticNonlinearRheonomic): each solved by :func:`static_equilibrium`
    from the previous one. Efforts of the drivers (N m / N) hold the mechanism at rest.
    stability=False: Newton only (no fallbacks, no stability), faster for long sequences."""
    from ..simulate import output_times
    if t is None:
        t = output_times(1.0 if t_end is None else t_end, output_step, None)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    nb = model.nb
    q = np.array(model.q0 if q_guess is None else q_guess, dtype=float).reshape(nb, 7)
    Q = np.empty((t.size, nb, 7))
    lam = np.empty((t.size, model.n_eq))
    stable = np.ones(t.size, dtype=bool)
    kmin = np.full(t.size, np.nan)
    messages = []
    for k, tk in enumerate(t):
        if stability:
            sol = static_equilibrium(model, q, tk, tol=tol, max_iter=max_iter)
            stable[k] = sol.stable
            kmin[k] = sol.stiffness.min() if sol.stiffness.size else np.nan
            q, lam_k = sol.q, sol.lam
        else:                                   # Newton only, no stability analysis
            loads = _Loads(model, tk)
            q, lam_k, _ = _newton(model, loads, q, tk, 1.0, tol, max_iter, default_step(),
                                  max(_scales(model, loads, q), 1e-9))
        Q[k], lam[k] = q, lam_k
    import pandas as pd
    rows = driver_rows(model)
    res = results_object(model, t, Q, np.zeros((t.size, nb, 6)), np.zeros((t.size, nb, 6)),
                         lam, settings={"analysis": "quasi_static"},
                         redundant_joints=nonunique_joints(model, Q[0], float(t[0])))
    efforts = pd.DataFrame({"t": t, **{n: lam[:, r] for n, r in rows.items()}})
    if not stable.all():
        messages.append(f"unstable equilibria at {int((~stable).sum())} of {t.size} times "
                        f"(first at t = {t[~stable][0]:.6g} s)")
    return QuasiStaticResults(model=model, t=t, efforts=efforts, reactions=res.reactions(),
                              stable=stable, results=res, units=driver_units(model),
                              min_stiffness=kmin, messages=messages)
