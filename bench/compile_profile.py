"""Where a cold compile spends its time: every Numba compilation of a first run, by function.

Runs one workload in a fresh compile cache (``NUMBA_CACHE_DIR`` set to a new temporary
directory, so nothing compiled earlier is reused), records Numba's ``numba:compile`` events
and prints, per compiled function, the exclusive time (its own typing, lowering and LLVM work),
the inclusive time (with the callees it compiled first) and how many signatures it got; then
the exclusive time summed by package (``forces.contact`` apart from the rest of ``forces``).

    PYTHONPATH=$PWD/src python bench/compile_profile.py [--workload dynamics|recursive|kinematics|batch|adjoint]
        [--top 30] [--out bench/results/compile_profile.md]

Workloads (what the test session's warm-up compiles, tests/conftest.py):
    kinematics  kinematic analysis of the slider-crank;
    dynamics    the flyball governor, standard method, rk45, 1 ms;
    recursive   a 2-link chain by the recursive method, and as a batch member;
    batch       the slider-crank as a member of a batch (rk45, standard);
    adjoint     the gradient of the damped pendulum's run by the discrete adjoint (RK4).

This is a benchmark, not a test: a workload takes minutes on a 2-core machine.
"""
from __future__ import annotations

import argparse
import collections
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _workload(name):
    from spatialmbd import models
    from spatialmbd.simulate import simulate
    if name == "kinematics":
        from spatialmbd.kinematics import kinematic_analysis
        kinematic_analysis(models.slider_crank(crank_speed=6.0).compile(), [0.0, 0.01])
    elif name == "dynamics":
        simulate(models.flyball_governor().compile(), 1e-3, method="standard",
                 integrator="rk45", output_step=1e-3)
    elif name == "recursive":
        from spatialmbd.io import Analysis
        from spatialmbd.sweep.batch import simulate_batch
        chain = models.chain(2, "revolute").compile()
        simulate(chain, 1e-3, method="recursive", output_step=1e-3)
        simulate_batch([chain], Analysis(t_end=1e-3, output_step=1e-3, method="recursive"))
    elif name == "batch":
        from spatialmbd.io import Analysis
        from spatialmbd.sweep.batch import simulate_batch
        crank = models.slider_crank(driven=False).compile()
        simulate_batch([crank], Analysis(t_end=1e-2, output_step=1e-2, integrator="rk45",
                                         method="standard", rtol=1e-8, atol=1e-10))
    elif name == "adjoint":
        import numpy as np
        from spatialmbd.design.adjoint import Adjoint
        model = ROOT / "examples" / "design" / "pendulum_damped.yaml"
        adj = Adjoint(model, ["bodies.pendulum.mass", "forces.pivot_damper.damping"],
                      dict(type="dynamic", t_end=0.05, output_step=0.01,
                           method=dict(name="standard"),
                           integrator=dict(name="rk4", step=0.005)))
        Y = adj.run(np.array([7.02, 0.8]))
        W = np.zeros(Y.shape)
        W[-1, adj.column("pendulum.wx")] = 1.0             # d final(pendulum.wx) / dx
        adj.gradient(W)
    else:
        raise SystemExit(f"unknown workload {name!r}")


def _profile(name, top):
    """In this process (with a fresh cache set by the caller): the table lines."""
    from numba.core import event

    stack = []
    incl, excl, count = collections.Counter(), collections.Counter(), collections.Counter()

    class Listener(event.Listener):
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            stack.append([f"{f.__module__}.{f.__qualname__}", time.perf_counter(), 0.0])

        def on_end(self, ev):
            fname, t0, children = stack.pop()
            d = time.perf_counter() - t0
            incl[fname] += d
            excl[fname] += d - children
            count[fname] += 1
            if stack:
                stack[-1][2] += d

    event.register("numba:compile", Listener())
    t0 = time.perf_counter()
    _workload(name)
    total = time.perf_counter() - t0
    lines = [f"## {name}: {total:.1f} s wall, {sum(excl.values()):.1f} s compiling, "
             f"{len(excl)} functions, {sum(count.values())} signatures", "",
             "| exclusive [s] | inclusive [s] | signatures | function |", "|---|---|---|---|"]
    for fname, v in excl.most_common(top):
        lines.append(f"| {v:.1f} | {incl[fname]:.1f} | {count[fname]} | `{fname}` |")
    by_pkg = collections.Counter()
    for fname, v in excl.items():
        parts = fname.split(".")
        key = ".".join(parts[1:3]) if parts[1:3] == ["forces", "contact"] else \
            (parts[1] if len(parts) > 2 else fname)
        by_pkg[key] += v
    lines += ["", "| package | exclusive [s] |", "|---|---|"]
    lines += [f"| `{k}` | {v:.1f} |" for k, v in by_pkg.most_common()]
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workload", default="dynamics",
                    choices=("dynamics", "recursive", "kinematics", "batch", "adjoint"))
    ap.add_argument("--top", type=int, default=30)
    ap.add_argument("--out", default=None, help="append the tables to this Markdown file")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:                          # the fresh-cache process
        print("\n".join(_profile(args.workload, args.top)))
        return 0
    with tempfile.TemporaryDirectory(prefix="spatialmbd-cold-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = subprocess.run([sys.executable, __file__, "--child", "--workload", args.workload,
                              "--top", str(args.top)], env=env, capture_output=True,
                             text=True, check=False)
    if out.returncode != 0:
        sys.stderr.write(out.stderr)
        return out.returncode
    text = (f"# Cold compile profile ({time.strftime('%Y-%m-%d %H:%M')}, {platform.node()}, "
            f"load average {os.getloadavg()[0]:.2f})\n\n" + out.stdout)
    print(text)
    if args.out:
        path = Path(args.out)
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
