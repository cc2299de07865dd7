"""Benchmark of spatialmbd.design (issue 32): identification of 3 parameters of the damped
pendulum (examples/design/pendulum_damped.yaml: mass, pivot damping, initial angular rate)
from 1,000 samples of a noisy recorded angle (pivot.angle, sigma 0.01 rad, 0..10 s).

    python bench/design.py [--repeats 5] [--seeds 30] [--out bench/results]
    python bench/design.py --gradient-only   # only the gradient section of the results

Measured in one run: the wall time of one identification (warm kernels; the shortest and the
median of --repeats fits of the same data), for the engines "simulate" and "batch" (the
Jacobian's 2 p members integrated in one compiled call) with central-difference Jacobians, and
for the forward-sensitivity Jacobian (method standard, RK4: the angle is not a body state
column, so that run fits the rate gyro pendulum.wx instead). Target: < 1 s. Then a Monte
Carlo over --seeds noise seeds: the fraction of estimates within one reported standard error
(expected 0.683) and the spread of the estimates over the mean reported standard error
(expected 1).

Gradient of one scalar with respect to 100 parameters (--links 13: a chain of 13 hinged
links with a rotational spring-damper at every hinge, method standard, RK4 0.005 s over
0.5 s; 8 parameters per link -- mass, three inertias, stiffness, damping, rest angle, initial
rate -- the first 100 of them; the output final(l12.z), the height of the last link): the
wall time of the adjoint (its model builds for dF/dp and dy0/dp -- none for the masses,
inertias and initial rates, the direct parameters --, its forward run, its backward run;
bench/adjoint.py has the same for 10 and 100 parameters) in units of one forward run (build + compiled RK4 run, as the batch engine
runs a member) and of one simulate() run, against central differences (2 p + 1 members in
one compiled batch call), with the largest difference between the two gradients. Target of
issue 32: the adjoint at most 5 forward runs.
"""
from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "design" / "pendulum_damped.yaml"
TRUTH = {"bodies.pendulum.mass": 7.02, "forces.pivot_damper.damping": 0.8,
         "bodies.pendulum.angular_velocity.0": 0.5}
START = {"bodies.pendulum.mass": 6.0, "forces.pivot_damper.damping": 0.5,
         "bodies.pendulum.angular_velocity.0": 0.0}
ANALYSIS = dict(type="dynamic", t_end=10.0, integrator=dict(name="rk45", rtol=1e-9,
                                                            atol=1e-11))
FORWARD = dict(type="dynamic", t_end=10.0, method=dict(name="standard"),
               integrator=dict(name="rk4", step=0.01))
SIGMA = 0.01
MARK = "## Adjoint gradient, 100 parameters"
T = np.linspace(0.0, 10.0, 1000)


def data_for(column, analysis, seed):
    import pandas as pd
    from spatialmbd.sweep import points, sweep
    ds = sweep(MODEL, points({k: [v] for k, v in TRUTH.items()}), [column],
               dict(analysis, t_eval=list(T)))
    clean = ds[column].values[0]
    noise = SIGMA * np.random.default_rng(seed).standard_normal(T.size)
    return pd.DataFrame({"t": T, column: clean + noise})


def timed(data, analysis, repeats, **kw):
    from spatialmbd.design import identify
    walls, fit = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        fit = identify(MODEL, data, START, noise=SIGMA, analysis=analysis, **kw)
        walls.append(time.perf_counter() - t0)
    return min(walls), float(np.median(walls)), fit


def chain(n):
    """A chain of n links (0.3 m, hinged about x), a rotational spring-damper at each hinge,
    falling from horizontal; and its parameters {path: value} (8 per link)."""
    bodies, joints, forces, params = [], [], [], {}
    for k in range(n):
        mass = 1.0 + 0.05 * k
        bodies.append({"name": f"l{k}", "mass": mass, "inertia": [0.03, 0.002, 0.03],
                       "position": [0.0, 0.3 * k + 0.15, 0.0]})
        joints.append({"name": f"j{k}", "type": "revolute",
                       "body_i": "ground" if k == 0 else f"l{k - 1}", "body_j": f"l{k}",
                       "point": [0.0, 0.3 * k, 0.0], "axis": [1.0, 0.0, 0.0]})
        forces.append({"name": f"s{k}", "type": "rotational_spring_damper", "joint": f"j{k}",
                       "stiffness": 20.0, "damping": 0.1, "rest_angle": 0.0})
        params.update({f"bodies.l{k}.mass": mass, f"bodies.l{k}.inertia.0": 0.03,
                       f"bodies.l{k}.inertia.1": 0.002, f"bodies.l{k}.inertia.2": 0.03,
                       f"forces.s{k}.stiffness": 20.0, f"forces.s{k}.damping": 0.1,
                       f"forces.s{k}.rest_angle": 0.0,
                       f"bodies.l{k}.angular_velocity.0": 0.0})
    model = {"spatialmbd": 1, "name": "chain", "gravity": [0.0, 0.0, -9.81],
             "bodies": bodies, "joints": joints, "forces": forces,
             "analysis": dict(type="dynamic", t_end=0.5, output_step=0.01,
                              method=dict(name="standard"),
                              integrator=dict(name="rk4", step=0.005))}
    return model, params


def gradient_benchmark(links, n_params, repeats):
    """Markdown lines: the 100-parameter gradient by the adjoint against forward runs and
    central differences."""
    from spatialmbd.design.adjoint import Adjoint
    from spatialmbd.io.modelfile import load_model
    from spatialmbd.sweep import ParameterSpace, sweep
    model, params = chain(links)
    names = list(params)[:n_params]
    x = np.array([params[n] for n in names])
    adj = Adjoint(model, names)
    adj.run(x)                                                       # warm
    tip = adj.column(f"l{links - 1}.z")

    def best(fn):
        walls = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            out = fn()
            walls.append(time.perf_counter() - t0)
        return min(walls), out
    Wt = np.zeros((adj.t_out.size, adj.y0.size))
    Wt[-1, tip] = 1.0
    t_forward, _ = best(lambda: adj.run(x, derivatives=False))
    t_run, _ = best(lambda: adj.run(x))
    t_back, g = best(lambda: adj.gradient(Wt))

    def first():
        fresh = Adjoint(model, names)
        fresh.run(x)
        return fresh.gradient(Wt)
    t_first, _ = best(first)
    m, an = load_model(model)
    t_sim, _ = best(lambda: an.run(m))
    h = 1e-6 * np.where(x != 0, np.abs(x), 1.0)
    X = np.repeat(x[None, :], 2 * x.size + 1, axis=0)
    for j in range(x.size):
        X[1 + 2 * j, j] += h[j]
        X[2 + 2 * j, j] -= h[j]
    space = ParameterSpace(names, X, "points")
    out = f"final(l{links - 1}.z)"
    t_fd, ds = best(lambda: sweep(model, space, [out], None, engine="batch"))
    v = ds[out].values
    g_fd = (v[1::2] - v[2::2]) / (2 * h)
    err = float(np.max(np.abs(g - g_fd)) / np.max(np.abs(g_fd)))
    t_adj = t_run + t_back
    n = adj.y0.size
    return [
        "", f"Gradient of final(l{links - 1}.z) with respect to {x.size} parameters: a chain "
        f"of {links} hinged links ({n} states, {adj.active.size} packed model floats moved "
        f"by the parameters), method standard, RK4 {adj.h:g} s, {adj.step_t.size} steps, "
        f"checkpoint every {adj.every} steps, vector-Jacobian products "
        f"{'structured' if adj.structured else 'dense'}; fastest of {repeats}.", "",
        "| what | wall [s] | forward runs | simulate() runs |", "|---|---|---|---|",
        f"| one forward run (build + compiled RK4) | {t_forward:.4f} | 1 | "
        f"{t_forward / t_sim:.2f} |",
        f"| one simulate() run | {t_sim:.4f} | {t_sim / t_forward:.2f} | 1 |",
        f"| adjoint, first gradient ({2 * x.size} builds for dF/dp, dy0/dp) | "
        f"{t_first:.3f} | {t_first / t_forward:.1f} | {t_first / t_sim:.1f} |",
        f"| adjoint, later gradients: {2 * len(adj._groups)} builds, {len(adj._direct)} "
        f"direct parameters, forward run | "
        f"{t_run:.3f} | {t_run / t_forward:.1f} | {t_run / t_sim:.1f} |",
        f"| adjoint, later gradients: backward run | {t_back:.3f} | "
        f"{t_back / t_forward:.1f} | {t_back / t_sim:.1f} |",
        f"| **adjoint, later gradients, total** | **{t_adj:.3f}** | "
        f"**{t_adj / t_forward:.1f}** | **{t_adj / t_sim:.1f}** |",
        f"| central differences ({2 * x.size + 1} members, one batch call) | {t_fd:.3f} | "
        f"{t_fd / t_forward:.1f} | {t_fd / t_sim:.1f} |", "",
        f"Largest difference adjoint - central differences: {err:.1e} of the largest "
        f"derivative. Target (issue 32): the adjoint at most 5 forward runs."]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    ap.add_argument("--links", type=int, default=13)
    ap.add_argument("--params", type=int, default=100)
    ap.add_argument("--gradient-only", action="store_true")
    args = ap.parse_args(argv)
    if args.gradient_only:              # replace the gradient section of the results file
        head = (f"{MARK} ({time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, load "
                f"average {os.getloadavg()[0]:.2f})")
        text = "\n".join([head] + gradient_benchmark(args.links, args.params,
                                                     args.repeats)) + "\n"
        print(text)
        path = Path(args.out) / "design.md"
        old = path.read_text(encoding="utf-8") if path.exists() else ""
        old = old.split(MARK)[0].rstrip("\n")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text((old + "\n\n" if old else "") + text, encoding="utf-8")
        return 0
    from spatialmbd.design import identify
    angle = data_for("pivot.angle", ANALYSIS, 0)
    identify(MODEL, angle, START, noise=SIGMA, analysis=ANALYSIS, engine="batch")   # warm
    lines = [f"# spatialmbd.design benchmark ({time.strftime('%Y-%m-%d %H:%M')}, "
             f"{platform.node()}, load average {os.getloadavg()[0]:.2f})", "",
             "Identification of 3 parameters (mass, damping, initial rate) of the damped "
             "pendulum from 1,000 samples (0..10 s, sigma 0.01), start 15-100 % off.", "",
             "| Jacobian, engine, column | fastest [s] | median [s] | runs | target |",
             "|---|---|---|---|---|"]
    truth = np.array(list(TRUTH.values()))
    for label, data, an, kw in (
            ("central differences, simulate, pivot.angle", angle, ANALYSIS,
             dict(engine="simulate")),
            ("central differences, batch, pivot.angle", angle, ANALYSIS,
             dict(engine="batch")),
            ("forward sensitivities (RK4 0.01 s), pendulum.wx",
             data_for("pendulum.wx", FORWARD, 0), FORWARD, dict(jacobian="forward"))):
        best, median, fit = timed(data, an, args.repeats, **kw)
        lines.append(f"| {label} | {best:.3f} | {median:.3f} | {fit.n_runs} | < 1 s |")
        z = (fit.estimates - truth) / fit.standard_errors
        print(label, best, median, fit.n_runs, "z =", np.round(z, 2))
    lines += ["", f"Monte Carlo over {args.seeds} noise seeds (batch engine, pivot.angle):",
              "", "| parameter | truth | mean estimate | within 1 se | spread / mean se |",
              "|---|---|---|---|---|"]
    from spatialmbd.sweep import points, sweep
    clean = sweep(MODEL, points({k: [v] for k, v in TRUTH.items()}), ["pivot.angle"],
                  dict(ANALYSIS, t_eval=list(T)))["pivot.angle"].values[0]
    import pandas as pd
    est, se = [], []
    for seed in range(args.seeds):
        d = pd.DataFrame({"t": T, "pivot.angle": clean + SIGMA *
                          np.random.default_rng(1000 + seed).standard_normal(T.size)})
        fit = identify(MODEL, d, START, noise=SIGMA, analysis=ANALYSIS, engine="batch")
        est.append(fit.estimates)
        se.append(fit.standard_errors)
    est, se = np.array(est), np.array(se)
    inside = np.mean(np.abs(est - truth) / se < 1.0, axis=0)
    ratio = est.std(axis=0, ddof=1) / se.mean(axis=0)
    for j, name in enumerate(TRUTH):
        lines.append(f"| {name} | {truth[j]:g} | {est[:, j].mean():.5g} | {inside[j]:.2f} | "
                     f"{ratio[j]:.2f} |")
    lines += ["", MARK] + gradient_benchmark(args.links, args.params, args.repeats)
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "design.md").write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
