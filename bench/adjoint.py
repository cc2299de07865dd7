"""Cost of the adjoint gradient (spatialmbd.design.adjoint) in forward runs, for 10 and 100
parameters, in one run (issue 32: at most 5 forward runs for 100 parameters).

    python bench/adjoint.py [--repeats 5] [--links 13] [--out bench/results]

The model is the chain of bench/design.py: 13 links hinged about x, a rotational
spring-damper at every hinge, method standard, RK4 0.005 s over 0.5 s (100 steps); 8
parameters per link (mass, three inertias, stiffness, damping, rest angle, initial rate), the
first 10 or 100 of them; the cost final(l12.z), the height of the last link. One forward run
is what a gradient-free evaluation at new parameter values costs: the model build and the
compiled RK4 run (Adjoint.run(x, derivatives=False)). Timed, fastest of --repeats, warm
kernels: the forward run; the gradient at a later call (the derivatives of the packed floats
and the initial state -- model builds only for the parameters that are not direct entries --,
the forward run with checkpoints, the backward run); the first gradient (one build pair per
parameter, the probe of direct entries). The gradient is checked against Richardson-extrapolated
central differences of the same discrete run (h = 1e-3 |x| and h/2) for the 10-parameter
case.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))


def best(fn, repeats):
    walls, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        walls.append(time.perf_counter() - t0)
    return min(walls), out


def case(model, params, n, repeats, check):
    from spatialmbd.design.adjoint import Adjoint
    names = list(params)[:n]
    x = np.array([params[k] for k in names])
    adj = Adjoint(model, names)
    adj.run(x)
    links = adj.model.nb
    Wt = np.zeros((adj.t_out.size, adj.y0.size))
    Wt[-1, adj.column(f"l{links - 1}.z")] = 1.0
    adj.gradient(Wt)                                            # warm, groups formed

    def first():
        fresh = Adjoint(model, names)
        fresh.run(x)
        return fresh.gradient(Wt)
    t_fwd, _ = best(lambda: adj.run(x, derivatives=False), repeats)
    builds0 = adj.n_builds
    t_run, _ = best(lambda: adj.run(x), repeats)
    builds = (adj.n_builds - builds0) // repeats
    t_back, g = best(lambda: adj.gradient(Wt), repeats)
    t_first, g1 = best(first, max(1, repeats // 2))
    err = None
    if check:                   # Richardson: D(h), D(h/2) -> (4 D(h/2) - D(h)) / 3
        h = 1e-3 * np.where(x != 0, np.abs(x), 1.0)
        fd = np.zeros(n)
        cost = lambda xx: adj.run(xx, derivatives=False)[-1] @ Wt[-1]   # noqa: E731
        for j in range(n):
            d = []
            for hh in (h[j], h[j] / 2):
                e = np.zeros(n)
                e[j] = hh
                d.append((cost(x + e) - cost(x - e)) / (2 * hh))
            fd[j] = (4 * d[1] - d[0]) / 3
        err = float(np.max(np.abs(g - fd)) / np.max(np.abs(fd)))
    S = adj.S
    return dict(n=n, t_fwd=t_fwd, t_run=t_run, t_back=t_back, t_first=t_first,
                builds=builds, direct=len(adj._direct), groups=len(adj._groups),
                colours=S[0].size - 1, fclasses=S[6].size - 1, analytic=S[12].shape[1],
                active=adj.active.size, states=adj.y0.size, steps=adj.step_t.size,
                every=adj.every, err=err, first_vs_later=float(
                    np.max(np.abs(g1 - g)) / np.max(np.abs(g))))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--links", type=int, default=13)
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = ap.parse_args(argv)
    from design import chain
    model, params = chain(args.links)
    load0 = os.getloadavg()[0]
    rows = [case(model, params, n, args.repeats, n <= 10) for n in (10, 100)]
    load1 = os.getloadavg()[0]
    r0 = rows[-1]
    lines = [
        f"# Adjoint gradient cost ({time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, "
        f"load average {load0:.2f} -> {load1:.2f}; `python bench/adjoint.py`)", "",
        f"Chain of {args.links} hinged links with a rotational spring-damper at every hinge "
        f"({r0['states']} states), method standard, RK4, {r0['steps']} steps, checkpoint every "
        f"{r0['every']} steps; cost final(l{args.links - 1}.z); fastest of {args.repeats}, "
        "warm kernels. One forward run = model build + compiled RK4 run.", "",
        "| parameters | forward run [s] | gradient, later call [s] | of which derivatives + "
        "forward [s] | of which backward [s] | **gradient / forward run** | first gradient / "
        "forward run | builds per gradient | direct parameters | packed floats moved |",
        "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        total = r["t_run"] + r["t_back"]
        lines.append(
            f"| {r['n']} | {r['t_fwd']:.4f} | {total:.3f} | {r['t_run']:.3f} | "
            f"{r['t_back']:.3f} | **{total / r['t_fwd']:.1f}** | "
            f"{r['t_first'] / r['t_fwd']:.1f} | {r['builds']} | {r['direct']} | "
            f"{r['active']} |")
    lines += ["", "Per RK4 stage of the backward run (100 parameters): "
              f"{r0['colours']} body colour classes x 12 state directions (Euler parameters "
              f"in their 3 tangent directions) and {r0['fclasses']} classes of packed floats "
              f"by central differences of the local residuals, {r0['analytic']} body floats "
              "(mass, J', J'^-1, weight) written out.", "",
              f"Gradient against Richardson-extrapolated central differences of the same run "
              f"(10 parameters): "
              f"{rows[0]['err']:.1e} of the largest derivative; first against later call "
              f"(100 parameters): {r0['first_vs_later']:.1e}. Target of issue 32: "
              "at most 5 forward runs for 100 parameters."]
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "adjoint.md").write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
