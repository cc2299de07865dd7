#!/usr/bin/env python
"""An independent reference for the IFToMM uncontrolled-bicycle manoeuvres, from Exudyn.

    OPENBLAS_NUM_THREADS=1 python bench/bicycle_reference.py      # ~1 min, needs exudyn

The IFToMM benchmark library's "uncontrolled bicycle" runs the Meijaard et al. (2007) bicycle
(models.whipple_bicycle) from upright and straight, pushed sideways:

    M1  4.0 m/s, lean rate 0.05 rad/s   (below the weave speed: the oscillation grows)
    M2  4.6 m/s, lean rate 0.5 rad/s    (self-stable: it dies out)
    M3  8.0 m/s, lean rate 0.05 rad/s   (above the capsize speed: a slow fall)

Its reference solutions are not reachable from here, so this script computes one with a
different code: Exudyn (Euler-parameter rigid bodies, its revolute joints, its exact
``ObjectJointRollingDisc`` for the wheels, generalized-alpha, as bench/loops_peers.py builds it
from the same ModelBuilder) at the fixed steps h = 1.25e-4 s and 6.25e-5 s. It prints the
centres of mass of the four bodies at t = 5 s at the finer step, and the difference between
the two steps (second order: the finer one's error is about a third of it), which
spatialmbd.validation.references stores as the case ``iftomm_bicycle`` (with this provenance).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import loops_peers as lp  # noqa: E402
import peers  # noqa: E402

from spatialmbd import models  # noqa: E402

MANOEUVRES = {"M1": (4.0, 0.05), "M2": (4.6, 0.5), "M3": (8.0, 0.05)}
T_END = 5.0
STEPS = (1.25e-4, 6.25e-5)


def main():
    peers.MIN_SPREAD = 0.0                      # one run each: no timing wanted
    out = {}
    for name, (speed, lean_rate) in MANOEUVRES.items():
        run = lp.exudyn_runner(dict(builder=models.whipple_bicycle(speed, lean_rate),
                                    t_end=T_END))
        coarse, fine = (run(h, t_end=T_END)[1] for h in STEPS)
        out[name] = dict(speed=speed, lean_rate=lean_rate, com=np.round(fine, 12).tolist(),
                         step_difference=float(np.abs(fine - coarse).max()))
        print(f"{name}: step difference {out[name]['step_difference']:.2g} m", flush=True)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
