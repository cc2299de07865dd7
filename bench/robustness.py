#!/usr/bin/env python
"""Robustness benchmark: random valid mechanisms x methods x integrators, 0.1 s each.

    python bench/robustness.py                       # 12 mechanisms, seed 0
    python bench/robustness.py --n 24 --seed 3 --timeout 30 --json out.json
    python bench/robustness.py --n 18 --methods penalty --integrators scipy-bdf \
        --timeout 2 --use-budget                     # the wall-time budget stops slow runs

Mechanisms (drawn with the seed): open chains of 2-8 links with spherical or revolute joints
and link masses log-uniform over 1e-3 .. 1e3 kg (mass ratios up to 1e6), some with stiff
spring-dampers to ground (stiffness log-uniform over 1e4 .. 1e8 N/m); closed loops (the
spatial four-bar RSSR of the text, the free slider-crank, the N-four-bar with N = 1..3,
whose planar revolute joints are redundant, some with a stiff spring); the Bricard mechanism
(redundant); an N-four-bar started exactly at its dead-centre (flat, singular) position,
moving through it; the two random closed loops of tests/dynamics/data (rand2000, rand2007:
redundant rows, a singular start, a flex initial velocity). Every mechanism runs for 0.1 s
with every method (standard, baumgarte, penalty, augmented_lagrangian, projection) and every
integrator given (default: rk45, dop853, bdf4, scipy-radau) at the default tolerances, each
run stopped after --timeout s of wall time (default 10 s: a run stopped counts as a failure).
Prints a table of failures and timeouts and the wall-time distribution per integrator;
--markdown writes the per mechanism x integrator table (steps, worst wall time, pass/fail).
Not part of the test suite.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from spatialmbd import ModelBuilder, models  # noqa: E402
from spatialmbd.simulate import simulate  # noqa: E402

METHODS = ["standard", "baumgarte", "penalty", "augmented_lagrangian", "projection"]
INTEGRATORS = ["rk45", "dop853", "bdf4", "scipy-radau"]
DATA = ROOT / "tests" / "dynamics" / "data"


def random_chain(rng, springs=False):
    n = int(rng.integers(2, 9))
    joint = str(rng.choice(["spherical", "revolute"]))
    b = ModelBuilder(f"chain{n}_{joint}_massratio", gravity=(0.0, 0.0, -9.81))
    prev = "ground"
    x = 0.0
    for k in range(n):
        m = float(10 ** rng.uniform(-3, 3))
        L = float(rng.uniform(0.2, 1.5))
        b.add_body(f"link{k}", m, (1e-4 * m, m * L * L / 12, m * L * L / 12),
                   r=(x + L / 2, 0.0, 0.0))
        if joint == "spherical":
            b.add_joint("spherical", f"j{k}", prev, f"link{k}", point=(x, 0.0, 0.0))
        else:
            b.add_joint("revolute", f"j{k}", prev, f"link{k}", point=(x, 0.0, 0.0),
                        axis=(0.0, 1.0, 0.0))
        prev = f"link{k}"
        x += L
    if springs:
        b.name = b.name.replace("massratio", "stiff")
        for k in rng.choice(n, size=min(n, 2), replace=False):
            stiffness = float(10 ** rng.uniform(4, 8))
            b.add_force("spring_damper", f"spring{k}", body_i="ground", body_j=f"link{k}",
                        point_i=(0.0, 0.0, -1.0), stiffness=stiffness,
                        damping=1e-3 * stiffness, natural_length=0.9)
    return b


def stiff_four_bar(n, stiffness):
    """The N-four-bar with a stiff spring-damper from its first coupler to the ground."""
    b = models.n_four_bar(n)
    b.name = f"n_four_bar{n}_spring{stiffness:.0e}"
    b.add_force("spring_damper", "spring", body_i="ground", body_j="coupler0",
                point_i=(1.5, 2.0, 0.0), stiffness=stiffness, damping=1e-3 * stiffness,
                natural_length=0.9)
    return b


def regression_model(name):
    from spatialmbd.io.modelfile import load_model
    model, _ = load_model(DATA / f"{name}.json")
    return model


def dead_centre_four_bar(n: int = 1):
    """models.n_four_bar_flat: the N-four-bar started in its flat (singular) position."""
    return models.n_four_bar_flat(n)


def mechanisms(n, rng):
    """(name, make) pairs; make() returns a compiled Model."""
    fixed = [
        ("four_bar_RSSR", lambda: models.four_bar().compile()),
        ("slider_crank_free", lambda: models.slider_crank(driven=False).compile()),
        ("bricard", lambda: models.bricard().compile()),
        ("dead_centre_1", lambda: dead_centre_four_bar(1).compile()),
        ("rand2000", lambda: regression_model("rand2000")),
        ("rand2007", lambda: regression_model("rand2007")),
        ("n_four_bar_1_k1e+08", lambda: stiff_four_bar(1, 1e8).compile()),
    ]
    out = list(fixed)
    while len(out) < n:
        kind = rng.integers(0, 5)
        if kind in (0, 1):
            b = random_chain(rng, springs=bool(kind))
            out.append((b.name, lambda b=b: b.compile()))
        elif kind == 2:
            k, stiffness = int(rng.integers(1, 4)), float(10 ** rng.integers(4, 9))
            out.append((f"n_four_bar_{k}_k{stiffness:.0e}",
                        lambda k=k, s=stiffness: stiff_four_bar(k, s).compile()))
        elif kind == 3:
            k = int(rng.integers(1, 4))
            out.append((f"n_four_bar_{k}", lambda k=k: models.n_four_bar(k).compile()))
        else:
            k = int(rng.integers(1, 3))
            out.append((f"dead_centre_{k}", lambda k=k: dead_centre_four_bar(k).compile()))
    seen: dict = {}
    unique = []
    for name, make in out[:n]:                     # a name drawn twice gets a suffix
        seen[name] = seen.get(name, 0) + 1
        unique.append((name if seen[name] == 1 else f"{name}_{seen[name]}", make))
    return unique


class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=13)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timeout", type=float, default=10.0)
    ap.add_argument("--t-end", type=float, default=0.1)
    ap.add_argument("--integrators", default=",".join(INTEGRATORS))
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--json", default=None)
    ap.add_argument("--markdown", default=None,
                    help="write the mechanism x integrator table (steps, wall, pass/fail)")
    ap.add_argument("--use-budget", action="store_true",
                    help="pass max_wall_time=--timeout to simulate (status 'budget', partial "
                         "results kept) and keep SIGALRM only as a backstop at 2x + 5 s")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    integrators = args.integrators.split(",")
    methods = args.methods.split(",")
    warnings.simplefilter("ignore")
    signal.signal(signal.SIGALRM, _alarm)
    # warm-up: compile every method's kernels once
    warm = models.four_bar().compile()
    for meth in methods:
        simulate(warm, 0.001, method=meth, integrator="rk45")
    rows = []
    for name, make in mechanisms(args.n, rng):
        model = make()
        for meth in methods:
            for integ in integrators:
                alarm = 2 * args.timeout + 5 if args.use_budget else args.timeout
                extra = dict(max_wall_time=args.timeout) if args.use_budget else {}
                signal.setitimer(signal.ITIMER_REAL, alarm)
                start = time.perf_counter()
                try:
                    res = simulate(model, args.t_end, method=meth, integrator=integ, **extra)
                    status, message = res.status, res.message
                    counters = res.counters
                except Timeout:
                    status, message, counters = "timeout", f"> {alarm} s", {}
                except Exception as exc:                  # noqa: BLE001 (recorded)
                    status, message, counters = "error", f"{type(exc).__name__}: {exc}", {}
                finally:
                    signal.setitimer(signal.ITIMER_REAL, 0.0)
                wall = time.perf_counter() - start
                rows.append(dict(mechanism=name, method=meth, integrator=integ, status=status,
                                 message=message[:300], wall=wall,
                                 steps=counters.get("steps"), rejected=counters.get("rejected"),
                                 nfev=counters.get("nfev")))
                flag = "" if status == "success" else f"  <-- {status}: {message[:120]}"
                print(f"{name:28s} {meth:22s} {integ:12s} {wall:7.3f} s "
                      f"{counters.get('steps')} steps{flag}", flush=True)
    print()
    print(f"{'integrator':12s} {'runs':>5s} {'failed':>6s} {'timeout':>7s} {'median s':>9s} "
          f"{'p90 s':>7s} {'max s':>7s} {'>1 s':>5s}")
    for integ in integrators:
        rs = [r for r in rows if r["integrator"] == integ]
        w = np.array([r["wall"] for r in rs])
        print(f"{integ:12s} {len(rs):5d} "
              f"{sum(r['status'] in ('failed', 'error') for r in rs):6d} "
              f"{sum(r['status'] in ('timeout', 'budget') for r in rs):7d} {np.median(w):9.3f} "
              f"{np.percentile(w, 90):7.3f} {w.max():7.3f} {int((w > 1).sum()):5d}")
    print()
    print(f"{'method':22s} {'runs':>5s} {'failed':>6s} {'timeout':>7s}")
    for meth in methods:
        rs = [r for r in rows if r["method"] == meth]
        print(f"{meth:22s} {len(rs):5d} "
              f"{sum(r['status'] in ('failed', 'error') for r in rs):6d} "
              f"{sum(r['status'] in ('timeout', 'budget') for r in rs):7d}")
    print("(timeout: stopped by SIGALRM, or with --use-budget by the wall-time budget, status "
          "'budget' with its partial results)")
    if args.json:
        Path(args.json).write_text(json.dumps(dict(args=vars(args), rows=rows), indent=1))
    if args.markdown:
        Path(args.markdown).write_text(markdown_table(rows, integrators, methods, args))


def markdown_table(rows, integrators, methods, args):
    """One line per mechanism, one column per integrator: the steps of every method (in the
    order of `methods`), the longest wall time over them and pass (every method succeeded
    within the time limit) or the failing methods."""
    lines = [f"{len(methods)} methods ({', '.join(methods)}) per cell; steps in that order; "
             f"wall = the slowest of them; t_end = {args.t_end} s, limit {args.timeout} s "
             f"per run", "",
             "| mechanism | " + " | ".join(integrators) + " |",
             "|---|" + "---|" * len(integrators)]
    names = list(dict.fromkeys(r["mechanism"] for r in rows))
    for name in names:
        cells = []
        for integ in integrators:
            rs = [r for r in rows if r["mechanism"] == name and r["integrator"] == integ]
            steps = "/".join("-" if r["steps"] is None else str(r["steps"]) for r in rs)
            wall = max(r["wall"] for r in rs)
            bad = [r["method"] for r in rs if r["status"] != "success"]
            verdict = "pass" if not bad else "FAIL " + ",".join(bad)
            cells.append(f"{steps}; {wall:.2f} s; {verdict}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "| integrator | runs | failed | stopped | median s | max s |",
              "|---|---|---|---|---|---|"]
    for integ in integrators:
        rs = [r for r in rows if r["integrator"] == integ]
        w = np.array([r["wall"] for r in rs])
        lines.append(f"| {integ} | {len(rs)} | "
                     f"{sum(r['status'] in ('failed', 'error') for r in rs)} | "
                     f"{sum(r['status'] in ('timeout', 'budget') for r in rs)} | "
                     f"{np.median(w):.3f} | {w.max():.3f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
