"""Rotations: Euler parameters, rotation matrices, G and L (text ch. 4-5).

Every function is vectorized: a leading batch shape ``...`` is allowed on every argument.

Conventions
-----------
* Euler parameters p = [e0, e1, e2, e3] (4.11), e0 = cos(phi/2), e = u sin(phi/2) (4.7)-(4.8).
* A maps body (local, primed) components to global ones: s = A s' (5.4).
* omega is the angular velocity in global components, omega_local in body components.
* zxz Euler angles (psi, theta, sigma): A = Rz(psi) Rx(theta) Rz(sigma) (4.1)-(4.2).
  Bryant angles (phi1, phi2, phi3): A = Rx(phi1) Ry(phi2) Rz(phi3) (4.4)-(4.5).
  At the singularities (sin theta = 0, cos phi2 = 0) the third angle is returned as 0 and the
  first carries the combined rotation.
* Unit Euler parameters are assumed by the chapter 5 maps (p^T p = 1, p^T pdot = 0).

Modules: ``euler_parameters`` (A, G, L and the rate maps of ch. 5), ``angles`` (zxz, Bryant,
axis-angle) and ``compiled`` (the compiled helpers of the hot path).
"""
from __future__ import annotations

from .angles import (_angles3, _EPS, _norm3, _SINGULAR_TOL, _wrap_angle, A_from_bryant,
                     A_from_euler_zxz, axis_angle_from_p, bryant_from_A, bryant_from_p,
                     euler_zxz_from_A, euler_zxz_from_p, p_from_axis_angle, p_from_bryant,
                     p_from_euler_zxz)
from .compiled import (_A_batch, _pdot_batch, _quat_batch, _rotate_p_batch, _rotvec_batch, A_into,
                       p_from_rotation_vector_scalar, pdot_scalar, quat_multiply_scalar,
                       rotate_p_scalar)
from .euler_parameters import (_mv, A_from_p, cross, G_dot, G_matrix, L_dot, L_matrix, normalize_p,
                               omega_from_pdot, omega_local_from_pdot, omegadot_from_pddot,
                               omegadot_local_from_pddot, p_from_A, p_from_rotation_vector,
                               pddot_from_omegadot, pddot_from_omegadot_local, pdot_from_omega,
                               pdot_from_omega_local, quat_multiply, rotate_p, skew)
