"""Singular positions: the N-four-bar (IFToMM A02) and the Bricard linkage through every
method x integrator x rtol x OpenBLAS kernel.

On the parallelogram branch every crank angle phi (from the vertical, about z) obeys
I phi'' = K sin phi (models.n_four_bar), so the joint B0 (tip of crank 1) has the exact path
(1 - sin phi, cos phi); a run passes when it ends with status success within END_TOL of it.
The Bricard linkage (a closed loop with one redundant equation and 1 DoF) passes when it ends
with status success and its constraint violation and energy stay bounded.

Each OpenBLAS kernel runs in its own process (OpenBLAS reads OPENBLAS_CORETYPE when it loads).

    python bench/singular.py                      # the whole table -> bench/results/singular.md
    python bench/singular.py --quick              # N = 2 and 8, fewer tolerances
    python bench/singular.py --worker N t_end ... # one process (used by the above)
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

METHODS = ("projection", "standard", "baumgarte", "penalty", "augmented_lagrangian")
INTEGRATORS = ("rk45", "dop853")
RTOLS = (1e-4, 1e-6, 1e-8, 1e-10)
KERNELS = ("Haswell", "Zen", "SkylakeX", "Prescott")
END_TOL = 1e-4
#: a stopped run (the singular-position guard) is still on the branch within this (m)
STOP_TOL = 1e-3
GUARD_TEXT = "stopped at a singular position"
WALL = 30.0


def reference(n: int, t_end: float):
    """phi(t) of the parallelogram branch (dense, rtol 1e-13)."""
    from scipy.integrate import solve_ivp
    L, a, m, g = 1.0, 0.02, 1.0, 9.81
    Ic = m * (L * L + a * a) / 12.0
    I = (n + 1) * (Ic + m * L * L / 4.0) + n * m * L * L
    K = m * g * L * ((n + 1) / 2.0 + n)
    sol = solve_ivp(lambda t, y: [y[1], K / I * np.sin(y[0])], (0.0, t_end), [0.0, -1.0],
                    method="DOP853", rtol=1e-13, atol=1e-13, dense_output=True)
    return sol.sol


def b0_error(model, res, phi) -> float:
    from spatialmbd.rotations import A_from_p
    k = model.body_index("crank1")
    q = res.q[-1, k]
    tip = q[:3] + A_from_p(q[3:]) @ np.array([0.0, 0.5, 0.0])
    ph = phi(res.t[-1])[0]
    exact = np.array([1.0 - np.sin(ph), np.cos(ph), 0.0])
    return float(np.linalg.norm(tip - exact))


def worker(n: int, t_end: float, methods, integrators, rtols, cap=WALL) -> list:
    from spatialmbd import models
    from spatialmbd.simulate import simulate
    model = models.n_four_bar(n).compile() if n else models.bricard().compile()
    phi = reference(n, t_end) if n else None
    rows = []
    for method in methods:
        for integrator in integrators:
            for rtol in rtols:
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    try:
                        res = simulate(model, t_end, method=method, integrator=integrator,
                                       rtol=rtol, atol=rtol * 1e-2, output_step=t_end / 200,
                                       max_wall_time=cap)
                        status, t_last, message = res.status, float(res.t[-1]), res.message
                        steps = int(res.counters.get("steps", 0))
                        evals = int(res.counters.get("nfev", 0))
                    except Exception as exc:                      # noqa: BLE001 (a table cell)
                        res, status, t_last, message, steps, evals = None, "error", 0.0, \
                            str(exc), 0, 0
                wall = time.perf_counter() - t0
                if res is not None and n and len(res.t):
                    err = b0_error(model, res, phi)     # where it ended or stopped
                elif res is not None and not n and status == "success":
                    err = float(np.max(list(res.constraint_violation().values())[0]))
                else:
                    err = float("nan")
                ok = status == "success" and t_last == t_end and err < END_TOL
                # the singular-position guard of the drift-following methods: stopped with
                # the diagnosis while still on the parallelogram branch
                stopped = (status == "failed" and GUARD_TEXT in (message or "")
                           and (not n or err < STOP_TOL))
                rows.append(dict(n=n, method=method, integrator=integrator, rtol=rtol,
                                 status=status, t=t_last, steps=steps, evals=evals,
                                 wall=wall, error=err, passed=bool(ok),
                                 verdict="pass" if ok else ("stopped" if stopped else "FAIL"),
                                 message=(message or "")[:120]))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--kernels", nargs="*", default=list(KERNELS))
    ap.add_argument("--methods", nargs="*", default=list(METHODS))
    ap.add_argument("--integrators", nargs="*", default=list(INTEGRATORS))
    ap.add_argument("--rtols", nargs="*", type=float, default=list(RTOLS))
    ap.add_argument("--sizes", nargs="*", type=int, default=None,
                    help="N of the N-four-bar (0: the Bricard linkage)")
    ap.add_argument("--wall", type=float, default=WALL, help="wall-time cap of one run (s)")
    ap.add_argument("--worker", nargs=2, metavar=("N", "T_END"))
    ap.add_argument("-o", default=str(Path(__file__).parent / "results" / "singular.md"))
    args = ap.parse_args(argv)
    if args.worker:
        rows = worker(int(args.worker[0]), float(args.worker[1]), args.methods,
                      args.integrators, args.rtols, args.wall)
        print(json.dumps(rows))
        return 0
    sizes = args.sizes or ([2, 8, 0] if args.quick else [2, 8, 40, 0])
    rtols = [1e-6, 1e-8] if args.quick else args.rtols
    table = []
    for kernel in args.kernels:
        for n in sizes:
            t_end = {0: 10.0, 40: 20.0}.get(n, 10.0)
            env = dict(os.environ, OPENBLAS_CORETYPE=kernel)
            cmd = [sys.executable, __file__, "--worker", str(n), str(t_end), "--methods",
                   *args.methods, "--integrators", *args.integrators, "--rtols",
                   *map(str, rtols), "--wall", str(args.wall)]
            out = subprocess.run(cmd, env=env, capture_output=True, text=True)
            if out.returncode:
                print(out.stderr[-2000:], file=sys.stderr)
                continue
            for row in json.loads(out.stdout.strip().splitlines()[-1]):
                row["kernel"] = kernel
                table.append(row)
                print(f"{kernel:9s} N={n:2d} {row['method']:21s} {row['integrator']:6s} "
                      f"{row['rtol']:.0e} {row['verdict']:7s} "
                      f"{row['status']:8s} t={row['t']:.4g} steps={row['steps']} "
                      f"wall={row['wall']:.2f}s err={row['error']:.2e}", flush=True)
    lines = ["# Singular positions: N-four-bar (A02) and Bricard", "",
             f"`python bench/singular.py{' --quick' if args.quick else ''}`; pass = status "
             f"success at t_end and (N-four-bar) B0 within {END_TOL:g} m of the exact "
             "parallelogram-branch path; stopped = the singular-position guard stopped the "
             f"run with its diagnosis, B0 still within {STOP_TOL:g} m of the path; FAIL = "
             "anything else (success off the branch, a stall, a budget). Wall-time cap per "
             f"run {args.wall:g} s. N = 0 is the Bricard linkage.", "",
             "| kernel | N | method | integrator | rtol | verdict | status | t end | steps | "
             "wall (s) | B0 error (m) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in table:
        verdict = r.get("verdict", "pass" if r["passed"] else "FAIL")
        lines.append(f"| {r['kernel']} | {r['n']} | {r['method']} | {r['integrator']} | "
                     f"{r['rtol']:.0e} | {verdict if verdict != 'FAIL' else '**FAIL**'} | "
                     f"{r['status']} | {r['t']:.4g} | {r['steps']} | {r['wall']:.2f} | "
                     f"{r['error']:.2e} |")
    passed = sum(r["passed"] for r in table)
    stopped = sum(r.get("verdict") == "stopped" for r in table)
    lines += ["", f"{passed} of {len(table)} runs pass, {stopped} stop with the diagnosis on "
              f"the branch, {len(table) - passed - stopped} fail."]
    Path(args.o).parent.mkdir(parents=True, exist_ok=True)
    Path(args.o).write_text("\n".join(lines) + "\n")
    print(f"{passed} of {len(table)} pass; table in {args.o}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
