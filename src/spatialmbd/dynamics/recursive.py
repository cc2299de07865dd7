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
5(4) or 8(5,3) with the controller of the integrator
(:mod:`..integrators.pairs`).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..errors import ModelError
from ..integrators.adaptive_driver import (OK, RHS_FAILED, STATUS_TEXT, UNDERFLOW,  # noqa: F401
                                           register_problem, rk_steps)
from ..integrators.explicit import rk_combine
from ..jit import njit
from .layout import body_views

from .joint_tree import (FREE, JOINT_KINDS, REVOLUTE, SIZES_Q, SIZES_V, SPHERICAL,  # noqa: F401
                         TRANSLATIONAL, TREE_FIELDS, JointTree, Tree, body_rows,
                         joint_kinematics, output_accelerations, tree_views)
from .joint_dynamics import rhs_joint  # noqa: F401

__all__ = ["JointTree", "JOINT_KINDS", "Recursive", "joint_kinematics", "rhs_joint",
           "dopri_joint", "body_rows", "joint_right_hand_side"]


# ----------------------------------------------------------------------------- the driver
#: the joint state x = [z, zdot, W] as a problem of the compiled driver: the tree (T), the
#: model's packs (F, I, W), the body-state work row yb (13 nb + 1), the outputs X (nt, nx) and
#: the offsets of the Euler parameters in x (quats)
JointProblem = namedtuple("JointProblem", ["T", "F", "I", "W", "yb", "X", "quats"])


@njit(inline="always")
def _joint_rhs(p, t, x, out):
    return rhs_joint(t, x, out, p.yb, p.T, p.F, p.I, p.W)


@njit                      # (not inlined: Numba's inliner loses a variable of its loop)
def _joint_stages(p, t, x, hs, tableau, nodes, K, s0, s1, out, t_last):
    yb, T, F, I, W = p.yb, p.T, p.F, p.I, p.W
    for s in range(s0, s1):
        rk_combine(x, hs, tableau, K, s, out)
        if not rhs_joint(t_last if s == s1 - 1 else t + nodes[s] * hs, out, K[s], yb, T, F, I,
                         W):
            return s
    return s1


@njit(inline="always")
def _joint_project(p, t, x):
    """Euler parameters back to unit length (the right-hand side uses p / |p|, so the
    derivative stays and the dense output is not corrected: flags 0)."""
    for q in range(p.quats.size):
        o = p.quats[q]
        nrm = math.sqrt(x[o] ** 2 + x[o + 1] ** 2 + x[o + 2] ** 2 + x[o + 3] ** 2)
        for i in range(4):
            x[o + i] /= nrm
    return 0


@njit(inline="always")
def _joint_output(p, t, row, x, interpolated):
    for i in range(x.size):
        p.X[row, i] = x[i]
    return True


register_problem(JointProblem, _joint_rhs, _joint_stages, _joint_project, _joint_output)


@njit
def dopri_joint(t, x, K0, h, err_prev, T, F, I, W, pair, t0, t_out, k_out, rtol, atol,
                max_step, max_steps, X, counters):
    """Up to ``max_steps`` accepted steps of the Dormand-Prince pair ``pair`` (rk45 or
    dop853 with its controller) of the joint state x from t (FSAL derivative K0,
    proposed step h; h = 0 starts the run: output at t, K0 and Hairer's starting step), every
    output time t_out[k_out:] reached written into X[k] (dense output):
    :func:`..integrators.adaptive_driver.rk_steps` of a :class:`JointProblem`. Returns
    (status, t, h, err_prev, k_out); call again to continue. counters: (nfev, steps,
    rejected)."""
    nb = body_views(F, I, W).mass.size
    problem = JointProblem(T, F, I, W, np.zeros(13 * nb + 1), X, tree_views(T).quats)
    return rk_steps(problem, t, x, K0, h, err_prev, pair, t0, t_out, k_out, 0, X.shape[0],
                    rtol, atol, max_step, max_steps, counters,
                    np.zeros((0, 1)))


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
