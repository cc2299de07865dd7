"""A long run streamed to HDF5 with bounded memory (docs/reliability.md, "Streaming").

    PYTHONPATH=src python examples/streaming/long_run_to_hdf5.py [out.h5]
"""
import sys

from spatialmbd import models
from spatialmbd.io.stream import read_stream, simulate_to_file

path = sys.argv[1] if len(sys.argv) > 1 else "long_run.h5"
model = models.double_pendulum().compile()
info = simulate_to_file(model, 20.0, path, segment=5.0, output_step=0.002, integrator="rk45")
print(f"{info['status']}: {info['rows']} rows in {info['segments']} segments -> {path}")
data = read_stream(path)
print(f"status {data['status']}, t = {data['t'][0]} .. {data['t'][-1]} s, "
      f"q {data['q'].shape}, lam {data['lam'].shape}")
