"""Models of Project Chrono joint tests that come without an ADAMS deck, rebuilt in code.

Chrono publishes MSC ADAMS tables for these tests (data/testing/joints/, copied unchanged into
data/adams/, see PROVENANCE.md there) but defines the model only in the C++ source of its unit
test. Each function here rebuilds one test's model from that source (Project Chrono,
github.com/projectchrono/chrono, commit 7689fbc02d12c5419fa6acad8791100fd89979dd) and returns
the builder together with a function giving, for a simulation result, our counterpart of every
table (the same body, point and axes as the table; the conventions are checked against the
tables in tests/validation/test_validation.py).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..model import ModelBuilder

G = 9.80665

#: utest_JOINT_revsph.cpp, TestRevSpherical(jointLocGnd, jointRevAxis, jointLocPend, PendCSYS):
#: the revolute end on the ground at jointLocGnd with axis jointRevAxis, the spherical end on
#: the pendulum at jointLocPend, the pendulum's centre of mass at PendCSYS.pos, orientation
#: QUNIT, released at rest; the link length is the initial distance of the two ends (2 m).
REVSPH_GEOMETRY = {
    "RevSpherical_Case01": dict(revolute_point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0),
                                spherical_point=(2.0, 0.0, 0.0), cm=(2.0, 2.0, 0.0)),
    "RevSpherical_Case02": dict(revolute_point=(1.0, 2.0, 3.0), axis=(0.0, 1.0, 1.0),
                                spherical_point=(3.0, 2.0, 3.0), cm=(3.0, 4.0, 3.0)),
}


def link_length(name: str) -> float:
    """The revolute-spherical link length of a case: the initial distance of its two ends."""
    geo = REVSPH_GEOMETRY[name]
    return float(np.linalg.norm(np.subtract(geo["spherical_point"], geo["revolute_point"])))


def revolute_spherical(name: str) -> tuple[ModelBuilder, Callable]:
    """RevSpherical_Case01/02 of Project Chrono's ``src/tests/unit_tests/joints/
    utest_JOINT_revsph.cpp`` (commit 7689fbc02d12c5419fa6acad8791100fd89979dd): a pendulum of
    1 kg, centroidal inertia diag(0.1, 0.04, 0.1) kg m^2, held by a ChLinkRevoluteSpherical
    (Initialize(ground, pendulum, false, jointLocGnd, jointRevAxis, jointLocPend, true): the
    revolute end on the ground, the spherical end on the pendulum, the distance as assembled),
    gravity 9.80665 m/s^2 along -z. Ours: the spherical_revolute composite joint with body i
    the ground (revolute end, point and axis) and body j the pendulum (point2).

    Tables: Pos/Vel/Acc of the centre of mass, Quat, Avel/Aacc in global axes; Rforce_Body1/
    Rtorque_Body1 the reaction on the ground (Chrono's body 1) about the revolute point, and
    Rforce_Body2/Rtorque_Body2 that on the pendulum about the spherical point, global axes:
    our force_i/moment_i and force_j/moment_j."""
    geo = REVSPH_GEOMETRY[name]
    axis = np.asarray(geo["axis"], float)
    b = ModelBuilder(name, gravity=(0.0, 0.0, -G))
    b.add_body("pendulum", 1.0, (0.1, 0.04, 0.1), r=geo["cm"])
    b.add_joint("spherical_revolute", "revsph", "ground", "pendulum",
                point=geo["revolute_point"], axis=axis / np.linalg.norm(axis),
                point2=geo["spherical_point"])

    def outputs(res) -> dict:
        body = res.body("pendulum")
        r = res.reactions()["revsph"]
        return dict(Pos=body["r"], Vel=body["rdot"], Acc=body["rddot"], Quat=body["p"],
                    Avel=body["omega"], Aacc=body["omegadot"],
                    Rforce_Body1=r.force_i, Rtorque_Body1=r.moment_i,
                    Rforce_Body2=r.force_j, Rtorque_Body2=r.moment_j)
    return b, outputs


#: utest_JOINT_linactuator.cpp, TestLinActuator(rot, desiredSpeed): the plate's orientation
#: (Euler parameters e0..e3; Case02 QuatFromAngleY(pi/4)) and imposed speed along its z axis.
LINACT_SETUP = {
    "LinActuator_Case01": dict(p=(1.0, 0.0, 0.0, 0.0), speed=1.0),
    "LinActuator_Case02": dict(p=(float(np.cos(np.pi / 8)), 0.0, float(np.sin(np.pi / 8)),
                                  0.0), speed=0.5),
}
LINACT_MASS = 1.0


def _linact_axis(name: str) -> np.ndarray:
    from ..rotations import A_from_p
    return A_from_p(np.asarray(LINACT_SETUP[name]["p"], float))[:, 2]


def linear_actuator(name: str) -> tuple[ModelBuilder, Callable]:
    """LinActuator_Case01/02 of Project Chrono's ``src/tests/unit_tests/joints/
    utest_JOINT_linactuator.cpp`` (commit 7689fbc02d12c5419fa6acad8791100fd89979dd): a plate
    of 1 kg, inertia diag(1, 1, 1) kg m^2, at the origin with orientation ``rot``, on a
    ChLinkLockPrismatic to the ground along rot's z axis n (at the origin), and a
    ChLinkLockLinActuator from the origin (ground) to the plate point n imposing the distance
    1 + v t (ChFunctionRamp(0, v)), i.e. the slide v t along n; initial velocity v n; gravity
    9.80665 m/s^2 along -z. Ours: a translational joint (ground, plate, point 0, axis n) with
    a translation driver v t on it.

    Tables: Pos/Vel/Acc of the centre of mass, Quat, Avel/Aacc; RforceP/RtorqueP the prismatic
    joint's reaction on the ground (Chrono's body 2 of the prismatic) about the origin, its
    fixed frame: our force_i/moment_i of the translational joint; RforceA/RtorqueA the
    actuator's force on the plate (body 2 of the actuator) and its moment about the plate's
    point: force_j/moment_j of the driver (which acts along n at the centre of mass)."""
    from ..motion import ConstantVelocity
    setup = LINACT_SETUP[name]
    n = _linact_axis(name)
    v = setup["speed"]
    b = ModelBuilder(name, gravity=(0.0, 0.0, -G))
    b.add_body("plate", LINACT_MASS, (1.0, 1.0, 1.0), r=(0.0, 0.0, 0.0), p=setup["p"],
               rdot=v * n)
    b.add_joint("translational", "prismatic", "ground", "plate", point=(0.0, 0.0, 0.0),
                axis=n)
    b.add_driver("translation", "actuator", ConstantVelocity(rate=v), joint="prismatic")

    def outputs(res) -> dict:
        body = res.body("plate")
        reactions = res.reactions()
        p, a = reactions["prismatic"], reactions["actuator"]
        return dict(Pos=body["r"], Vel=body["rdot"], Acc=body["rddot"], Quat=body["p"],
                    Avel=body["omega"], Aacc=body["omegadot"], RforceP=p.force_i,
                    RtorqueP=p.moment_i, RforceA=a.force_j, RtorqueA=a.moment_j)
    return b, outputs


def linear_actuator_exact(name: str, t) -> dict:
    """The exact solution of a LinActuator case: the motion is prescribed (no degree of
    freedom left), r = v t n, constant orientation, no acceleration; the plate is in
    equilibrium, so the actuator (its only direction n) carries the axial part of the weight,
    -m (g.n) n on the plate, and the prismatic joint the normal part: on the ground
    m g_n = m (g - (g.n) n), acting along the line through the centre of mass (the plate does
    not turn, gravity and the actuator act at its centre of mass), so its moment about the
    origin is r x m g_n. Arrays (nt, k) per table."""
    t = np.asarray(t, float)
    n = _linact_axis(name)
    v = LINACT_SETUP[name]["speed"]
    m, g = LINACT_MASS, np.array([0.0, 0.0, -G])
    gn = g - (g @ n) * n
    r = v * t[:, None] * n
    zero = np.zeros((len(t), 3))
    return dict(Pos=r, Vel=np.tile(v * n, (len(t), 1)), Acc=zero,
                Quat=np.tile(LINACT_SETUP[name]["p"], (len(t), 1)), Avel=zero, Aacc=zero,
                RforceP=np.tile(m * gn, (len(t), 1)), RtorqueP=np.cross(r, m * gn),
                RforceA=np.tile(-m * (g @ n) * n, (len(t), 1)), RtorqueA=zero)


def linear_actuator_scales(name: str, t) -> dict:
    """Natural sizes of the LinActuator quantities for the integration bound: the travel
    |r|max, the speed v, |g| for accelerations, the weight m |g| for forces and m |g| |r|max
    for moments; the rates (none in the exact motion) with the floor sqrt(|g| / 1 m)."""
    v = LINACT_SETUP[name]["speed"]
    ell = max(1.0, v * float(np.max(t)))
    w = float(np.sqrt(G / 1.0))
    return dict(Pos=ell, Vel=v, Acc=G, Quat=1.0, Avel=w, Aacc=w * w, RforceP=LINACT_MASS * G,
                RtorqueP=LINACT_MASS * G * ell, RforceA=LINACT_MASS * G,
                RtorqueA=LINACT_MASS * G * ell)


#: utest_JOINT_transpring.cpp, Case01: TestTranSpring with both ends at the origin, the body
#: (1 kg, centroidal inertia diag(0.04, 0.1, 0.1)) at the origin, k = 10 N/m, c = 0.5 N s/m
SPRING_DROP = dict(mass=1.0, inertia=(0.04, 0.1, 0.1), stiffness=10.0, damping=0.5)


def spring_drop(name: str) -> tuple[ModelBuilder, Callable]:
    """TranSpring_Case01 of Project Chrono's ``src/tests/unit_tests/joints/
    utest_JOINT_transpring.cpp`` (commit 7689fbc02d12c5419fa6acad8791100fd89979dd): a body of
    1 kg at rest at the origin, held by a ChLinkTSDA from its centre of mass to the origin on
    the ground, free length the initial distance (0), k = 10 N/m, c = 0.5 N s/m, and dropped
    under gravity 9.80665 m/s^2 along -z. Ours: a spring_damper of zero free length between
    the same points (its direction at the coincident start is that of the motion).

    Tables: Pos/Vel/Acc of the centre of mass, Quat, Avel/Aacc; Rforce the spring-damper's
    force on the ground (Chrono writes GetForce() times the unit vector from the ground point
    to the body's): our element's force f (tension positive) along that unit vector."""
    p = SPRING_DROP
    b = ModelBuilder(name, gravity=(0.0, 0.0, -G))
    b.add_body("pendulum", p["mass"], p["inertia"], r=(0.0, 0.0, 0.0))
    b.add_force("spring_damper", "spring", body_i="ground", body_j="pendulum",
                point_i=(0.0, 0.0, 0.0), point_j=(0.0, 0.0, 0.0), stiffness=p["stiffness"],
                damping=p["damping"], natural_length=0.0)

    def outputs(res) -> dict:
        from ..outputs import force_outputs
        body = res.body("pendulum")
        r = body["r"]
        length = np.linalg.norm(r, axis=1, keepdims=True)
        u = np.divide(r, length, out=np.zeros_like(r), where=length > 0)
        f = force_outputs(res, "spring")["force"]
        return dict(Pos=r, Vel=body["rdot"], Acc=body["rddot"], Quat=body["p"],
                    Avel=body["omega"], Aacc=body["omegadot"], Rforce=f[:, None] * u)
    return b, outputs


def spring_drop_exact(name: str, t) -> dict:
    """The exact solution of TranSpring_Case01: the body falls along z as the damped oscillator
    m z'' + c z' + k z = -m g from rest at 0, z = z_s (1 - e^(-a t) (cos w t + a/w sin w t)),
    z_s = -m g / k, a = c / (2 m), w = sqrt(k/m - a^2); it does not turn; the force on the
    ground is k z + c z' along z. Arrays (nt, k) per table."""
    p = SPRING_DROP
    t = np.asarray(t, float)
    m, k, c = p["mass"], p["stiffness"], p["damping"]
    zs, a = -m * G / k, c / (2 * m)
    w = float(np.sqrt(k / m - a * a))
    e, cs, sn = np.exp(-a * t), np.cos(w * t), np.sin(w * t)
    z = zs * (1 - e * (cs + a / w * sn))
    zd = zs * e * (a * a / w + w) * sn
    zdd = -(k * z + c * zd) / m - G
    zero = np.zeros((len(t), 3))

    def along_z(x):
        out = zero.copy()
        out[:, 2] = x
        return out
    return dict(Pos=along_z(z), Vel=along_z(zd), Acc=along_z(zdd),
                Quat=np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)), Avel=zero, Aacc=zero,
                Rforce=along_z(k * z + c * zd))


def spring_drop_scales(name: str, t) -> dict:
    """Natural sizes for the integration bound: the static drop |z_s|, the speed w |z_s|, the
    acceleration g, the weight; the rates (none) with the floor w."""
    p = SPRING_DROP
    zs = p["mass"] * G / p["stiffness"]
    w = float(np.sqrt(p["stiffness"] / p["mass"]))
    return dict(Pos=2 * zs, Vel=2 * w * zs, Acc=G, Quat=1.0, Avel=w, Aacc=w * w,
                Rforce=2 * p["mass"] * G)


#: utest_JOINT_tsda.cpp, TestTranSpringCB(jointLocGnd, jointLocPend, PendCSYS, type): the same
#: 1 kg body (inertia diag(0.04, 0.1, 0.1)) at rest at PendCSYS (position, rotation about z),
#: a ChLinkTSDA from the body's point jointLocPend to the ground point jointLocGnd (global,
#: free length their initial distance) with a force functor: type 1 k = 10, c = 0.5; type 2
#: k = 100, c = 5; type 3 the nonlinear 50 (l - l0) + 10 |l - l0| (l - l0), c = 5
TSDA_LAWS = {1: dict(stiffness=10.0, damping=0.5), 2: dict(stiffness=100.0, damping=5.0),
             3: dict(stiffness=50.0, damping=5.0, nonlinear_stiffness=[10.0])}
TSDA_SETUP = {
    "TranSpringCB_Case01": dict(ground=(0.0, 0.0, 0.0), attach=(0.0, 0.0, 0.0),
                                cm=(0.0, 0.0, 0.0), angle_z=0.0, law=1),
    "TranSpringCB_Case02": dict(ground=(0.0, 0.0, 0.0), attach=(0.0, 2.0, 0.0),
                                cm=(0.0, 2.0, 0.0), angle_z=0.0, law=2),
    "TranSpringCB_Case03": dict(ground=(1.0, 2.0, 3.0), attach=(1.0, 4.0, 3.0),
                                cm=(-1.0, 4.0, 3.0), angle_z=0.0, law=3),
    "TranSpringCB_Case04": dict(ground=(0.0, 0.0, 0.0), attach=(0.0, 2.0, 0.0),
                                cm=(0.0, 4.0, 0.0), angle_z=-np.pi / 2, law=3),
}


def spring_callback(name: str) -> tuple[ModelBuilder, Callable]:
    """TranSpringCB_Case01..04 of Project Chrono's ``src/tests/unit_tests/joints/
    utest_JOINT_tsda.cpp`` (commit 7689fbc02d12c5419fa6acad8791100fd89979dd): a ChLinkTSDA
    with a force functor (TSDA_LAWS, TSDA_SETUP), gravity 9.80665 m/s^2 along -z. Ours: a
    spring_damper between the same points with the same law (the nonlinear one through
    ``nonlinear_stiffness``). Case01 is TranSpring_Case01's set-up (a zero-length spring at
    the centre of mass); Case03 and Case04 hang the body off its centre of mass, so it turns.

    Tables: Pos/Vel/Acc of the centre of mass, Quat, Avel/Aacc; Rforce the spring-damper's
    force on the ground (GetForce() times the unit vector from the body's point to the
    ground's, GetForce() negative in tension): our force f (tension positive) along the unit
    vector from the ground point to the body's."""
    from ..rotations import A_from_p, p_from_axis_angle
    setup = TSDA_SETUP[name]
    p = p_from_axis_angle(np.array([0.0, 0.0, 1.0]), setup["angle_z"])
    A = A_from_p(p)
    cm, attach = np.asarray(setup["cm"], float), np.asarray(setup["attach"], float)
    b = ModelBuilder(name, gravity=(0.0, 0.0, -G))
    b.add_body("pendulum", SPRING_DROP["mass"], SPRING_DROP["inertia"], r=tuple(cm), p=p,
               points={"attach": tuple(A.T @ (attach - cm))})
    length = float(np.linalg.norm(attach - np.asarray(setup["ground"], float)))
    b.add_force("spring_damper", "spring", body_i="ground", body_j="pendulum",
                point_i=tuple(setup["ground"]), point_j="attach", natural_length=length,
                **TSDA_LAWS[setup["law"]])

    def outputs(res) -> dict:
        from ..outputs import force_outputs
        body = res.body("pendulum")
        d = res.point("pendulum.attach")["r"] - np.asarray(setup["ground"], float)
        ell = np.linalg.norm(d, axis=1, keepdims=True)
        u = np.divide(d, ell, out=np.zeros_like(d), where=ell > 0)
        f = force_outputs(res, "spring")["force"]
        return dict(Pos=body["r"], Vel=body["rdot"], Acc=body["rddot"], Quat=body["p"],
                    Avel=body["omega"], Aacc=body["omegadot"], Rforce=f[:, None] * u)
    return b, outputs


MODELS = {"RevSpherical_Case01": revolute_spherical, "RevSpherical_Case02": revolute_spherical,
          "LinActuator_Case01": linear_actuator, "LinActuator_Case02": linear_actuator,
          "TranSpring_Case01": spring_drop,
          **{f"TranSpringCB_Case0{k}": spring_callback for k in range(1, 5)}}
#: which of our outputs each case's reaction tables are (the ``outputs`` functions above)
_REVSPH = ("Rforce/Rtorque_Body1 = our force_i/moment_i (on the ground, about the revolute "
           "point), _Body2 = force_j/moment_j (on the pendulum, about the spherical point), "
           "global axes")
_LINACT = ("RforceP/RtorqueP = the translational joint's force_i/moment_i (on the ground, "
           "about the origin), RforceA/RtorqueA = the translation driver's force_j/moment_j "
           "(on the plate, about its centre of mass)")
CONVENTIONS = {"RevSpherical_Case01": _REVSPH, "RevSpherical_Case02": _REVSPH,
               "LinActuator_Case01": _LINACT, "LinActuator_Case02": _LINACT,
               "TranSpring_Case01": ("Rforce = the spring-damper's force f (tension positive) "
                                     "along the unit vector from the ground point to the "
                                     "body's: its force on the ground")}
CONVENTIONS.update({f"TranSpringCB_Case0{k}": CONVENTIONS["TranSpring_Case01"]
                    for k in range(1, 5)})
#: why a case without an exact solution has none
NO_CLOSED_FORM = {
    "RevSpherical_Case01": "a body on a revolute-spherical link (two constraint equations, four "
                           "degrees of freedom) released off its equilibrium",
    "TranSpringCB_Case02": "an elastic pendulum (a body on a spring-damper, three degrees of "
                           "freedom of its centre of mass)",
    "TranSpringCB_Case03": "a body hung off its centre of mass on a nonlinear spring-damper: "
                           "it falls, swings and turns",
}
NO_CLOSED_FORM["RevSpherical_Case02"] = NO_CLOSED_FORM["RevSpherical_Case01"]
NO_CLOSED_FORM["TranSpringCB_Case04"] = NO_CLOSED_FORM["TranSpringCB_Case03"]
#: the cases with an exact solution: (exact quantities(name, t), natural sizes(name, t))
EXACT = {"LinActuator_Case01": (linear_actuator_exact, linear_actuator_scales),
         "LinActuator_Case02": (linear_actuator_exact, linear_actuator_scales),
         "TranSpring_Case01": (spring_drop_exact, spring_drop_scales),
         "TranSpringCB_Case01": (spring_drop_exact, spring_drop_scales)}
