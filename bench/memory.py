"""Memory per output row of a run and of writing its results (issue 16, docs/reliability.md).

Each measurement runs in a fresh subprocess: the one-body pendulum of examples/pendulum_ch15.yaml
over T s with N output rows, then (optionally) the results written as the CLI does
(io.results_io.save_all: CSV and HDF5, the table computed and written in chunks), or
streamed to those files while it runs (io.stream.simulate_to_file, the CLI's way above
--stream-rows). The peak
resident memory (ru_maxrss) of two runs with N1 < N2 rows gives the memory per output row,
(peak2 - peak1) / (N2 - N1), free of the fixed cost (Python, NumPy, Numba kernels).

    PYTHONPATH=src python bench/memory.py            # about a minute
    PYTHONPATH=src python bench/memory.py --rows 10000 200000
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {src!r})
from spatialmbd.io import load_model
from spatialmbd.io.results_io import save_all
from spatialmbd.simulate import simulate
model, _ = load_model({model!r})
t_end, rows, write = {t_end!r}, {rows!r}, {write!r}
start = time.perf_counter()
if write == "stream":
    from spatialmbd.io.stream import simulate_to_file
    res, _ = simulate_to_file(model, t_end, [{csv!r}, {h5!r}], output_step=t_end / (rows - 1))
    res.t = list(range(rows))             # rows written (the tail holds the last chunk)
else:
    res = simulate(model, t_end, output_step=t_end / (rows - 1))
run = time.perf_counter() - start
after_run = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
if write is True:
    save_all(res, [{csv!r}, {h5!r}])
total = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps(dict(rows=len(res.t), run_s=run, total_s=total, peak_run_kb=after_run,
                      peak_kb=peak)))
"""


def measure(rows: int, t_end: float, write: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        code = CHILD.format(src=str(ROOT / "src"), model=str(ROOT / "examples" /
                                                             "pendulum_ch15.yaml"),
                            t_end=t_end, rows=rows, write=write,
                            csv=os.path.join(tmp, "r.csv"), h5=os.path.join(tmp, "r.h5"))
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, nargs=2, default=(10_001, 100_001),
                        metavar=("N1", "N2"))
    parser.add_argument("--t-end", type=float, default=200.0, help="simulated time [s]")
    args = parser.parse_args(argv)
    n1, n2 = args.rows
    print(f"pendulum_ch15, {args.t_end:g} s simulated, rows {n1} and {n2}")
    for write in (False, True, "stream"):
        a, b = measure(n1, args.t_end, write), measure(n2, args.t_end, write)
        key = "peak_kb"
        per_row = (b[key] - a[key]) * 1024 / (b["rows"] - a["rows"])
        label = {False: "simulate only", True: "simulate + write CSV and HDF5",
                 "stream": "streamed to CSV and HDF5"}[write]
        print(f"{label:32s} peak {a[key] / 1024:7.1f} MB / {b[key] / 1024:7.1f} MB, "
              f"{per_row:7.0f} bytes per output row; wall {a['total_s']:.2f} s / "
              f"{b['total_s']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
