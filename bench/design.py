"""Benchmark of spatialmbd.design (issue 32): identification of 3 parameters of the damped
pendulum (examples/design/pendulum_damped.yaml: mass, pivot damping, initial angular rate)
from 1,000 samples of a noisy recorded angle (pivot.angle, sigma 0.01 rad, 0..10 s).

    python bench/design.py [--repeats 5] [--seeds 30] [--out bench/results]

Measured in one run: the wall time of one identification (warm kernels; the shortest and the
median of --repeats fits of the same data), for the engines "simulate" and "batch" (the
Jacobian's 2 p members integrated in one compiled call) with central-difference Jacobians, and
for the forward-sensitivity Jacobian (method standard, RK4: the angle is not a body state
column, so that run fits the rate gyro pendulum.wx instead). Target: < 1 s. Then a Monte
Carlo over --seeds noise seeds: the fraction of estimates within one reported standard error
(expected 0.683) and the spread of the estimates over the mean reported standard error
(expected 1).
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = ap.parse_args(argv)
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
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "design.md").write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
