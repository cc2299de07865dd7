"""Benchmark of spatialmbd.sweep (issue 15): every ratio is measured in one run.

    python bench/sweep.py [--quick] [--members 200] [--batch-members 1000] [--out bench/results]

1. Dask speed-up: a sweep of the chapter-15 pendulum (bodies.pendulum.mass, period and
   extremes as outputs) serial vs on a 2-worker LocalCluster (processes) as
   spatialmbd.sweep.local_cluster starts it (what scheduler="dask" uses), workers warmed by
   one sweep first. Target: >= 1.8x on two cores.
   Each Dask-part figure is the shortest of five repetitions, serial and Dask alternating
   (a shared machine).
2. Per-member overhead of the Dask path once the workers are warm: members that do almost
   nothing (t_end = 1 ms), overhead = (workers x wall_dask - wall_serial) / members, the
   worker-seconds spent per member outside the member's own work. Target: < 20 ms.
3. Batches of one topology: the same members by engine="batch" (one compiled call per chunk)
   and engine="simulate" (one simulate() per member), both serial, for the pendulum and the
   free slider-crank (rod mass and initial crank speed varied), both engines with the default
   method (recursive for the pendulum, projection for the slider-crank); also the batch with its
   members spread over threads, one per core (batch_options={"threads": True}, the default of the
   serial scheduler on several cores). Target: >= 10x.

The machine is shared (2 cores, other jobs running): the load average is recorded with the
figures; repeat when it is high.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

# one BLAS thread in this process, as Dask gives each of its worker processes (its nanny's
# pre-spawn environment): the serial figure is then not slowed by BLAS threads fighting over
# two cores on small matrices
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "examples" / "pendulum_ch15.yaml"
SLIDER = ROOT / "examples" / "sweeps" / "slider_crank_free.yaml"
OUTS = ["period(pendulum.wx)", "min(pendulum.z)", "max(pendulum.wx)"]


def _load():
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def timed(fn, repeat=1):
    """(shortest wall time of ``repeat`` calls, last result): the minimum is the figure least
    disturbed by the other jobs of a shared machine."""
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def _warm():
    from spatialmbd.sweep import sweep
    sweep(PENDULUM, {"bodies.pendulum.mass": [1.0]}, OUTS, progress=False)
    return True


def dask_part(members, workers, sweep, points, repeat=5):
    from spatialmbd.sweep import local_cluster
    masses = np.linspace(1.0, 10.0, members)
    params = {"bodies.pendulum.mass": masses}
    sweep(PENDULUM, {"bodies.pendulum.mass": masses[:4]}, OUTS, progress=False)   # warm
    tiny = dict(type="dynamic", t_end=1e-3, output_step=1e-3)
    light = {"bodies.pendulum.mass": masses}
    serial_run = lambda: sweep(PENDULUM, params, OUTS, scheduler="serial",  # noqa: E731
                               progress=False)
    tiny_serial_run = lambda: sweep(PENDULUM, light, ["final(pendulum.z)"],  # noqa: E731
                                    tiny, scheduler="serial", progress=False)
    with local_cluster(workers) as client:
        client.run(_warm)                      # every worker imports and loads the kernels
        sweep(PENDULUM, {"bodies.pendulum.mass": masses[:2 * workers]}, OUTS, scheduler=client,
              chunk_size=1, progress=False)
        # serial and Dask repetitions alternate, so both see the same state of a shared
        # machine (the idle workers cost the serial run nothing measurable)
        t_serial = t_dask = t_tiny_serial = t_tiny_dask = float("inf")
        for _ in range(repeat):
            t, serial = timed(serial_run)
            t_serial = min(t_serial, t)
            t, dask = timed(lambda: sweep(PENDULUM, params, OUTS, scheduler=client,
                                          progress=False))
            t_dask = min(t_dask, t)
            t_tiny_serial = min(t_tiny_serial, timed(tiny_serial_run)[0])
            t_tiny_dask = min(t_tiny_dask, timed(lambda: sweep(
                PENDULUM, light, ["final(pendulum.z)"], tiny, scheduler=client,
                progress=False))[0])
    same = all(np.array_equal(serial[o].values, dask[o].values, equal_nan=True) for o in OUTS)
    return dict(members=members, workers=workers, serial_s=t_serial, dask_s=t_dask,
                speedup=t_serial / t_dask, identical=bool(same),
                tiny_serial_s=t_tiny_serial, tiny_dask_s=t_tiny_dask,
                overhead_ms_per_member=1e3 * (workers * t_tiny_dask - t_tiny_serial) / members,
                dask_ms_per_member=1e3 * t_dask / members,
                serial_ms_per_member=1e3 * t_serial / members)


def batch_part(name, model, params, outs, analysis, sweep):
    first = {k: v[:2] for k, v in params.items()}
    threads, single = dict(threads=True), dict(threads=False)
    sweep(model, first, outs, analysis, progress=False, engine="batch",            # compile
          batch_options=single)
    sweep(model, first, outs, analysis, progress=False, engine="batch", batch_options=threads)
    t_sim, a = timed(lambda: sweep(model, params, outs, analysis, progress=False,
                                   engine="simulate"))
    t_bat, b = timed(lambda: sweep(model, params, outs, analysis, progress=False,
                                   engine="batch", batch_options=single))
    t_thr, c = timed(lambda: sweep(model, params, outs, analysis, progress=False,
                                   engine="batch", batch_options=threads))
    diff = max(float(np.nanmax(np.abs(a[o].values - x[o].values))) for o in outs
               for x in (b, c))
    n = int(a.attrs["n_members"])
    return dict(model=name, members=n, simulate_s=t_sim, batch_s=t_bat, ratio=t_sim / t_bat,
                batch_threads_s=t_thr, ratio_threads=t_sim / t_thr,
                simulate_ms_per_member=1e3 * t_sim / n, batch_ms_per_member=1e3 * t_bat / n,
                max_abs_difference=diff,
                all_success=bool((a["status"] == "success").all()
                                 and (b["status"] == "success").all()))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer members (a smoke run)")
    ap.add_argument("--members", type=int, default=200)
    ap.add_argument("--batch-members", type=int, default=1000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "bench" / "results"))
    args = ap.parse_args()
    if args.quick:
        args.members, args.batch_members = 40, 100
    from spatialmbd.sweep import points, sweep
    report = dict(machine=dict(cpus=os.cpu_count(), python=platform.python_version(),
                               load_before=_load()))
    report["dask"] = dask_part(args.members, args.workers, sweep, points)
    n = args.batch_members
    # the default method "auto" in both engines: the recursive method (joint coordinates) for
    # the pendulum, a tree, and the projection method for the slider-crank, a closed loop
    pend_an = dict(type="dynamic", t_end=10.0, output_step=0.02, method="auto",
                   integrator=dict(name="rk45", rtol=1e-6, atol=1e-9))
    report["batch_pendulum"] = batch_part(
        "pendulum_ch15", PENDULUM, {"bodies.pendulum.mass": np.linspace(1.0, 10.0, n)},
        OUTS, pend_an, sweep)
    side = int(round(np.sqrt(n)))
    slider_an = dict(type="dynamic", t_end=1.0, output_step=0.01, method="auto",
                     integrator=dict(name="rk45", rtol=1e-8, atol=1e-10))
    report["batch_slider_crank"] = batch_part(
        "slider_crank_free", SLIDER,
        {"bodies.rod.mass": np.linspace(0.3, 1.0, side),
         "bodies.crank.angular_velocity.0": np.linspace(4.0, 8.0, max(1, n // side))},
        ["max(slider.x)", "min(slider.vx)", "final(crank.wx)"], slider_an, sweep)
    report["machine"]["load_after"] = _load()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sweep.json").write_text(json.dumps(report, indent=2))
    d, bp, bs = report["dask"], report["batch_pendulum"], report["batch_slider_crank"]
    lines = [
        "| measurement | value | target |",
        "|---|---|---|",
        f"| {d['members']}-member pendulum sweep, serial | {d['serial_s']:.2f} s "
        f"({d['serial_ms_per_member']:.1f} ms/member) | |",
        f"| same on a {d['workers']}-worker LocalCluster | {d['dask_s']:.2f} s "
        f"({d['dask_ms_per_member']:.1f} ms/member), identical results: {d['identical']} | |",
        f"| Dask speed-up | {d['speedup']:.2f}x | >= 1.8x |",
        f"| Dask per-member overhead (warm workers) | {d['overhead_ms_per_member']:.2f} ms "
        "| < 20 ms |",
        f"| {bp['members']}-member pendulum: simulate / batch on one core | "
        f"{bp['simulate_s']:.2f} s / {bp['batch_s']:.2f} s = {bp['ratio']:.1f}x (max diff "
        f"{bp['max_abs_difference']:.1e}) | >= 10x |",
        f"| same, batch on threads, one per core (the default) | {bp['batch_threads_s']:.2f} s = "
        f"{bp['ratio_threads']:.1f}x | >= 10x |",
        f"| {bs['members']}-member free slider-crank: simulate / batch on one core | "
        f"{bs['simulate_s']:.2f} s / {bs['batch_s']:.2f} s = {bs['ratio']:.1f}x (max diff "
        f"{bs['max_abs_difference']:.1e}) | >= 10x |",
        f"| same, batch on threads, one per core (the default) | {bs['batch_threads_s']:.2f} s = "
        f"{bs['ratio_threads']:.1f}x | >= 10x |",
        f"| load average before / after | {report['machine']['load_before']:.2f} / "
        f"{report['machine']['load_after']:.2f} ({report['machine']['cpus']} cores) | |",
    ]
    text = "\n".join(lines)
    (out / "sweep.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
