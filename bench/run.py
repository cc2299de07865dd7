#!/usr/bin/env python
"""spatialmbd performance benchmark, with Exudyn run on the same problems in the same run.

    python bench/run.py --quick            # a few minutes
    python bench/run.py --full             # adds N = 10 000, Exudyn at N = 1024, finer steps
    python bench/run.py --quick --no-exudyn

Writes ``bench/results/<mode>.json`` (every number), ``bench/results/<mode>.md`` (the
tables) and the plots ``bench/results/<mode>_work_precision.png`` and
``bench/results/<mode>_scaling.png``; prints the tables. Sections:

1. chapter 15 study (pendulum, 10 s, Table 15.2 settings), each method; Exudyn's
   generalized-alpha at h = 1e-3 on the same pendulum;
2. N-link chains (spherical and revolute joints), N = 4 .. 4096 (10 000 in --full): wall time
   per equation-of-motion evaluation, per simulated second and memory; Exudyn per simulated
   second at h = 1e-3; log-log slopes between N = 256 and 4096;
3. kinematic analysis of the driven spatial slider-crank: time per output instant;
4. work-precision: final centre-of-mass error against a tight-tolerance reference versus wall
   time, for our integrators and methods and for Exudyn at several step sizes (pendulum,
   chains N = 4 .. 256 and, in --full, 1024); the equal-accuracy table (final error <= 1e-6).

Timing: every figure is the minimum over repetitions (the machine is shared), single thread
for both codes (OPENBLAS_NUM_THREADS=1 is set before NumPy is imported; Exudyn runs with one
thread). "wall" of a simulation is the integration as timed by each code (spatialmbd's
Results.wall_time, Exudyn's SolveDynamic); "total" adds our set-up and the recomputation of
accelerations and multipliers at the output times. The load average is recorded at the start
and the end. Compile time of the Numba kernels is measured separately, in a fresh process
with an empty cache.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import exudyn_peer as ex  # noqa: E402

from spatialmbd import models  # noqa: E402
from spatialmbd.kinematics import kinematic_analysis  # noqa: E402
from spatialmbd.simulate import right_hand_side, simulate  # noqa: E402
from spatialmbd.study_ch15 import METHODS as CH15_METHODS  # noqa: E402
from spatialmbd.study_ch15 import SETTINGS as CH15  # noqa: E402

TARGET_ERROR = 1e-6
#: Exudyn 1.13.6 as quoted in the issue (another 2-core machine): pendulum at h = 1e-3, and
#: spherical chains, 1 s at h = 1e-3, N -> seconds
ISSUE_EXUDYN = dict(pendulum=0.116, chains={4: 0.045, 16: 0.164, 64: 0.735, 256: 2.45,
                                             1024: 11.9})


# ---------------------------------------------------------------------------------- helpers
def log(*args):
    print(*args, flush=True)


def load() -> list:
    return [round(x, 2) for x in os.getloadavg()]


def machine() -> dict:
    cpu = platform.processor()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {}
    for mod in ("numpy", "scipy", "numba", "exudyn"):
        try:
            versions[mod] = __import__(mod).__version__
        except Exception:
            versions[mod] = None
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE,
                                capture_output=True, text=True).stdout.strip()
    except OSError:
        commit = None
    return dict(cpu=cpu, cores=os.cpu_count(), python=platform.python_version(),
                platform=platform.platform(), versions=versions, commit=commit,
                blas_threads=os.environ.get("OPENBLAS_NUM_THREADS"))


def best_of(fn, repeat: int):
    """(min wall, result of the last call) of fn() over at least ``repeat`` calls spread over
    MIN_SPREAD seconds (at most 40 calls)."""
    best, out = math.inf, None
    began = time.perf_counter()
    count = 0
    while count < repeat or (count < 40 and time.perf_counter() - began < MIN_SPREAD):
        count += 1
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def com_error(final_com, ref) -> float:
    """Largest distance between final centres of mass and the reference (m)."""
    d = np.asarray(final_com, dtype=float).reshape(-1, 3) - np.asarray(ref).reshape(-1, 3)
    return float(np.linalg.norm(d, axis=1).max())


#: repetitions of a timed run go on until they have taken this long (s): the shared machine has
#: phases of about a second in which everything runs up to twice as slowly
MIN_SPREAD = 1.5


def run_ours(model, t_end, repeat=1, **kw) -> dict:
    """simulate() with output only at the end; min integration wall over at least ``repeat``
    runs spread over MIN_SPREAD seconds (at most 40 runs)."""
    best, best_total, res = math.inf, math.inf, None
    began = time.perf_counter()
    count = 0
    while count < repeat or (repeat > 1 and count < 40
                             and time.perf_counter() - began < MIN_SPREAD):
        count += 1
        start = time.perf_counter()
        res = simulate(model, t_end, output_step=t_end, **kw)
        total = time.perf_counter() - start
        if not res.success:
            raise RuntimeError(res.message)
        best = min(best, res.wall_time)
        best_total = min(best_total, total)
    return dict(wall=best, total=best_total, steps=int(res.counters["steps"]),
                nfev=int(res.counters["nfev"]), final_com=res.q[-1, :, :3].tolist())


def run_exudyn(fn, *args, repeat=1, **kw) -> dict:
    best, out = math.inf, None
    for _ in range(repeat):
        try:
            out = fn(*args, **kw)
        except Exception as exc:           # e.g. Newton failure at a large step
            return dict(failed=str(exc))
        best = min(best, out["wall_time"])
    out = dict(out)
    out["wall"] = best
    return out


def loglog_slope(x, y) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


# ---------------------------------------------------------------------------------- 0. compile
COMPILE_SNIPPET = """
import time, os
t0 = time.perf_counter()
from spatialmbd import models
from spatialmbd.simulate import simulate
t1 = time.perf_counter()
m = models.pendulum_ch15().compile()
out = {"import": t1 - t0}
for key in ("standard", "penalty", "projection"):
    t = time.perf_counter()
    simulate(m, 0.1, method=key, output_step=0.1, correct_initial=False)
    out[key] = time.perf_counter() - t
print(repr(out))
"""


def bench_compile() -> dict:
    """First-call cost: a fresh process with an empty Numba cache, then a warm one."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        for label in ("cold", "warm"):
            start = time.perf_counter()
            proc = subprocess.run([sys.executable, "-c", COMPILE_SNIPPET], env=env,
                                  capture_output=True, text=True)
            wall = time.perf_counter() - start
            if proc.returncode:
                out[label] = dict(failed=proc.stderr[-500:])
                continue
            out[label] = dict(process=wall, **eval(proc.stdout.strip().splitlines()[-1]))
    return out


# ---------------------------------------------------------------------------------- 1. ch. 15
def pendulum_reference(t_end=10.0) -> np.ndarray:
    """Centre of mass at t_end from the planar equation of the ch. 15 pendulum (DOP853,
    rtol 1e-13): an independent reference (the same as exudyn_peer's self-check)."""
    return ex._pendulum_reference(t_end)


def bench_ch15(repeat, exudyn, ref) -> dict:
    model = models.pendulum_ch15().compile()
    rows = []
    for key, label, options, text_nfev, text_time in CH15_METHODS:
        kw = dict(method=key, method_options=options, integrator=CH15["integrator"],
                  rtol=CH15["rtol"], atol=CH15["atol"], output_step=CH15["output_step"],
                  correct_initial=False)
        simulate(model, 0.1, **kw)                               # warm-up
        best, best_total, res = math.inf, math.inf, None
        began, count = time.perf_counter(), 0
        while count < repeat or (count < 40 and time.perf_counter() - began < MIN_SPREAD):
            count += 1
            start = time.perf_counter()
            res = simulate(model, CH15["t_end"], **kw)
            best_total = min(best_total, time.perf_counter() - start)
            best = min(best, res.wall_time)
        rows.append(dict(method=key, label=label, wall=best, total=best_total,
                         nfev=int(res.counters["nfev"]), steps=int(res.counters["steps"]),
                         error=com_error(res.q[-1, 0, :3], ref), text_time=text_time,
                         text_nfev=text_nfev))
        log(f"  ch15 {key:22s} wall {best * 1e3:7.2f} ms  total {best_total * 1e3:7.2f} ms  "
            f"nfev {rows[-1]['nfev']:5d}  error {rows[-1]['error']:.1e} m")
    out = dict(methods=rows)
    if exudyn:
        e = run_exudyn(ex.pendulum_ch15, 1e-3, CH15["t_end"], repeat=repeat)
        if "failed" not in e:
            e["error"] = com_error(e["final_com"], ref)
            log(f"  ch15 exudyn h=1e-3             wall {e['wall'] * 1e3:7.2f} ms  "
                f"error {e['error']:.1e} m")
        out["exudyn"] = _slim(e)
    return out


def _slim(d: dict) -> dict:
    return {k: v for k, v in d.items() if k not in ("final_com", "final_p", "final_vel",
                                                     "final_omega_local", "final_tip")}


# ---------------------------------------------------------------------------------- 2. chains
def eval_cost(model, repeat) -> float:
    """Seconds per right-hand-side evaluation (standard method)."""
    f, y0 = right_hand_side(model)
    rng = np.random.default_rng(0)
    y = y0.copy()
    y[7 * model.nb:13 * model.nb] = 0.1 * rng.normal(size=6 * model.nb)
    f(0.0, y)
    start = time.perf_counter()
    f(0.0, y)
    once = time.perf_counter() - start
    calls = max(3, int(0.05 / max(once, 1e-7)))          # about 50 ms per repetition
    best, _ = best_of(lambda: [f(0.0, y) for _ in range(calls)], max(repeat, 5))
    return best / calls


def memory(model, t_end) -> dict:
    """Peak traced allocation of a short simulation, and the size of the compiled system."""
    from spatialmbd.dynamics import EquationsOfMotion
    tracemalloc.start()
    simulate(model, t_end, output_step=t_end, rtol=1e-6, atol=1e-8)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    s = EquationsOfMotion(model).system
    return dict(peak_bytes=int(peak), system_bytes=int(s.F.nbytes + s.I.nbytes + s.W.nbytes))


def bench_chains(sizes, exudyn_sizes, repeat, exudyn, t_sim) -> dict:
    out = {}
    for joint in ("spherical", "revolute"):
        rows = []
        for n in sizes:
            t0 = time.perf_counter()
            model = models.chain(n, joint).compile()
            build = time.perf_counter() - t0
            per_eval = eval_cost(model, repeat)
            t_end = t_sim(n)
            reps = repeat if n <= 1024 else 1
            r = run_ours(model, t_end, repeat=reps, rtol=1e-6, atol=1e-8)
            mem = memory(model, min(t_end, 0.01))
            row = dict(n=n, build=build, per_eval=per_eval, t_end=t_end,
                       per_second=r["wall"] / t_end, total_per_second=r["total"] / t_end,
                       steps=r["steps"], nfev=r["nfev"], per_step=r["wall"] / r["steps"],
                       **mem)
            if exudyn and n in exudyn_sizes:
                import psutil
                rss0 = psutil.Process().memory_info().rss
                e = run_exudyn(ex.chain, n, joint, 1e-3, 1.0, repeat=1 if n >= 256 else repeat)
                if "failed" not in e:
                    row["exudyn_per_second"] = e["wall"]
                    row["exudyn_per_step"] = e["wall"] / e["steps"]
                    row["exudyn_rss_growth_mb"] = (psutil.Process().memory_info().rss
                                                   - rss0) / 2**20
                else:
                    row["exudyn_failed"] = e["failed"]
            rows.append(row)
            ex_txt = (f"  exudyn h=1e-3 {row['exudyn_per_second']:8.3f} s/s"
                      if "exudyn_per_second" in row else "")
            log(f"  {joint:9s} N={n:6d}  eval {per_eval * 1e6:9.1f} us "
                f"({per_eval / n * 1e9:6.0f} ns/body)  rk45 1e-6: {row['per_second']:8.3f} s/s "
                f"({r['steps']} steps)  peak {mem['peak_bytes'] / 2**20:7.1f} MB{ex_txt}")
        big = [r for r in rows if 256 <= r["n"] <= 4096]
        slopes = {}
        if len(big) >= 2:
            ns = [r["n"] for r in big]
            slopes = dict(per_eval=loglog_slope(ns, [r["per_eval"] for r in big]),
                          per_step=loglog_slope(ns, [r["per_step"] for r in big]),
                          memory=loglog_slope(ns, [r["peak_bytes"] for r in big]),
                          system_memory=loglog_slope(ns, [r["system_bytes"] for r in big]))
            log(f"  {joint}: log-log slopes N=256..4096: " +
                ", ".join(f"{k} {v:.3f}" for k, v in slopes.items()))
        out[joint] = dict(rows=rows, slopes_256_4096=slopes)
    return out


# ---------------------------------------------------------------------------------- 3. kinematics
def bench_kinematics(repeat) -> dict:
    model = models.slider_crank(driven=True, crank_speed=6.0).compile()
    t = np.linspace(0.0, 2 * np.pi / 6.0, 1001)
    kinematic_analysis(model, t[:5])
    best, res = best_of(lambda: kinematic_analysis(model, t), repeat)
    x, _, _ = models.slider_crank_exact(6.0 * t)
    err = float(np.abs(res.body("slider")["r"][:, 0] - x).max())
    out = dict(instants=int(t.size), wall=best, per_instant=best / t.size,
               newton_iterations=float(np.mean(res.newton_iterations)), max_error=err)
    log(f"  slider-crank kinematics: {out['per_instant'] * 1e6:.1f} us per instant "
        f"({t.size} instants, {out['newton_iterations']:.2f} Newton iterations each, "
        f"error vs closed form {err:.1e} m)")
    return out


# ---------------------------------------------------------------------------------- 4. work-precision
def wp_ours(model, t_end, ref, configs, repeat) -> list:
    rows = []
    warm = set()
    for label, kw in configs:
        if label not in warm:                  # compile / load the kernels outside the timing
            warm.add(label)
            try:
                simulate(model, min(t_end, 0.01), output_step=min(t_end, 0.01), **kw)
            except Exception:
                pass
        try:
            r = run_ours(model, t_end, repeat=repeat, **kw)
        except Exception as exc:
            rows.append(dict(label=label, settings=kw, failed=str(exc)))
            continue
        rows.append(dict(label=label, settings=kw, wall=r["wall"], total=r["total"],
                         nfev=r["nfev"], steps=r["steps"], error=com_error(r["final_com"], ref)))
    return rows


def wp_exudyn(fn, args, hs, ref, repeat) -> list:
    rows = []
    for h in hs:
        e = run_exudyn(fn, *args[:-1], h, args[-1], repeat=repeat)
        if "failed" in e:
            rows.append(dict(label="exudyn gen.-alpha", h=h, failed=e["failed"]))
            continue
        rows.append(dict(label="exudyn gen.-alpha", h=h, wall=e["wall"], steps=e["steps"],
                         newton_iterations=e["newton_iterations"],
                         error=com_error(e["final_com"], ref)))
    return rows


def equal_accuracy(ours: list, exu: list, target=TARGET_ERROR) -> dict:
    """Cheapest of our runs with error <= target; Exudyn's wall at the step that reaches it
    (measured if one of its runs did, else extrapolated from its error ~ h^p fit, wall ~ 1/h)."""
    ok = [r for r in ours if "error" in r and r["error"] <= target]
    best = min(ok, key=lambda r: r["wall"]) if ok else None
    out = dict(ours=best)
    good = [r for r in exu if "error" in r and np.isfinite(r["error"]) and r["error"] > 0]
    hit = [r for r in good if r["error"] <= target]
    if hit:
        e = min(hit, key=lambda r: r["wall"])
        out["exudyn"] = dict(wall=e["wall"], h=e["h"], error=e["error"], estimated=False)
    elif len(good) >= 2:
        hs = np.array([r["h"] for r in good])
        errs = np.array([r["error"] for r in good])
        p, logc = np.polyfit(np.log(hs), np.log(errs), 1)
        h_star = math.exp((math.log(target) - logc) / p)
        ref = min(good, key=lambda r: r["h"])
        out["exudyn"] = dict(wall=ref["wall"] * ref["h"] / h_star, h=h_star, order=p,
                             estimated=True)
    if best and "exudyn" in out:
        out["ratio"] = out["exudyn"]["wall"] / best["wall"]
    return out


def bench_work_precision(quick, repeat, exudyn, chain_sizes) -> dict:
    out = {}
    # --- pendulum, 10 s
    model = models.pendulum_ch15().compile()
    ref = pendulum_reference(10.0)
    tols = [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10] if quick else \
        [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
    configs = []
    for key, label, options, _, _ in CH15_METHODS:
        for tol in tols:
            configs.append((f"rk45 {key}", dict(method=key, method_options=options,
                                                 integrator="rk45", rtol=tol, atol=tol * 1e-3,
                                                 correct_initial=False)))
    for h in ([4e-3, 2e-3, 1e-3, 5e-4] if quick else [1e-2, 4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4]):
        configs.append(("rk4 standard", dict(integrator="rk4", step=h, correct_initial=False)))
    for tol in tols[:-1]:
        configs.append(("abm4 standard", dict(integrator="abm4", rtol=tol, atol=tol * 1e-3,
                                              correct_initial=False)))
    ours = wp_ours(model, 10.0, ref, configs, repeat)
    exu = []
    if exudyn:
        hs = [2e-3, 1e-3, 5e-4, 2e-4, 1e-4] if quick else [4e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4,
                                                              5e-5]
        exu = wp_exudyn(ex.pendulum_ch15, (10.0,), hs, ref, repeat)
    out["pendulum"] = dict(t_end=10.0, reference="planar ODE, DOP853 rtol 1e-13",
                           ours=ours, exudyn=exu, equal_accuracy=equal_accuracy(ours, exu))
    _log_eq("pendulum", out["pendulum"]["equal_accuracy"])
    # --- chains, 1 s
    for joint in ("spherical", "revolute"):
        for n in chain_sizes:
            model = models.chain(n, joint).compile()
            ref_tol = 1e-12 if n <= 256 else 1e-10
            log(f"  {joint} N={n}: reference (rk45 rtol {ref_tol:g}) ...")
            ref = np.array(run_ours(model, 1.0, rtol=ref_tol, atol=ref_tol * 1e-2)["final_com"])
            tolsc = [1e-5, 1e-6, 1e-7, 1e-8] if (quick or n > 256) else \
                [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]
            configs = [("rk45 standard", dict(rtol=t, atol=t * 1e-2)) for t in tolsc]
            configs += [("rk45 projection", dict(method="projection", rtol=t, atol=t * 1e-2))
                        for t in tolsc[:3]]
            if n <= 64:
                configs += [("rk4 standard", dict(integrator="rk4", step=h))
                            for h in (4e-3, 2e-3, 1e-3)]
            reps = repeat if n <= 64 else 1
            ours = wp_ours(model, 1.0, ref, configs, reps)
            exu = []
            if exudyn:
                if n > 256 and not quick:
                    hs = [2e-3, 1e-3, 5e-4]
                elif n <= 16:
                    hs = [2e-3, 1e-3, 5e-4, 2.5e-4] if quick else [2e-3, 1e-3, 5e-4, 2.5e-4,
                                                                    1.25e-4]
                elif n <= 64:
                    hs = [2e-3, 1e-3, 5e-4] if quick else [2e-3, 1e-3, 5e-4, 2.5e-4]
                elif n <= 256:
                    hs = [2e-3, 1e-3] if quick else [2e-3, 1e-3, 5e-4]
                else:
                    hs = [2e-3, 1e-3]
                exu = wp_exudyn(ex.chain, (n, joint, 1.0), hs, ref, 1)
            key = f"chain_{joint}_{n}"
            if n > 256 and (quick and joint != "spherical"):
                continue
            out[key] = dict(t_end=1.0, reference=f"spatialmbd rk45 rtol {ref_tol:g}",
                            ours=ours, exudyn=exu, equal_accuracy=equal_accuracy(ours, exu))
            _log_eq(key, out[key]["equal_accuracy"])
    return out


def _exudyn_from_work_precision(data) -> None:
    """Chain rows without an Exudyn figure take its h = 1e-3 run of the work-precision
    section (same problem, same run), marked as such."""
    for joint, d in data.get("chains", {}).items():
        for row in d["rows"]:
            if "exudyn_per_second" in row:
                continue
            wp = data["work_precision"].get(f"chain_{joint}_{row['n']}")
            runs = [r for r in (wp or {}).get("exudyn", []) if r.get("h") == 1e-3 and "wall" in r]
            if runs:
                row["exudyn_per_second"] = runs[0]["wall"]
                row["exudyn_per_step"] = runs[0]["wall"] / runs[0]["steps"]
                row["exudyn_from"] = "work-precision run"


def _log_eq(name, eq):
    o, e = eq.get("ours"), eq.get("exudyn")
    txt = f"  equal accuracy {name:22s}"
    if o:
        txt += f" ours {o['wall']:8.4f} s ({o['label']}, error {o['error']:.1e})"
    if e:
        txt += (f"  exudyn {e['wall']:8.3f} s (h={e['h']:.2g}"
                + (", extrapolated" if e.get("estimated") else "") + ")")
    if "ratio" in eq:
        txt += f"  ratio {eq['ratio']:.1f}"
    log(txt)


# ---------------------------------------------------------------------------------- report
def plots(data, outdir: Path, stem: str) -> list:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    files = []
    wp = data.get("work_precision")
    if wp:
        keys = ["pendulum"] + [k for k in wp if k.startswith("chain_spherical")]
        ncol = 3
        nrow = math.ceil(len(keys) / ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(5.2 * ncol, 4.2 * nrow), squeeze=False)
        all_labels = sorted({r["label"] for k in keys for r in wp[k]["ours"]})
        color = {label: f"C{i % 10}" for i, label in enumerate(all_labels)}
        for ax, key in zip(axes.ravel(), keys):
            d = wp[key]
            labels = sorted({r["label"] for r in d["ours"]})
            for label in labels:
                pts = sorted((r["wall"], r["error"]) for r in d["ours"]
                             if r["label"] == label and "error" in r)
                if pts:
                    ax.loglog(*zip(*pts), "o-", ms=3, lw=1, color=color[label], label=label)
            pts = sorted((r["wall"], r["error"]) for r in d["exudyn"] if "error" in r)
            if pts:
                ax.loglog(*zip(*pts), "ks--", ms=5, lw=1.5, label="Exudyn gen.-alpha")
            ax.axhline(TARGET_ERROR, color="grey", lw=0.8, ls=":")
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.set_title(key.replace("_", " ") + f", {d['t_end']:g} s", fontsize=10)
            ax.set_xlabel("wall time (s)")
            ax.set_ylabel("final centre-of-mass error (m)")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=6)
        for ax in axes.ravel()[len(keys):]:
            ax.axis("off")
        fig.suptitle("Work-precision: spatialmbd integrators/methods vs Exudyn "
                     "generalized-alpha (same run)", fontsize=11)
        fig.tight_layout()
        path = outdir / f"{stem}_work_precision.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files.append(str(path))
    ch = data.get("chains")
    if ch:
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
        colors = {"spherical": "C0", "revolute": "C3"}
        for joint, d in ch.items():
            col = colors.get(joint, "C2")
            ns = [r["n"] for r in d["rows"]]
            a1.loglog(ns, [r["per_eval"] for r in d["rows"]], "o-", color=col, alpha=0.6,
                      label=f"{joint}: per evaluation")
            a1.loglog(ns, [r["per_step"] for r in d["rows"]], "s-", color=col,
                      label=f"{joint}: per rk45 step")
            ex_rows = [r for r in d["rows"] if "exudyn_per_step" in r]
            if ex_rows:
                a1.loglog([r["n"] for r in ex_rows], [r["exudyn_per_step"] for r in ex_rows],
                          "^--", color=col, mfc="white", label=f"{joint}: Exudyn per step")
            a2.loglog(ns, [r["per_second"] for r in d["rows"]], "o-", color=col,
                      label=f"{joint}: rk45 rtol 1e-6")
            if ex_rows:
                a2.loglog([r["n"] for r in ex_rows], [r["exudyn_per_second"] for r in ex_rows],
                          "^--", color=col, mfc="white", label=f"{joint}: Exudyn h = 1e-3")
        for a, title in ((a1, "cost per evaluation / step (s)"),
                         (a2, "wall time per simulated second (s)")):
            a.set_xlabel("N (bodies)")
            a.set_title(title, fontsize=10)
            a.grid(True, which="both", alpha=0.3)
            a.legend(fontsize=7)
        fig.tight_layout()
        path = outdir / f"{stem}_scaling.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files.append(str(path))
    return files


def tables(data) -> str:
    lines = []
    m = data["machine"]
    lines += [f"Machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, "
              f"NumPy {m['versions']['numpy']}, Numba {m['versions']['numba']}, "
              f"Exudyn {m['versions']['exudyn']}; load average {data['load_start']} at the "
              f"start, {data.get('load_end')} at the end; commit {m['commit']}.", ""]
    if "compile" in data:
        c = data["compile"]
        if "cold" in c and "standard" in c["cold"]:
            lines += ["First call in a fresh process (s): "
                      f"empty cache: import {c['cold']['import']:.2f}, first standard run "
                      f"{c['cold']['standard']:.1f}, first penalty {c['cold']['penalty']:.1f}, "
                      f"first projection {c['cold']['projection']:.1f}; warm cache: import "
                      f"{c['warm']['import']:.2f}, first standard run "
                      f"{c['warm']['standard']:.2f}.", ""]
    if "ch15" in data:
        d = data["ch15"]
        e = d.get("exudyn", {})
        lines += ["### Chapter 15 study (pendulum, 10 s, Table 15.2: rk45 rtol 1e-6, "
                  "atol 1e-9, output every 0.02 s)", "",
                  "| method | wall (ms) | total (ms) | nfev | error (m) | text (s) | "
                  "Exudyn h=1e-3 / ours |", "|---|---|---|---|---|---|---|"]
        for r in d["methods"]:
            ratio = f"{e['wall'] / r['wall']:.1f}" if "wall" in e else "-"
            lines.append(f"| {r['method']} | {r['wall'] * 1e3:.1f} | {r['total'] * 1e3:.1f} | "
                         f"{r['nfev']} | {r['error']:.1e} | {r['text_time'] or '-'} | {ratio} |")
        if "wall" in e:
            lines.append(f"| Exudyn gen.-alpha h=1e-3 | {e['wall'] * 1e3:.1f} | | "
                         f"{e['steps']} steps | {e['error']:.1e} | | 1 |")
        lines.append("")
    if "chains" in data:
        lines += ["### N-link chains (standard method, rk45 rtol 1e-6 / atol 1e-8, 1 s "
                  "simulated unless noted)", "",
                  "| joint | N | per evaluation (us) | ns/body | steps | s per simulated s | "
                  "Exudyn h=1e-3 (s/s) | Exudyn / ours | peak memory (MB) |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for joint, d in data["chains"].items():
            for r in d["rows"]:
                exs = r.get("exudyn_per_second")
                sim = f" ({r['t_end']:g} s)" if r["t_end"] < 1 else ""
                ex_txt = f"{exs:.3f} | {exs / r['per_second']:.1f}" if exs else "- | -"
                lines.append(f"| {joint} | {r['n']} | {r['per_eval'] * 1e6:.1f} | "
                             f"{r['per_eval'] / r['n'] * 1e9:.0f} | {r['steps']} | "
                             f"{r['per_second']:.3f}{sim} | {ex_txt} | "
                             f"{r['peak_bytes'] / 2**20:.1f} |")
            s = d.get("slopes_256_4096")
            if joint == "spherical":
                lines.append("| (issue's Exudyn figures, s/s) | " + ", ".join(
                    f"N={n}: {v}" for n, v in ISSUE_EXUDYN["chains"].items()) + " | | | | | | |")
            if s:
                lines.append(f"| {joint} | slope 256..4096 | {s['per_eval']:.3f} | | | "
                             f"per step {s['per_step']:.3f} | | | {s['memory']:.3f} |")
        lines.append("")
    if "kinematics" in data:
        k = data["kinematics"]
        lines += [f"### Kinematic analysis, driven slider-crank: {k['per_instant'] * 1e6:.1f} us "
                  f"per output instant ({k['instants']} instants over one revolution, "
                  f"{k['newton_iterations']:.2f} Newton iterations on average, max error "
                  f"{k['max_error']:.1e} m against the closed form).", ""]
    if "work_precision" in data:
        lines += [f"### Equal accuracy (final centre-of-mass error <= {TARGET_ERROR:g} m)", "",
                  "| problem | ours: cheapest setting | ours (s) | ours error | Exudyn h | "
                  "Exudyn (s) | Exudyn / ours |", "|---|---|---|---|---|---|---|"]
        for key, d in data["work_precision"].items():
            eq = d["equal_accuracy"]
            o, e = eq.get("ours"), eq.get("exudyn")
            ours_txt = (f"{o['label']} {_settings_txt(o['settings'])} | {o['wall']:.4f} | "
                        f"{o['error']:.1e}") if o else "none <= target | - | -"
            ex_txt = (f"{e['h']:.2g}{' (extrapolated)' if e.get('estimated') else ''} | "
                      f"{e['wall']:.3f}") if e else "- | -"
            ratio = f"{eq['ratio']:.1f}" if "ratio" in eq else "-"
            lines.append(f"| {key} | {ours_txt} | {ex_txt} | {ratio} |")
        lines.append("")
    return "\n".join(lines)


def _settings_txt(s: dict) -> str:
    keys = ("rtol", "step")
    return ", ".join(f"{k} {s[k]:g}" for k in keys if k in s)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="the quick run (default)")
    mode.add_argument("--full", action="store_true", help="N up to 10 000, finer Exudyn steps")
    ap.add_argument("--no-exudyn", action="store_true", help="run spatialmbd only")
    ap.add_argument("--only", default="compile,ch15,chains,kinematics,work_precision",
                    help="comma-separated sections")
    ap.add_argument("--repeat", type=int, default=None, help="repetitions (min is kept)")
    ap.add_argument("--out", default=str(HERE / "results"))
    ap.add_argument("--replot", action="store_true",
                    help="only redraw the plots and tables from <out>/<mode>.json")
    args = ap.parse_args(argv)
    quick = not args.full
    stem = "quick" if quick else "full"
    repeat = args.repeat or (5 if quick else 7)
    exudyn = not args.no_exudyn and ex.available()
    if not args.no_exudyn and not exudyn:
        log("exudyn is not installed (pip install -e '.[bench]'): running spatialmbd only")
    sections = set(args.only.split(","))
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    if args.replot:
        data = json.loads((outdir / f"{stem}.json").read_text())
        data["plots"] = plots(data, outdir, stem)
        (outdir / f"{stem}.md").write_text(tables(data) + "\n")
        log(tables(data))
        return 0
    data = dict(mode=stem, machine=machine(), load_start=load(), started=time.ctime(),
                exudyn=exudyn, repeat=repeat)
    log(f"spatialmbd benchmark ({stem}), load average {data['load_start']}")
    if "compile" in sections:
        log("compile time (fresh processes)")
        data["compile"] = bench_compile()
        log(f"  {data['compile']}")
    if "ch15" in sections:
        log("chapter 15 study")
        data["ch15"] = bench_ch15(repeat, exudyn, pendulum_reference(10.0))
    if "chains" in sections:
        log("N-link chains")
        sizes = [4, 16, 64, 256, 1024, 4096] + ([] if quick else [10000])
        ex_sizes = [4, 16, 64, 256] + ([] if quick else [1024])
        t_sim = lambda n: 1.0  # noqa: E731
        data["chains"] = bench_chains(sizes, ex_sizes, repeat, exudyn, t_sim)
    if "kinematics" in sections:
        log("kinematic analysis")
        data["kinematics"] = bench_kinematics(repeat)
    if "work_precision" in sections:
        log("work-precision")
        sizes = [4, 16, 64, 256, 1024]          # N = 1024: spherical only in --quick
        data["work_precision"] = bench_work_precision(quick, min(repeat, 3), exudyn, sizes)
        _exudyn_from_work_precision(data)
    data["load_end"] = load()
    data["plots"] = plots(data, outdir, stem)
    text = tables(data)
    (outdir / f"{stem}.json").write_text(json.dumps(data, indent=1, default=float))
    (outdir / f"{stem}.md").write_text(text + "\n")
    log("")
    log(text)
    log(f"written: {outdir / (stem + '.json')}, {outdir / (stem + '.md')}, "
        + ", ".join(data["plots"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
