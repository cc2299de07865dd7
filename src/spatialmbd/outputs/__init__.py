"""Engineering outputs computed from a result: joint coordinates, force-element and driver
outputs, momentum, energy per body and IMU signals, and the output requests that name them.

Everything here is evaluated after the analysis, from the recorded states (t, q, v, vdot) and,
for driver efforts, the multipliers lam; nothing runs inside the time loop. The functions take
any result with ``model``, ``t``, ``q``, ``v``, ``vdot`` (dynamic :class:`~spatialmbd.results.
Results` and :class:`~spatialmbd.kinematics.KinematicResults`; efforts need ``lam``).

Requests
--------
An :class:`Output` names one thing to record, like an Adams request or an Exudyn sensor::

    Output("joint", "pivot")                 # coordinates and rates of joint "pivot"
    Output("force", "spring")                # length, deflection, rate, force, power
    Output("driver", "crank")                # coordinate, rate, effort, power
    Output("momentum")                       # system: linear, angular about its centre of mass
    Output("momentum", "link", about=(0, 0, 0))   # one body, angular about a fixed point
    Output("energy", "link")                 # kinetic and gravitational energy of one body
    Output("imu", "link.tip")                # acceleration, specific force, angular velocity

``"joints"``, ``"drivers"``, ``"forces"``, ``"bodies"`` (momentum and energy of every body) and
``"all"`` request every element of a kind. Model files take the same entries in their
``outputs:`` section (see docs/outputs.md).

Column names
------------
Every output is a set of columns ``<prefix>.<quantity>`` (the prefix is ``name`` when given,
else the element, body or point name, ``system`` for the whole system, ``<point>.imu`` for an
IMU). Vectors end in x, y, z; rates end in ``_rate``. The quantities of each kind, with their
units, are listed in :data:`QUANTITIES`; :func:`column_units` gives the unit of any column.

Sign conventions
----------------
Joint coordinates describe body j (the joint's second body) relative to body i, in the joint
frame of body i, whose columns are [u, a, b] (u the joint axis, a and b normal to it, b = u x a):

- an angle about u (revolute, cylindrical, planar) is theta = atan2(b_i . a_j, a_i . a_j),
  positive by the right-hand rule about u_i, zero when a_j = a_i (so zero in the assembled
  configuration of a joint defined globally) -- the same angle an angle driver prescribes;
- a translation (translational, cylindrical) is u_i . d with d = P_j - P_i, the joint point of
  body j minus that of body i (positive when j moves along +u_i);
- planar: translation_a = a_i . d, translation_b = b_i . d in the plane;
- universal: angle_i, the rotation of the cross about u_i (body i's axis), and angle_j, the
  rotation of body j about u_j relative to the cross, both right-handed and zero at the model's
  initial configuration;
- spherical: Bryant angles rx, ry, rz (x-y-z: C = Rx(rx) Ry(ry) Rz(rz), C = T_i^T T_j the
  rotation of the joint frame of j relative to that of i); their rates are singular at
  ry = +-90 degrees;
- every other type (fixed, spherical-spherical, spherical-revolute, basic constraints): the
  relative position dx, dy, dz = T_i^T d and the Bryant angles rx, ry, rz as for spherical.

Angles are unwrapped over time (continuous, not limited to (-pi, pi]). Rates are the exact time
derivatives of the coordinates (from the velocities, not by differencing).

A spring-damper's ``force`` is its tension f = k (l - l0) + c ldot + f_a (positive pulls the
two points together; Eq. 11.10), ``deflection`` = l - l0; a rotational spring-damper's
``torque`` is the moment it applies on body j about u (on body i: minus that), ``deflection``
= theta - theta0 wrapped to (-pi, pi]. ``power`` is always the power delivered TO the bodies
(W): negative for a damper. ``energy`` is the elastic energy stored in a spring (J). A
bushing reports its deflections dx, dy, dz and rotation vector rx, ry, rz (bushing axes of
body i) and the force fx, fy, fz and moment mx, my, mz it applies on body j, in the same axes.
Force types without outputs of their own report power and energy when the model has one
element of that type.

A driver's ``effort`` is the generalized force it exerts along its coordinate (N for a
translation or an x, y, z coordinate, N m for an angle; for e0..e3 the generalized force
conjugate to that Euler parameter): with Phi = coordinate - f(t), the reaction on the bodies is
D^T lam (dynamics/eom.py) and D is the gradient of the coordinate, so the effort is lam itself.
``power`` = effort * coordinate_rate: positive when the driver does positive work on the
mechanism (the effort pushes the coordinate the way it is moving).
"""
from __future__ import annotations

from .columns import (body_energy, compute_outputs, driver_outputs, force_outputs, imu,
                      joint_coordinates, momentum)
from .dataset import to_xarray
from .vocabulary import (GENERIC_COORDINATES, JOINT_COORDINATES, KINDS, QUANTITIES, SHORTHANDS,
                         Output, column_units, output_units, parse_outputs)

__all__ = ["Output", "QUANTITIES", "KINDS", "parse_outputs", "compute_outputs",
           "joint_coordinates", "force_outputs", "driver_outputs", "momentum", "body_energy",
           "imu", "column_units", "to_xarray"]

