"""Computing the output columns from a result: joint coordinates and rates, force-element and
driver outputs, momentum, energy per body and IMU signals (after the run, from the recorded
states)."""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..errors import ModelError
from ..forces.base import spring_law
from .vocabulary import (GENERIC_COORDINATES, JOINT_COORDINATES, QUANTITIES, _force_group,
                         _force_kind, parse_outputs)


class _Track:
    """Body states at all output times, with the ground appended as body nb:
    r, rdot, rddot, omega, omegadot (nt, nb+1, 3), A (nt, nb+1, 3, 3)."""

    def __init__(self, results):
        from ..rotations import A_from_p
        self.model = results.model
        q = np.asarray(results.q, dtype=float)
        v = np.asarray(results.v, dtype=float)
        vdot = results.vdot
        vdot = np.zeros_like(v) if vdot is None else np.asarray(vdot, dtype=float)
        nt, nb = q.shape[0], q.shape[1]
        self.t = np.asarray(results.t, dtype=float)
        self.nt, self.nb = nt, nb

        def pad(x):
            return np.concatenate([x, np.zeros((nt, 1, x.shape[2]))], axis=1)
        self.r = pad(q[:, :, :3])
        p = q[:, :, 3:] / np.linalg.norm(q[:, :, 3:], axis=2, keepdims=True) if nb else \
            q[:, :, 3:]
        self.p = p
        A = A_from_p(p) if nb else np.zeros((nt, 0, 3, 3))
        self.A = np.concatenate([A, np.broadcast_to(np.eye(3), (nt, 1, 3, 3))], axis=1)
        self.rdot, self.omega = pad(v[:, :, :3]), pad(v[:, :, 3:])
        self.rddot, self.omegadot = pad(vdot[:, :, :3]), pad(vdot[:, :, 3:])

    def vector(self, body, local):
        """A body-fixed vector (global axes) and its rate omega x e: (nt, 3) each."""
        e = self.A[:, body] @ np.asarray(local, dtype=float)
        return e, np.cross(self.omega[:, body], e)

    def point(self, body, local):
        """Position, velocity and acceleration (5.8)-(5.9) of a body point: (nt, 3) each."""
        s = self.A[:, body] @ np.asarray(local, dtype=float)
        w, wd = self.omega[:, body], self.omegadot[:, body]
        return (self.r[:, body] + s, self.rdot[:, body] + np.cross(w, s),
                self.rddot[:, body] + np.cross(wd, s) + np.cross(w, np.cross(w, s)))


def _dot(a, b):
    return np.einsum("ni,ni->n", a, b)


def _angle(e1, e1d, e2, e2d, f, fd):
    """theta = atan2(e2 . f, e1 . f) and its rate (x ydot - y xdot) / (x^2 + y^2), unwrapped."""
    x, y = _dot(e1, f), _dot(e2, f)
    xd, yd = _dot(e1d, f) + _dot(e1, fd), _dot(e2d, f) + _dot(e2, fd)
    theta = np.unwrap(np.arctan2(y, x)) if x.size else x
    return theta, (x * yd - y * xd) / (x * x + y * y)


def _bryant(C, w):
    """Bryant angles (x-y-z) of the rotation matrices C (nt, 3, 3) and their rates from the
    relative angular velocity w (nt, 3) in the first frame:
    w = e_x rx' + Rx e_y ry' + Rx Ry e_z rz'."""
    rx = np.arctan2(-C[:, 1, 2], C[:, 2, 2])
    ry = np.arcsin(np.clip(C[:, 0, 2], -1.0, 1.0))
    rz = np.arctan2(-C[:, 0, 1], C[:, 0, 0])
    if rx.size:
        rx, rz = np.unwrap(rx), np.unwrap(rz)
    c1, s1, c2, s2 = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry)
    with np.errstate(divide="ignore", invalid="ignore"):
        rz_d = (c1 * w[:, 2] - s1 * w[:, 1]) / c2
    ry_d = c1 * w[:, 1] + s1 * w[:, 2]
    rx_d = w[:, 0] - s2 * rz_d
    return (rx, ry, rz), (rx_d, ry_d, rz_d)


# ============================================================================ joints
def joint_coordinates(results, joint: str) -> dict:
    """Coordinates and rates of one joint over time: {"angle": (nt,), "angle_rate": ...}
    (the coordinates of each joint type and their sign conventions: module docstring)."""
    return _joint(_Track(results), results.model, joint)


def _joint(tr: _Track, model, joint: str) -> dict:
    g, k, _ = model.element(joint)
    if g.rheonomic:
        raise ModelError(f"{joint!r} is a driver; request it as a driver output")
    bi, bj = int(g.body_i[k]), int(g.body_j[k])
    geo = g.geometry
    Ri, Rj = geo.R_i[k], geo.R_j[k]
    u_i, a_i, b_i = (tr.vector(bi, Ri[:, c]) for c in range(3))
    u_j, a_j, b_j = (tr.vector(bj, Rj[:, c]) for c in range(3))
    Pi, vPi, _ = tr.point(bi, geo.s_i[k])
    Pj, vPj, _ = tr.point(bj, geo.s_j[k])
    d, dd = Pj - Pi, vPj - vPi

    def along(e):                      # e . d and its rate
        return _dot(e[0], d), _dot(e[1], d) + _dot(e[0], dd)

    out = {}
    kind = g.name
    coords = JOINT_COORDINATES.get(kind, GENERIC_COORDINATES)
    if "angle" in coords:
        out["angle"], out["angle_rate"] = _angle(*a_i, *b_i, *a_j)
    if kind in ("translational", "cylindrical", "screw"):
        out["translation"], out["translation_rate"] = along(u_i)
    if kind == "planar":
        out["translation_a"], out["translation_a_rate"] = along(a_i)
        out["translation_b"], out["translation_b_rate"] = along(b_i)
    if kind == "universal":
        # angle of the cross (u_j) about u_i, and of body j about u_j relative to the cross
        # (u_i seen from j turns the other way); zero at the model's initial configuration
        th1, th1d = _angle(*a_i, *b_i, *u_j)
        th2, th2d = _angle(*a_j, *b_j, *u_i)
        th2, th2d = -th2, -th2d
        z1, z2 = _universal_offsets(model, bi, bj, Ri, Rj)
        out["angle_i"], out["angle_i_rate"] = _shift(th1, z1), th1d
        out["angle_j"], out["angle_j_rate"] = _shift(th2, -z2), th2d
    if "rx" in coords:
        Ti = np.stack([u_i[0], a_i[0], b_i[0]], axis=2)
        Tj = np.stack([u_j[0], a_j[0], b_j[0]], axis=2)
        C = np.einsum("nji,njk->nik", Ti, Tj)
        w = np.einsum("nji,nj->ni", Ti, tr.omega[:, bj] - tr.omega[:, bi])
        angles, rates = _bryant(C, w)
        if "dx" in coords:
            dl = np.einsum("nji,nj->ni", Ti, d)
            # d/dt (T_i^T d) = T_i^T (ddot - omega_i x d)
            dld = np.einsum("nji,nj->ni", Ti, dd - np.cross(tr.omega[:, bi], d))
            for c, name in enumerate(("dx", "dy", "dz")):
                out[name], out[name + "_rate"] = dl[:, c], dld[:, c]
        for name, a, ad in zip(("rx", "ry", "rz"), angles, rates):
            out[name], out[name + "_rate"] = a, ad
    return out


def _universal_offsets(model, bi, bj, Ri, Rj):
    """The two raw universal-joint angles at the model's initial configuration."""
    from ..rotations import A_from_p

    def A(b):
        return np.eye(3) if b == model.nb else A_from_p(np.asarray(model.q0[b, 3:]))
    Ai, Aj = A(bi), A(bj)
    ui, ai, bbi = (Ai @ Ri[:, c] for c in range(3))
    uj, aj, bbj = (Aj @ Rj[:, c] for c in range(3))
    return math.atan2(bbi @ uj, ai @ uj), math.atan2(bbj @ ui, aj @ ui)


def _shift(theta, zero):
    """theta - zero, with the 2 pi multiple chosen so that the first value is nearest zero."""
    if not theta.size:
        return theta
    x = theta - zero
    return x - 2 * np.pi * np.round(x[0] / (2 * np.pi))


# ============================================================================ force elements
def force_outputs(results, element: str) -> dict:
    """Outputs of one force element over time (quantities by type: :data:`QUANTITIES`).

    Each element is evaluated by its own force law (the methods the dynamics uses), so the
    outputs are exactly the forces that acted in the analysis."""
    return _force(results, results.model, element)


def _states(results) -> list:
    from ..state import BodyState
    return [BodyState.from_qv(results.q[k], results.v[k], results.t[k])
            for k in range(len(results.t))]


def _force(results, model, element: str, states=None) -> dict:
    g, i = _force_group(model, element)
    nt = len(results.t)
    kind = _force_kind(g)
    if kind is None:
        raise ModelError(f"force element {element!r}: no outputs for elements of type "
                         f"{g.name!r} when the model has several of them")
    if kind == "contact":
        return _contact(results, g.names[i])
    if kind == "own":
        return g.output_columns(results, i, _states(results) if states is None else states)
    cols = {q: np.zeros(nt) for q in QUANTITIES[kind]}
    for k, state in enumerate(_states(results) if states is None else states):
        t = float(results.t[k])
        if kind == "spring_damper":
            # Eqs. (11.5)-(11.10) for instance i
            A_i, A_j = state.A[g.bi[i]], state.A[g.bj[i]]
            si, sj = A_i @ g.s_i[i], A_j @ g.s_j[i]
            lvec = state.r[g.bj[i]] + sj - state.r[g.bi[i]] - si
            ldvec = (state.rdot[g.bj[i]] + np.cross(state.omega[g.bj[i]], sj)
                     - state.rdot[g.bi[i]] - np.cross(state.omega[g.bi[i]], si))
            length = float(np.linalg.norm(lvec))
            if length == 0.0 and g.l0[i] == 0.0:
                # coincident points of a zero-length spring: u along the relative velocity,
                # as in the kernel (forces.spring_damper)
                ldot = float(np.linalg.norm(ldvec))
            else:
                ldot = float(lvec @ ldvec) / length
            spring, energy = spring_law(g.k[i], g.nonlinear[i], length - g.l0[i])
            f = spring + g.c[i] * ldot + g.law_values(t)[i, 0]
            cols["length"][k], cols["length_rate"][k] = length, ldot
            cols["deflection"][k] = length - g.l0[i]
            cols["force"][k] = f
            cols["power"][k] = -f * ldot            # f u on i, -f u on j: -f ldot
            cols["energy"][k] = energy
        elif kind == "rotational_spring_damper":
            from ..constraints.primitives import relative_angle
            theta, _, thetad, _ = relative_angle(state, g.bi[i:i + 1], g.bj[i:i + 1],
                                                 g.R_i[i:i + 1], g.R_j[i:i + 1])
            dtheta = float(np.remainder(theta[0] - g.theta0[i] + np.pi, 2 * np.pi) - np.pi)
            spring, energy = spring_law(g.k[i], g.nonlinear[i], dtheta)
            tau = -(spring + g.c[i] * thetad[0] + g.law_values(t)[i, 0])
            cols["angle_rate"][k], cols["deflection"][k] = thetad[0], dtheta
            cols["torque"][k] = tau
            cols["power"][k] = tau * thetad[0]      # generalized force tau D_theta: tau thetadot
            cols["energy"][k] = energy
        elif kind in ("point_force", "torque"):
            b = g.body[i]
            direction = state.A[b] @ g.direction[i] if g.in_body[i] else g.direction[i]
            vec = g.law_values(t)[i, 0] * direction
            if kind == "point_force":
                s = state.A[b] @ g.point[i]
                vP = state.rdot[b] + np.cross(state.omega[b], s)
                cols["fx"][k], cols["fy"][k], cols["fz"][k] = vec
                cols["power"][k] = vec @ vP
            else:
                cols["mx"][k], cols["my"][k], cols["mz"][k] = vec
                cols["power"][k] = vec @ state.omega[b]
        elif kind == "bushing":
            # bushing axes of body i; the force and moment the bushing applies ON body j
            delta, deltadot, theta, thetadot, fl, ml = g.deflections(state, i)
            for c, axis in enumerate("xyz"):
                cols["d" + axis][k], cols["r" + axis][k] = delta[c], theta[c]
                cols["f" + axis][k], cols["m" + axis][k] = -fl[c], -ml[c]
            cols["power"][k] = -(deltadot @ fl
                                 + thetadot @ (g.Kr[i] * theta + g.Cr[i] * thetadot))
            cols["energy"][k] = 0.5 * (g.Kt[i] @ delta ** 2 + g.Kr[i] @ theta ** 2)
        elif kind == "*":
            # the only element of its type: its generalized forces on every body, Eq. (10.6)
            z = getattr(results, "force_states", None)        # LuGre bristles
            st = None
            if z is not None:
                from ..forces.kernels import states_by_group
                st = states_by_group(results.model.force_groups, z[k]).get(id(g))
            gen, energies, _ = g._run(state, t, st)
            v = np.concatenate([state.rdot, state.omega], axis=1)
            cols["power"][k] = float(np.sum(gen[:-1] * v[:-1]))
            cols["energy"][k] = float(np.sum(energies))
        elif kind == "user":
            f, n = g.functions[i](t, results.q[k], results.v[k])
            v = np.asarray(results.v[k])
            cols["power"][k] = float(np.sum(np.asarray(f) * v[:, :3])
                                     + np.sum(np.asarray(n) * v[:, 3:]))
    if kind == "rotational_spring_damper":
        # the joint angle itself, unwrapped (the deflection stays wrapped, as the element uses it)
        cols["angle"] = np.unwrap(g.theta0[i] + cols["deflection"]) if nt else cols["angle"]
    return cols


def _contact(results, name: str) -> dict:
    """The QUANTITIES["contact"] columns of contact instance ``name`` (all contacts of the
    results are evaluated once and kept with them)."""
    from ..forces.contact.memory import contact_table
    cache = getattr(results, "_contact_columns", None)
    if cache is None or cache[0] != len(results.t):
        cache = (len(results.t), contact_table(results))
        try:
            results._contact_columns = cache
        except AttributeError:
            pass
    c = cache[1][name]
    cols = {key: c[key] for key in ("gap", "penetration", "gap_rate", "impact_velocity",
                                    "normal_force", "slip_speed", "power_normal",
                                    "power_friction", "dissipated_normal",
                                    "dissipated_friction", "damping")}
    for key, vec in (("friction", c["friction"]), ("slip", c["slip"]), ("point", c["point"])):
        for a, axis in enumerate("xyz"):
            cols[f"{key}_{axis}"] = vec[:, a]
    cols["active"] = c["active"].astype(float)
    return {q: cols[q] for q in QUANTITIES["contact"]}


# ============================================================================ drivers
def driver_outputs(results, driver: str) -> dict:
    """coordinate, coordinate_rate, effort and power of one driver over time (module
    docstring: effort = lam of the driver's equation, power = effort * coordinate_rate)."""
    return _driver(_Track(results), results, driver)


def _driver(tr: _Track, results, driver: str) -> dict:
    model = results.model
    g, k, rows = model.element(driver)
    if not g.rheonomic:
        raise ModelError(f"{driver!r} is a joint, not a driver; request it as a joint output")
    bi, bj = int(g.body_i[k]), int(g.body_j[k])
    geo = g.geometry
    if g.name == "angle":
        Ri, Rj = geo.R_i[k], geo.R_j[k]
        a_i, b_i = tr.vector(bi, Ri[:, 1]), tr.vector(bi, Ri[:, 2])
        a_j = tr.vector(bj, Rj[:, 1])
        x, xd = _angle(*a_i, *b_i, *a_j)
        if x.size:                     # the turn the prescribed angle f(t0) is in
            f0 = float(g.law_values(float(tr.t[0]))[k, 0])
            x = x + 2 * np.pi * np.round((f0 - x[0]) / (2 * np.pi))
    elif g.name == "translation":
        u_i = tr.vector(bi, geo.R_i[k][:, 0])
        Pi, vPi, _ = tr.point(bi, geo.s_i[k])
        Pj, vPj, _ = tr.point(bj, geo.s_j[k])
        d, dd = Pj - Pi, vPj - vPi
        x, xd = _dot(u_i[0], d), _dot(u_i[1], d) + _dot(u_i[0], dd)
    else:
        c = int(g.coordinate[k])
        if c < 3:
            x, xd = tr.r[:, bi, c].copy(), tr.rdot[:, bi, c].copy()
        else:
            from ..rotations import pdot_from_omega
            x = tr.p[:, bi, c - 3]
            xd = pdot_from_omega(tr.p[:, bi], tr.omega[:, bi])[:, c - 3]
    lam = getattr(results, "lam", None)
    if lam is None:
        effort = np.full(tr.nt, np.nan)
    else:
        effort = np.asarray(lam)[:, rows.start]
    return dict(coordinate=x, coordinate_rate=xd, effort=effort, power=effort * xd)


# ============================================================================ momentum, energy
def _inertia_global(tr: _Track, model):
    A = tr.A[:, :tr.nb]
    return A @ model.inertia[None] @ np.swapaxes(A, 2, 3)


def momentum(results, body: Optional[str] = None, about=None) -> dict:
    """Linear momentum p = m rdot (N s) and angular momentum h (N m s), global axes, of one
    body or (body None) the whole system: h about the centre of mass (of the body or of the
    system) or, with ``about`` (3,), about that fixed point: h_O = sum J omega + (r - O) x m rdot.
    Returns px, py, pz, hx, hy, hz, each (nt,)."""
    return _momentum(_Track(results), results.model, body, about)


def _momentum(tr: _Track, model, body, about) -> dict:
    m = model.mass
    nb = tr.nb
    rdot, r, w = tr.rdot[:, :nb], tr.r[:, :nb], tr.omega[:, :nb]
    J = _inertia_global(tr, model)
    p_b = m[None, :, None] * rdot                              # (nt, nb, 3)
    h_b = np.einsum("tnij,tnj->tni", J, w)                     # about each centre of mass
    if body is not None:
        k = model.body_index(body)
        sel = slice(k, k + 1)
    else:
        sel = slice(0, nb)
    msel = m[sel]
    if about is not None:
        O = np.broadcast_to(np.asarray(about, dtype=float), (tr.nt, 3))
    elif body is not None:
        O = r[:, sel][:, 0]
    else:
        O = np.einsum("n,tni->ti", msel, r[:, sel]) / msel.sum()     # system centre of mass
    p = p_b[:, sel].sum(axis=1)
    h = (h_b[:, sel] + np.cross(r[:, sel] - O[:, None], p_b[:, sel])).sum(axis=1)
    return dict(px=p[:, 0], py=p[:, 1], pz=p[:, 2], hx=h[:, 0], hy=h[:, 1], hz=h[:, 2])


def body_energy(results, body: Optional[str] = None) -> dict:
    """Kinetic energy 1/2 m rdot^2 + 1/2 omega^T J omega and gravitational potential energy
    -m g^T r (J, zero at r = 0) of one body, or summed over all bodies (body None)."""
    return _energy(_Track(results), results.model, body)


def _energy(tr: _Track, model, body) -> dict:
    nb = tr.nb
    m = model.mass
    J = _inertia_global(tr, model)
    w = tr.omega[:, :nb]
    kin = 0.5 * m[None] * np.sum(tr.rdot[:, :nb] ** 2, axis=2) \
        + 0.5 * np.einsum("tni,tnij,tnj->tn", w, J, w)
    pot = -np.einsum("n,tni,i->tn", m, tr.r[:, :nb], model.gravity)
    if body is not None:
        k = model.body_index(body)
        return dict(kinetic=kin[:, k], potential=pot[:, k])
    return dict(kinetic=kin.sum(axis=1), potential=pot.sum(axis=1))


# ============================================================================ IMU
def imu(results, point: str) -> dict:
    """What an inertial measurement unit fixed at ``point`` ("body.point") measures, in the
    body's axes: acceleration a of the point (ax, ay, az; m/s^2), specific force a - g (sfx,
    sfy, sfz; what an accelerometer reads: +9.81 upwards at rest) and angular velocity
    (wx, wy, wz; rad/s)."""
    return _imu(_Track(results), results.model, point)


def _imu(tr: _Track, model, point: str) -> dict:
    if point not in model.points:
        raise ModelError(f"no named point {point!r}; points: {', '.join(model.points) or 'none'}")
    body, local = model.points[point]
    _, _, acc = tr.point(body, local)
    A = tr.A[:, body]
    to_body = lambda x: np.einsum("nji,nj->ni", A, x)  # noqa: E731  A^T x
    a = to_body(acc)
    sf = to_body(acc - np.asarray(model.gravity, dtype=float)[None])
    w = to_body(tr.omega[:, body])
    out = {}
    for tag, arr in (("a", a), ("sf", sf), ("w", w)):
        for c, axis in enumerate("xyz"):
            out[f"{tag}{axis}"] = arr[:, c]
    return out


# ============================================================================ all requests
def compute_outputs(results, requests=None) -> dict:
    """Columns {"<prefix>.<quantity>": (nt,)} of the requested outputs (default: the
    results' own requests, ``results.output_requests``), in request order."""
    model = results.model
    reqs = parse_outputs(model, getattr(results, "output_requests", None)
                         if requests is None else requests)
    if not reqs:
        return {}
    tr = _Track(results)
    states = _states(results) if any(r.kind == "force" for r in reqs) else None
    cols: dict = {}
    for req in reqs:
        if req.kind == "joint":
            part = _joint(tr, model, req.of)
        elif req.kind == "force":
            part = _force(results, model, req.of, states)
        elif req.kind == "driver":
            part = _driver(tr, results, req.of)
        elif req.kind == "momentum":
            part = _momentum(tr, model, req.of, req.about)
        elif req.kind == "energy":
            part = _energy(tr, model, req.of)
        else:
            part = _imu(tr, model, req.of)
        for q, arr in part.items():
            cols[f"{req.prefix}.{q}"] = np.asarray(arr, dtype=float)
    return cols
