"""Contact benchmark (issue 29): N mixed convex bodies (boxes, spheres, capsules, cylinders,
convex hulls) falling into a box, spatialmbd and MuJoCo in one run: cost per step against N and
the ratio at the largest N both codes run.

    PYTHONPATH=src OPENBLAS_NUM_THREADS=1 python bench/contact_mixed.py             # ~15 min
    PYTHONPATH=src python bench/contact_mixed.py --sizes 25 50 --smbd-sizes 25 50 \
        --pairwise 10 --t-end 0.2 --quick --out /tmp/mixed        # a smoke run

Scene: N bodies of m = 0.5 kg, one shape each in turn (box 0.1 x 0.08 x 0.06 m; sphere R 0.04
m; capsule R 0.025 m, half length 0.035 m; cylinder R 0.035 m, half length 0.03 m; the hull
of 14 points, point-symmetric, inside an ellipsoid of 0.05 x 0.04 x 0.035 m), the same
explicit inertia in both codes, on a lattice of nx x ny x 5 bodies 0.15 m apart, turned at
random (seeded), dropped into an open box of four walls and a floor that fits the lattice's
footprint (nx x ny = 5 x 5, 5 x 10, 10 x 10, 10 x 20 for N = 125, 250, 500, 1000: the same
pile height, so a cost per step linear in N is the goal). Contact: linear spring-damper per
contact point K = 1e5 N/m, c = 100 N s/m, Coulomb friction mu = 0.5; MuJoCo's solref given as
direct stiffness and damping (-K A, -c A), A = 1/m_i + 1/m_j (docs/import.md; the walls, of
higher priority, -K/m, -c/m), solimp at its default.

Accuracy, the same for both codes (there is no closed form for a random pile): after T, no
body sunk into or passed through the floor or a wall -- every centre at least its inner radius
(the smallest distance from its centre to its surface) less DEPTH = 5 mm from each -- and all
finite. The largest speed at the end is reported, not required small: spheres, capsules and
cylinders roll without rolling resistance in both codes (MuJoCo condim 3; spatialmbd has no
rolling friction), so a pile on a flat floor is not at rest after T.

spatialmbd: one ``shape_set`` element holds every body's shape and the walls (its compiled
kernel finds the pairs by the grid broad phase at every evaluation), rk4 at the largest step of
``--smbd-steps`` that passes at the first size, then that step at every size, each run to the
end and judged. ``--pairwise N`` also probes the scene at N with a ``contact`` element for
every pair and per body and wall (what a user without the set writes: N^2 elements). Profile:
one evaluation of the right-hand side at the start, with the set and of the bodies alone.

MuJoCo: every timestep x solver (Newton, CG) x integrator (Euler, implicitfast) at the first
size, then its two fastest passing settings at every size.

Results: bench/results/contact_mixed.md.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
M, G, K, C, MU = 0.5, 9.81, 1e5, 100.0, 0.5
SPACING, LAYERS, LIFT = 0.15, 5, 0.1
T_END, DEPTH = 2.0, 5e-3
KINDS = ("box", "sphere", "capsule", "cylinder", "hull")
BOX = (0.05, 0.04, 0.03)
SPHERE_R = 0.04
CAPSULE = (0.025, 0.035)
CYLINDER = (0.035, 0.03)


def hull_points():
    rng = np.random.default_rng(7)
    d = rng.normal(size=(7, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    p = d * np.array([0.05, 0.04, 0.035])
    return np.vstack([p, -p])


def inertia(kind):
    """Diagonal inertia (kg m^2) in the shape's axes (the capsule as a cylinder of its length,
    the hull as its bounding box: the same values in both codes)."""
    if kind == "box":
        a, b, c = BOX
        return (M / 3 * (b * b + c * c), M / 3 * (a * a + c * c), M / 3 * (a * a + b * b))
    if kind == "sphere":
        return (0.4 * M * SPHERE_R ** 2,) * 3
    if kind in ("capsule", "cylinder"):
        r, h = CAPSULE if kind == "capsule" else CYLINDER
        if kind == "capsule":
            h = h + r
        ix = M * (3 * r * r + 4 * h * h) / 12
        return (ix, ix, 0.5 * M * r * r)
    a, b, c = np.abs(hull_points()).max(axis=0)
    return (M / 3 * (b * b + c * c), M / 3 * (a * a + c * c), M / 3 * (a * a + b * b))


def layout(n):
    """(nx, ny): the lattice's footprint for n bodies in LAYERS layers."""
    per = math.ceil(n / LAYERS)
    nx = max(1, int(round(math.sqrt(per / 2)))) if per >= 50 else int(math.ceil(math.sqrt(per)))
    ny = math.ceil(per / nx)
    return nx, ny


def scene(n, seed=11):
    """(Lx, Ly, kinds, positions (n, 3), rotation matrices (n, 3, 3), quaternions (n, 4))."""
    nx, ny = layout(n)
    Lx, Ly = nx * SPACING, ny * SPACING
    rng = np.random.default_rng(seed)
    pos, kinds = [], []
    for k in range(n):
        layer, rest = divmod(k, nx * ny)
        i, j = divmod(rest, ny)
        pos.append((-Lx / 2 + (i + 0.5) * SPACING, -Ly / 2 + (j + 0.5) * SPACING,
                    LIFT + layer * SPACING))
        kinds.append(KINDS[k % len(KINDS)])
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1)[:, None]
    w, x, y, z = quat.T
    A = np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)
    return Lx, Ly, kinds, np.array(pos), A, quat


def _walls(Lx, Ly):
    return [([0, 0, 1], [0, 0, 0]), ([1, 0, 0], [-Lx / 2, 0, 0]), ([-1, 0, 0], [Lx / 2, 0, 0]),
            ([0, 1, 0], [0, -Ly / 2, 0]), ([0, -1, 0], [0, Ly / 2, 0])]


def inner_radius(kind):
    """The smallest distance from the centre to the shape's surface (m)."""
    if kind == "box":
        return min(BOX)
    if kind == "sphere":
        return SPHERE_R
    if kind == "capsule":
        return CAPSULE[0]
    if kind == "cylinder":
        return min(CYLINDER)
    from scipy.spatial import ConvexHull
    return float(-ConvexHull(hull_points()).equations[:, 3].max())


def check(Lx, Ly, pos, vel, kinds):
    """(inside, largest speed): every centre at least its inner radius less DEPTH from the
    floor and the walls (no body sunk or passed through), all finite."""
    d = np.array([inner_radius(k) for k in kinds]) - DEPTH
    inside = bool(np.all(np.isfinite(pos)) and np.all(Lx / 2 - np.abs(pos[:, 0]) >= d)
                  and np.all(Ly / 2 - np.abs(pos[:, 1]) >= d) and np.all(pos[:, 2] >= d))
    speed = float(np.linalg.norm(vel, axis=1).max()) if np.all(np.isfinite(vel)) else math.inf
    return inside, speed


# ---------------------------------------------------------------------------- spatialmbd
def smbd_shape(kind):
    if kind == "box":
        return {"type": "box", "half_extents": list(BOX)}
    if kind == "sphere":
        return {"type": "sphere", "radius": SPHERE_R}
    if kind == "capsule":
        return {"type": "capsule", "radius": CAPSULE[0], "half_length": CAPSULE[1]}
    if kind == "cylinder":
        return {"type": "cylinder", "radius": CYLINDER[0], "half_length": CYLINDER[1]}
    return {"type": "convex", "vertices": hull_points().tolist()}


def smbd_model(n, contacts=True, pairwise=False):
    """A body per shape; one ``shape_set`` element (the broad phase) holding every shape with
    the walls, or (pairwise) a ``contact`` element for every pair and per body and wall."""
    from spatialmbd import ModelBuilder
    Lx, Ly, kinds, pos, A, _ = scene(n)
    b = ModelBuilder("mixed", gravity=(0, 0, -G))
    law = dict(law="linear", stiffness=K, damping=C, friction="coulomb", mu=MU,
               creep_velocity=1e-2)
    for k in range(n):
        b.add_body(f"b{k}", M, inertia(kinds[k]), r=tuple(pos[k]), A=A[k])
    if contacts and not pairwise:
        b.add_force("shape_set", "pile", bodies=[f"b{k}" for k in range(n)],
                    shapes=[smbd_shape(kd) for kd in kinds],
                    walls=[{"normal": nn, "point": pp} for nn, pp in _walls(Lx, Ly)], **law)
    elif contacts:
        for k in range(n):
            for w, (normal, point) in enumerate(_walls(Lx, Ly)):
                b.add_force("contact", f"w{w}_{k}", body_i="ground", body_j=f"b{k}",
                            shape_i={"type": "plane", "normal": normal, "point": point},
                            shape_j=smbd_shape(kinds[k]), **law)
            for j in range(k + 1, n):
                b.add_force("contact", f"c{k}_{j}", body_i=f"b{k}", body_j=f"b{j}",
                            shape_i=smbd_shape(kinds[k]), shape_j=smbd_shape(kinds[j]), **law)
    return b.compile()


def smbd_run(model, n, h, t_end):
    from spatialmbd.simulate import simulate
    Lx, Ly, kinds = scene(n)[:3]
    start = time.perf_counter()
    res = simulate(model, t_end, method="standard", integrator="rk4", step=h, output_step=t_end)
    wall = time.perf_counter() - start
    inside, speed = check(Lx, Ly, res.q[-1, :, :3], res.v[-1, :, :3], kinds)
    return dict(code="spatialmbd", n=n, setting=f"rk4 h={h:g}", t_end=t_end,
                wall_per_s=wall / t_end, per_step_ms=1e3 * wall / round(t_end / h),
                inside=inside and res.status == "success", speed=speed,
                mean_z=float(res.q[-1, :, 2].mean()))


def smbd_profile(n, model):
    """ms per evaluation of the right-hand side at the start, with the contacts and of the
    bodies alone."""
    out = {}
    for label, mdl in (("with contacts", model), ("bodies only", smbd_model(n, False))):
        f, y0 = _rhs(mdl)
        f(0.0, y0)
        reps = max(3, int(500 / n))
        start = time.perf_counter()
        for _ in range(reps):
            f(0.0, y0)
        out[label] = 1e3 * (time.perf_counter() - start) / reps
    return out


def _rhs(model):
    from spatialmbd.simulate import right_hand_side
    return right_hand_side(model, "standard")


# ---------------------------------------------------------------------------- MuJoCo
def mj_xml(n, h, solver, integrator, cone="pyramidal"):
    Lx, Ly, kinds, pos, A, quat = scene(n)
    fr = f'friction="{MU} 0.005 0.0001"'
    body_ref = f'solref="{-2 * K / M:.17g} {-2 * C / M:.17g}"'
    wall_ref = f'solref="{-K / M:.17g} {-C / M:.17g}" priority="1"'
    hp = " ".join(f"{v:.17g}" for v in hull_points().ravel())
    geoms = {"box": 'type="box" size="{} {} {}"'.format(*BOX),
             "sphere": f'type="sphere" size="{SPHERE_R}"',
             "capsule": f'type="capsule" size="{CAPSULE[0]} {CAPSULE[1]}"',
             "cylinder": f'type="cylinder" size="{CYLINDER[0]} {CYLINDER[1]}"',
             "hull": 'type="mesh" mesh="hull"'}
    bodies = []
    for k in range(n):
        I = inertia(kinds[k])
        x, y, z = pos[k]
        q = quat[k]
        bodies.append(f'<body pos="{x:.17g} {y:.17g} {z:.17g}" quat="{q[0]:.17g} {q[1]:.17g} '
                      f'{q[2]:.17g} {q[3]:.17g}"><freejoint/><inertial pos="0 0 0" mass="{M}" '
                      f'diaginertia="{I[0]:.17g} {I[1]:.17g} {I[2]:.17g}"/><geom '
                      f'{geoms[kinds[k]]} {body_ref} {fr}/></body>')
    walls = "".join(
        f'<geom type="plane" size="0 0 1" pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}" '
        f'zaxis="{nn[0]} {nn[1]} {nn[2]}" {wall_ref} {fr}/>' for nn, p in _walls(Lx, Ly))
    return (f'<mujoco><option gravity="0 0 {-G}" timestep="{h:.17g}" integrator="{integrator}" '
            f'solver="{solver}" cone="{cone}"/><size memory="1G"/>'
            f'<asset><mesh name="hull" vertex="{hp}"/></asset><worldbody>{walls}'
            f'{"".join(bodies)}</worldbody></mujoco>')


def mj_run(n, h, solver, integrator, t_end, cone="pyramidal"):
    import mujoco
    Lx, Ly, kinds = scene(n)[:3]
    model = mujoco.MjModel.from_xml_string(mj_xml(n, h, solver, integrator, cone))
    data = mujoco.MjData(model)
    steps = int(round(t_end / h))
    start = time.perf_counter()
    mujoco.mj_step(model, data, steps)
    wall = time.perf_counter() - start
    # MuJoCo resets the state to the start when it meets a bad acceleration: not a result
    unstable = data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    q, v = data.qpos.reshape(-1, 7), data.qvel.reshape(-1, 6)
    inside, speed = check(Lx, Ly, q[:, :3], v[:, :3], kinds)
    inside = inside and not unstable
    return dict(code="mujoco", n=n, setting=f"{solver} {integrator} {cone} h={h:g}"
                + (" [unstable: reset by MuJoCo]" if unstable else ""),
                t_end=t_end, wall_per_s=wall / t_end, per_step_ms=1e3 * wall / steps,
                inside=inside, speed=speed, mean_z=float(q[:, 2].mean()), ncon=int(data.ncon),
                pos=q[:, :3].copy())


# ---------------------------------------------------------------------------- main
def _load():
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def passes(r):
    return r["inside"]


def slope(ns, ts):
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0]) if len(ns) > 1 else math.nan


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[125, 250, 500, 1000])
    ap.add_argument("--smbd-sizes", type=int, nargs="+", default=[125, 250, 500, 1000])
    ap.add_argument("--smbd-steps", type=float, nargs="+", default=[2e-3, 1e-3, 5e-4],
                    help="rk4 steps tried at the first size (the largest passing one is kept)")
    ap.add_argument("--pairwise", type=int, default=50,
                    help="also probe this size with a contact element per pair (0: no)")
    ap.add_argument("--smbd-probe", type=float, default=0.01, help="s simulated, pairwise")
    ap.add_argument("--t-end", type=float, default=T_END)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = ap.parse_args(argv)
    load0 = _load()
    rows, lines = [], []
    # MuJoCo: a sweep at the smallest size, then its passing settings at every size
    hs = (4e-3, 2e-3, 1e-3) if args.quick else (4e-3, 2e-3, 1e-3, 5e-4)
    sweep = [(h, s, i) for h in hs for s in ("Newton", "CG") for i in ("Euler", "implicitfast")]
    n0 = args.sizes[0]
    for h, s, i in sweep:
        rows.append(mj_run(n0, h, s, i, args.t_end))
        print({k: v for k, v in rows[-1].items() if k != "pos"}, flush=True)
    good = [r for r in rows if passes(r)]
    keep = sorted(good, key=lambda r: r["wall_per_s"])[:2]
    for n in args.sizes[1:]:
        for r in keep:
            s, i, cone, hh = r["setting"].split(" ")[:4]
            rows.append(mj_run(n, float(hh.split("=")[1]), s, i, args.t_end))
            print({k: v for k, v in rows[-1].items() if k != "pos"}, flush=True)
    # spatialmbd: one shape_set (the broad phase); its largest passing rk4 step at the first
    # size, then that step at every size, each run to the end and judged
    prof = {}
    steps = sorted(args.smbd_steps, reverse=True)
    h_smbd = None
    for n in args.smbd_sizes:
        start = time.perf_counter()
        model = smbd_model(n)
        build = time.perf_counter() - start
        for h in (steps if h_smbd is None else [h_smbd]):
            smbd_run(model, n, h, 4 * h)                        # compile / load
            r = smbd_run(model, n, h, args.t_end)
            r["build_s"] = build
            rows.append(r)
            print({k: v for k, v in r.items() if k != "pos"}, flush=True)
            if h_smbd is None and passes(r):
                h_smbd = h
                break
        if h_smbd is None:
            h_smbd = steps[-1]
        prof[n] = smbd_profile(n, model)
        del model
    pairwise = None
    if args.pairwise:
        n = args.pairwise
        model = smbd_model(n, pairwise=True)
        smbd_run(model, n, h_smbd, 4 * h_smbd)
        pairwise = smbd_run(model, n, h_smbd, args.smbd_probe)
        del model
    load1 = _load()
    import mujoco
    lines += ["# Mixed convex bodies falling into a box (bench/contact_mixed.py)", "",
              f"Command: `PYTHONPATH=src OPENBLAS_NUM_THREADS=1 python bench/contact_mixed.py "
              f"{' '.join(sys.argv[1:] if argv is None else argv)}`; "
              f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load average {load0:.2f} "
              f"before, {load1:.2f} after (2 cores); MuJoCo {mujoco.__version__}. Settle time "
              f"{args.t_end:g} s. spatialmbd: one `shape_set` element (the broad phase), rk4 "
              f"at the largest step of {', '.join(f'{h:g}' for h in steps)} s that passes at "
              f"N = {args.smbd_sizes[0]}, then at every N.", "",
              f"Pass (the same for both codes): every body centre at least its inner radius "
              f"less {DEPTH * 1e3:g} mm from the floor and the walls, all finite.", "",
              "| code | N | setting | simulated s | wall s per simulated s | ms per step | inside "
              "| largest speed (m/s) | mean height (m) | pass |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['code']} | {r['n']} | {r['setting']} | {r['t_end']:g} | "
                     f"{r['wall_per_s']:.3f} | {r['per_step_ms']:.3f} | {r['inside']} | "
                     f"{r['speed']:.2e} | {r['mean_z']:.3f} | "
                     f"{'yes' if passes(r) else 'no'} |")
    lines += [""]
    best = {}
    for code in ("mujoco", "spatialmbd"):
        sel = [r for r in rows if r["code"] == code]
        if code == "mujoco" and keep:
            sel = [r for r in sel if r["setting"] == keep[0]["setting"]]
        if code == "spatialmbd":
            sel = [r for r in sel if r["setting"] == f"rk4 h={h_smbd:g}"]
        best[code] = {r["n"]: r for r in sel}
        ns = [r["n"] for r in sel]
        ts = [r["per_step_ms"] for r in sel]
        if ns:
            lines.append(f"{code} ({sel[0]['setting']}): ms per step " + ", ".join(
                f"{t:.3f} at N = {n}" for n, t in zip(ns, ts)) +
                f"; log-log slope {slope(ns, ts):.2f} (1 = linear).")
    for n in sorted(set(best["mujoco"]) & set(best["spatialmbd"])):
        sm, mj = best["spatialmbd"][n], best["mujoco"][n]
        ok = passes(sm) and passes(mj)
        lines.append(f"Wall time per simulated s at N = {n}: spatialmbd {sm['wall_per_s']:.3g} "
                     f"s, MuJoCo {mj['wall_per_s']:.3g} s: ratio "
                     f"{sm['wall_per_s'] / mj['wall_per_s']:.1f}x"
                     f"{'' if ok else ' (not both passing)'} (goal <= 1.0x at N = 1000: "
                     f"{'met' if ok and sm['wall_per_s'] <= mj['wall_per_s'] else 'not met'}).")
    if pairwise is not None:
        n = pairwise["n"]
        ref = best["spatialmbd"].get(n)
        lines.append(f"The same scene with a `contact` element per pair and wall (N = {n}, "
                     f"{n * (n - 1) // 2 + 5 * n} elements, probed {args.smbd_probe:g} s): "
                     f"{pairwise['per_step_ms']:.2f} ms per step" +
                     (f" against {ref['per_step_ms']:.2f} with the `shape_set`" if ref else "")
                     + ".")
    lines += ["", "spatialmbd profile: one right-hand-side evaluation at the start (no contact "
              "yet: the broad phase alone), with the `shape_set` and of the bodies alone:",
              "", "| N | ms per evaluation, with the shape_set | bodies only | model build (s) |",
              "|---|---|---|---|"]
    for n, p in prof.items():
        build = next(r["build_s"] for r in rows if r["code"] == "spatialmbd" and r["n"] == n)
        lines.append(f"| {n} | {p['with contacts']:.3f} | {p['bodies only']:.4f} | "
                     f"{build:.1f} |")
    text = "\n".join(lines) + "\n"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    name = "contact_mixed_quick.md" if args.quick else "contact_mixed.md"
    from spatialmbd.atomic import atomic_write
    with atomic_write(out / name) as tmp:
        Path(tmp).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
