#!/usr/bin/env python
"""Stiff benchmark: the flyball governor (examples/flyball_governor.yaml, IFToMM A05) with its
own analysis settings (method, rtol, atol, t_end, output_step), integrated by bdf4, rk45 and
scipy-radau (and, with --all, scipy-bdf).

    python bench/stiff.py                 # the file's t_end (10 s)
    python bench/stiff.py --t-end 2       # shorter
    python bench/stiff.py --json out.json

Prints one row per integrator: wall time of the integration (Results.wall_time, s), accepted
and rejected steps, function evaluations (nfev, including those of finite-difference
Jacobians), Jacobian evaluations (njev), LU factorisations (nlu), the final slider height and
the difference of that height from the tightest-tolerance run (scipy-radau at rtol/100) as a
check that every integrator solved the same problem. A warm-up run on 0.05 s compiles the
kernels first. Not part of the test suite (no timing assertions in tests/).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from spatialmbd.io.modelfile import load_model  # noqa: E402
from spatialmbd.simulate import simulate  # noqa: E402


def run(model, analysis, integrator, t_end, rtol=None, atol=None):
    start = time.perf_counter()
    res = simulate(model, t_end, method=analysis.method,
                   method_options=dict(analysis.method_options), integrator=integrator,
                   rtol=rtol or analysis.rtol, atol=atol or analysis.atol,
                   output_step=analysis.output_step, correct_initial=analysis.correct_initial)
    total = time.perf_counter() - start
    k = model.body_index("slider")
    return dict(integrator=integrator, status=res.status, message=res.message[:160],
                wall=res.wall_time, total=total, z_end=float(res.q[-1, k, 2]),
                t_reached=float(res.t[-1]), **{k_: v for k_, v in res.counters.items()
                                               if k_ != "wall_time"})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--t-end", type=float, default=None)
    ap.add_argument("--all", action="store_true", help="also scipy-bdf")
    ap.add_argument("--json", default=None)
    ap.add_argument("--only", default=None, help="comma-separated integrators")
    args = ap.parse_args(argv)
    model, analysis = load_model(ROOT / "examples" / "flyball_governor.yaml")
    t_end = args.t_end or analysis.t_end
    names = ["bdf4", "rk45", "scipy-radau"] + (["scipy-bdf"] if args.all else [])
    if args.only:
        names = args.only.split(",")
    run(model, analysis, "bdf4", 0.05)
    run(model, analysis, "rk45", 0.05)
    rows = [run(model, analysis, name, t_end) for name in names]
    ref = run(model, analysis, "scipy-radau", t_end, rtol=analysis.rtol / 100,
              atol=analysis.atol / 100)
    print(f"flyball governor, t_end = {t_end} s, method {analysis.method}, rtol {analysis.rtol}"
          f", atol {analysis.atol}; reference z_slider(t_end) = {ref['z_end']:.9f} m")
    print(f"{'integrator':12s} {'wall s':>8s} {'steps':>7s} {'rejected':>8s} {'nfev':>8s} "
          f"{'njev':>6s} {'nlu':>6s} {'|dz| m':>9s}  status")
    for r in rows:
        dz = abs(r["z_end"] - ref["z_end"]) if r["t_reached"] == ref["t_reached"] else float("nan")
        r["dz"] = dz
        print(f"{r['integrator']:12s} {r['wall']:8.2f} {r['steps']:7d} {r['rejected']:8d} "
              f"{r['nfev']:8d} {r['njev']:6d} {r['nlu']:6d} {dz:9.2e}  {r['status']}")
    if args.json:
        Path(args.json).write_text(json.dumps(dict(t_end=t_end, rows=rows, reference=ref),
                                              indent=1))


if __name__ == "__main__":
    main()
