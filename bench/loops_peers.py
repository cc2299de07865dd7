#!/usr/bin/env python
"""spatialmbd against its pip-installable peers on CLOSED-LOOP mechanisms, at equal accuracy.

    OPENBLAS_NUM_THREADS=1 python bench/loops_peers.py          # all problems (~6 min)
    python bench/loops_peers.py --problems four_bar bricard      # some of them
    python bench/loops_peers.py --quick                          # fewer settings (smoke run)

The companion of bench/peers.py (open chains): the same accuracy measure, sweep, timing and
tables, reused from it (``peers.sweep``, ``peers.best_of``, ``peers.ours_runner``,
``peers.best_rows``, ``peers.per_call``), on the closed-loop models of ``spatialmbd.models``.

Problems (geometry, masses, inertias, joints, initial velocities, gravity and force elements
exactly as in src/spatialmbd/models/; every peer model is generated from the same
``ModelBuilder``, never retyped):

* ``four_bar``: ``four_bar()`` (RSSR, spherical coupler joints, crank_speed=None: no driver),
  released at rest, gravity -z; 2 DoF (the second is the coupler's idle spin, which stays 0);
  1 s.
* ``n_four_bar N``: ``n_four_bar(N)``, N = 2 and 8 (IFToMM A02, all revolute axes global z,
  3N redundant equations), cranks starting at -1 rad/s. Simulated 0.6 s only: at t ~ 0.714 s
  (N = 2) / 0.720 s (N = 8) the cranks are horizontal, a singular position where the branch is
  not determined and where spatialmbd's rk45 at tight tolerances stalls (its step underflows;
  see the notes). The span 0 .. 0.6 s is regular. Independent reference: every crank angle obeys
  I phi'' = K sin phi (models/iftomm.py), solved with SciPy DOP853 at rtol 1e-13.
* ``bricard``: ``bricard()`` (IFToMM A04; 6 revolute joints, Gruebler 0 DoF, moves with 1 DoF,
  one redundant equation everywhere), released at rest, gravity -y; 1 s.
* ``flyball``: ``flyball_governor()`` (IFToMM A05): kinematically an open tree (shaft revolute,
  slider translational along the shaft, two rods revolute on the shaft); its loops are closed
  by two stiff spring-dampers (k = 8e5 N/m, c = 4e4 N s/m) from the slider to the rods. Every
  body starts spinning at 2 pi rad/s; 1 s.
* ``bicycle``: ``whipple_bicycle(4.6, 0.5)`` (the Meijaard et al. 2007 benchmark bicycle, the
  IFToMM uncontrolled-bicycle manoeuvre: 4.6 m/s, pushed sideways at 0.5 rad/s): two knife-edge
  wheels rolling without slip, nonholonomic; 1 s. Only Exudyn has an exact rolling joint
  (``ObjectJointRollingDisc``: the plane on a ground marker, the disc's centre, axis and
  radius on the wheel); MuJoCo (contacts only) and Pinocchio are not run on it.

Accuracy: the largest distance between a body's final centre of mass and the reference (m);
target 1e-6 m. Reference: spatialmbd, method "projection", rk45 at rtol 1e-12 (atol 1e-14),
cross-checked (printed, and in the tables) against spatialmbd "standard" rk45 rtol 1e-12,
against Pinocchio at its tightest setting (DOP853 rtol 1e-12) and, for the N-four-bar, against
the closed-form crank-angle ODE.

How each peer's model is built (a spanning tree of the mechanism: each body hangs from its
parent by the joint that first reaches it from the ground; the remaining "cut" joints close
the loops: C for the four-bar, the crank pivots O_1..O_N for the N-four-bar (a serial tree
O_0, A_0, B_0, ..., B_{N-1}; see the notes for why not B_k), P5 for Bricard, none for the
flyball governor):

* MuJoCo (``mujoco``): the tree as nested MJCF bodies (body frame = spatialmbd's body frame:
  origin at the centre of mass, same axes; ``<inertial>`` mass and full inertia there; hinge,
  ball, slide joints at the joint points/axes; armature, damping 0; contact disabled).
  Loop closures: ``<equality><connect>`` at the cut joint's point (spherical cuts; the planar
  N-four-bar's revolute cuts, whose other four equations hold identically in a tree of z
  hinges), two connects at the point and 1 m along the axis for a spatial revolute cut
  (Bricard; 6 rows for 5 equations, redundant rows are fine for MuJoCo's soft constraints).
  Constraint softness: solimp (0.9999, 0.9999, 0.001, 0.5, 2) (MuJoCo's largest impedance)
  and solref time constant 1e-6 s, which MuJoCo's refsafe clamps to 2 x timestep: the
  stiffest stable setting (it stiffens as the step shrinks). Newton solver, tolerance 1e-12.
  Spring-dampers: spatial tendons between two sites (stiffness, damping, springlength = the
  natural length: f = k (l - l0) + c ldot along the line, as spatialmbd's). Integrators RK4,
  implicit, implicitfast at fixed steps, ``mj_step(m, d, nstep)``. COM: ``d.xipos``.
* Pinocchio (``pin``): the tree with ``JointModelRevoluteUnaligned``,
  ``JointModelPrismaticUnaligned`` and ``JointModelSpherical`` (joint frame at the joint
  point, axes = the child body's axes; the inertia at the COM lever in that frame). Loops:
  ``pin.RigidConstraintModel(CONTACT_3D, ...)`` at the same points as MuJoCo's connects (two
  for Bricard's cut), accelerations from ``pin.constraintDynamics`` (proximal settings:
  accuracy 1e-12, mu 1e-8, at most 20 iterations; mu > 0 handles the redundant rows) with
  Baumgarte correction ``setBaumgarteCorrectorParameters`` Kp = 100 s^-2, Kd = 20 s^-1
  (critically damped at 10 rad/s; without it the constraint drift grows as t^2). The state
  y = [q, v] is integrated by SciPy ``solve_ivp`` RK45 / DOP853 (unit quaternions of ball
  joints: qdot = 1/2 q (x) (omega, 0), used divided by |q|, as bench/peers.py). The flyball
  governor has no kinematic loop: ``pin.aba`` with the two spring-damper forces as external
  forces (computed in Python from ``forwardKinematics``). COM: ``data.oMi[j].act(lever)``.
* Exudyn (``exudyn==1.13.6``): not a tree: every body an Euler-parameter rigid body (reference
  point = COM, same axes), every joint of the builder as Exudyn's joint object (global-frame
  ``CreateRevoluteJoint``, ``CreateSphericalJoint``, ``CreatePrismaticJoint``), spring-dampers
  ``CreateSpringDamper``; its generalized-alpha solver (bench/exudyn_peer.py ``_settings``,
  ``_solve``: rho_inf 0.9, fixed step, modified Newton). Redundant equations make its
  Jacobian singular, so they are removed: the N-four-bar's coupler-to-crank joints B_k become
  ``CreateGenericJoint`` constraining only the in-plane displacement (x, y) -- the dropped
  equations hold identically; Bricard's closing joint P5 drops its one redundant equation the
  same way (rotation about the global z axis left free, see ``exudyn_cut_axes``); the motion
  is unchanged (checked at t = 0.1 s). Exudyn's explicit solvers do not accept joints of
  Euler-parameter bodies ("incompatible constraints are ignored"), so none is run on the
  loops; for the flyball governor (a tree) its ``ObjectKinematicTree`` with the springs on
  ``MarkerKinematicTreeRigid`` markers runs with RK44, RK67, DOPRI5 and ODE23.

Each peer model is checked before timing: its COM positions at t = 0.1 s (a tight run) must
match spatialmbd's reference within 1e-5 m (a setting error shows as 1e-2 m and more); the
differences are printed and in the tables.

"Best setting": for each code and setting family (integrator and, for spatialmbd, method)
the step or tolerance is swept from coarse to fine and the first (cheapest) setting with
error <= 1e-6 m is kept (tolerances rtol = 1e-2 .. 1e-12 in half decades, atol = 1e-2 rtol;
fixed steps 0.1 .. 2.5e-4 s, finer for the stiff flyball governor; ``peers.sweep``: a family
stops once one run exceeds 3 s, or is estimated above 9 s). Families that never reach it are
shown "not reached" with their best error and its time. spatialmbd's families:
``simulate(model, t_end, output_step=t_end, method=M, integrator=I, rtol, atol)`` (or ``step``)
with (I, M) = (rk45, projection), (rk45, standard), (rk45, baumgarte), (dop853, projection),
(dop853, standard), (scipy-dop853, projection), (rk4, projection), (abm4, projection), and for
the flyball governor also scipy-radau and bdf4 (stiff) and its recursive method with rk45 and
dop853 (joint coordinates: an open tree). Pinocchio: RK45, DOP853 (and Radau for the flyball
governor); MuJoCo: RK4, implicit, implicitfast; Exudyn: generalized-alpha (and the
KinematicTree integrators).

Timing: as bench/peers.py: the minimum over repetitions (at least 3, spread over >= 0.3 s) of
the integration alone: spatialmbd's ``Results.wall_time``, MuJoCo's ``mj_step`` loop, the
``solve_ivp`` call, Exudyn's ``SolveDynamic``. Single thread. Per-RHS cost: one call from
Python of spatialmbd's ``right_hand_side(model, method)``, of ``pin.constraintDynamics`` (and
of the whole Pinocchio RHS, with its Python glue), and of ``mujoco.mj_forward``.

Caveats: MuJoCo's equality constraints are soft (a stiff spring-damper toward the
constraint), so its error has a floor; Pinocchio's constrained dynamics drifts (Baumgarte);
the machine is shared and noisy: ratios within ~1.5x are not conclusive.

Writes bench/results/loops_peers.md and bench/results/loops_peers.json.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import exudyn_peer as ex  # noqa: E402
import peers  # noqa: E402
from peers import TARGET, available, best_of, com_error, log, per_call, sweep  # noqa: E402

from spatialmbd import models  # noqa: E402
from spatialmbd.rotations import A_from_p  # noqa: E402
from spatialmbd.simulate import RedundantConstraintsWarning, simulate  # noqa: E402

warnings.filterwarnings("ignore", category=RedundantConstraintsWarning)

CHECK_T = 0.1          # s, the short run that checks each peer model
CHECK_TOL = 1e-5       # m
LEVER = 1.0            # m, second closure point along a spatial revolute cut's axis
BAUMGARTE = (100.0, 20.0)          # Pinocchio Kp (1/s^2), Kd (1/s)
PROX = (1e-12, 1e-8, 20)           # Pinocchio proximal accuracy, mu, max iterations
#: relative tolerances swept (absolute = 1e-2 x relative): peers.TOLS and two coarser ones (a
#: smooth 1-DoF loop reaches 1e-6 m at rtol 1e-3)
TOLS = [1e-2, 10.0**-2.5] + peers.TOLS
#: Exudyn generalized-alpha steps (s): all divide 0.6 s and 1 s
GA_STEPS = [1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5]
# fixed-step families (for peers.fmt_setting / peers.best_rows)
peers.FIXED_STEP = peers.FIXED_STEP + ("rk4 projection", "RK44", "RK67")


NOTES = [
    "Pinocchio 4.1.0: with the N-four-bar's tree cut at the coupler-to-crank joints B_k (every "
    "middle crank then in two closure constraints) `pin.constraintDynamics` returns wrong "
    "accelerations (non-zero at rest in the vertical position, where the exact ones are 0; "
    "independent of mu, Baumgarte gains and LOCAL / LOCAL_WORLD_ALIGNED). Cut at the crank "
    "pivots O_1..O_N (a serial tree) it is right, so that is the tree used for every peer.",
    "The closed form of the N-four-bar in the docstring of `models.n_four_bar` uses slender "
    "bars (I = m L^2 ((N+1)/3 + N)); the builder's bars have a 0.02 m section, which changes I "
    "by 3e-5 relatively and the positions at 0.6 s by ~1e-5 m. The reference check here uses "
    "the builder's inertia.",
    "spatialmbd `right_hand_side(model, method)` does no redundancy analysis (its docstring): "
    "on the redundant models (N-four-bar, Bricard) every row enters the multiplier solve and "
    "one call costs hundreds of microseconds, while `simulate` (redundant rows removed) pays "
    "a few: see the 'in simulate (wall / nfev)' columns.",
    "The flyball governor is stiff (k = 8e5 N/m, c = 4e4 N s/m): every explicit integrator is "
    "held by stability, not accuracy; fixed steps above ~5e-4 s blow up.",
]


# --------------------------------------------------------------------------------- problems
def _nfb(n):
    return dict(build=lambda: models.n_four_bar(n), t_end=0.6,
                cuts={f"O{k}": "point" for k in range(1, n + 1)},
                exudyn_axes={f"B{k}": [1, 1, 0, 0, 0, 0] for k in range(n)},
                note="0.6 s (the cranks reach the singular horizontal position at ~0.71 s)")


PROBLEMS = {
    "four_bar": dict(build=lambda: models.four_bar(crank_speed=None), t_end=1.0,
                     cuts={"C": "point"}, note="1 s, released at rest"),
    "n_four_bar 2": _nfb(2),
    "n_four_bar 8": _nfb(8),
    "bricard": dict(build=models.bricard, t_end=1.0, cuts={"P5": "axis"},
                    exudyn_axes={"P5": [1, 1, 1, 0, 1, 0]}, note="1 s, released at rest"),
    "flyball": dict(build=models.flyball_governor, t_end=1.0, cuts={},
                    note="1 s, spinning at 2 pi rad/s",
                    # stiff (k = 8e5 N/m, c = 4e4 N s/m): explicit fixed steps above ~5e-4 s
                    # are unstable, so the fixed-step sweeps start finer
                    steps=[1e-3, 5e-4, 4e-4, 2.5e-4, 2e-4, 1.25e-4, 1e-4, 5e-5]),
    # two knife-edge wheels rolling without slip (nonholonomic): neither MuJoCo (contacts
    # only) nor Pinocchio has an exact rolling joint; Exudyn's ObjectJointRollingDisc is one
    "bicycle": dict(build=lambda: models.whipple_bicycle(4.6, 0.5), t_end=1.0, cuts={},
                    peers=("exudyn",),
                    note="1 s of the Whipple bicycle at 4.6 m/s pushed at 0.5 rad/s"),
}


def n_four_bar_exact(n, t_end, builder):
    """COM of n_four_bar(n) at t_end from I phi'' = K sin phi, DOP853 rtol 1e-13. The
    docstring of models.n_four_bar gives I = m L^2 ((N+1)/3 + N) for slender bars; the builder's
    cranks have the section 0.02 m, so I = (N+1) (J_zz + m (L/2)^2) + N m L^2 here (the slender
    formula is off by 3e-5 relatively, 1e-5 m at 0.6 s)."""
    from scipy.integrate import solve_ivp
    crank = builder.bodies["crank0"]
    m, jzz = float(crank.mass), float(np.asarray(crank.inertia)[2, 2])
    I = (n + 1) * (jzz + m * 0.25) + n * m
    K = models.G_TEXT * m * ((n + 1) / 2 + n)
    sol = solve_ivp(lambda t, y: [y[1], K / I * math.sin(y[0])], (0, t_end), [0.0, -1.0],
                    method="DOP853", rtol=1e-13, atol=1e-15)
    phi = sol.y[0, -1]
    e = np.array([-math.sin(phi), math.cos(phi), 0.0])        # crank direction (from +y)
    com = []
    for name in builder.bodies:
        k = int(name.removeprefix("crank").removeprefix("coupler"))
        com.append([k, 0, 0] + (0.5 * e if name.startswith("crank") else [0.5, 0, 0] + e))
    return np.array(com, dtype=float)


# -------------------------------------------------------------- the mechanism, as a tree
def body_data(builder):
    out = {}
    for name, b in builder.bodies.items():
        out[name] = dict(mass=float(b.mass), inertia=np.asarray(b.inertia, float),
                         r=np.asarray(b.r, float), R=A_from_p(np.asarray(b.p, float)),
                         rdot=np.asarray(b.rdot, float), omega=np.asarray(b.omega, float))
    out["ground"] = dict(mass=0.0, inertia=np.zeros((3, 3)), r=np.zeros(3), R=np.eye(3),
                         rdot=np.zeros(3), omega=np.zeros(3))
    return out


def spanning_tree(builder, cuts):
    """[(child, parent, joint spec)] parent-first, and the cut joints [(spec, kind)]."""
    placed, tree = {"ground"}, []
    todo = [j for j in builder.joints.values() if j.name not in cuts]
    while todo:
        for j in todo:
            a, b = j.body_i, j.body_j
            if (a in placed) != (b in placed):
                child, parent = (b, a) if a in placed else (a, b)
                tree.append((child, parent, j))
                placed.add(child)
                todo.remove(j)
                break
        else:
            raise ValueError(f"joints {[j.name for j in todo]} close loops: list them as cuts")
    missing = set(builder.bodies) - placed
    if missing:
        raise ValueError(f"bodies {missing} not reached by the tree")
    return tree, [(builder.joints[name], kind) for name, kind in cuts.items()]


def joint_rate(kind, bd, child, parent, point, axis):
    """Initial joint velocity from the bodies' initial velocities (global)."""
    c, p = bd[child], bd[parent]
    if kind == "revolute":
        return [float((c["omega"] - p["omega"]) @ axis)]
    if kind == "translational":
        vc = c["rdot"] + np.cross(c["omega"], point - c["r"])
        vp = p["rdot"] + np.cross(p["omega"], point - p["r"])
        return [float((vc - vp) @ axis)]
    return list(c["R"].T @ (c["omega"] - p["omega"]))         # spherical: child axes


def closure_points(spec, kind):
    pt = np.asarray(spec.geometry["point"], float)
    if kind == "point":
        return [pt]
    axis = np.asarray(spec.geometry["axis"], float)
    return [pt, pt + LEVER * axis / np.linalg.norm(axis)]


def springs(builder):
    """[(body_i, local point i, body_j, local point j, k, c, l0)] of the spring-dampers."""
    out = []
    for f in builder.forces.values():
        if f.type != "spring_damper":
            raise ValueError(f"force element {f.type} not mapped to the peers")
        p = f.params

        def local(body, pt):
            return (np.asarray(builder.bodies[body].points[pt], float) if isinstance(pt, str)
                    else np.asarray(pt, float))
        out.append((p["body_i"], local(p["body_i"], p["point_i"]), p["body_j"],
                    local(p["body_j"], p["point_j"]), float(p["stiffness"]),
                    float(p.get("damping", 0.0)), float(p["natural_length"])))
    return out


def _v(x):
    return " ".join(f"{float(a):.17g}" for a in np.ravel(x))


# ---------------------------------------------------------------------------------- MuJoCo
def mjcf(prob):
    import mujoco
    b = prob["builder"]
    bd = body_data(b)
    tree, cuts = spanning_tree(b, prob["cuts"])
    kids = {}
    for child, parent, j in tree:
        kids.setdefault(parent, []).append((child, j))
    g = b.gravity

    def body_xml(name, parent):
        c, p = bd[name], bd[parent]
        Rrel = p["R"].T @ c["R"]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, Rrel.reshape(-1))
        pos = p["R"].T @ (c["r"] - p["r"])
        j = next(j for ch, j in kids[parent] if ch == name)
        pt = c["R"].T @ (np.asarray(j.geometry["point"], float) - c["r"])
        if j.type == "spherical":
            jx = f'type="ball" pos="{_v(pt)}"'
        else:
            ax = c["R"].T @ np.asarray(j.geometry["axis"], float)
            jx = (f'type="{"hinge" if j.type == "revolute" else "slide"}" pos="{_v(pt)}" '
                  f'axis="{_v(ax)}"')
        I = c["inertia"]
        sites = "".join(f'<site name="{nm}" pos="{_v(lp)}"/>'
                        for nm, body, lp in prob["_sites"] if body == name)
        inner = "".join(body_xml(k, name) for k, _ in kids.get(name, []))
        return (f'<body name="{name}" pos="{_v(pos)}" quat="{_v(quat)}">'
                f'<joint name="{j.name}" {jx} armature="0" damping="0" limited="false"/>'
                f'<inertial pos="0 0 0" mass="{c["mass"]:.17g}" fullinertia="'
                f'{_v([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])}"/>'
                f'{sites}{inner}</body>')
    soft = 'solref="0.000001 1" solimp="0.9999 0.9999 0.001 0.5 2"'
    eq = ""
    for spec, kind in cuts:
        a, c = (spec.body_i, spec.body_j) if spec.body_i != "ground" else (spec.body_j,
                                                                           spec.body_i)
        for pt in closure_points(spec, kind):
            anchor = bd[a]["R"].T @ (pt - bd[a]["r"])
            other = "" if c == "ground" else f' body2="{c}"'
            eq += f'<connect body1="{a}"{other} anchor="{_v(anchor)}" {soft}/>'
    ten = "".join(f'<spatial stiffness="{k:.17g}" damping="{cc:.17g}" springlength="{l0:.17g}">'
                  f'<site site="s{i}a"/><site site="s{i}b"/></spatial>'
                  for i, (_, _, _, _, k, cc, l0) in enumerate(springs(b)))
    world = "".join(body_xml(k, "ground") for k, _ in kids["ground"])
    return (f'<mujoco model="{b.name}"><compiler angle="radian" inertiafromgeom="false"/>'
            f'<option timestep="0.001" gravity="{_v(g)}" integrator="RK4" tolerance="1e-12">'
            f'<flag contact="disable"/></option><worldbody>{world}</worldbody>'
            + (f"<equality>{eq}</equality>" if eq else "")
            + (f"<tendon>{ten}</tendon>" if ten else "") + "</mujoco>")


def mujoco_model(prob):
    import mujoco
    b = prob["builder"]
    prob["_sites"] = [x for i, (bi, pi, bj, pj, *_) in enumerate(springs(b))
                      for x in ((f"s{i}a", bi, pi), (f"s{i}b", bj, pj))]
    m = mujoco.MjModel.from_xml_string(mjcf(prob))
    bd = body_data(b)
    tree, _ = spanning_tree(b, prob["cuts"])
    qvel = np.zeros(m.nv)
    for child, parent, j in tree:
        jid = m.joint(j.name).id
        adr = m.jnt_dofadr[jid]
        rate = joint_rate(j.type, bd, child, parent, np.asarray(j.geometry["point"], float),
                          np.asarray(j.geometry.get("axis", (0, 0, 1)), float))
        qvel[adr:adr + len(rate)] = rate
    ids = [m.body(name).id for name in b.bodies]
    return m, qvel, ids


def mujoco_runner(prob, integrator):
    import mujoco
    m, qvel0, ids = mujoco_model(prob)
    m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    d = mujoco.MjData(m)
    t_end = prob["t_end"]

    def run(h, t_end=t_end):
        steps = int(round(t_end / h))
        m.opt.timestep = t_end / steps

        def once():
            mujoco.mj_resetData(m, d)
            d.qvel[:] = qvel0
            t0 = time.perf_counter()
            mujoco.mj_step(m, d, nstep=steps)
            wall = time.perf_counter() - t0
            bad = sum(d.warning[w].number for w in (mujoco.mjtWarning.mjWARN_BADQACC,
                                                    mujoco.mjtWarning.mjWARN_BADQVEL,
                                                    mujoco.mjtWarning.mjWARN_BADQPOS))
            if bad:          # MuJoCo resets the state and carries on: not a result
                raise RuntimeError(f"unstable (MuJoCo reset the state {bad} times)")
            return wall, None
        wall, _ = best_of(once)
        mujoco.mj_kinematics(m, d)
        if not np.all(np.isfinite(d.qpos)):
            raise RuntimeError("diverged")
        return wall, d.xipos[ids].copy(), dict(steps=steps)
    return run


# ------------------------------------------------------------------------------- Pinocchio
def pin_problem(prob, baumgarte=BAUMGARTE):
    """(f, y0, com(y), extras) of the problem in Pinocchio; y = [q, v]."""
    import pinocchio as pin
    b = prob["builder"]
    bd = body_data(b)
    tree, cuts = spanning_tree(b, prob["cuts"])
    model = pin.Model()
    jid, frame = {"ground": 0}, {"ground": (np.zeros(3), np.eye(3))}   # joint frames, global
    lever, v0 = {}, []
    for child, parent, j in tree:
        c = bd[child]
        pt = np.asarray(j.geometry["point"], float)
        if j.type == "spherical":
            jm = pin.JointModelSpherical()
        else:
            ax = c["R"].T @ np.asarray(j.geometry["axis"], float)
            jm = (pin.JointModelRevoluteUnaligned(ax) if j.type == "revolute"
                  else pin.JointModelPrismaticUnaligned(ax))
        op, Rp = frame[parent]
        place = pin.SE3(Rp.T @ c["R"], Rp.T @ (pt - op))
        k = model.addJoint(jid[parent], jm, place, j.name)
        jid[child], frame[child] = k, (pt, c["R"])
        lever[child] = c["R"].T @ (c["r"] - pt)
        model.appendBodyToJoint(k, pin.Inertia(c["mass"], lever[child], c["inertia"]),
                                pin.SE3.Identity())
        v0.append((model.joints[k].idx_v,
                   joint_rate(j.type, bd, child, parent, pt,
                              np.asarray(j.geometry.get("axis", (0, 0, 1)), float))))
    model.gravity.linear = np.asarray(b.gravity, float)
    data = model.createData()
    nq, nv = model.nq, model.nv
    y0 = np.concatenate([pin.neutral(model), np.zeros(nv)])
    for idx, rate in v0:
        y0[nq + idx:nq + idx + len(rate)] = rate
    balls = [(model.joints[k].idx_q, model.joints[k].idx_v) for k in range(1, model.njoints)
             if model.joints[k].shortname() == "JointModelSpherical"]
    scalar_q = [model.joints[k].idx_q for k in range(1, model.njoints)
                if model.joints[k].nq == 1]
    scalar_v = [model.joints[k].idx_v for k in range(1, model.njoints)
                if model.joints[k].nq == 1]
    cms = []
    for spec, kind in cuts:
        for pt in closure_points(spec, kind):
            ends = []
            for body in (spec.body_i, spec.body_j):
                o, R = frame[body]
                ends += [jid[body], pin.SE3(np.eye(3), R.T @ (pt - o))]
            cm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, model, *ends,
                                          pin.ReferenceFrame.LOCAL)
            bp = cm.m_baumgarte_parameters
            bp.Kp, bp.Kd = baumgarte
            cm.setBaumgarteCorrectorParameters(bp)
            cms.append(cm)
    tau = np.zeros(nv)

    def unit(q):
        q = q.copy()
        for iq, _ in balls:
            q[iq:iq + 4] /= np.linalg.norm(q[iq:iq + 4])
        return q

    def qdot(q, v):
        if not balls:
            return v
        qd = np.empty(nq)
        qd[scalar_q] = v[scalar_v]
        for iq, iv in balls:                          # qdot = 1/2 q (x) (omega, 0)
            x, yy, z, w = q[iq:iq + 4]
            a, bb, c = v[iv:iv + 3]
            qd[iq:iq + 4] = 0.5 * np.array([w * a + yy * c - z * bb, w * bb + z * a - x * c,
                                            w * c + x * bb - yy * a, -(x * a + yy * bb + z * c)])
        return qd
    extras = dict(model=model, data=data, n_constraints=3 * len(cms))
    if cms:
        cds = [cm.createData() for cm in cms]
        cmv = pin.StdVec_RigidConstraintModel()
        cdv = pin.StdVec_RigidConstraintData()
        for cm, cd in zip(cms, cds):
            cmv.append(cm)
            cdv.append(cd)
        pin.initConstraintDynamics(model, data, cmv, cdv)
        prox = pin.ProximalSettings(PROX[0], PROX[1], PROX[2])
        cdyn = pin.constraintDynamics

        def acc(q, v):
            return cdyn(model, data, q, v, tau, cmv, cdv, prox)
        extras.update(constraint_call=lambda q, v: cdyn(model, data, q, v, tau, cmv, cdv, prox),
                      prox=prox)
    else:
        # spring points are given from the COM in body axes: in the joint frame add the lever
        sp = [(jid[bi], pi + lever[bi], jid[bj], pj + lever[bj], k, c, l0)
              for bi, pi, bj, pj, k, c, l0 in springs(b)]
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        fv = pin.StdVec_Force()
        for fz in fext:
            fv.append(fz)
        aba, fk = pin.aba, pin.forwardKinematics

        def cross(a, b):                     # np.cross costs ~20 us on 3-vectors
            return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                             a[0] * b[1] - a[1] * b[0]])

        def acc(q, v):
            fk(model, data, q, v)
            for k in range(model.njoints):
                fv[k] = pin.Force.Zero()
            for ji, pi, jj, pj, k, c, l0 in sp:
                Mi, Mj = data.oMi[ji], data.oMi[jj]
                Ri, Rj = Mi.rotation, Mj.rotation
                vi, vj = data.v[ji], data.v[jj]
                lv = Mj.act(pj) - Mi.act(pi)
                ln = math.sqrt(lv @ lv)
                u = lv / ln
                ldot = u @ (Rj @ (vj.linear + cross(vj.angular, pj))
                            - Ri @ (vi.linear + cross(vi.angular, pi)))
                f = (k * (ln - l0) + c * ldot) * u           # tension pulls i towards j
                fi, fj = Ri.T @ f, -(Rj.T @ f)
                fv[ji] = fv[ji] + pin.Force(fi, cross(pi, fi))
                fv[jj] = fv[jj] + pin.Force(fj, cross(pj, fj))
            return aba(model, data, q, v, tau, fv)

    def f(t, y):
        q = unit(y[:nq]) if balls else y[:nq]
        v = y[nq:]
        return np.concatenate([qdot(q, v), acc(q, v)])

    names = list(b.bodies)

    def com(y):
        pin.forwardKinematics(model, data, unit(y[:nq]))
        return np.array([data.oMi[jid[n]].act(lever[n]) for n in names])
    extras.update(acc=acc)
    return f, y0, com, extras


def pin_scipy_runner(prob, method):
    f, y0, com, _ = pin_problem(prob)
    return peers.scipy_runner(f, y0, com, method, prob["t_end"])


# ---------------------------------------------------------------------------------- Exudyn
def exudyn_runner(prob):
    """Generalized-alpha on Euler-parameter bodies and the builder's joints (see docstring)."""
    b = prob["builder"]
    bd = body_data(b)
    axes = prob.get("exudyn_axes", {})
    t_end = prob["t_end"]

    def build(h, t_end):
        exu = ex._exu()
        from exudyn.rigidBodyUtilities import RigidBodyInertia
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()
        item = {"ground": mbs.CreateGround(referencePosition=[0.0, 0.0, 0.0], show=False)}
        nodes = {}
        for name in b.bodies:
            c = bd[name]
            d = mbs.CreateRigidBody(
                inertia=RigidBodyInertia(mass=c["mass"], inertiaTensor=c["inertia"],
                                         com=np.zeros(3), inertiaTensorAtCOM=True),
                referencePosition=list(c["r"]), referenceRotationMatrix=c["R"],
                initialVelocity=list(c["rdot"]), initialAngularVelocity=list(c["omega"]),
                gravity=list(b.gravity), nodeType=exu.NodeType.RotationEulerParameters,
                show=False, returnDict=True)
            item[name], nodes[name] = d["bodyNumber"], d["nodeNumber"]
        for j in b.joints.values():
            pair = [item[j.body_i], item[j.body_j]]
            pt = list(np.asarray(j.geometry["point"], float))
            if j.type == "rolling_disc":
                # the plane (a point and its normal) on body j, the disc's centre and axis on
                # body i (all initially in global axes, the bodies unturned)
                from exudyn.itemInterface import MarkerBodyRigid, ObjectJointRollingDisc
                if j.body_j != "ground":
                    raise ValueError("the rolling plane must be the ground here")
                wheel = bd[j.body_i]
                plane = mbs.AddMarker(MarkerBodyRigid(
                    bodyNumber=item["ground"],
                    localPosition=list(np.asarray(j.geometry["point2"], float))))
                centre = mbs.AddMarker(MarkerBodyRigid(
                    bodyNumber=item[j.body_i],
                    localPosition=list(wheel["R"].T @ (np.asarray(pt) - wheel["r"]))))
                mbs.AddObject(ObjectJointRollingDisc(
                    markerNumbers=[plane, centre], discRadius=float(j.params["radius"]),
                    discAxis=list(wheel["R"].T @ np.asarray(j.geometry["axis"], float)),
                    planeNormal=list(np.asarray(j.geometry["axis2"], float))))
            elif j.name in axes:
                mbs.CreateGenericJoint(itemNumbers=pair, position=pt,
                                       constrainedAxes=axes[j.name], useGlobalFrame=True,
                                       show=False)
            elif j.type == "revolute":
                mbs.CreateRevoluteJoint(itemNumbers=pair, position=pt,
                                        axis=list(j.geometry["axis"]), useGlobalFrame=True,
                                        show=False)
            elif j.type == "spherical":
                mbs.CreateSphericalJoint(itemNumbers=pair, position=pt, useGlobalFrame=True,
                                         show=False)
            elif j.type == "translational":
                mbs.CreatePrismaticJoint(itemNumbers=pair, position=pt,
                                         axis=list(j.geometry["axis"]), useGlobalFrame=True,
                                         show=False)
            elif j.type == "universal":
                # a generic joint free to turn about axis (of body i) and axis2 (of body j):
                # the frame's x and y axes; its z rotation (x0 . y1 = 0) and the point held
                a = np.asarray(j.geometry["axis"], float)
                c = np.asarray(j.geometry["axis2"], float)
                a, c = a / np.linalg.norm(a), c / np.linalg.norm(c)
                mbs.CreateGenericJoint(itemNumbers=pair, position=pt,
                                       rotationMatrixAxes=np.column_stack([a, c, np.cross(a, c)]),
                                       constrainedAxes=[1, 1, 1, 0, 0, 1], useGlobalFrame=True,
                                       show=False)
            else:
                raise ValueError(j.type)
        for bi, pi, bj, pj, k, c, l0 in springs(b):
            mbs.CreateSpringDamper(itemNumbers=[item[bi], item[bj]], localPosition0=list(pi),
                                   localPosition1=list(pj), referenceLength=l0, stiffness=k,
                                   damping=c, show=False)
        mbs.Assemble()
        return exu, mbs, nodes, ex._settings(exu, h, t_end, ex.DEFAULT_SPECTRAL_RADIUS)

    def run(h, t_end=t_end):
        def once():
            exu, mbs, nodes, st = build(h, t_end)
            info = ex._solve(mbs, exu, st)
            pos = [mbs.GetNodeOutput(nodes[n], exu.OutputVariableType.Position)
                   for n in b.bodies]
            return info["wall_time"], (np.array(pos), info["steps"])
        wall, (com, steps) = best_of(once)
        return wall, com, dict(steps=steps)
    return run


def exudyn_kt_runner(prob, solver):
    """The flyball governor as Exudyn's ObjectKinematicTree (minimal coordinates) with the
    spring-dampers on MarkerKinematicTreeRigid markers, explicit solver ``solver``."""
    b = prob["builder"]
    bd = body_data(b)
    tree, _ = spanning_tree(b, {})
    t_end = prob["t_end"]
    names = [c for c, _, _ in tree]

    def build():
        exu = ex._exu()
        from exudyn.itemInterface import (MarkerKinematicTreeRigid, NodeGenericODE2,
                                          ObjectConnectorSpringDamper, ObjectKinematicTree)
        # link frame = joint frame: origin at the joint point, axes = the body's (as Pinocchio)
        types, parents, T, off, com_local, rates = [], [], [], [], [], []
        origin = {"ground": np.zeros(3)}
        for child, parent, j in tree:
            c, p = bd[child], bd[parent]
            pt = np.asarray(j.geometry["point"], float)
            ax = c["R"].T @ np.asarray(j.geometry["axis"], float)
            k = int(np.argmax(np.abs(ax)))
            if abs(ax[k] - 1) > 1e-12:
                raise ValueError("KinematicTree: a joint axis must be a body axis")
            types.append(getattr(exu.JointType, ("Revolute" if j.type == "revolute"
                                                 else "Prismatic") + "XYZ"[k]))
            parents.append(names.index(parent) if parent != "ground" else -1)
            origin[child] = pt
            T.append(p["R"].T @ c["R"])
            off.append(p["R"].T @ (pt - origin[parent]))
            com_local.append(c["R"].T @ (c["r"] - pt))
            rates += joint_rate(j.type, bd, child, parent, pt,
                                np.asarray(j.geometry["axis"], float))
        n = len(tree)
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()
        node = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * n,
                                           initialCoordinates=[0.0] * n,
                                           initialCoordinates_t=rates,
                                           numberOfODE2Coordinates=n))
        kt = mbs.AddObject(ObjectKinematicTree(
            nodeNumber=node, jointTypes=types, linkParents=parents,
            jointTransformations=exu.Matrix3DList(T), jointOffsets=exu.Vector3DList(off),
            linkInertiasCOM=exu.Matrix3DList([bd[c]["inertia"] for c in names]),
            linkCOMs=exu.Vector3DList(com_local),
            linkMasses=[bd[c]["mass"] for c in names], gravity=list(b.gravity)))
        for bi, pi, bj, pj, k, c, l0 in springs(b):
            mk = [mbs.AddMarker(MarkerKinematicTreeRigid(
                objectNumber=kt, linkNumber=names.index(bn),
                localPosition=list(lp + com_local[names.index(bn)])))
                for bn, lp in ((bi, pi), (bj, pj))]
            mbs.AddObject(ObjectConnectorSpringDamper(markerNumbers=mk, referenceLength=l0,
                                                      stiffness=k, damping=c))
        mbs.Assemble()
        return exu, mbs, node, kt, com_local

    adaptive = solver in ("ODE23", "DOPRI5")

    def run(s, t_end=t_end):
        def once():
            exu, mbs, node, kt, com_local = build()
            st = peers.kt_settings(exu, s, adaptive, t_end)
            t0 = time.perf_counter()
            ok = mbs.SolveDynamic(st, solverType=getattr(exu.DynamicSolverType, solver))
            wall = time.perf_counter() - t0
            if not ok or abs(float(mbs.systemData.GetTime()) - t_end) > 1e-9:
                raise RuntimeError("SolveDynamic failed")
            q = np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates))
            steps = int(mbs.sys["dynamicSolver"].it.currentStepIndex) - 1
            return wall, (q, steps)
        wall, (q, steps) = best_of(once)
        return wall, kt_com(q), dict(steps=steps)

    _, _, com_pin, _ = pin_problem(prob)      # the same tree, 1-dof joints: same q

    def kt_com(q):
        return com_pin(np.concatenate([q, np.zeros(len(q))]))
    return run


# ------------------------------------------------------------------------------- spatialmbd
def ours_families(prob, quick):
    tols = TOLS[::2] if quick else TOLS
    fam = [("spatialmbd rk45 projection", dict(integrator="rk45", method="projection"), tols),
           ("spatialmbd rk45 standard", dict(integrator="rk45", method="standard"), tols),
           ("spatialmbd rk45 baumgarte", dict(integrator="rk45", method="baumgarte"), tols),
           ("spatialmbd dop853 projection", dict(integrator="dop853", method="projection"),
            tols),
           ("spatialmbd dop853 standard", dict(integrator="dop853", method="standard"), tols),
           ("spatialmbd scipy-dop853 projection",
            dict(integrator="scipy-dop853", method="projection"), tols),
           ("spatialmbd rk4 projection", dict(integrator="rk4", method="projection"),
            prob.get("steps", peers.STEPS))]
    if not quick:
        fam.append(("spatialmbd abm4 projection", dict(integrator="abm4", method="projection"),
                    tols))
    if prob["key"] == "flyball":                   # stiff springs: implicit ones, and the tree
        fam += [("spatialmbd scipy-radau projection",
                 dict(integrator="scipy-radau", method="projection"), tols),
                ("spatialmbd bdf4 projection", dict(integrator="bdf4", method="projection"),
                 tols),
                ("spatialmbd rk45 recursive", dict(integrator="rk45", method="recursive"),
                 tols),
                ("spatialmbd dop853 recursive", dict(integrator="dop853", method="recursive"),
                 tols)]
    return fam


def reference(prob):
    model = prob["model"]
    t_end = prob["t_end"]
    out = {}
    for meth in ("projection", "standard"):
        simulate(model, 0.01, output_step=0.01, method=meth, rtol=1e-12, atol=1e-14)
        res = simulate(model, t_end, output_step=CHECK_T, method=meth, rtol=1e-12, atol=1e-14)
        if not res.success:
            raise RuntimeError(f"reference {meth}: {res.message}")
        out[meth] = (res.q[-1, :, :3].copy(), res.q[1, :, :3].copy())    # t_end, CHECK_T
    return out


# -------------------------------------------------------------------------------- per RHS
def rhs_costs(prob, peers_of=("mujoco", "pinocchio", "exudyn")):
    model = prob["model"]
    out = peers.body_rhs_costs(model)
    for method in ("standard", "projection"):        # what a run pays per evaluation
        best = math.inf
        for _ in range(3):
            res = simulate(model, prob["t_end"], output_step=prob["t_end"], method=method,
                           rtol=1e-8, atol=1e-10)
            best = min(best, res.wall_time / res.counters["nfev"])
        out[f"spatialmbd {method} in simulate (wall / nfev, rk45 rtol 1e-8)"] = best
    if available("pinocchio") and "pinocchio" in peers_of:
        f, y0, _, ext = pin_problem(prob)
        nq = ext["model"].nq
        q, v = y0[:nq].copy(), y0[nq:].copy()
        if "constraint_call" in ext:
            out["pinocchio constraintDynamics"] = per_call(lambda: ext["constraint_call"](q, v))
        else:
            import pinocchio as pin
            tau = np.zeros(ext["model"].nv)
            out["pinocchio aba"] = per_call(lambda: pin.aba(ext["model"], ext["data"], q, v,
                                                            tau))
        out["pinocchio whole RHS (Python)"] = per_call(lambda: f(0.0, y0))
    if available("mujoco") and "mujoco" in peers_of:
        import mujoco
        m, qvel, _ = mujoco_model(prob)
        d = mujoco.MjData(m)
        d.qvel[:] = qvel
        out["mujoco mj_forward"] = per_call(lambda: mujoco.mj_forward(m, d))
    return out


# ------------------------------------------------------------------------------------ main
def check_peer(label, run, setting, ref_check, checks):
    """Run the peer to CHECK_T at a tight setting; record its COM difference to spatialmbd."""
    try:
        old = peers.MIN_SPREAD
        peers.MIN_SPREAD = 0.0
        try:
            _, com, _ = run(setting, t_end=CHECK_T)
        finally:
            peers.MIN_SPREAD = old
        diff = com_error(com, ref_check)
    except Exception as exc:
        log(f"  check {label}: failed {exc}")
        checks[label] = f"failed: {type(exc).__name__}: {exc}"[:160]
        return False
    checks[label] = diff
    log(f"  check {label} at t = {CHECK_T} s ({setting}): {diff:.1e} m")
    return diff <= CHECK_TOL


def problem(key, quick):
    prob = dict(PROBLEMS[key], key=key)
    prob["builder"] = prob["build"]()
    prob["model"] = prob["builder"].compile()
    t_end = prob["t_end"]
    peers.T_END = t_end                    # peers.ours_runner integrates to peers.T_END
    log(f"\n== {key} (t = 0 .. {t_end} s)")
    refs = reference(prob)
    ref, ref_check = refs["projection"]
    crosses = {"spatialmbd standard rk45 rtol 1e-12": com_error(refs["standard"][0], ref)}
    if key.startswith("n_four_bar"):
        n = int(key.split()[1])
        crosses["closed form (crank-angle ODE)"] = com_error(
            n_four_bar_exact(n, t_end, prob["builder"]), ref)
    if available("pinocchio") and "pinocchio" in prob.get("peers", ("pinocchio",)):
        try:
            crosses["pinocchio DOP853 rtol 1e-12"] = com_error(
                pin_scipy_runner(prob, "DOP853")(1e-12)[1], ref)
        except Exception as exc:
            crosses["pinocchio DOP853 rtol 1e-12"] = f"failed: {exc}"[:120]
    for k, v in crosses.items():
        log(f"  reference vs {k}: {v if isinstance(v, str) else f'{v:.1e} m'}")
    rows, checks = [], {}
    for label, fixed, settings in ours_families(prob, quick):
        try:
            rows += sweep(label, settings, peers.ours_runner(prob["model"], **fixed), ref)
        except Exception as exc:
            rows.append(dict(code=label, setting=settings[0], failed=str(exc)[:120]))
            log(f"    {label}: failed {exc}")
    steps = prob.get("steps", peers.STEPS)
    steps = steps[::2] if quick else steps
    tols = TOLS[::2] if quick else TOLS
    peers_of = prob.get("peers", ("mujoco", "pinocchio", "exudyn"))
    if available("mujoco") and "mujoco" in peers_of:
        runs = {"RK4": mujoco_runner(prob, "RK4")}
        if check_peer("mujoco RK4", runs["RK4"], 1e-4, ref_check, checks):
            rows += sweep("mujoco RK4", sorted(set(steps + [1e-4, 5e-5]), reverse=True),
                          runs["RK4"], ref)
            for integ in ("implicit", "implicitfast"):
                rows += sweep(f"mujoco {integ}", [1e-3, 1e-4, 1e-5, 5e-6, 2.5e-6],
                              mujoco_runner(prob, integ), ref)
        else:
            rows.append(dict(code="mujoco", setting=0, failed="model check at t = 0.1 s"))
    if available("pinocchio") and "pinocchio" in peers_of:
        run = pin_scipy_runner(prob, "DOP853")
        if check_peer("pinocchio DOP853", run, 1e-11, ref_check, checks):
            what = "constraintDynamics" if prob["cuts"] else "aba + spring forces"
            for meth in ("RK45", "DOP853"):
                rows += sweep(f"pinocchio {what} + scipy {meth}", tols,
                              pin_scipy_runner(prob, meth), ref)
            if key == "flyball":
                rows += sweep(f"pinocchio {what} + scipy Radau", tols[:10],
                              pin_scipy_runner(prob, "Radau"), ref)
        else:
            rows.append(dict(code="pinocchio", setting=0, failed="model check at t = 0.1 s"))
    if available("exudyn") and "exudyn" in peers_of:
        run = exudyn_runner(prob)
        if check_peer("exudyn gen.-alpha", run, 1e-4 if key != "flyball" else 2.5e-5,
                      ref_check, checks):
            rows += sweep("exudyn gen.-alpha (Euler parameters)",
                          GA_STEPS[::2] if quick else GA_STEPS, run, ref)
        else:
            rows.append(dict(code="exudyn gen.-alpha", setting=0,
                             failed="model check at t = 0.1 s"))
        if key == "flyball":
            run = exudyn_kt_runner(prob, "RK67")
            if check_peer("exudyn KinematicTree RK67", run, 1e-4, ref_check, checks):
                rows += sweep("exudyn KinematicTree RK67", steps, run, ref)
                rows += sweep("exudyn KinematicTree RK44", steps,
                              exudyn_kt_runner(prob, "RK44"), ref)
                for s in ("DOPRI5", "ODE23"):
                    rows += sweep(f"exudyn KinematicTree {s}", tols,
                                  exudyn_kt_runner(prob, s), ref)
    log("  per-RHS cost ...")
    costs = rhs_costs(prob, peers_of)
    return dict(name=key, t_end=t_end, note=prob["note"], nb=prob["model"].nb,
                n_eq=prob["model"].n_eq, reference_checks=crosses, model_checks=checks,
                rows=rows, rhs=costs)


def _ms(x):
    return f"{x * 1e3:.3f}"


def tables(results, meta):
    lines = ["# spatialmbd against its peers on closed-loop mechanisms, at equal accuracy", "",
             f"Generated by `bench/loops_peers.py` on {meta['date']} ({meta['machine']}); "
             f"versions: {meta['versions']}.", "",
             f"Accuracy target: final centre-of-mass error <= {TARGET:g} m (largest over the "
             "bodies) at the end of the span. For each code and setting family the cheapest "
             "swept setting reaching it; wall = integration only, minimum over repetitions, "
             "single thread. The machine is shared and noisy: ratios within ~1.5x are not "
             "conclusive. Ratio = wall / best peer's wall. How each peer's model is built: "
             "the docstring of bench/loops_peers.py.", ""]
    lines += ["## Summary", "",
              "| problem | best peer (setting) | its wall (ms) | best spatialmbd (setting) | "
              "its wall (ms) | spatialmbd / best peer |", "|---|---|---:|---|---:|---:|"]
    for p in results:
        ok, _ = peers.best_rows(p["rows"])
        pr = [r for r in ok if not r["code"].startswith("spatialmbd")]
        ours = [r for r in ok if r["code"].startswith("spatialmbd")]
        a = (f"{pr[0]['code']} ({peers.fmt_setting(pr[0])}) | {_ms(pr[0]['wall'])}" if pr
             else "none reached 1e-6 m | --")
        o = (f"{ours[0]['code']} ({peers.fmt_setting(ours[0])}) | {_ms(ours[0]['wall'])}"
             if ours else "not reached | --")
        ratio = f"{ours[0]['wall'] / pr[0]['wall']:.2f}" if pr and ours else "--"
        lines.append(f"| {p['name']} ({p['t_end']:g} s) | {a} | {o} | {ratio} |")
    lines += [""]
    for p in results:
        lines += [f"## {p['name']}", "", f"Span: {p['note']}; {p['nb']} bodies, "
                  f"{p['n_eq']} constraint equations (spatialmbd).", ""]
        lines += ["Reference: spatialmbd projection rk45 rtol 1e-12; it differs from "
                  + "; ".join(f"{k} by " + (v if isinstance(v, str) else f"{v:.1e} m")
                              for k, v in p["reference_checks"].items()) + ".", ""]
        if p["model_checks"]:
            lines += ["Peer models against the reference at t = 0.1 s (COM, tight setting): "
                      + "; ".join(f"{k} " + (v if isinstance(v, str) else f"{v:.1e} m")
                                  for k, v in p["model_checks"].items()) + ".", ""]
        ok, missed = peers.best_rows(p["rows"])
        table, best_peer = peers.reached_rows(ok)
        lines += table
        for r in missed:
            if "error" in r:
                ev = peers.evaluations(r)
                est = ""
                if "wall_star" in r and r["order"] > 0.5:
                    est = (f"; error ~ h^{r['order']:.2f} extrapolates to "
                           f"~{r['wall_star'] * 1e3:.0f} ms")
                lines.append(f"| {r['code']} | not reached: best {peers.fmt_setting(r)}{est} "
                             f"| {_ms(r['wall'])} | {r['error']:.1e} | {ev} | -- |")
            else:
                lines.append(f"| {r['code']} | failed: {r.get('failed', '')} | | | | -- |")
        if p["rhs"]:
            lines += ["", "Per right-hand side (one call from Python at the initial state, "
                      "min over repetitions): "
                      + ", ".join(f"{k} {v * 1e6:.2f} µs" for k, v in p["rhs"].items())]
        lines += [""]
    lines += ["## Notes", ""] + [f"* {n}" for n in NOTES] + [""]
    keys = list(dict.fromkeys(k for p in results for k in p["rhs"]))
    lines += ["## Per right-hand side", "", "µs per call from Python (call overhead "
              "included): spatialmbd `right_hand_side(model, method)`; Pinocchio "
              "`pin.constraintDynamics` (`pin.aba` for the flyball governor) and its whole "
              "Python RHS; MuJoCo `mj_forward`.", "",
              "| problem | " + " | ".join(keys) + " |", "|---|" + "---:|" * len(keys)]
    for p in results:
        lines.append(f"| {p['name']} | " + " | ".join(
            f"{p['rhs'][k] * 1e6:.2f}" if k in p["rhs"] else "" for k in keys) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--problems", nargs="+", default=["four_bar", "n_four_bar", "bricard",
                                                      "flyball", "bicycle"],
                    help="four_bar n_four_bar bricard flyball bicycle (n_four_bar = N 2 and "
                         "8)")
    ap.add_argument("--quick", action="store_true", help="fewer settings (smoke run)")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results"
                                         / "loops_peers"))
    args = ap.parse_args(argv)
    keys = []
    for p in args.problems:
        keys += [k for k in PROBLEMS if k == p or k.split()[0] == p]
    meta = dict(peers.run_meta(), quick=args.quick)
    results = [problem(k, args.quick) for k in keys]
    meta["machine"] += f" -> {os.getloadavg()[0]:.1f} at the end"
    md = tables(results, meta)
    peers.write_results(args.out, md, meta, results)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
