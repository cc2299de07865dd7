#!/usr/bin/env python
"""Independent references from Exudyn for validation cases whose published reference is only
a plot, or out of reach here.

    OPENBLAS_NUM_THREADS=1 python bench/exudyn_references.py      # ~2 min, needs exudyn

Exudyn (Euler-parameter rigid bodies, its own joints -- revolute, spherical, prismatic, and the
exact ``ObjectJointRollingDisc`` for wheels -- spring-dampers, generalized-alpha) runs the
same ModelBuilder as bench/loops_peers.py builds it, at two fine fixed steps. The script prints
the centres of mass of every body at the end at the finer step, and the difference between the
two steps (second order: the finer one's error is about a third of it), which
spatialmbd.validation.references stores (with this provenance) for:

* ``iftomm_bicycle``: the IFToMM uncontrolled-bicycle manoeuvres of the Meijaard et al. (2007)
  bicycle (models.whipple_bicycle), 5 s, steps 1.25e-4 and 6.25e-5 s:

      M1  4.0 m/s, lean rate 0.05 rad/s   (below the weave speed: the oscillation grows)
      M2  4.6 m/s, lean rate 0.5 rad/s    (self-stable: it dies out)
      M3  8.0 m/s, lean rate 0.05 rad/s   (above the capsize speed: a slow fall)

* ``iftomm_a04``: Bricard's mechanism (models.bricard), 10 s, steps 2e-4 and 1e-4 s (Exudyn's
  copy drops the one redundant equation, as in loops_peers.py);
* ``iftomm_a05``: the flyball governor (models.flyball_governor, stiff), 2 s, steps 5e-5 and
  2.5e-5 s;
* ``spatial_slider_crank``: the IFToMM spatial slider-crank (models.slider_crank_iftomm), 2 s,
  steps 1e-4 and 5e-5 s, started from the consistent velocities spatialmbd's correction gives
  with the crank's 6 rad/s held (energy 0.76643568 J, the published value); its universal
  joint as a generic joint free about the two axes (loops_peers.py);
* ``double_pendulum``: models.double_pendulum (chaotic), 2 s, steps 5e-5 and 2.5e-5 s.
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


def exudyn_com(prob, steps):
    """Centres of mass (nb, 3) at prob["t_end"] at the finer of two steps, and the largest
    difference between the two."""
    run = lp.exudyn_runner(prob)
    coarse, fine = (run(h, t_end=prob["t_end"])[1] for h in steps)
    return np.round(fine, 12).tolist(), float(np.abs(fine - coarse).max())


def main():
    peers.MIN_SPREAD = 0.0                      # one run each: no timing wanted
    out = {"iftomm_bicycle": {}}
    for name, (speed, lean_rate) in MANOEUVRES.items():
        com, diff = exudyn_com(dict(builder=models.whipple_bicycle(speed, lean_rate),
                                    t_end=5.0), (1.25e-4, 6.25e-5))
        out["iftomm_bicycle"][name] = dict(speed=speed, lean_rate=lean_rate, com=com,
                                           step_difference=diff)
        print(f"bicycle {name}: step difference {diff:.2g} m", flush=True)
    for key, t_end, steps in (("bricard", 10.0, (2e-4, 1e-4)),
                              ("flyball", 2.0, (5e-5, 2.5e-5))):
        prob = dict(lp.PROBLEMS[key], key=key, t_end=t_end)
        prob["builder"] = prob["build"]()
        com, diff = exudyn_com(prob, steps)
        out[key] = dict(t_s=t_end, steps=list(steps), com=com, step_difference=diff)
        print(f"{key}: step difference {diff:.2g} m", flush=True)
    b = slider_crank_consistent()
    com, diff = exudyn_com(dict(builder=b, t_end=2.0), (1e-4, 5e-5))
    out["spatial_slider_crank"] = dict(t_s=2.0, steps=[1e-4, 5e-5], com=com,
                                       step_difference=diff)
    print(f"spatial slider-crank: step difference {diff:.2g} m", flush=True)
    com, diff = exudyn_com(dict(builder=models.double_pendulum(), t_end=2.0), (5e-5, 2.5e-5))
    out["double_pendulum"] = dict(t_s=2.0, steps=[5e-5, 2.5e-5], com=com,
                                  step_difference=diff)
    print(f"double pendulum: step difference {diff:.2g} m", flush=True)
    print(json.dumps(out, indent=1))


def slider_crank_consistent():
    """models.slider_crank_iftomm with the velocities of spatialmbd's initial correction,
    the crank's 6 rad/s held."""
    from spatialmbd.simulate import simulate
    b = models.slider_crank_iftomm()
    model = b.compile()
    v0 = simulate(model, 1e-6, output_step=1e-6, method="projection", rtol=1e-12, atol=1e-14,
                  hold={"crank": ["rx"]}).v[0]
    for k, name in enumerate(model.body_names):
        b.bodies[name].rdot, b.bodies[name].omega = v0[k, :3].copy(), v0[k, 3:].copy()
    return b


if __name__ == "__main__":
    main()
