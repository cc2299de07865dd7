"""The Whipple bicycle benchmark (Meijaard, Papadopoulos, Ruina & Schwab 2007)."""
from __future__ import annotations

import math

import numpy as np

from ..model import ModelBuilder


# ------------------------------------------------------------------------------------------
# The Whipple bicycle benchmark (Meijaard, Papadopoulos, Ruina & Schwab 2007)
# ------------------------------------------------------------------------------------------
#: Data of the benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab, "Linearized
#: dynamics equations for the balance and steer of a bicycle: a benchmark and review",
#: Proc. R. Soc. A 463 (2007) 1955-1982, its parameter table (SI units). Their axes are x
#: forward, y to the right, z down, origin at the rear contact point; here they are turned into
#: x forward, y to the left, z up (y and z change sign, so do the xz products of inertia).
#: w wheelbase, c trail, lam steer-axis tilt from the vertical (rad), g gravity; rear wheel
#: (rR, mR, IRxx = IRzz, IRyy about the axle); rear frame and rider B (centre of mass xB, zB
#: as in the source, z down; inertia IB about it, source axes); front frame (fork and
#: handlebar) H likewise; front wheel (rF, mF, IFxx, IFyy).
MEIJAARD = dict(
    w=1.02, c=0.08, lam=math.pi / 10.0, g=9.81,
    rR=0.3, mR=2.0, IRxx=0.0603, IRyy=0.12,
    xB=0.3, zB=-0.9, mB=85.0, IB=((9.2, 0.0, 2.4), (0.0, 11.0, 0.0), (2.4, 0.0, 2.8)),
    xH=0.9, zH=-0.7, mH=4.0, IH=((0.05892, 0.0, -0.00756), (0.0, 0.06, 0.0),
                                 (-0.00756, 0.0, 0.00708)),
    rF=0.35, mF=3.0, IFxx=0.1405, IFyy=0.28,
)


def bicycle_lean_steer(results):
    """Lean angle phi of the rear frame (rad, positive leaning to the right, as in Meijaard et
    al.) and steer angle delta (rad, positive turning right) at every output of a run of
    :func:`whipple_bicycle`: phi = asin of the upward component of the rear frame's lateral
    axis; delta = the turn of the front frame's lateral axis about the steer axis."""
    from ..rotations import A_from_p
    q = np.asarray(results.q)
    A_B = A_from_p(q[:, 0, 3:])
    A_H = A_from_p(q[:, 2, 3:])
    lean = np.arcsin(np.clip(A_B[:, 2, 1], -1.0, 1.0))
    lam = MEIJAARD["lam"]
    s = A_B @ np.array([math.sin(lam), 0.0, -math.cos(lam)])   # steer axis, pointing down
    yB, yH = A_B[:, :, 1], A_H[:, :, 1]
    steer = np.arctan2(np.einsum("ij,ij->i", np.cross(yB, yH), s),
                       np.einsum("ij,ij->i", yB, yH))
    return lean, steer


def whipple_bicycle(speed: float = 4.6, lean_rate: float = 0.0) -> ModelBuilder:
    """The benchmark bicycle of Meijaard, Papadopoulos, Ruina and Schwab (2007): four rigid
    bodies -- rear frame with the rider, rear wheel, front frame (fork and handlebar), front
    wheel -- three revolute joints (the hubs and the steer axis) and two knife-edge wheels
    rolling without slip on the ground (rolling_disc: one holonomic and two nonholonomic
    equations each). Data: models.MEIJAARD, in axes x forward, y left, z up.

    It starts upright and straight ahead, every body moving forward at ``speed`` (m/s), the
    wheels turning at speed / radius, and the whole bicycle leaning to the right at
    ``lean_rate`` (rad/s) about the line through the contact points. Linearized about the
    straight run (linearize(..., steady=True)), its lean and steer eigenvalues are those of
    the benchmark's M q'' + v C1 q' + (g K0 + v^2 K2) q = 0: self-stable between the weave
    speed 4.292 m/s and the capsize speed 6.024 m/s. The steer joint's axis points down the
    head tube, so its angle is the benchmark's steer angle (positive turning right); see
    :func:`bicycle_lean_steer` for the lean angle.
    """
    P = MEIJAARD
    w, c, lam, rR, rF = P["w"], P["c"], P["lam"], P["rR"], P["rF"]
    flip = np.diag([1.0, -1.0, -1.0])                       # source axes -> x fwd, y left, z up
    IB = flip @ np.array(P["IB"]) @ flip
    IH = flip @ np.array(P["IH"]) @ flip
    v, wx = float(speed), float(lean_rate)

    def motion(point):
        """Velocity of a point turning at wx about the x axis (the ground contact line)."""
        return (v, -wx * point[2], 0.0)

    rear_hub, front_hub = (0.0, 0.0, rR), (w, 0.0, rF)
    com_B, com_H = (P["xB"], 0.0, -P["zB"]), (P["xH"], 0.0, -P["zH"])
    # the steer axis meets the ground the trail c ahead of the front contact point and leans
    # back by lam; its top point level with the rear frame's centre of mass, for display
    down = np.array([math.sin(lam), 0.0, -math.cos(lam)])
    foot = np.array([w + c, 0.0, 0.0])
    head = foot - down * (com_B[2] / math.cos(lam))
    b = ModelBuilder("whipple_bicycle", gravity=(0.0, 0.0, -P["g"]))
    frame_tube = head - np.array(rear_hub)
    b.add_body("rear_frame", P["mB"], IB, r=com_B, rdot=motion(com_B), omega=(wx, 0.0, 0.0),
               points={"hub": tuple(np.array(rear_hub) - com_B),
                       "head": tuple(head - com_B)},
               shapes=[{"type": "sphere", "radius": 0.15, "center": [0, 0, 0]},
                       {"type": "capsule", "radius": 0.02, "length":
                        float(np.linalg.norm(frame_tube)), "axis": list(frame_tube),
                        "center": list(0.5 * (head + np.array(rear_hub)) - com_B)}])
    fork_tube = head - np.array(front_hub)
    b.add_body("rear_wheel", P["mR"], (P["IRxx"], P["IRyy"], P["IRxx"]), r=rear_hub,
               rdot=motion(rear_hub), omega=(wx, v / rR, 0.0),
               shapes=[{"type": "cylinder", "radius": rR, "length": 0.03,
                        "axis": [0.0, 1.0, 0.0]}])
    b.add_body("front_frame", P["mH"], IH, r=com_H, rdot=motion(com_H), omega=(wx, 0.0, 0.0),
               shapes=[{"type": "capsule", "radius": 0.015, "length":
                        float(np.linalg.norm(fork_tube)), "axis": list(fork_tube),
                        "center": list(0.5 * (head + np.array(front_hub)) - com_H)}])
    b.add_body("front_wheel", P["mF"], (P["IFxx"], P["IFyy"], P["IFxx"]), r=front_hub,
               rdot=motion(front_hub), omega=(wx, v / rF, 0.0),
               shapes=[{"type": "cylinder", "radius": rF, "length": 0.03,
                        "axis": [0.0, 1.0, 0.0]}])
    y = (0.0, 1.0, 0.0)
    b.add_joint("revolute", "rear_hub", "rear_frame", "rear_wheel", point=rear_hub, axis=y)
    b.add_joint("revolute", "steer", "rear_frame", "front_frame", point=tuple(foot),
                axis=tuple(down))
    b.add_joint("revolute", "front_hub", "front_frame", "front_wheel", point=front_hub, axis=y)
    for name, wheel, hub, radius in (("rear_contact", "rear_wheel", rear_hub, rR),
                                     ("front_contact", "front_wheel", front_hub, rF)):
        b.add_joint("rolling_disc", name, wheel, "ground", point=hub, axis=y,
                    point2=(0.0, 0.0, 0.0), axis2=(0.0, 0.0, 1.0), radius=radius)
    return b


EXAMPLES = {
    # the benchmark bicycle in its self-stable speed range, pushed sideways: the lean and steer
    # oscillation (weave) dies out and it runs on straight, on a new heading
    "whipple_bicycle": (whipple_bicycle, {"speed": 4.6, "lean_rate": 0.5}, dict(
        type="dynamic", t_end=5.0, output_step=0.01, method={"name": "projection"},
        integrator={"name": "rk45", "rtol": 1e-8, "atol": 1e-10})),
}
