"""Linearization about an equilibrium or a steady motion (modes: modes.py; the reduced
system without the ignorable modes: deflation.py; inputs and outputs: linear_io.py).

Reference: (q*, v*, t) with vdot*, lam* from the equations of motion M vdot = g + D^T lam,
D vdot = gamma (dynamics/eom.py sign convention). Perturbations live in the tangent space:
q = exp(dx) q* (dx = [dr, dpi] per body, dpi a global rotation vector, 6 per body -- not 7:
the Euler-parameter normalisation is built in) and v = v* + dv. Differentiating
A = exp(dpi~) A* gives omega = omega* + dpi' - omega*~ dpi, i.e.

    dv = dx' - W dx,    W = blockdiag(0, omega*~) per body.

Linearizing the residual R(q, v, vdot, lam) = M(q) vdot - g(q, v) - D(q)^T lam = B_q u:

    M dx'' + (R_v - M W) dx' + (R_x - R_v W - M W') dx = D^T dlam + B_q u

with R_x = dR/dx at fixed (v*, vdot*, lam*) and R_v = dR/dv = -dg/dv (gyroscopic term
omega~J - (J omega)~, damping). The constraints give D dx = 0 to first order, so dx = N z with
N a basis of the null space of D (orthonormal, or by coordinate partitioning: z are chosen
body velocity coordinates); premultiplying by N^T removes dlam:

    M_r z'' + C_r z' + K_r z = B_r u,   M_r = N^T M N, C_r = N^T (R_v - M W) N,
                                        K_r = N^T (R_x - R_v W - M W') N,  B_r = N^T B_q.

At an equilibrium W = 0 and K_r is the reduced tangent stiffness of statics.py (including the
constraint-curvature term lam^T d2Phi). For a steady motion the basis may follow a frame turning
at omega_f (``frame_rate``): N(t) = R_f(t) N, N' = Om N, N'' = Om^2 N with Om = blockdiag(
omega_f~) on every 3-vector, and dx = N z gives

    C_r = N^T (2 M Om + (R_v - M W)) N,   K_r = N^T (M Om^2 + (R_v - M W) Om + K2) N,

constant for a relative equilibrium. A fixed frame (default) is exact when the null space of D
does not turn along the motion (a rotor about a fixed axis, a top spinning about the vertical);
otherwise a warning says how fast it turns relative to the chosen frame.

Nonholonomic constraints (rows that constrain velocities only: rolling without slip) leave
fewer velocity than position freedoms, and no second-order form. The positions stay in the null
space of the holonomic rows D_h, dx = N_h a; the velocities satisfy the linearized velocity
constraints D dv + d(D v*)/dx dx = 0, so dv = P a + N_v b with N_v the null space of all of D
and P = -D^+ d(D v*)/dx N_h. With dx' = dv + W dx and N_v^T removing dlam:

    a' = N_h^+ (P a + N_v b + W N_h a)          (N_h^+ = N_h^T for an orthonormal basis)
    N_v^T M N_v b' = -N_v^T [M P a' + R_v dv + R_x dx] + N_v^T B_q u

the first-order model x = [a, b] (C and K None). The bases are frozen at the reference
instant; a TurningNullSpaceWarning says how fast they turn along the motion (not at all for a
vehicle running straight, whose wheels spin about their axles). With ``frame_rate`` they turn
with the frame instead: a' loses N_h^+ Om N_h a, and dv' gains Om (P a + N_v b).

Derivatives: M, the gyroscopic term and their q-dependence analytic; force elements and the
constraint term D^T lam by central differences (step eps^(1/3), checked against half the step).
``derivatives="fd"`` differences everything (the tests compare the two).
"""
from __future__ import annotations

import warnings
from typing import Optional, Sequence

import numpy as np

from ..errors import ModelError, SimulationError
from ..rotations import skew
from ..state import BodyState
from .common import (COMPONENTS, central_jacobian, default_step, dense, driver_rows,
                     null_space, perturb)
from .linear_io import _input_columns, _output_rows
from .linear_model import LinearModel


class NotEquilibriumError(SimulationError):
    """Linearization asked about a state that is neither at rest in equilibrium nor declared a
    steady motion."""


class TurningNullSpaceWarning(UserWarning):
    """The constraint null space turns along the steady motion: frozen-time linearization."""


def _skew_blocks(w: np.ndarray) -> np.ndarray:
    """blockdiag(0, w~) per body (6 nb, 6 nb) for w (nb, 3)."""
    nb = w.shape[0]
    W = np.zeros((6 * nb, 6 * nb))
    for b in range(nb):
        W[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = skew(w[b])
    return W


def _force_elements(model, q, v, t) -> np.ndarray:
    """Generalized forces of the force elements (6 nb,) at (q, v)."""
    nb = model.nb
    g = np.zeros((nb + 1, 6))
    if model.force_groups:
        state = BodyState.from_qv(q, v, t)
        for grp in model.force_groups:
            grp.evaluate(state, t, g)
    return g[:nb].reshape(-1)


def _global_inertia(model, q):
    from ..rotations import A_from_p
    A = A_from_p(np.asarray(q).reshape(-1, 7)[:, 3:])
    return A @ model.inertia @ np.swapaxes(A, 1, 2)



def _velocity_only_rows(model) -> np.ndarray:
    """(n_eq,) bool: the equations that constrain velocities only (nonholonomic rows)."""
    mask = np.zeros(model.n_eq, dtype=bool)
    for g, start in zip(model.constraint_groups, model.group_offsets[:-1]):
        for r in g.velocity_rows:
            mask[start + r:start + g.size:g.n_eq] = True
    return mask


#: the velocity named after each tangent coordinate (partitioned coordinates)
RATE_OF = {"x": "vx", "y": "vy", "z": "vz", "rx": "wx", "ry": "wy", "rz": "wz"}


def _first_order(model, q, v, t, keep, D, velocity_only, M, Rv, Rx, W, Om, B_q, inputs,
                 outputs, D_full, step, steady, fd_error, messages, input_reference, framed,
                 coordinates="nullspace", labels=()):
    """The linear model of a nonholonomic system, in first-order form (module docstring,
    "Nonholonomic constraints"): positions dx = N_h a in the null space of the holonomic rows
    D_h, velocities dv = P a + N_v b with N_v the null space of all of D and P the least-norm
    solution of the linearized velocity constraints D dv + d(D v*)/dx dx = 0. With a frame
    turning at Om the bases turn with it (N_h' = Om N_h, N_v' = Om N_v, P' = Om P).
    coordinates "partition": N_h and N_v by coordinate partitioning (a = chosen body tangent
    coordinates, b = chosen body velocities), a' read through the left inverse of N_h."""
    nb = model.nb
    qv = q.reshape(nb, 7)
    if coordinates == "partition":
        N_h, zlabels = _partition_basis(D[~velocity_only], labels)
        N_v, wlabels = _partition_basis(D, labels)
        wlabels = [f"{w.rsplit('.', 1)[0]}.{RATE_OF[w.rsplit('.', 1)[1]]}" for w in wlabels]
    else:
        N_h, _ = null_space(D[~velocity_only])
        N_v, _ = null_space(D)
        zlabels = [f"z{k}" for k in range(N_h.shape[1])]
        wlabels = [f"w{k}" for k in range(N_v.shape[1])]
    L_h = np.linalg.pinv(N_h)                  # N_h^T for an orthonormal basis
    npos, nvel = N_h.shape[1], N_v.shape[1]
    if np.abs(v).max() > 0:
        Dv_x, err = central_jacobian(
            lambda dx: dense(model.assembler.evaluate(perturb(qv, dx), None, t).D)[keep] @ v,
            6 * nb, step, what="d(D v*)/dx")
        fd_error = max(fd_error, err)
    else:
        Dv_x = np.zeros_like(D)
    P = -np.linalg.lstsq(D, Dv_x @ N_h, rcond=None)[0]          # dv = P a + N_v b
    if steady and np.abs(v).max() > 0:
        rate = _basis_turn_rate(model, qv, v, t, keep, D, velocity_only, N_h, N_v, Om)
        spin = max(float(np.abs(v.reshape(nb, 6)[:, 3:]).max()), 1.0)
        if rate > 1e-6 * spin:
            text = (f"the constraint tangent spaces turn along the steady motion at {rate:.3g} "
                    "rad/s" + (" relative to the frame_rate given" if framed else "")
                    + ": the linearization freezes them at this instant (approximate). For a "
                    "mechanism turning steadily as a whole (a relative equilibrium) pass its "
                    "rate as frame_rate")
            messages.append(text)
            warnings.warn(text, TurningNullSpaceWarning, stacklevel=3)
    Xa = P + W @ N_h                                   # dx' = dv + W dx = Xa a + N_v b
    # a' = N_h^+ (dx' - N_h' a)
    A_aa, A_ab = L_h @ (Xa - Om @ N_h), L_h @ N_v
    # N_v^T [M dv' + R_v dv + R_x dx] = N_v^T B_q u (N_v^T D^T dlam = 0), with
    # dv' = P a' + Om P a + N_v b' + Om N_v b
    Mv = N_v.T @ M @ N_v
    Minv = np.linalg.inv(Mv) if nvel else np.zeros((0, 0))
    G_a = -Minv @ N_v.T @ (M @ (P @ A_aa + Om @ P) + Rv @ P + Rx @ N_h)
    G_b = -Minv @ N_v.T @ (M @ (P @ A_ab + Om @ N_v) + Rv @ N_v)
    A = np.block([[A_aa, A_ab], [G_a, G_b]])
    B = np.vstack([np.zeros((npos, B_q.shape[1])), Minv @ N_v.T @ B_q])
    Cx, Cv = _output_rows(model, list(outputs), D_full, q, W, v, t, step)
    C_out = np.hstack([Cx @ N_h + Cv @ Xa, Cv @ N_v])
    D_out = np.zeros((C_out.shape[0], B.shape[1]))
    return LinearModel(model=model, q=q, v=v.reshape(nb, 6), t=float(t), M=Mv, C=None, K=None,
                       B_u=N_v.T @ B_q, A=A, B=B, C_out=C_out, D_out=D_out, basis=N_h,
                       coordinates=zlabels, inputs=list(inputs),
                       outputs=list(outputs), steady=steady, fd_error=fd_error,
                       messages=messages, input_reference=np.array(input_reference),
                       velocity_basis=N_v, velocity_map=P, velocity_coordinates=wlabels)


def _basis_turn_rate(model, qv, v, t, keep, D, velocity_only, N_h, N_v, Om) -> float:
    """How fast (rad/s) the null spaces of D_h and D turn as the state moves along v, relative
    to a frame turning at Om: -D^+ D' N (the rate at which N leaves the null space) against
    the frame's Om N - N N^T Om N."""
    h = 1e-6
    rates = []
    D_p = dense(model.assembler.evaluate(perturb(qv, h * v), None, t + h).D)[keep]
    D_m = dense(model.assembler.evaluate(perturb(qv, -h * v), None, t - h).D)[keep]
    for rows, N in ((~velocity_only, N_h), (slice(None), N_v)):
        Dd = (D_p[rows] - D_m[rows]) / (2 * h)
        if N.shape[1] and D[rows].shape[0]:
            out_of = -np.linalg.lstsq(D[rows], Dd @ N, rcond=None)[0]
            modelled = Om @ N - N @ (np.linalg.pinv(N) @ Om @ N)
            rates.append(float(np.linalg.norm(out_of - modelled, 2)))
    return max(rates, default=0.0)


def _partition_basis(D: np.ndarray, labels):
    """Coordinate partitioning: independent velocity coordinates chosen by QR with column
    pivoting of D (the dependent ones are the first rank pivots); N = [I; -D_d^-1 D_i]."""
    import scipy.linalg as sla
    n = D.shape[1]
    if D.shape[0] == 0:
        return np.eye(n), list(labels)
    _, R, piv = sla.qr(D, pivoting=True, mode="economic")
    d = np.abs(np.diag(R))
    rank = int(np.sum(d > max(D.shape) * np.finfo(float).eps * 1e3 * (d[0] if d.size else 1)))
    dep, ind = piv[:rank], np.sort(piv[rank:])
    N = np.zeros((n, ind.size))
    N[ind, np.arange(ind.size)] = 1.0
    N[dep] = -np.linalg.lstsq(D[:, dep], D[:, ind], rcond=None)[0]
    return N, [labels[i] for i in ind]


def linearize(model, q=None, v=None, t: float = 0.0, *, steady: bool = False,
              inputs: Sequence[str] = (), outputs: Sequence[str] = (),
              coordinates: str = "nullspace", derivatives: str = "analytic",
              step: Optional[float] = None, tol: float = 1e-6,
              frame_rate: Optional[Sequence[float]] = None) -> LinearModel:
    """Linear model about (q, v, t) (defaults: the model's q0, v0).

    steady: False -- (q, v) must be an equilibrium (v = 0, no unbalanced force; else
        NotEquilibriumError: find one with static_equilibrium first); True -- a steady motion
        (e.g. a spinning top), linearized at this instant.
    inputs: driver names (the driver is removed from the constraints and its effort, N m or N,
        becomes the input), point_force / torque element names (their magnitude, N or N m, as
        an additive input), rotational_spring_damper names (a torque along its joint angle,
        N m: positive does positive work as the angle increases, i.e. minus its actuator) or
        "<body>.<fx|fy|fz|mx|my|mz>" (N, N m, global axes, at the CoM).
    outputs: "<body>.<x|y|z|rx|ry|rz>" (m, rad), "<body>.<vx|..|wz>" (m/s, rad/s),
        "<body>.<point>.<x|y|z|vx|vy|vz>", "<joint>.angle" / "<joint>.angle_rate" of revolute
        and cylindrical joints (rad, rad/s), a driver name (change of its coordinate) or
        "<driver>.rate".
    coordinates: "nullspace" (orthonormal basis of the null space of D) or "partition"
        (independent body velocity coordinates, named "<body>.<x|y|z|rx|ry|rz>").
    derivatives: "analytic" (analytic where the kernels have them) or "fd" (all central
        differences, step ``step``; default eps^(1/3)).
    tol: relative size of the unbalanced force below which the state counts as equilibrium.
    frame_rate: (3,) rad/s, steady motions only: the coordinates z follow a frame turning at
        this rate about an axis through the origin (N(t) = R_f(t) N). For a relative
        equilibrium -- the whole mechanism turning steadily, e.g. a pendulum on a driven shaft,
        a flyball governor -- the linear model is then constant and its frequencies are those
        seen in the turning frame. Default: a fixed frame.
    """
    from ..dynamics.eom import EquationsOfMotion
    from ..dynamics.reaction_friction import refuse
    refuse(model, "linearize")
    from ..forces.armature import refuse_armature
    refuse_armature(model, "linearize")
    nb = model.nb
    q = np.array(model.q0 if q is None else q, dtype=float).reshape(nb, 7)
    q[:, 3:] /= np.linalg.norm(q[:, 3:], axis=1, keepdims=True)
    v = np.array(model.v0 if v is None else v, dtype=float).reshape(-1)
    if v.size != 6 * nb:
        raise ModelError(f"linearize: v must hold {6 * nb} numbers, got {v.size}")
    if coordinates not in ("nullspace", "partition"):
        raise ModelError(f"linearize: coordinates {coordinates!r} is not 'nullspace' or "
                         "'partition'")
    if derivatives not in ("analytic", "fd"):
        raise ModelError(f"linearize: derivatives {derivatives!r} is not 'analytic' or 'fd'")
    step = default_step() if step is None else float(step)
    eom = EquationsOfMotion(model)
    ev = eom.evaluate(t, q, v)
    D_full = dense(ev.cv.D)
    phi = ev.cv.phi
    if phi.size and np.abs(phi).max() > 1e-6:
        raise ModelError(f"linearize: the reference positions violate the constraints (max "
                         f"|Phi| = {np.abs(phi).max():.3g}); assemble them first "
                         "(kinematics.solve_positions or static_equilibrium)")
    B_q, dropped = _input_columns(model, list(inputs), D_full, q)
    keep = np.setdiff1d(np.arange(model.n_eq), dropped)
    D = D_full[keep]
    M = ev.M.dense()
    g = ev.g
    m = D.shape[0]
    # reference accelerations and multipliers with every constraint, input drivers included:
    # their multipliers are the reference efforts u*, whose forces D_k^T u* stay applied (and
    # turn with the bodies) while the inputs u are perturbations about them
    m_all = D_full.shape[0]
    kkt = np.block([[M, -D_full.T], [D_full, np.zeros((m_all, m_all))]])
    sol = np.linalg.lstsq(kkt, np.concatenate([g, ev.cv.gamma]), rcond=1e-12)[0]
    vdot, lam = sol[:6 * nb], sol[6 * nb:]
    rows_all = driver_rows(model)

    messages = []
    force_scale = max(float(np.abs(model.mass[:, None] * model.gravity).max()),
                      float(np.abs(g).max()),
                      float(np.abs(D_full.T @ lam).max() if m_all else 0), 1e-12)
    unbalanced = M @ vdot                                   # = g + D^T lam
    if not steady:
        if np.abs(v).max() > 1e-9:
            raise NotEquilibriumError(
                f"linearize: the reference state moves (max |v| = {np.abs(v).max():.3g}); pass "
                "steady=True to linearize about a steady motion, or v = 0 for an equilibrium")
        if np.abs(unbalanced).max() > tol * force_scale:
            worst = int(np.argmax(np.abs(unbalanced)))
            raise NotEquilibriumError(
                "linearize: the reference state is not an equilibrium: unbalanced generalized "
                f"force {np.abs(unbalanced).max():.4g} (N or N m) on body "
                f"{model.body_names[worst // 6]!r} ({COMPONENTS[worst % 6]}); find the "
                "equilibrium first (static_equilibrium) or pass steady=True for a steady motion")
    qv = q.reshape(nb, 7)
    w = v.reshape(nb, 6)[:, 3:]
    wd = vdot.reshape(nb, 6)[:, 3:]
    W = _skew_blocks(w)
    Wd = _skew_blocks(wd)

    # R_v = -dg/dv
    if derivatives == "fd":
        Rv, err_v = central_jacobian(lambda dv: -eom.evaluate(t, q, v + dv).g, 6 * nb, step,
                                     what="dg/dv")
    else:
        J = _global_inertia(model, q)
        Rv = np.zeros((6 * nb, 6 * nb))
        for b in range(nb):                                 # d(omega~ J omega)/d omega
            sl = slice(6 * b + 3, 6 * b + 6)
            Rv[sl, sl] = skew(w[b]) @ J[b] - skew(J[b] @ w[b])
        err_v = 0.0
        if model.force_groups:
            Jf, err_v = central_jacobian(lambda dv: -_force_elements(model, q, v + dv, t),
                                         6 * nb, step, what="d(force elements)/dv")
            Rv += Jf

    # R_x = dR/dx at fixed v, vdot, lam
    def residual_fd(dx):
        qq = perturb(qv, dx)
        e = eom.evaluate(t, qq, v)
        return e.M.dot(vdot) - e.g - dense(e.cv.D).T @ lam

    if derivatives == "fd":
        Rx, err_x = central_jacobian(residual_fd, 6 * nb, step, what="dR/dx")
    else:
        J = _global_inertia(model, q)
        Rx = np.zeros((6 * nb, 6 * nb))
        for b in range(nb):
            sl = slice(6 * b + 3, 6 * b + 6)
            Jw, Jwd = J[b] @ w[b], J[b] @ wd[b]
            # d(J wdot)/dpi = -(J wdot)~ + J wdot~ ; d(w~ J w)/dpi = w~ (-(J w)~ + J w~)
            Rx[sl, sl] = (-skew(Jwd) + J[b] @ skew(wd[b])) \
                + skew(w[b]) @ (-skew(Jw) + J[b] @ skew(w[b]))

        def rest(dx):
            qq = perturb(qv, dx)
            Dq = dense(model.assembler.evaluate(qq, None, t).D)
            return -_force_elements(model, qq, v, t) - Dq.T @ lam
        Jr, err_x = central_jacobian(rest, 6 * nb, step, what="d(-Q - D^T lam)/dx")
        Rx += Jr

    C2 = Rv - M @ W
    K2 = Rx - Rv @ W - M @ Wd
    labels = [f"{name}.{c}" for name in model.body_names for c in COMPONENTS]
    # bases moving with the frame: N(t) = R_f(t) N, N' = Om N, N'' = Om^2 N
    Om = np.zeros((6 * nb, 6 * nb))
    if frame_rate is not None:
        if not steady:
            raise ModelError("linearize: frame_rate applies to steady motions (steady=True)")
        wf = np.asarray(frame_rate, dtype=float).reshape(-1)
        if wf.size != 3 or not np.all(np.isfinite(wf)):
            raise ModelError(f"linearize: frame_rate must be 3 finite numbers (rad/s), got "
                             f"{frame_rate!r}")
        for k in range(2 * nb):
            Om[3 * k:3 * k + 3, 3 * k:3 * k + 3] = skew(wf)
    velocity_only = _velocity_only_rows(model)[keep]
    if velocity_only.any():
        lin = _first_order(model, q, v, t, keep, D, velocity_only, M, Rv, Rx, W, Om, B_q,
                            inputs, outputs, D_full, step, steady, max(err_x, err_v),
                            messages, [lam[rows_all[n]] if n in rows_all else 0.0
                                       for n in inputs], frame_rate is not None,
                            coordinates, labels)
        lin.frame_rate = None if frame_rate is None else wf
        return lin
    if coordinates == "partition":
        N, zlabels = _partition_basis(D, labels)
    else:
        N, rank = null_space(D)
        zlabels = [f"z{k}" for k in range(N.shape[1])]
    Ndot, Nddot = Om @ N, Om @ Om @ N
    if steady and N.shape[1] and m:
        h = 1e-6
        Dp = dense(model.assembler.evaluate(perturb(qv, h * v), None, t + h).D)[keep]
        Dm = dense(model.assembler.evaluate(perturb(qv, -h * v), None, t - h).D)[keep]
        # rate at which the null space leaves itself, -D^+ D' N, against the frame's rotation
        out_of = -np.linalg.lstsq(D, (Dp - Dm) / (2 * h) @ N, rcond=None)[0]
        modelled = Ndot - N @ (N.T @ Ndot)
        turn = float(np.linalg.norm(out_of - modelled, 2))
        spin = max(float(np.abs(w).max()), 1.0)
        if turn > 1e-6 * spin:
            text = (f"the null space of D turns along the steady motion at {turn:.3g} rad/s "
                    + ("relative to the frame_rate given" if frame_rate is not None else "")
                    + ": the linearization freezes it at this instant (approximate). For a "
                    "mechanism turning steadily as a whole (a relative equilibrium) pass its "
                    "rate as frame_rate")
            messages.append(text)
            warnings.warn(text, TurningNullSpaceWarning, stacklevel=2)
    Mr = N.T @ M @ N
    Cr = N.T @ (2 * M @ Ndot + C2 @ N)
    Kr = N.T @ (M @ Nddot + C2 @ Ndot + K2 @ N)
    Br = N.T @ B_q
    n = N.shape[1]
    Minv = np.linalg.inv(Mr) if n else np.zeros((0, 0))
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ Kr, -Minv @ Cr]])
    B = np.vstack([np.zeros((n, B_q.shape[1])), Minv @ Br])
    Cx, Cv = _output_rows(model, list(outputs), D_full, q, W, v, t, step)
    C_out = np.hstack([Cx @ N, Cv @ N])
    D_out = np.zeros((C_out.shape[0], B.shape[1]))
    return LinearModel(model=model, q=q, v=v.reshape(nb, 6), t=float(t), M=Mr, C=Cr, K=Kr,
                       B_u=Br, A=A, B=B, C_out=C_out, D_out=D_out, basis=N,
                       coordinates=zlabels, inputs=list(inputs), outputs=list(outputs),
                       steady=steady, fd_error=max(err_x, err_v), messages=messages,
                       input_reference=np.array([lam[rows_all[n]] if n in rows_all else 0.0
                                                 for n in inputs]),
                       frame_rate=None if frame_rate is None else wf)
