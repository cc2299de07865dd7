"""Inputs and outputs of a linear model (analyses.linearize): the generalized force per unit
input, B_q (6 nb, k), and the output rows (C_x, C_v) with output = C_x dx + C_v dx', in the
body tangent coordinates dx = [dr, dpi] per body of the linearization.
"""
from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..rotations import skew
from ..state import BodyState
from .common import central_jacobian, dense, driver_rows, perturb


def _input_columns(model, inputs, D_full, q):
    """B_q (6 nb, k): generalized force per unit input; input drivers' rows."""
    nb = model.nb
    rows = driver_rows(model)
    cols, dropped = [], []
    state = BodyState.from_qv(q, None, 0.0)
    for name in inputs:
        if name in rows:
            cols.append(D_full[rows[name]].copy())          # effort lam_k acts as D_k^T lam_k
            dropped.append(rows[name])
            continue
        body, _, comp = name.rpartition(".")
        forces = ("fx", "fy", "fz", "mx", "my", "mz")
        if body in model.body_names and comp in forces:
            col = np.zeros(6 * nb)
            col[6 * model.body_index(body) + forces.index(comp)] = 1.0
            cols.append(col)
            continue
        group = next((g for g in model.force_groups if name in g.names), None)
        if group is not None and group.name == "rotational_spring_damper":
            k = group.names.index(name)             # torque along the joint angle (effort
            cols.append(_angle_row(model, q, group.bi[k], group.bj[k], group.R_i[k],
                                   group.R_j[k]))   # convention: -actuator)
            continue
        if group is not None and group.name in ("point_force", "torque"):
            k = group.names.index(name)
            b = group.body[k]
            d = group.direction[k]
            d = state.A[b] @ d if group.in_body[k] else d
            col = np.zeros(6 * nb)
            if group.name == "point_force":
                s = state.A[b] @ group.point[k]
                col[6 * b:6 * b + 3], col[6 * b + 3:6 * b + 6] = d, np.cross(s, d)
            else:
                col[6 * b + 3:6 * b + 6] = d
            cols.append(col)
            continue
        raise ModelError(f"linearize input {name!r}: not a driver, a point_force, torque or "
                         "rotational_spring_damper element or '<body>.<fx|fy|fz|mx|my|mz>' "
                         f"(drivers: {', '.join(rows) or 'none'})")
    B = np.column_stack(cols) if cols else np.zeros((6 * nb, 0))
    return B, dropped


OUTPUT_COMPONENTS = ("x", "y", "z", "rx", "ry", "rz", "vx", "vy", "vz", "wx", "wy", "wz")


def _angle_row(model, q, body_i, body_j, R_i, R_j) -> np.ndarray:
    """d(theta)/dv (6 nb,) of the rotation of body j relative to body i about u_i (the angle
    of angle drivers and rotational springs) at q."""
    from ..constraints.primitives import relative_angle
    nb = model.nb
    state = BodyState.from_qv(q, None, 0.0)
    _, D, _, _ = relative_angle(state, np.array([body_i]), np.array([body_j]),
                                np.asarray(R_i)[None], np.asarray(R_j)[None])
    row = np.zeros(6 * (nb + 1))
    row[6 * body_i:6 * body_i + 6] += D[0, :6]
    row[6 * body_j:6 * body_j + 6] += D[0, 6:]
    return row[:6 * nb]


def _joint_angle(model, name):
    """(body_i, body_j, R_i, R_j) of a revolute or cylindrical joint, or None."""
    for g in model.constraint_groups:
        if g.name in ("revolute", "cylindrical") and name in g.names:
            k = g.names.index(name)
            return g.body_i[k], g.body_j[k], g.geometry.R_i[k], g.geometry.R_j[k]
    return None


def _output_rows(model, outputs, D_full, q, W, v, t, step):
    """(C_x, C_v): output = C_x dx + C_v dx' for each named output (dv = dx' - W dx)."""
    nb = model.nb
    rows = driver_rows(model)
    state = BodyState.from_qv(q, None, 0.0)
    w = np.asarray(v, dtype=float).reshape(nb, 6)[:, 3:]
    Cx, Cv = [], []
    for name in outputs:
        cx, cv = np.zeros(6 * nb), np.zeros(6 * nb)
        base, _, comp = name.rpartition(".")
        if name in rows or (comp == "rate" and base in rows):
            row = D_full[rows[name if name in rows else base]]
            if name in rows:
                cx = row.copy()                              # change of the driven coordinate
            else:                                            # its rate D_k v: D_k dv + ...
                cv, cx = row.copy(), -row @ W
                if np.abs(v).max() > 0:                      # ... + d(D_k v*)/dx dx
                    k = rows[base]
                    cx = cx + central_jacobian(
                        lambda dx: np.atleast_1d(dense(model.assembler.evaluate(
                            perturb(q, dx), None, t).D)[k] @ v), 6 * nb, step,
                        what=f"d(rate of {base})/dx")[0][0]
        elif comp in ("angle", "angle_rate") and _joint_angle(model, base) is not None:
            geo = _joint_angle(model, base)
            row = _angle_row(model, q, *geo)
            if comp == "angle":
                cx = row
            else:                                    # D_theta dv + d(D_theta v*)/dx dx
                cv, cx = row.copy(), -row @ W
                if np.abs(v).max() > 0:
                    cx = cx + central_jacobian(
                        lambda dx: np.atleast_1d(_angle_row(model, perturb(q, dx), *geo) @ v),
                        6 * nb, step, what=f"d(rate of {base})/dx")[0][0]
        elif base in model.body_names and comp in OUTPUT_COMPONENTS:
            k = 6 * model.body_index(base) + OUTPUT_COMPONENTS.index(comp) % 6
            if OUTPUT_COMPONENTS.index(comp) < 6:
                cx[k] = 1.0
            else:                                            # dv = dx' - W dx
                cv[k] = 1.0
                cx = -W[k].copy()
        elif base in model.points and comp in ("x", "y", "z", "vx", "vy", "vz"):
            b, local = model.points[base]
            s = state.A[b] @ local
            c = ("x", "y", "z", "vx", "vy", "vz").index(comp)
            sel = np.zeros(6 * nb)
            sel[6 * b + c % 3] = 1.0
            # point displacement dr - s~ dpi (row c of [I, -s~])
            sel[6 * b + 3:6 * b + 6] = -skew(s)[c % 3]
            if c < 3:
                cx = sel
            else:                    # d(rdot + w x s) = dv_r - s~ dw + w*~ (-s~ dpi)
                cv, cx = sel, -sel @ W
                cx[6 * b + 3:6 * b + 6] += -(skew(w[b]) @ skew(s))[c % 3]
        else:
            raise ModelError(f"linearize output {name!r}: use '<body>.<x|y|z|rx|ry|rz|vx|vy|vz|"
                             "wx|wy|wz>', '<body>.<point>.<x|y|z|vx|vy|vz>', "
                             "'<joint>.angle' / '<joint>.angle_rate' (revolute, cylindrical) "
                             "or a driver name (its coordinate; '<driver>.rate' for its rate)")
        Cx.append(cx)
        Cv.append(cv)
    return (np.array(Cx).reshape(-1, 6 * nb), np.array(Cv).reshape(-1, 6 * nb))
