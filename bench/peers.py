#!/usr/bin/env python
"""spatialmbd against its pip-installable peers, in one run, at equal accuracy.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=src python bench/peers.py        # N = 1, 4, 16, 64
    python bench/peers.py --sizes 1 4                                    # fewer problems

Peers (each optional: a peer that does not import is reported as missing):

* MuJoCo (``mujoco``): minimal coordinates, the mechanism written as an MJCF string here
  (hinge chain, contact disabled, armature 0, damping 0); its RK4 and its implicit and
  implicitfast integrators at fixed steps, ``mj_step(m, d, nstep)`` (the loop runs in C);
* Pinocchio (``pin``): ``pin.aba`` with scipy's ``solve_ivp`` (RK45, DOP853) and with a
  fixed-step RK4 loop in Python;
* Exudyn (``exudyn==1.13.6``): its generalized-alpha solver on Euler-parameter bodies
  (bench/exudyn_peer.py) and its ``ObjectKinematicTree`` (minimal coordinates) with its
  explicit integrators RK44, RK67 (fixed step), ODE23 and DOPRI5 (automatic step).

Problems: the revolute chain of ``spatialmbd.models.chain(n, "revolute")`` (and the spherical
chain of ``chain(n, "spherical")``: ball joints at the same points, ``--spherical-sizes``) -- links 1 m, 1 kg,
slender rods with centroidal inertia diag(1e-4, 1/12, 1/12) kg m^2, released at rest
horizontally along +x, revolute joints about global y at (k, 0, 0), gravity 9.81 m/s^2 along
-z, 1 s simulated. "pendulum" is N = 1 (one rod on one revolute joint).

Accuracy: the error of a run is the largest distance between a body's final centre of mass
and the reference (m). Reference: spatialmbd, rk45 at rtol 1e-12, checked against Pinocchio's
ABA with DOP853 at rtol 1e-13 (an independent code and formulation; the difference is
printed). Each peer's joint coordinates are mapped to centres of mass with the closed-form
planar chain kinematics (checked against MuJoCo's own ``xipos``). For each code and setting
family the tolerance or step is swept from coarse to fine and the first (cheapest) setting
with error <= 1e-6 m is kept.

Timing: the minimum over repetitions (at least 3, spread over >= 0.3 s) of the integration
alone (model building, compilation and MJCF parsing excluded): spatialmbd's
``Results.wall_time``, Exudyn's ``SolveDynamic``, MuJoCo's ``mj_step`` loop, the Pinocchio
integration loop. Single thread: OPENBLAS_NUM_THREADS=1 is set before NumPy is imported,
Exudyn with one thread. The machine is shared and noisy: ratios within ~1.5x are not
conclusive. Per-RHS cost: one call of spatialmbd's ``right_hand_side(model, method)``
function (and of ``dynamics.recursive.joint_right_hand_side(model)`` for the recursive method),
of ``pin.aba`` and of ``mujoco.mj_forward``, each from Python (call overhead
included), minimum over repetitions.

Writes bench/results/peers.md and bench/results/peers.json and prints the tables.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import exudyn_peer as ex  # noqa: E402

from spatialmbd import models  # noqa: E402
from spatialmbd.simulate import right_hand_side, simulate  # noqa: E402

TARGET = 1e-6          # m, final centre-of-mass error
T_END = 1.0            # s
L = 1.0                # m, link length
MASS = 1.0             # kg
INERTIA = (1e-4, MASS * L**2 / 12, MASS * L**2 / 12)   # kg m^2, centroidal, link axes
G = 9.81               # m/s^2 along -z
MIN_SPREAD = 0.3       # s, repetitions of a timed run span at least this long
#: fixed steps swept, coarse to fine (s); all divide T_END
STEPS = [0.1, 0.05, 0.04, 0.025, 0.02, 0.0125, 0.01, 0.008, 0.005, 0.004, 0.0025, 0.002,
         0.00125, 0.001, 5e-4, 2.5e-4]
#: relative tolerances swept (absolute = 1e-2 x relative), coarse to fine: half decades
TOLS = [10.0**(-k / 2) for k in range(6, 25)]
MAX_RUN = 3.0          # s, a single run slower than this is not repeated; sweeps stop past it


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def best_of(fn, reps=3):
    """(min seconds reported by fn, last output); fn returns (seconds, output)."""
    best, out, count = math.inf, None, 0
    began = time.perf_counter()
    while count < reps or time.perf_counter() - began < MIN_SPREAD:
        count += 1
        sec, out = fn()
        best = min(best, sec)
        if sec > MAX_RUN or count >= 50:
            break
    return best, out


def com_from_angles(q):
    """Centres of mass (n, 3) of the planar chain from relative joint angles q (rad) about +y.

    Link k turns by phi_k = q_0 + ... + q_k; a rotation by phi about +y maps the link axis x
    to (cos phi, 0, -sin phi).
    """
    phi = np.cumsum(np.asarray(q, dtype=float))
    e = np.stack([np.cos(phi), np.zeros_like(phi), -np.sin(phi)], axis=1)
    joints = np.vstack([np.zeros(3), np.cumsum(L * e, axis=0)[:-1]])
    return joints + 0.5 * L * e


def com_error(com, ref):
    d = np.asarray(com, dtype=float).reshape(-1, 3) - np.asarray(ref).reshape(-1, 3)
    return float(np.linalg.norm(d, axis=1).max())


def sweep(label, settings, run, ref):
    """Run coarse -> fine; stop at the first setting reaching TARGET (or past MAX_RUN)."""
    rows = []
    for i, s in enumerate(settings):
        if rows and "wall" in rows[-1] and rows[-1]["wall"] * settings[i - 1] / s > 3 * MAX_RUN:
            log(f"    {label}: {s} skipped (estimated > {3 * MAX_RUN:g} s)")
            break
        try:
            wall, com, extra = run(s)
        except Exception as exc:              # a setting that fails (e.g. Newton) is reported
            rows.append(dict(code=label, setting=s, failed=f"{type(exc).__name__}: {exc}"[:120]))
            log(f"    {label} {s}: failed {exc}")
            continue
        err = com_error(com, ref)
        if not np.isfinite(err):
            err = math.inf
        rows.append(dict(code=label, setting=s, wall=wall, error=err, **extra))
        log(f"    {label:34s} {str(s):>10s}  wall {wall*1e3:9.3f} ms  err {err:.2e}")
        if err <= TARGET or wall > MAX_RUN:
            break
    return rows


# ------------------------------------------------------------------------------- spatialmbd
def ours_runner(model, **fixed):
    def run(s):
        kw = dict(fixed)
        if kw.get("integrator") == "rk4":
            kw["step"] = s
        else:
            kw.update(rtol=s, atol=s * 1e-2)
        simulate(model, 0.01, output_step=0.01, **kw)          # compile / load outside timing

        def once():
            res = simulate(model, T_END, output_step=T_END, **kw)
            if not res.success:
                raise RuntimeError(res.message)
            return res.wall_time, res
        wall, res = best_of(once)
        return wall, res.q[-1, :, :3], dict(nfev=int(res.counters["nfev"]))
    return run


def ours_families(n):
    tols = TOLS
    return [
        ("spatialmbd rk45 recursive", dict(integrator="rk45", method="recursive"), tols),
        ("spatialmbd dop853 recursive", dict(integrator="dop853", method="recursive"), tols),
        ("spatialmbd rk45 standard", dict(integrator="rk45", method="standard"), tols),
        ("spatialmbd scipy-dop853 standard", dict(integrator="scipy-dop853", method="standard"),
         tols),
        ("spatialmbd abm4 standard", dict(integrator="abm4", method="standard"), tols),
        ("spatialmbd rk4 standard", dict(integrator="rk4", method="standard"), STEPS),
    ]


# ---------------------------------------------------------------------------------- MuJoCo
def mjcf(n, joint="revolute"):
    """The chain as MJCF: nested bodies, a hinge about y (revolute) or a ball joint
    (spherical) at each body's origin."""
    ixx, iyy, izz = INERTIA
    body = ""
    kind = 'type="hinge" axis="0 1 0"' if joint == "revolute" else 'type="ball"'
    for k in reversed(range(n)):
        pos = "0 0 0" if k == 0 else f"{L} 0 0"
        body = (f'<body name="link{k}" pos="{pos}"><joint name="j{k}" {kind}'
                f' armature="0" damping="0" limited="false"/>'
                f'<inertial pos="{L/2} 0 0" mass="{MASS}" diaginertia="{ixx} {iyy} {izz}"/>'
                f'{body}</body>')
    return (f'<mujoco model="chain{n}"><option timestep="0.001" gravity="0 0 {-G}" '
            f'integrator="RK4"><flag contact="disable"/></option>'
            f'<worldbody>{body}</worldbody></mujoco>')


def mujoco_runner(n, integrator, joint="revolute"):
    import mujoco
    m = mujoco.MjModel.from_xml_string(mjcf(n, joint))
    m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    d = mujoco.MjData(m)

    def run(h):
        steps = int(round(T_END / h))
        m.opt.timestep = T_END / steps

        def once():
            mujoco.mj_resetData(m, d)
            t0 = time.perf_counter()
            mujoco.mj_step(m, d, nstep=steps)
            return time.perf_counter() - t0, None
        wall, _ = best_of(once)
        mujoco.mj_kinematics(m, d)
        if joint != "revolute":                        # ball joints: MuJoCo's own centres
            return wall, d.xipos[1:].copy(), dict(steps=steps, t=float(d.time))
        com = com_from_angles(d.qpos)
        check = com_error(d.xipos[1:], com)           # our mapping against MuJoCo's own
        if check > 1e-12:
            raise RuntimeError(f"COM mapping disagrees with mujoco xipos by {check:.1e} m")
        return wall, com, dict(steps=steps, t=float(d.time))
    return run


# ------------------------------------------------------------------------------- Pinocchio
def pin_model(n, joint="revolute"):
    import pinocchio as pin
    model = pin.Model()
    parent = 0
    for k in range(n):
        place = pin.SE3(np.eye(3), np.array([0.0 if k == 0 else L, 0.0, 0.0]))
        jm = pin.JointModelRY() if joint == "revolute" else pin.JointModelSpherical()
        jid = model.addJoint(parent, jm, place, f"j{k}")
        model.appendBodyToJoint(jid, pin.Inertia(MASS, np.array([L / 2, 0, 0]),
                                                 np.diag(INERTIA)), pin.SE3.Identity())
        parent = jid
    model.gravity.linear = np.array([0.0, 0.0, -G])
    return model


def pin_problem(n, joint="revolute"):
    """(f, y0, com(y)) of the chain in Pinocchio: y = [q, v], ydot = [qdot, aba]. Revolute:
    q the angles, qdot = v. Spherical: q the unit quaternions (x, y, z, w) of the joints, v their
    angular velocities in the child's axes, qdot = 1/2 q (x) (v, 0) (used divided by |q|)."""
    import pinocchio as pin
    model = pin_model(n, joint)
    data = model.createData()
    tau = np.zeros(model.nv)
    aba = pin.aba
    nq, nv = model.nq, model.nv
    if joint == "revolute":
        def f(t, y):
            return np.concatenate([y[n:], aba(model, data, y[:n], y[n:], tau)])
        y0 = np.zeros(2 * n)
        return f, y0, lambda y: com_from_angles(y[:n])

    def unit(q):
        Q = q.reshape(n, 4)
        return (Q / np.linalg.norm(Q, axis=1, keepdims=True)).ravel()

    def f(t, y):
        q, v = unit(y[:nq]), y[nq:]
        Q, W = q.reshape(n, 4), v.reshape(n, 3)
        x, yy, z, w = Q[:, 0], Q[:, 1], Q[:, 2], Q[:, 3]
        a, b, c = W[:, 0], W[:, 1], W[:, 2]
        qd = 0.5 * np.stack([w * a + yy * c - z * b, w * b + z * a - x * c,
                             w * c + x * b - yy * a, -(x * a + yy * b + z * c)], axis=1)
        return np.concatenate([qd.ravel(), aba(model, data, q, v, tau)])

    y0 = np.concatenate([np.tile([0.0, 0.0, 0.0, 1.0], n), np.zeros(nv)])

    def com(y):
        pin.forwardKinematics(model, data, unit(y[:nq]))
        return np.array([data.oMi[k + 1].act(np.array([L / 2, 0.0, 0.0])) for k in range(n)])
    return f, y0, com


def scipy_runner(f, y0, com, method, t_end=T_END):
    """run(tol[, t_end]) -> (wall, centres of mass at t_end, counters): y' = f(t, y) from y0
    by SciPy's solve_ivp (method, rtol = tol, atol = 1e-2 tol), best of repetitions."""
    from scipy.integrate import solve_ivp

    def run(tol, t_end=t_end):
        def once():
            t0 = time.perf_counter()
            sol = solve_ivp(f, (0.0, t_end), y0, method=method, rtol=tol, atol=tol * 1e-2,
                            t_eval=[t_end])
            return time.perf_counter() - t0, sol
        wall, sol = best_of(once)
        if sol.status != 0:
            raise RuntimeError(sol.message)
        return wall, com(sol.y[:, -1]), dict(nfev=int(sol.nfev))
    return run


def pin_scipy_runner(n, method, joint="revolute"):
    f, y0, com = pin_problem(n, joint)
    return scipy_runner(f, y0, com, method)


def pin_rk4_runner(n, joint="revolute"):
    f, y0, com = pin_problem(n, joint)

    def run(h):
        steps = int(round(T_END / h))
        hh = T_END / steps

        def once():
            t0 = time.perf_counter()
            y, t = y0.copy(), 0.0
            for _ in range(steps):
                k1 = f(t, y)
                k2 = f(t + hh / 2, y + hh / 2 * k1)
                k3 = f(t + hh / 2, y + hh / 2 * k2)
                k4 = f(t + hh, y + hh * k3)
                y = y + hh / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
                t += hh
            return time.perf_counter() - t0, y
        wall, y = best_of(once)
        return wall, com(y), dict(steps=steps, nfev=4 * steps)
    return run


# ---------------------------------------------------------------------------------- Exudyn
def exudyn_ga_runner(n, joint="revolute"):
    def run(h):
        wall, out = best_of(lambda: (lambda r: (r["wall_time"], r))(
            ex.chain(n, joint, h, T_END)))
        return wall, np.array(out["final_com"]), dict(steps=out["steps"])
    return run


def kt_settings(exu, s, adaptive, t_end):
    """Exudyn SimulationSettings for its explicit solvers: tolerance s (rtol, atol = 1e-2 s;
    at most 10 steps' worth of h_max) when adaptive, else the fixed step s; one thread, no
    files, no sensors, nothing printed."""
    st = exu.SimulationSettings()
    ti = st.timeIntegration
    ti.endTime = t_end
    ti.verboseMode = 0
    if adaptive:
        ti.numberOfSteps = 10                  # h_max = t_end / 10
        ti.automaticStepSize = True
        ti.relativeTolerance = s
        ti.absoluteTolerance = s * 1e-2
        ti.minimumStepSize = 1e-12
    else:
        ti.numberOfSteps = int(round(t_end / s))
        ti.automaticStepSize = False
    return ex.quiet(st)


def exudyn_kt_runner(n, solver):
    """Exudyn ObjectKinematicTree (minimal coordinates) with an explicit solver."""
    import exudyn as exu
    import exudyn.utilities  # noqa: F401
    from exudyn.itemInterface import NodeGenericODE2, ObjectKinematicTree

    def build():
        SC = exu.SystemContainer()
        mbs = SC.AddSystem()
        node = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * n,
                                               initialCoordinates=[0.0] * n,
                                               initialCoordinates_t=[0.0] * n,
                                               numberOfODE2Coordinates=n))
        mbs.AddObject(ObjectKinematicTree(
            nodeNumber=node,
            jointTypes=[exu.JointType.RevoluteY] * n,
            linkParents=list(range(-1, n - 1)),
            jointTransformations=exu.Matrix3DList([np.eye(3)] * n),
            jointOffsets=exu.Vector3DList([[0.0 if k == 0 else L, 0.0, 0.0] for k in range(n)]),
            linkInertiasCOM=exu.Matrix3DList([np.diag(INERTIA)] * n),
            linkCOMs=exu.Vector3DList([[L / 2, 0.0, 0.0]] * n),
            linkMasses=[MASS] * n,
            gravity=[0.0, 0.0, -G],
        ))
        mbs.Assemble()
        return mbs, node

    adaptive = solver in ("ODE23", "DOPRI5")

    def run(s):
        def once():
            mbs, node = build()
            st = kt_settings(exu, s, adaptive, T_END)
            solver_type = getattr(exu.DynamicSolverType, solver)
            t0 = time.perf_counter()
            ok = mbs.SolveDynamic(st, solverType=solver_type)
            wall = time.perf_counter() - t0
            if not ok:
                raise RuntimeError("SolveDynamic failed")
            t = float(mbs.systemData.GetTime())
            if abs(t - T_END) > 1e-9:
                raise RuntimeError(f"stopped at t = {t}")
            q = np.array(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates))
            steps = int(mbs.sys["dynamicSolver"].it.currentStepIndex) - 1
            return wall, (q, steps)
        wall, (q, steps) = best_of(once)
        return wall, com_from_angles(q), dict(steps=steps)
    return run


# -------------------------------------------------------------------------------- per RHS
def per_call(fn, reps=7):
    fn()
    t0 = time.perf_counter()
    fn()
    once = max(time.perf_counter() - t0, 1e-7)
    calls = max(10, int(0.02 / once))

    def block():
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        return (time.perf_counter() - t0) / calls, None
    return best_of(block, reps)[0]


def body_rhs_costs(model, at_rest=False):
    """s per call of ``right_hand_side(model, method)`` from Python for the standard and
    projection methods, at the model's initial state (its velocities zeroed with at_rest)."""
    out = {}
    for method in ("standard", "projection"):
        try:
            f, y0 = right_hand_side(model, method)
        except Exception as exc:
            log(f"  right_hand_side({method}) failed: {exc}")
            continue
        y = y0.copy()
        if at_rest:
            y[7 * model.nb:13 * model.nb] = 0.0
        out[f"spatialmbd {method}"] = per_call(lambda: f(0.0, y))
    return out


def rhs_costs(n, model):
    out = body_rhs_costs(model, at_rest=True)
    from spatialmbd.dynamics.recursive import joint_right_hand_side
    fj, x0 = joint_right_hand_side(model)
    out["spatialmbd recursive"] = per_call(lambda: fj(0.0, x0))
    try:
        import pinocchio as pin
        pm = pin_model(n)
        pd = pm.createData()
        q, v, tau = np.zeros(n), np.zeros(n), np.zeros(n)          # the initial state
        out["pinocchio aba"] = per_call(lambda: pin.aba(pm, pd, q, v, tau))
    except ImportError:
        pass
    try:
        import mujoco
        m = mujoco.MjModel.from_xml_string(mjcf(n))
        d = mujoco.MjData(m)
        out["mujoco mj_forward"] = per_call(lambda: mujoco.mj_forward(m, d))
    except ImportError:
        pass
    return out


# ------------------------------------------------------------------------------------ main
def available(mod):
    try:
        __import__(mod)
        return True
    except Exception:
        return False


def problem(n, joint="revolute"):
    name = ("pendulum (N = 1)" if n == 1 and joint == "revolute"
            else f"{joint} chain N = {n}")
    log(f"\n== {name}")
    model = models.chain(n, joint).compile()
    simulate(model, 0.01, output_step=0.01, rtol=1e-12, atol=1e-14)
    res = simulate(model, T_END, output_step=T_END, rtol=1e-12, atol=1e-14)
    ref = res.q[-1, :, :3]
    check = None
    if available("pinocchio"):
        from scipy.integrate import solve_ivp
        f, y0, com = pin_problem(n, joint)
        sol = solve_ivp(f, (0.0, T_END), y0, method="DOP853", rtol=1e-13, atol=1e-15,
                        t_eval=[T_END])
        check = com_error(com(sol.y[:, -1]), ref)
        log(f"  reference: spatialmbd rk45 rtol 1e-12 vs pinocchio aba DOP853 rtol 1e-13: "
            f"{check:.1e} m")
    rows = []
    for label, fixed, settings in ours_families(n):
        rows += sweep(label, settings, ours_runner(model, **fixed), ref)
    if available("mujoco"):
        rows += sweep("mujoco RK4", STEPS,
                      mujoco_runner(n, "RK4", joint), ref)
        for integ in ("implicit", "implicitfast"):
            rows += sweep(f"mujoco {integ}", [1e-3, 1e-4, 1e-5, 5e-6, 2.5e-6],
                          mujoco_runner(n, integ, joint), ref)
    if available("pinocchio"):
        tols = TOLS
        for meth in ("RK45", "DOP853"):
            rows += sweep(f"pinocchio aba + scipy {meth}", tols,
                          pin_scipy_runner(n, meth, joint), ref)
        rows += sweep("pinocchio aba + RK4 (Python loop)", STEPS, pin_rk4_runner(n, joint), ref)
    if available("exudyn"):
        if joint == "revolute":                  # KinematicTree: 1-dof joints only
            rows += sweep("exudyn KinematicTree RK67", [0.2, 0.1, 0.05, 0.04, 0.025, 0.02,
                                                        1e-2, 5e-3, 2.5e-3, 1e-3],
                          exudyn_kt_runner(n, "RK67"), ref)
            rows += sweep("exudyn KinematicTree RK44", STEPS, exudyn_kt_runner(n, "RK44"), ref)
            for s in ("DOPRI5", "ODE23"):
                rows += sweep(f"exudyn KinematicTree {s}", TOLS,
                              exudyn_kt_runner(n, s), ref)
        rows += sweep("exudyn gen.-alpha (Euler parameters)",
                      [2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5], exudyn_ga_runner(n, joint),
                      ref)
    costs = {}
    if joint == "revolute":
        log("  per-RHS cost ...")
        costs = rhs_costs(n, model)
    return dict(name=name, n=n, joint=joint, reference_check=check, rows=rows, rhs=costs)


def best_rows(rows):
    """Per code/setting family: the cheapest run reaching TARGET, else the most accurate."""
    fam = {}
    for r in rows:
        fam.setdefault(r["code"], []).append(r)
    ok, missed = [], []
    for code, rs in fam.items():
        good = [r for r in rs if "error" in r and r["error"] <= TARGET]
        if good:
            ok.append(min(good, key=lambda r: r["wall"]))
        else:
            done = [r for r in rs if "error" in r]
            m = dict(min(done, key=lambda r: r["error"])) if done else dict(rs[-1])
            fixed = [r for r in done if any(k in code for k in FIXED_STEP)
                     and np.isfinite(r["error"])]
            if len(fixed) >= 2:       # extrapolate error ~ h^p, wall ~ 1/h to the target
                a, b = fixed[-2], fixed[-1]
                p = math.log(a["error"] / b["error"]) / math.log(a["setting"] / b["setting"])
                h_star = b["setting"] * (TARGET / b["error"]) ** (1.0 / p)
                m.update(order=p, h_star=h_star, wall_star=b["wall"] * b["setting"] / h_star)
            missed.append(m)
    return sorted(ok, key=lambda r: r["wall"]), missed


FIXED_STEP = ("rk4 standard", "mujoco RK4", "RK4 (Python loop)", "RK44", "RK67", "gen.-alpha",
              "implicit")


def fmt_setting(r):
    s = r["setting"]
    if any(k in r["code"] for k in FIXED_STEP):
        return f"h = {s:g} s"
    return f"rtol = {s:.3g}"


def run_meta() -> dict:
    """date, machine (with the load average at the start) and the versions of the codes."""
    versions = {}
    for mod, key in (("numpy", "numpy"), ("scipy", "scipy"), ("mujoco", "mujoco"),
                     ("pinocchio", "pin"), ("exudyn", "exudyn")):
        try:
            versions[key] = __import__(mod).__version__
        except Exception:
            versions[key] = "missing"
    return dict(date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                machine=f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                        f"load {os.getloadavg()[0]:.1f}",
                versions=", ".join(f"{k} {v}" for k, v in versions.items()))


def write_results(out, md, meta, results):
    """<out>.md (the tables) and <out>.json (meta and every row), each written atomically."""
    from spatialmbd.atomic import atomic_write
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    for suffix, text in ((".md", md + "\n"), (".json", json.dumps(
            dict(meta=meta, results=results), indent=1, default=str))):
        with atomic_write(out.with_suffix(suffix)) as tmp:
            Path(tmp).write_text(text)


def evaluations(r) -> str:
    """'123 f' or '45 steps' (what a row counted), or ''."""
    ev = r.get("nfev", r.get("steps", ""))
    return f"{ev} {'f' if 'nfev' in r else 'steps'}" if ev != "" else ""


def reached_rows(ok):
    """(table lines, best peer's wall) of the settings that reached the accuracy: the best
    peer first, then every row in order, each with its ratio to the best peer."""
    peer_rows = [r for r in ok if not r["code"].startswith("spatialmbd")]
    best_peer = peer_rows[0]["wall"] if peer_rows else math.nan
    ordered = peer_rows[:1] + [r for r in ok if r is not (peer_rows[0] if peer_rows else None)]
    lines = ["| code, setting family | cheapest setting | wall (ms) | error (m) | "
             "evaluations / steps | ratio to best peer |",
             "|---|---|---:|---:|---:|---:|"]
    for r in ordered:
        lines.append(f"| {r['code']} | {fmt_setting(r)} | {r['wall'] * 1e3:.3f} | "
                     f"{r['error']:.1e} | {evaluations(r)} | {r['wall'] / best_peer:.2f} |")
    return lines, best_peer


def tables(results, meta, rhs_only=None):
    lines = ["# spatialmbd against its peers at equal accuracy", "",
             f"Generated by `bench/peers.py` on {meta['date']} ({meta['machine']}); "
             f"versions: {meta['versions']}.", "",
             f"Accuracy target: final centre-of-mass error <= {TARGET:g} m at t = {T_END:g} s "
             "(largest over the bodies). For each code and setting family the cheapest swept "
             "setting reaching it; wall = integration only, minimum over repetitions, single "
             "thread. The machine is shared by several jobs and noisy: ratios within ~1.5x "
             "are not conclusive. Ratio = wall / best peer's wall (best peer first; "
             "spatialmbd's rows are in the same list).", ""]
    lines += ["## Summary", "",
              "| problem | best peer (setting) | its wall (ms) | best spatialmbd (setting) | "
              "its wall (ms) | spatialmbd / best peer |", "|---|---|---:|---|---:|---:|"]
    for p in results:
        ok, _ = best_rows(p["rows"])
        peers = [r for r in ok if not r["code"].startswith("spatialmbd")]
        ours = [r for r in ok if r["code"].startswith("spatialmbd")]
        if peers and ours:
            a, b = peers[0], ours[0]
            lines.append(f"| {p['name']} | {a['code']} ({fmt_setting(a)}) | {a['wall']*1e3:.3f}"
                         f" | {b['code']} ({fmt_setting(b)}) | {b['wall']*1e3:.3f} | "
                         f"{b['wall']/a['wall']:.2f} |")
    lines += [""]
    for p in results:
        lines += [f"## {p['name']}", ""]
        if p["reference_check"] is not None:
            lines += [f"Reference: spatialmbd rk45 rtol 1e-12; Pinocchio ABA + DOP853 rtol "
                      f"1e-13 differs by {p['reference_check']:.1e} m.", ""]
        ok, missed = best_rows(p["rows"])
        table, best_peer = reached_rows(ok)
        lines += table
        for r in missed:
            if "wall_star" in r:
                lines.append(f"| {r['code']} | not reached: {fmt_setting(r)} gives "
                             f"{r['error']:.1e} m in {r['wall']*1e3:.1f} ms; error ~ h^"
                             f"{r['order']:.2f} extrapolates to h = {r['h_star']:.1e} s | "
                             f"~{r['wall_star']*1e3:.0f} (estimate) | | | "
                             f"~{r['wall_star']/best_peer:.0f} |")
            elif "error" in r:
                lines.append(f"| {r['code']} | not reached (finest tried {fmt_setting(r)}) | "
                             f"{r['wall']*1e3:.3f} | {r['error']:.1e} | | -- |")
            else:
                lines.append(f"| {r['code']} | failed: {r.get('failed', '')} | | | | -- |")
        if p["rhs"]:
            lines += ["", "Per right-hand side (one call from Python, min over repetitions): "
                      + ", ".join(f"{k} {v*1e6:.2f} µs" for k, v in p["rhs"].items())]
        lines += [""]
    all_rhs = {p["n"]: p["rhs"] for p in results if p["rhs"]}
    all_rhs.update(rhs_only or {})
    keys = list(dict.fromkeys(k for c in all_rhs.values() for k in c))
    lines += ["## Per right-hand side, revolute chain", "",
              "One evaluation of the accelerations at the initial state, called from Python "
              "(call overhead included), minimum over repetitions, µs. spatialmbd: the function "
              "of `spatialmbd.simulate.right_hand_side(model, method)`; Pinocchio: `pin.aba`; "
              "MuJoCo: `mujoco.mj_forward` (the whole forward pass).", "",
              "| N | " + " | ".join(keys) + " | spatialmbd standard / pin.aba | "
              "spatialmbd recursive / pin.aba |",
              "|---:|" + "---:|" * (len(keys) + 2)]
    for n in sorted(all_rhs):
        c = all_rhs[n]
        ratios = [c[k] / c["pinocchio aba"] if k in c and "pinocchio aba" in c else math.nan
                  for k in ("spatialmbd standard", "spatialmbd recursive")]
        lines.append(f"| {n} | " + " | ".join(f"{c[k]*1e6:.2f}" if k in c else "" for k in keys)
                     + "".join(f" | {x:.2f}" for x in ratios) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 4, 16, 64])
    ap.add_argument("--spherical-sizes", type=int, nargs="*", default=[4, 16],
                    help="spherical chains (MuJoCo ball joints, Pinocchio JointModelSpherical, "
                         "Exudyn's Euler-parameter solver: its KinematicTree has 1-dof joints)")
    ap.add_argument("--rhs-sizes", type=int, nargs="*", default=[64, 256],
                    help="further chain sizes for the per-RHS cost only")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results" / "peers"))
    args = ap.parse_args(argv)
    meta = run_meta()
    results = [problem(n) for n in args.sizes]
    results += [problem(n, "spherical") for n in args.spherical_sizes]
    rhs_only = {}
    for n in (k for k in args.rhs_sizes if k not in args.sizes):
        log(f"\n== per-RHS cost, revolute chain N = {n}")
        rhs_only[n] = rhs_costs(n, models.chain(n, "revolute").compile())
    meta["machine"] += f" -> {os.getloadavg()[0]:.1f} at the end"
    md = tables(results, meta, rhs_only)
    write_results(args.out, md, meta, results)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
