"""Contact benchmark (issue 10): spheres settling in a box and a bouncing ball, spatialmbd,
MuJoCo and Exudyn side by side in one run, each at its cheapest setting that meets the accuracy.

    python bench/contact_peers.py            # N = 1000 (and 125, 8000 for the scaling); minutes
    python bench/contact_peers.py --quick    # N = 125 and 1000, fewer settings

Scene "box": N = n^3 spheres (R = 0.05 m, m = 1 kg) on a lattice (0.01 m apart) in a box of four
walls and a floor, dropped from 5 mm and left to settle for 2 s. Contact: linear spring-damper,
K = 1e5 N/m, c = 300 N s/m per contact, friction mu = 0.3. Without lateral jitter every column
stays a column, so the settled heights are known in closed form:

* spatialmbd (``sphere_set``, the same K and c): a column of linear springs under its weight,
  sphere k (from 0 at the bottom) at z_k = R - d_floor + sum_{j<k} (2R - d_j), d_floor =
  n m g / K, d_j = (n - 1 - j) m g / K;
* MuJoCo (soft contacts, solref = (-K, -c) in acceleration units, solimp 0.9 0.95): against the
  rigid stack z_k = (2k + 1) R, counting its constraint softness as error.

Accuracy: max |z - reference| over all spheres <= TOL (1e-3 m, 2 % of R). For each code every
setting is tried (spatialmbd: rk4 steps; MuJoCo: timestep x solver CG / Newton x Euler /
implicitfast) and the cheapest one within TOL is the code's figure: wall time per simulated
second. The ratio spatialmbd / MuJoCo is printed; the per-step cost at N = 125, 1000 (8000)
shows the scaling.

Scene "ball": one sphere dropped from 1 m on the floor (same K and m, c = 40 N s/m); apex
heights of the first three bounces, spatialmbd (``contact`` element, linear law) and MuJoCo,
against the 1-D reference (:func:`ball_reference`: the spring-damper without tension, its
contact phases integrated to 1e-12).

Exudyn (GeneralContact, same scene): spheres as rigid bodies (rotation-vector nodes, Lie-group
explicit integration) and, its cheapest granular setting, as mass points (no rotation); floor
and walls as static triangles of thin bricks (the floor off-centre, so that the diagonal edge of
its top face runs between the columns: a sphere on that edge gets two contacts). Exudyn's law
(measured here, matching its source): sphere-sphere stiffness and damping in series, sphere-
triangle stiffness in series and damping summed, and the spring-damper force may pull. So
every shape gets stiffness 2K, the spheres damping 2c and the triangles none: sphere-sphere
contacts have K and c as in the other codes, floor and wall contacts K and 2c (the settled
heights do not depend on c; they match the spring-column reference to 2e-5 m). Rigid-body
spheres on the triangle mesh leave their columns (the top spheres roll into the pockets
between columns), so their error against the columns does not pass; the mass points stay in
columns. The settings tried: explicit Euler, midpoint and RK44 at several steps, on one and two
threads. The ball in Exudyn (sphere damping c, floor none) is measured against the reference
of its own tensile law (``ball_reference(tension=True)``).

Results: bench/results/contact_peers.md (machine load recorded).
"""
from __future__ import annotations

import argparse
import itertools
import math
import os
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
R, M, G, K, C, MU = 0.05, 1.0, 9.81, 1e5, 300.0, 0.3
GAP, LIFT, T_END = 0.01, 0.005, 2.0
TOL = 1e-3
TOL_BALL = 0.02       # relative apex error of the bouncing ball


def lattice(n):
    L = n * (2 * R + GAP)
    pts = [(-L / 2 + R + GAP / 2 + i * (2 * R + GAP), -L / 2 + R + GAP / 2 + j * (2 * R + GAP),
            R + LIFT + k * (2 * R + GAP)) for i in range(n) for j in range(n) for k in range(n)]
    return L, np.array(pts)


def exact_column(n):
    """Settled heights of a column of n spheres on linear springs (bottom first)."""
    z, out = R - n * M * G / K, []
    for k in range(n):
        out.append(z)
        z += 2 * R - (n - 1 - k) * M * G / K
    return np.array(out)


# ---------------------------------------------------------------------------- spatialmbd
def smbd_box(n):
    from spatialmbd import ModelBuilder
    L, pts = lattice(n)
    b = ModelBuilder("box", gravity=(0, 0, -G))
    names = [b.add_body(f"s{k}", M, (0.4 * M * R * R,) * 3, r=tuple(p))
             for k, p in enumerate(pts)]
    walls = [{"normal": [0, 0, 1], "point": [0, 0, 0]},
             {"normal": [1, 0, 0], "point": [-L / 2, 0, 0]},
             {"normal": [-1, 0, 0], "point": [L / 2, 0, 0]},
             {"normal": [0, 1, 0], "point": [0, -L / 2, 0]},
             {"normal": [0, -1, 0], "point": [0, L / 2, 0]}]
    b.add_force("sphere_set", "grains", bodies=names, radius=R, walls=walls, law="linear",
                stiffness=K, damping=C, mu=MU, creep_velocity=1e-2)
    return b.compile()


def smbd_run(model, n, h, t_end=T_END):
    from spatialmbd.simulate import simulate
    start = time.perf_counter()
    res = simulate(model, t_end, method="standard", integrator="rk4", step=h,
                   output_step=t_end)
    wall = time.perf_counter() - start
    z = res.q[-1, :, 2].reshape(n * n, n)
    err = float(np.abs(z - exact_column(n)).max()) if res.status == "success" else math.inf
    return dict(code="spatialmbd", setting=f"rk4 h={h:g}", h=h, wall_per_s=wall / t_end,
                per_step_ms=1e3 * wall / (t_end / h), error=err, status=res.status)


# ---------------------------------------------------------------------------- MuJoCo
# ---------------------------------------------------------------------------- Exudyn
def _exu_scene(pts, L, rigid, damping):
    """An Exudyn system: spheres at pts (rigid bodies or mass points) in GeneralContact with a
    floor (and, if L, four walls) of static triangles. (exudyn, (container, mbs), nodes), or
    None; the container must outlive the system."""
    try:
        import exudyn as exu
        import exudyn.graphics as graphics
        from exudyn.itemInterface import (Force, MarkerNodePosition, MarkerNodeRigid, MassPoint,
                                          NodePoint, NodePointGround)
        from exudyn.rigidBodyUtilities import InertiaSphere
    except ImportError:
        return None
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    gc = mbs.AddGeneralContact()
    gc.SetFrictionPairings(MU * np.eye(1))
    gc.frictionProportionalZone = 1e-2            # regularised Coulomb, as spatialmbd's creep
    cells = max(2, round(len(pts) ** (1 / 3)))
    gc.SetSearchTreeCellSize(numberOfCells=[cells] * 3)
    t, S = 0.1, max(L, 4 * R)
    walls = graphics.Brick([0.37 * S, 0.11 * S, -t / 2], [3 * S, 3 * S, t])
    a, H = L / 2 + t / 2, 4 * L
    sides = ((([-a, 0, H / 2], [t, L, H]), ([a, 0, H / 2], [t, L, H]),
              ([0, -a, H / 2], [L, t, H]), ([0, a, H / 2], [L, t, H])) if L else ())
    for c, size in sides:
        walls = graphics.MergeTriangleLists(walls, graphics.Brick(c, size))
    ground = mbs.AddMarker(MarkerNodeRigid(nodeNumber=mbs.AddNode(
        NodePointGround(referenceCoordinates=[0, 0, 0]))))
    points, trigs = graphics.ToPointsAndTrigs(walls)
    gc.AddTrianglesRigidBodyBased(rigidBodyMarkerIndex=ground, contactStiffness=2 * K,
                                  contactDamping=0.0, frictionMaterialIndex=0,
                                  pointList=points, triangleList=trigs)
    nodes = []
    for p in pts:
        if rigid:
            node = mbs.CreateRigidBody(inertia=InertiaSphere(M, R), referencePosition=list(p),
                                       gravity=[0, 0, -G], returnDict=True,
                                       nodeType=exu.NodeType.RotationRotationVector)["nodeNumber"]
            marker = mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))
        else:
            node = mbs.AddNode(NodePoint(referenceCoordinates=list(p)))
            mbs.AddObject(MassPoint(physicsMass=M, nodeNumber=node))
            marker = mbs.AddMarker(MarkerNodePosition(nodeNumber=node))
            mbs.AddLoad(Force(markerNumber=marker, loadVector=[0, 0, -M * G]))
        gc.AddSphereWithMarker(marker, radius=R, contactStiffness=2 * K,
                               contactDamping=damping, frictionMaterialIndex=0)
        nodes.append(node)
    return exu, (sc, mbs), nodes


def _exu_solve(exu, mbs, h, t_end, solver, threads):
    """Assemble and integrate with an explicit solver; wall time (s)."""
    import warnings
    mbs.Assemble()
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps, ti.endTime, ti.verboseMode = int(round(t_end / h)), t_end, 0
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = h
    ti.explicitIntegration.computeEndOfStepAccelerations = False
    ti.explicitIntegration.useLieGroupIntegration = True
    ti.reuseConstantMassMatrix = True
    s.linearSolverType = exu.LinearSolverType.EigenSparse
    s.parallel.numberOfThreads = threads
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ti.explicitIntegration.computeMassMatrixInversePerBody = True
    start = time.perf_counter()
    exu.SolveDynamic(mbs, s, solverType=getattr(exu.DynamicSolverType, solver))
    return time.perf_counter() - start


def _exu_label(rigid, solver, h, threads):
    kind = "rigid bodies" if rigid else "mass points"
    return f"{kind}, {solver} h={h:g}, {threads} thread{'s' if threads > 1 else ''}"


def exu_run(n, h, solver, rigid, threads=1, t_end=T_END):
    """The box scene in Exudyn's GeneralContact; a row as smbd_run's (None without Exudyn)."""
    L, pts = lattice(n)
    scene = _exu_scene(pts, L, rigid, 2 * C)
    if scene is None:
        return None
    exu, (sc, mbs), nodes = scene
    wall = _exu_solve(exu, mbs, h, t_end, solver, threads)
    z = np.array([mbs.GetNodeOutput(k, exu.OutputVariableType.Position)[2] for k in nodes])
    z = z.reshape(n * n, n)
    err = float(np.abs(z - exact_column(n)).max()) if np.all(np.isfinite(z)) else math.inf
    return dict(code="exudyn", setting=_exu_label(rigid, solver, h, threads), h=h,
                wall_per_s=wall / t_end, per_step_ms=1e3 * wall / (t_end / h), error=err,
                status="ok")


def exu_ball(h, solver, rigid=True, t_end=2.5):
    """The bouncing ball in Exudyn (apexes from the position stored every step)."""
    scene = _exu_scene([(0.0, 0.0, 1.0)], 0.0, rigid, C_BALL)
    if scene is None:
        return None
    exu, (sc, mbs), nodes = scene
    from exudyn.itemInterface import SensorNode
    sensor = mbs.AddSensor(SensorNode(nodeNumber=nodes[0], storeInternal=True,
                                      outputVariableType=exu.OutputVariableType.Position))
    wall = _exu_solve(exu, mbs, h, t_end, solver, 1)
    data = np.asarray(mbs.GetSensorStoredData(sensor))
    return dict(code="exudyn", setting=_exu_label(rigid, solver, h, 1), wall_per_s=wall / t_end,
                error=_apex_error(apexes(data[:, 0], data[:, 3]), ball_reference(tension=True)))


def mj_xml(pts, L, h, solver, integrator):
    ref = f'solref="{-K / M:g} {-C / M:g}" solimp="0.9 0.95 0.001 0.5 2"'
    fr = f'friction="{MU} 0 0"'
    b = L / 2
    walls = "".join(f'<geom type="plane" size="0 0 1" pos="{p}" zaxis="{a}" {ref} {fr}/>'
                    for p, a in ((f"{b} 0 0", "-1 0 0"), (f"{-b} 0 0", "1 0 0"),
                                 (f"0 {b} 0", "0 -1 0"), (f"0 {-b} 0", "0 1 0")))
    bodies = "".join(f'<body pos="{x} {y} {z}"><freejoint/><geom type="sphere" size="{R}" '
                     f'mass="{M}" {ref} {fr}/></body>' for x, y, z in pts)
    return (f'<mujoco><option gravity="0 0 {-G}" timestep="{h}" integrator="{integrator}" '
            f'solver="{solver}" cone="pyramidal"/><size memory="400M"/><worldbody>'
            f'<geom type="plane" size="0 0 1" {ref} {fr}/>{walls}{bodies}</worldbody></mujoco>')


def mj_run(n, h, solver, integrator, t_end=T_END):
    import mujoco
    L, pts = lattice(n)
    model = mujoco.MjModel.from_xml_string(mj_xml(pts, L, h, solver, integrator))
    data = mujoco.MjData(model)
    steps = int(round(t_end / h))
    start = time.perf_counter()
    mujoco.mj_step(model, data, steps)
    wall = time.perf_counter() - start
    z = data.qpos.reshape(-1, 7)[:, 2].reshape(n * n, n)
    rigid = R + 2 * R * np.arange(n)
    err = float(np.abs(z - rigid).max())
    return dict(code="mujoco", setting=f"{solver} {integrator} h={h:g}", h=h,
                wall_per_s=wall / t_end, per_step_ms=1e3 * wall / steps, error=err,
                status="ok" if np.all(np.isfinite(z)) else "nan")


# ---------------------------------------------------------------------------- the ball
C_BALL = 40.0        # N s/m: restitution 0.82, so that three bounces are clear


def ball_reference(tension=False):
    """Apex heights (centre, m) of the first three bounces of the 1-D problem spatialmbd and
    MuJoCo model: free flight, then m z'' = K d + c d' - m g with d = R - z while that force is
    positive (no tension: the ball leaves when it reaches zero, a little before d = 0). The
    contact phases are integrated by SciPy to 1e-12; the classical e = exp(-zeta pi /
    sqrt(1 - zeta^2)) assumes a tensile spring and is off by a few per cent here.
    tension=True: the law of Exudyn's GeneralContact, whose spring-damper force may pull (the
    ball leaves at d = 0)."""
    from scipy.integrate import solve_ivp
    z, out = 1.0, []
    v = -math.sqrt(2 * G * (z - R))                    # speed at first touch
    for _ in range(3):
        def f(t, y):
            d, dd = R - y[0], -y[1]
            return [y[1], (K * d + C_BALL * dd) / M - G]

        def leave(t, y):
            return R - y[0] if tension else K * (R - y[0]) - C_BALL * y[1]
        leave.terminal, leave.direction = True, -1
        sol = solve_ivp(f, (0, 1.0), [R, v], events=leave, rtol=1e-12, atol=1e-14)
        zl, vl = sol.y_events[0][0]
        out.append(float(zl + vl * vl / (2 * G)))
        v = -math.sqrt(2 * G * (out[-1] - R))          # back at the touch height
    return out


def apexes(t, z):
    out = []
    for i in range(1, len(z) - 1):
        if z[i] > R + 1e-3 and z[i] >= z[i - 1] and z[i] > z[i + 1] and t[i] > 0.05:
            out.append(float(z[i]))
    return out[:3]


def ball_runs(h_smbd, h_mj, h_exu=(1e-3, 5e-4, 2e-4)):
    from spatialmbd import ModelBuilder
    from spatialmbd.simulate import simulate
    import mujoco
    ref = ball_reference()
    rows = []
    b = ModelBuilder("ball", gravity=(0, 0, -G))
    b.add_body("ball", M, (0.4 * M * R * R,) * 3, r=(0, 0, 1.0))
    b.add_force("contact", "floor", body_i="ground", body_j="ball",
                shape_i={"type": "plane", "normal": [0, 0, 1]},
                shape_j={"type": "sphere", "radius": R}, law="linear", stiffness=K,
                damping=C_BALL)
    model = b.compile()
    simulate(model, 0.01, method="standard", integrator="rk45")          # compile / load
    settings = [("rk4", dict(step=h), f"rk4 h={h:g}") for h in h_smbd] + \
        [("rk45", dict(rtol=r, atol=r * 1e-2), f"rk45 rtol={r:g}") for r in (1e-5, 1e-7, 1e-9)]
    from types import SimpleNamespace
    apex = SimpleNamespace(function=lambda t, s: s.rdot[0, 2], direction=-1.0, name="apex",
                           terminal=False)
    for integrator, options, label in settings:
        start = time.perf_counter()
        res = simulate(model, 2.5, method="standard", integrator=integrator, output_step=2.5,
                       events=[apex], **options)
        wall = time.perf_counter() - start
        # the apexes located by the event (v_z falling through 0; the first is the release)
        a = [float(q[0, 2]) for q, _ in res.event_states if q[0, 2] > R + 1e-3]
        a = [x for x, e in zip(a, res.events) if e["t"] > 0.05][:3]
        rows.append(dict(code="spatialmbd", setting=label, wall_per_s=wall / 2.5,
                         error=_apex_error(a, ref)))
    for h in h_mj:
        xml = (f'<mujoco><option gravity="0 0 {-G}" timestep="{h}" integrator="Euler"/>'
               f'<worldbody><geom type="plane" size="0 0 1" solref="{-K / M:g} {-C_BALL / M:g}" '
               f'solimp="0.9 0.95 0.001 0.5 2"/><body pos="0 0 1"><freejoint/><geom '
               f'type="sphere" size="{R}" mass="{M}" solref="{-K / M:g} {-C_BALL / M:g}" '
               f'solimp="0.9 0.95 0.001 0.5 2"/></body></worldbody></mujoco>')
        mm = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(mm)
        steps = int(round(2.5 / h))
        zs, ts = np.empty(steps), np.arange(1, steps + 1) * h
        start = time.perf_counter()
        for i in range(steps):
            mujoco.mj_step(mm, d)
            zs[i] = d.qpos[2]
        wall = time.perf_counter() - start
        rows.append(dict(code="mujoco", setting=f"Euler h={h:g}", wall_per_s=wall / 2.5,
                         error=_apex_error(apexes(ts, zs), ref)))
    for solver in ("ExplicitEuler", "RK44"):
        for h in h_exu:
            row = exu_ball(h, solver)
            if row:
                rows.append(row)
    return ref, rows


def _apex_error(a, ref):
    if len(a) < 3:
        return math.inf
    return max(abs(x - y) / (y - R) for x, y in zip(a, ref))


# ---------------------------------------------------------------------------- main
def _load():
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def best(rows, tol=TOL):
    ok = [r for r in rows if r["error"] <= tol]
    return min(ok, key=lambda r: r["wall_per_s"]) if ok else None


def _verdict(rows, tol, fmt):
    """The cheapest setting of each code within tol and the ratio spatialmbd / best peer."""
    picks = {code: best([r for r in rows if r["code"] == code], tol)
             for code in dict.fromkeys(r["code"] for r in rows)}
    found = {c: r for c, r in picks.items() if r}
    text = "Cheapest within tolerance: " + ", ".join(
        f"{c} {r['setting']} {fmt % r['wall_per_s']} s" for c, r in found.items())
    missing = [c for c, r in picks.items() if not r]
    if missing:
        text += f" ({', '.join(missing)}: no setting within tolerance)"
    peers = [r for c, r in found.items() if c != "spatialmbd"]
    if "spatialmbd" in found and peers:
        bp = min(peers, key=lambda r: r["wall_per_s"])
        text += (f". Ratio spatialmbd / best peer ({bp['code']}) = "
                 f"{found['spatialmbd']['wall_per_s'] / bp['wall_per_s']:.2f}x.")
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = ap.parse_args(argv)
    load0 = _load()
    lines = [f"# Contact benchmark (bench/contact_peers.py)", "",
             f"Load average before: {load0:.2f} (2 cores).", ""]
    sizes = (5, 10) if args.quick else (5, 10, 20)
    smbd_h = (5e-3, 4e-3, 2e-3) if args.quick else (6e-3, 5e-3, 4e-3, 3e-3, 2e-3)
    mj_settings = list(itertools.product((4e-3, 2e-3, 1e-3), ("CG", "Newton"),
                                         ("Euler",) if args.quick else ("Euler",
                                                                       "implicitfast")))
    # Newton with implicitfast at 1,000 spheres: 129 and 320 s per simulated second at 2 and
    # 1 ms, outside the tolerance (run of 2026-11-24): only its 4 ms row is kept there
    slow = {(2e-3, "Newton", "implicitfast"), (1e-3, "Newton", "implicitfast")}
    exu_settings = [(False, "ExplicitEuler", 1e-3, 1), (False, "RK44", 2e-3, 1),
                    (False, "RK44", 1e-3, 1), (False, "RK44", 1e-3, 2),
                    (False, "RK44", 5e-4, 2), (True, "RK44", 1e-3, 1)]
    if args.quick:
        exu_settings = exu_settings[3:5]
    for n in sizes:
        model = smbd_box(n)
        smbd_run(model, n, 5e-3, t_end=0.01)                          # compile / load
        rows = [smbd_run(model, n, h) for h in (smbd_h if n <= 10 else (4e-3,))]
        if n <= 10:
            rows += [mj_run(n, h, s, i) for h, s, i in mj_settings
                     if n < 10 or (h, s, i) not in slow]
            rows += [r for r in (exu_run(n, h, solver, rigid, threads)
                                 for rigid, solver, h, threads in exu_settings) if r]
        else:                                   # the scaling only (the peers' best settings)
            rows += [mj_run(n, 2e-3, "CG", "Euler")]
            rows += [r for r in (exu_run(n, 1e-3, "RK44", False, 2),) if r]
        lines += [f"## {n ** 3} spheres settling in a box (2 s)", "",
                  "| code | setting | wall s per simulated s | ms per step | max height error "
                  "(m) | within 1e-3 m |", "|---|---|---|---|---|---|"]
        for r in rows:
            lines.append(f"| {r['code']} | {r['setting']} | {r['wall_per_s']:.3f} | "
                         f"{r['per_step_ms']:.3f} | {r['error']:.2e} | "
                         f"{'yes' if r['error'] <= TOL else 'no'} |")
        lines += ["", _verdict(rows, TOL, "%.3f"), ""]
        print("\n".join(lines[-len(rows) - 6:]), flush=True)
    ref, ball = ball_runs((1e-3, 5e-4, 2e-4), (2e-3, 1e-3, 5e-4, 2.5e-4))
    lines += ["## Bouncing ball (K = 1e5 N/m, c = 40 N s/m, 1 kg, from 1 m)", "",
              "Reference apex heights (m): " + ", ".join(f"{a:.6f}" for a in ref), "",
              "| code | setting | wall s per simulated s | max relative apex error |",
              "|---|---|---|---|"]
    for r in ball:
        lines.append(f"| {r['code']} | {r['setting']} | {r['wall_per_s']:.4f} | "
                     f"{r['error']:.2e} |")
    lines += ["", _verdict(ball, TOL_BALL, "%.4f") + " MuJoCo's soft contact is not this "
              "spring-damper law, so its error does not fall with the step below about 1 %; "
              "spatialmbd's does (rk45: 2.4e-7 at rtol 1e-9; its apexes are located by an event "
              "on v_z). Exudyn's error is against its own (tensile) law."]
    lines += ["", f"Load average after: {_load():.2f}."]
    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / ".contact_peers.md.tmp"
    tmp.write_text(text)
    os.replace(tmp, out / "contact_peers.md")
    print("\n".join(lines[-len(ball) - 6:]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
