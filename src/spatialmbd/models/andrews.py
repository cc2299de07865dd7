"""IFToMM A03: Andrews' squeezer mechanism (Hairer & Wanner; Test Set for IVP Solvers)."""
from __future__ import annotations

import math

import numpy as np

from ..model import ModelBuilder


# ------------------------------------------------------------------------------------------
# IFToMM A03: Andrews' squeezer mechanism
# ------------------------------------------------------------------------------------------
#: Data of Andrews' squeezer mechanism (SI), as in Hairer & Wanner, Solving ODEs II, sec. VII.7
#: (after Schiehlen's benchmark book, 1990) and the Test Set for IVP Solvers (Mazzia &
#: Magherini, problem "andrews"): masses m1..m7 (kg), centroidal moments i1..i7 (kg m^2), the
#: fixed points A, B, C, lengths, the spring (c0 N/m, free length l0) and the drive torque mom
#: (N m). Initial angles (rad) of the test set; the mechanism starts at rest.
ANDREWS = dict(
    m=(0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498),
    i=(2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5),
    xa=-0.06934, ya=-0.00227, xb=-0.03635, yb=0.03273, xc=0.014, yc=0.072,
    c0=4530.0, l0=0.07785, mom=0.033,
    d=28e-3, da=115e-4, e=2e-2, ea=1421e-5, rr=7e-3, ra=92e-5,
    ss=35e-3, sa=1874e-5, sb=1043e-5, sc=18e-3, sd=2e-2, ta=2308e-5, tb=916e-5,
    u=4e-2, ua=1228e-5, ub=449e-5, zf=2e-2, zt=4e-2, fa=1421e-5,
    # beta, Theta, gamma, Phi, delta, Omega, epsilon
    angles0=(-0.0617138900142764496358948458001, 0.0, 0.455279819163070380255912382449,
             0.222668390165885884674473185609, 0.487364979543842550225598953530,
             -0.222668390165885884674473185609, 1.23054744454982119249735015568),
)

#: Bodies of :func:`andrews_squeezer` in the order of the test set's masses.
ANDREWS_BODIES = ("crank", "rod", "arm_b", "link_a", "arm_a", "link_f", "arm_f")


def andrews_body_angles(angles) -> np.ndarray:
    """The absolute rotation angle about z of each of the seven bodies from the test set's
    seven coordinates (beta, Theta, gamma, Phi, delta, Omega, epsilon), (..., 7)."""
    a = np.asarray(angles, dtype=float)
    be, th, ga, ph, de, om, ep = np.moveaxis(a, -1, 0)
    return np.stack([be, be + th, ga, ph + de, de, om + ep, ep], axis=-1)


def andrews_coordinates(body_angles) -> np.ndarray:
    """The test set's seven coordinates (beta, Theta, gamma, Phi, delta, Omega, epsilon) from
    the bodies' absolute angles (or their rates, accelerations), the inverse of
    :func:`andrews_body_angles`, (..., 7)."""
    a = np.asarray(body_angles, dtype=float)
    t1, t2, t3, t4, t5, t6, t7 = np.moveaxis(a, -1, 0)
    return np.stack([t1, t2 - t1, t3, t4 - t5, t5, t6 - t7, t7], axis=-1)


def andrews_squeezer() -> ModelBuilder:
    """IFToMM benchmark A03, Andrews' squeezer mechanism: seven rigid bodies in the plane
    z = 0, ten revolute joints about z, a linear spring and a constant drive torque; no gravity.
    Data: models.ANDREWS (Hairer & Wanner, Solving ODEs II, VII.7; Test Set for IVP Solvers).

    The crank (1) turns about the origin O, driven by the torque mom = 0.033 N m; the rod (2)
    is pinned to it at distance rr from O, and its far end E (distance d) is pinned to three
    bodies: arm_b (3), which turns about the fixed point B and carries the spring from its
    point D to the fixed point C (stiffness c0, free length l0); link_a (4), pinned at H to
    arm_a (5), which turns about the fixed point A; and link_f (6), pinned at G to arm_f (7),
    which also turns about A. One degree of freedom, three closed loops. Built from spatial
    revolute joints, the planar loops carry 3 x 3 = 9 redundant equations.

    Every body's axes are the global ones turned about z by the body's absolute angle
    (:func:`andrews_body_angles`), starting at the test set's initial angles, at rest. The
    source gives the centres of mass of the three arms turning about fixed points (3, 5, 7)
    only by their distances from the pivots, sqrt(sa^2 + sb^2) and so on; with a fixed pivot
    and no gravity the direction does not enter the motion, and they are placed at (sa, -sb),
    (ta, tb), (ua, ub) in the arm's axes from the pivot.
    """
    P = ANDREWS
    th = andrews_body_angles(P["angles0"])

    def rot(a, x, y):
        c, s = math.cos(a), math.sin(a)
        return np.array([c * x - s * y, s * x + c * y, 0.0])

    def Rz(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    O = np.zeros(3)
    A = np.array([P["xa"], P["ya"], 0.0])
    B = np.array([P["xb"], P["yb"], 0.0])
    C = np.array([P["xc"], P["yc"], 0.0])
    # centre of mass and named points (local, in the body's axes) of each body
    local = {
        "crank": ((P["ra"], 0.0), {"O": (0.0, 0.0), "P": (P["rr"], 0.0)}),
        "rod": ((-P["da"], 0.0), {"P": (0.0, 0.0), "E": (-P["d"], 0.0)}),
        "arm_b": ((P["sa"], -P["sb"]), {"B": (0.0, 0.0), "E": (0.0, -P["ss"]),
                                        "D": (P["sd"], -P["sc"])}),
        "link_a": ((0.0, -(P["e"] - P["ea"])), {"H": (0.0, 0.0), "E": (0.0, -P["e"])}),
        "arm_a": ((P["ta"], P["tb"]), {"A": (0.0, 0.0), "H": (P["zt"], 0.0)}),
        "link_f": ((P["zf"] - P["fa"], 0.0), {"G": (0.0, 0.0), "E": (P["zf"], 0.0)}),
        "arm_f": ((P["ua"], P["ub"]), {"A": (0.0, 0.0), "G": (0.0, -P["u"])}),
    }
    # each body's reference point (the first named point) in the global frame
    P_crank = O + rot(th[0], P["rr"], 0.0)
    origin = {"crank": O, "rod": P_crank, "arm_b": B, "arm_a": A, "arm_f": A}
    origin["link_a"] = A + rot(th[4], P["zt"], 0.0)                        # H
    origin["link_f"] = A + rot(th[6], 0.0, -P["u"])                        # G
    b = ModelBuilder("andrews_squeezer", gravity=(0.0, 0.0, 0.0))
    for k, name in enumerate(ANDREWS_BODIES):
        (cx, cy), pts = local[name]
        r = origin[name] + rot(th[k], cx, cy)
        inertia = P["i"][k]
        length = max(math.hypot(x - cx, y - cy) for x, y in pts.values())
        b.add_body(name, P["m"][k], (inertia, inertia, inertia), r=r, A=Rz(th[k]),
                   points={key: (x - cx, y - cy, 0.0) for key, (x, y) in pts.items()},
                   shapes=[{"type": "box", "size": [2 * length, 0.01, 0.01],
                            "center": [0, 0, 0]}])
    E = P_crank + rot(th[1], -P["d"], 0.0)
    z = (0.0, 0.0, 1.0)
    for name, bi, bj, pt in (("O", "ground", "crank", O), ("P", "crank", "rod", P_crank),
                             ("E_b", "rod", "arm_b", E), ("E_a", "rod", "link_a", E),
                             ("E_f", "rod", "link_f", E), ("B", "ground", "arm_b", B),
                             ("A_a", "ground", "arm_a", A), ("A_f", "ground", "arm_f", A),
                             ("H", "arm_a", "link_a", origin["link_a"]),
                             ("G", "arm_f", "link_f", origin["link_f"])):
        b.add_joint("revolute", name, bi, bj, point=pt, axis=z)
    b.add_force("spring_damper", "spring", body_i="arm_b", body_j="ground", point_i="D",
                point_j=tuple(C), stiffness=P["c0"], natural_length=P["l0"])
    b.add_force("torque", "drive", body="crank", direction=z, magnitude=P["mom"])
    return b


EXAMPLES = {
    # the test set's interval; dop853 at a tight tolerance: the crank turns at up to 1400 rad/s
    "andrews_squeezer": (andrews_squeezer, {}, dict(
        type="dynamic", t_end=0.03, output_step=1e-4, method={"name": "projection"},
        integrator={"name": "dop853", "rtol": 1e-10, "atol": 1e-12})),
}
