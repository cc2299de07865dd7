"""A long run streamed to its result files with bounded memory (docs/reliability.md,
"Streaming").

    python examples/streaming/long_run_to_hdf5.py [out.h5]
"""
import sys

from spatialmbd import models
from spatialmbd.io.results_io import load_results
from spatialmbd.io.stream import simulate_to_file

path = sys.argv[1] if len(sys.argv) > 1 else "long_run.h5"
model = models.double_pendulum().compile()
tail, written = simulate_to_file(model, 20.0, path, output_step=0.002, chunk_rows=2000,
                                 integrator="rk45")
rows, columns = written[next(iter(written))]
print(f"{tail.status}: {rows} rows, {columns} columns -> {path}")
res = load_results(path)
print(f"status {res.metadata['status']}, t = {res.t[0]} .. {res.t[-1]} s, "
      f"q {res.q.shape}, lam {res.lam.shape}")
