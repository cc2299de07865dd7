"""Time to first result on a fresh install (issue 12 item 1): cold compile cache vs warm.

Each measurement runs in a subprocess with ``NUMBA_CACHE_DIR`` pointing to a fresh temporary
directory (so nothing compiled earlier on this machine is reused: the library's own cache
locator then uses ``$NUMBA_CACHE_DIR/spatialmbd-<source hash>`` first), and is repeated once
in the same directory to give the warm figure. Measured, in wall-clock seconds:

* ``import spatialmbd``;
* ``spatialmbd demo``: time of the first line on stderr (progress / compile notice),
  of the first line on stdout (the first result) and the total;
* ``spatialmbd run <example>`` likewise.

Usage (from the worktree root; the tree under test is ``src/`` on PYTHONPATH)::

    PYTHONPATH=$PWD/src python bench/coldstart.py [--example examples/pendulum_ch15.yaml]

A cold ``demo`` or ``run`` races (``spatialmbd.cli._race``): the kernels compile in a
background process while the command runs interpreted in a child; the first result comes from
whichever finishes first. Before the warm measurement the script waits for that background
compile (``spatialmbd warmup`` waits for it on its lock).

This is a benchmark, not a test: the cold runs compile the whole hot path (minutes on a
2-core machine: ``spatialmbd warmup`` takes 275 s; bench/compile_profile.py shows where).
"""
from __future__ import annotations

import argparse
import os
import pathlib
import selectors
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _env(cache: str) -> dict:
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = cache
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("NUMBA_DISABLE_JIT", None)
    return env


def timed(cmd, cache: str, cwd: str) -> dict:
    """Run ``cmd``; return the times (s) of the first stderr line, first stdout line, end."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=_env(cache), cwd=cwd)
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ, "out")
    sel.register(proc.stderr, selectors.EVENT_READ, "err")
    first = {"out": None, "err": None}
    open_streams = 2
    while open_streams:
        for key, _ in sel.select():
            line = key.fileobj.readline()
            if not line:
                sel.unregister(key.fileobj)
                open_streams -= 1
                continue
            if first[key.data] is None and line.strip():
                first[key.data] = time.perf_counter() - t0
    rc = proc.wait()
    return {"first_progress": first["err"], "first_result": first["out"],
            "total": time.perf_counter() - t0, "rc": rc}


def _fmt(x):
    return "   -  " if x is None else f"{x:6.2f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--example", default=str(ROOT / "examples" / "pendulum_ch15.yaml"))
    ap.add_argument("--skip-demo", action="store_true")
    ap.add_argument("--skip-run", action="store_true")
    args = ap.parse_args(argv)

    py = sys.executable
    cases = [("import spatialmbd", [py, "-c", "import spatialmbd"])]
    if not args.skip_demo:
        cases.append(("spatialmbd demo", [py, "-m", "spatialmbd", "demo",
                                          "--outdir", "{tmp}/demo"]))
    if not args.skip_run:
        cases.append((f"spatialmbd run {pathlib.Path(args.example).name}",
                      [py, "-m", "spatialmbd", "run", args.example]))
    print(f"{'command':40s} {'cache':5s} {'progress':>8s} {'result':>8s} {'total':>8s}  rc")
    for label, cmd in cases:
        with tempfile.TemporaryDirectory(prefix="smbd-coldstart-") as tmp:
            cache = os.path.join(tmp, "numba-cache")
            os.makedirs(cache)
            argv_ = [a.replace("{tmp}", tmp) for a in cmd]
            for state in ("cold", "warm"):
                if state == "warm" and "import" not in label:   # the cold run's background
                    # compile must have finished
                    subprocess.run([py, "-m", "spatialmbd", "warmup", "--quiet"],
                                   env=_env(cache), cwd=tmp, check=True)
                r = timed(argv_, cache, tmp)
                print(f"{label:40s} {state:5s} {_fmt(r['first_progress']):>8s} "
                      f"{_fmt(r['first_result']):>8s} {_fmt(r['total']):>8s}  {r['rc']}",
                      flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
