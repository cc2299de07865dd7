"""Recursive forward dynamics in joint coordinates for open trees (method "recursive").

A model whose joints are revolute, translational (prismatic) or spherical and connect every
body to the ground by at most one chain is a tree: its configuration is its joint coordinates z
(an angle or a slide per joint, the relative Euler parameters of a spherical joint, position and
Euler parameters of a body without a joint: a free joint), with no constraint equations left and
no drift. This module
integrates z and its rates with an articulated-body (O(N)) evaluation of the accelerations, as
recursive codes do, and hands the body coordinates (positions, Euler parameters, velocities)
to the Results at the output times, where every other output (accelerations, reactions from
the multipliers, energies) is evaluated as for the body-coordinate methods.

Per right-hand side (compiled, no Python per body):

* forward kinematics, parents first (:func:`joint_kinematics`): for joint k between parent P
  and child C, with the axis u' fixed in P, the joint points s'_P (in P) and s'_C (in C), the
  relative orientation p0 at z = 0 and the slide offset sigma0:
  p_C = p_P (x) p_axis(theta) (x) p0 (revolute; p_axis the rotation by theta about u'), or
  p_P (x) p0 (translational); r_C = r_P + A_P (s'_P + u' (sigma0 + s)) - A_C s'_C; omega_C =
  omega_P + u theta_dot; rdot_C = rdot_P + omega_P x A_P (s'_P + u' sigma) + u s_dot +
  omega_C x (-A_C s'_C), u = A_P u' (4.13, 5.9, 5.7);
* the body terms of the body-coordinate formulation at that state (as
  :func:`.system.stage_state`, without the constraint equations: M = diag(m I, J), g =
  gravity, -omega~ J omega, the compiled force elements (10.4, 11.1));
* the articulated-body recursion in world axes, about the centres of mass: with the rigid
  transfer X from P to C (d = r_C - r_P), the motion subspace H and the velocity-product
  acceleration c of each joint,

      revolute:       H = [u x d_JC; u],  c = [omega_P x (omega_P x d_PJ) + omega_C x (omega_C x
                      d_JC) + ((omega_P x u) theta_dot) x d_JC;  (omega_P x u) theta_dot],
      translational:  H = [u; 0],         c = [2 omega_P x u s_dot + omega_P x (omega_P x d); 0],

  (d_PJ = r_J - r_P, d_JC = r_C - r_J), vdot_C = X vdot_P + H zdd + c; backward (leaves first)
  U = I_C H, D = H^T U, Ia = I_C - U U^T / D, p~ = p_C - U H^T p_C / D, I_P += X^T Ia X,
  p_P += X^T (p~ - Ia c) (initially I_b = M_b, p_b = g_b); forward zdd = (H^T p_C - U^T w) / D,
  w = X vdot_P + c.

The state is x = [z (nj), zdot (nj), W] (W: the work of the non-conservative forces, as in
:mod:`..simulate`). The compiled driver :func:`dopri_joint` integrates it by Dormand-Prince
5(4) or 8(5,3) with the default controller of the integrator
(:mod:`..integrators.pairs`).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ModelError
from ..integrators.controller import (end_step, min_step_size, pi_factor, rejected_factor,
                                      start_first_guess, start_step)
from ..integrators.pairs import (DP8, pair_dense, pair_error, pair_interpolate,
                                 pair_stages)
from ..jit import njit
from .fused import OK, RHS_FAILED, UNDERFLOW, _rms
from .layout import body_views

from .joint_tree import (FREE, JOINT_KINDS, REVOLUTE, SIZES_Q, SIZES_V, SPHERICAL,  # noqa: F401
                         TRANSLATIONAL, TREE_FIELDS, JointTree, Tree, body_rows,
                         joint_kinematics, output_accelerations, tree_views)
from .joint_dynamics import rhs_joint  # noqa: F401

__all__ = ["JointTree", "JOINT_KINDS", "Recursive", "joint_kinematics", "rhs_joint",
           "dopri_joint", "body_rows", "joint_right_hand_side"]


# ----------------------------------------------------------------------------- the driver
# dopri_joint shares the status codes (OK, RHS_FAILED, UNDERFLOW), the embedded pairs
# (..integrators.pairs: rk45 and dop853 with their default controllers) and the weighted norm
# of the compiled drivers of .fused


@njit
def _joint_stages(t, x, hs, tableau, nodes, K, s0, s1, tmp, t_last, yb, T, F, I, W):
    """Stages s0 .. s1-1 of the joint state: tmp = x + hs sum_j tableau[s, j] K[j],
    K[s] = f(t + nodes[s] hs, tmp) (t_last for the last). False if one failed."""
    n = x.size
    for s in range(s0, s1):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += tableau[s, j] * K[j, i]
            tmp[i] = x[i] + hs * acc
        ts = t_last if s == s1 - 1 else t + nodes[s] * hs
        if not rhs_joint(ts, tmp, K[s], yb, T, F, I, W):
            return False
    return True


@njit
def dopri_joint(t, x, K0, h, err_prev, T, F, I, W, pair, t0, t_out, k_out, rtol, atol,
                max_step, max_steps, X, counters):
    """Up to ``max_steps`` accepted steps of the Dormand-Prince pair ``pair`` (rk45 or
    dop853 with its default controller) of the joint state x from t (FSAL derivative K0,
    proposed step h; h = 0 starts the run: output at t, K0 and Hairer's starting step), every
    output time t_out[k_out:] reached written into X[k] (dense output). Returns
    (status, t, h, err_prev, k_out); call again to continue. counters: (nfev, steps,
    rejected)."""
    kind, tableau, nodes, ctrl = pair
    k_inv, beta, safety, min_factor, max_factor = ctrl[0], ctrl[1], ctrl[2], ctrl[3], ctrl[4]
    S = pair_stages(kind)
    n = x.size
    nb = body_views(F, I, W).mass.size
    yb = np.zeros(13 * nb + 1)
    t_end = t_out[-1]
    span = t_end - t0
    nt = t_out.size
    if h <= 0.0:
        if k_out < nt and t_out[k_out] == t:
            for i in range(n):
                X[k_out, i] = x[i]
            k_out += 1
        if t >= t_end:
            return OK, t, h, err_prev, k_out
        if not rhs_joint(t, x, K0, yb, T, F, I, W):
            return RHS_FAILED, t, h, err_prev, k_out
        counters[0] += 1
        scale = np.empty(n)
        for i in range(n):
            scale[i] = atol + abs(x[i]) * rtol
        d0, d1 = _rms(x, scale), _rms(K0, scale)
        h0 = start_first_guess(d0, d1, max_step, span)
        x1 = np.empty(n)
        f1 = np.empty(n)
        for i in range(n):
            x1[i] = x[i] + h0 * K0[i]
        if not rhs_joint(t + h0, x1, f1, yb, T, F, I, W):
            return RHS_FAILED, t, h, err_prev, k_out
        counters[0] += 1
        for i in range(n):
            x1[i] = f1[i] - K0[i]
        h = start_step(h0, d1, _rms(x1, scale) / h0, ctrl[5], max_step, span)
    K = np.empty((tableau.shape[0], n))
    for i in range(n):
        K[0, i] = K0[i]
    x_new = np.empty(n)
    xo = np.empty(n)
    tmp = np.empty(n)
    atol_v = np.full(n, atol)
    coef = np.empty((7, n))
    empty = np.zeros(0)
    alpha = k_inv - 0.75 * beta
    after_reject = False
    steps = 0
    while t < t_end and steps < max_steps:
        h_min = min_step_size(t, span, 0.0)
        while True:
            hs = end_step(t, h, t_end)
            if hs < h_min:
                return UNDERFLOW, t, h, err_prev, k_out
            t_new = t_end if hs == t_end - t else t + hs
            ok = _joint_stages(t, x, hs, tableau, nodes, K, 1, S, tmp, t_new, yb, T, F, I, W)
            counters[0] += S - 1
            if ok:
                for i in range(n):
                    x_new[i] = tmp[i]
                err = pair_error(kind, x, x_new, K, hs, atol_v, rtol)
            else:
                err = math.inf
            if err <= 1.0:
                break
            counters[2] += 1
            h = hs * rejected_factor(err, k_inv, safety, min_factor)
            after_reject = True
        if k_out < nt and t_out[k_out] < t_new:      # an output inside: the dense output
            if kind == DP8:
                if not _joint_stages(t, x, hs, tableau, nodes, K, S, S + 3, tmp,
                                     t + nodes[S + 2] * hs, yb, T, F, I, W):
                    return RHS_FAILED, t, h, err_prev, k_out
                counters[0] += 3
            pair_dense(kind, x, x_new, K, hs, coef)
        quats = tree_views(T).quats              # Euler parameters back to unit length
        for q in range(quats.size):              # (the right-hand side uses p / |p|)
            o = quats[q]
            nrm = math.sqrt(x_new[o] ** 2 + x_new[o + 1] ** 2 + x_new[o + 2] ** 2
                            + x_new[o + 3] ** 2)
            for i in range(4):
                x_new[o + i] /= nrm
        fac, err_prev = pi_factor(err, err_prev, alpha, beta, safety, min_factor, max_factor,
                                  after_reject)
        after_reject = False
        while k_out < nt and t_out[k_out] <= t_new:
            to = t_out[k_out]
            if to == t_new:
                for i in range(n):
                    X[k_out, i] = x_new[i]
            else:
                pair_interpolate(kind, x, hs, coef, (to - t) / hs, empty, xo)
                for i in range(n):
                    X[k_out, i] = xo[i]
            k_out += 1
        for i in range(n):
            x[i] = x_new[i]
            K[0, i] = K[S - 1, i]
        t = t_new
        h = min(hs * fac, max_step)
        steps += 1
        counters[1] += 1
    for i in range(n):
        K0[i] = K[0, i]
    return OK, t, h, err_prev, k_out


# ----------------------------------------------------------------------------- the method
from .base import register  # noqa: E402
from .standard import Standard  # noqa: E402


@register
class Recursive(Standard):
    """Joint coordinates of an open tree (revolute, translational and spherical joints, free
    bodies), accelerations by
    the articulated-body recursion, integrated by the compiled Dormand-Prince 5(4) driver: no
    constraint equations, so no drift and no projection. The outputs (accelerations, reactions,
    energies) are evaluated at the output times as the standard method's, at the body
    coordinates the joints give. Models it cannot represent raise ModelError naming the
    element (use "standard" or "projection" for them)."""

    name = "recursive"
    joint_coordinates = True

    def __init__(self):
        super().__init__("schur")

    def parameters(self):
        return {}


def joint_right_hand_side(model, q0=None, v0=None):
    """(f, x0): the x' = f(t, x) the recursive method integrates (x = [z, zdot, W], joint
    coordinates from the assembled state q0, v0, default the model's; :class:`JointTree`)
    and its initial state;
    for benchmarks and one's own integrators (as :func:`..simulate.right_hand_side`)."""
    from .system import System
    q0 = model.q0 if q0 is None else q0
    v0 = model.v0 if v0 is None else v0
    tree = JointTree(model, q0, v0)
    tree.check_initial(q0)
    T = tree.arrays()
    system = System.for_model(model)
    F, I, W = system.F, system.I, system.W
    yb = np.zeros(13 * model.nb + 1)

    def f(t, x):
        x = np.ascontiguousarray(x, dtype=float)
        xd = np.empty(x.size)
        if not rhs_joint(float(t), x, xd, yb, T, F, I, W):
            raise ModelError(f"t = {t:.6g} s: the accelerations are not finite (an "
                             "articulated inertia is singular)")
        return xd
    return f, tree.x0.copy()
