"""The same answer on every machine: the rank decisions and the singular-position run repeated
in processes that force different OpenBLAS kernels (OpenBLAS reads OPENBLAS_CORETYPE when it
loads, so each kernel needs its own process).

Haswell (AVX2) and Prescott (SSE3) are the kernels under which the N-four-bar example used to
stall and the Bricard reactions used to be called unique, while SkylakeX passed: the redundant
rows were chosen by a pivoted QR whose ties (equal column norms of symmetric loops) round-off
broke differently per kernel. spatialmbd.rank decides in the model's order instead."""
from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"),
                                reason="OPENBLAS_CORETYPE names x86-64 kernels")

KERNELS = ("Haswell", "Prescott")

SCRIPT = textwrap.dedent("""
    import json, warnings
    from pathlib import Path
    import numpy as np
    from spatialmbd import models
    from spatialmbd.analyses.inverse import inverse_dynamics
    from spatialmbd.io.modelfile import load_model
    from spatialmbd.kinematics import mobility
    from spatialmbd.motion import ConstantVelocity
    from spatialmbd.rotations import A_from_p
    out = {}
    for n in (2, 8):
        mob = mobility(models.n_four_bar(n).compile())
        out[f"n{n}"] = [r[0] for r in mob.redundant]
    b = models.bricard()
    b.add_driver("angle", "drive", ConstantVelocity(rate=0.8), joint="O")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = inverse_dynamics(b.compile(), np.linspace(0.0, 0.5, 3), warn=False)
    out["bricard_unique"] = {k: bool(v.unique) for k, v in res.reactions.items()}
    out["bricard_efforts_unique"] = bool(res.unique)
    model, analysis = load_model(Path(EXAMPLE))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = analysis.run(model)
    k = model.body_index("crank1")
    q = run.q[-1, k]
    out["run"] = [run.status, float(run.t[-1]),
                  (q[:3] + A_from_p(q[3:]) @ np.array([0.0, 0.5, 0.0])).tolist()]
    print(json.dumps(out))
""")


def _in_kernel(kernel: str) -> dict:
    from pathlib import Path
    example = Path(__file__).resolve().parents[1] / "examples" / "n_four_bar.yaml"
    env = dict(os.environ, OPENBLAS_CORETYPE=kernel)
    proc = subprocess.run([sys.executable, "-c", f"EXAMPLE = {str(example)!r}\n" + SCRIPT],
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_rank_decisions_and_the_singular_run_agree_under_every_kernel():
    results = {k: _in_kernel(k) for k in KERNELS}
    first = results[KERNELS[0]]
    for kernel, res in results.items():
        # the same rows left out, the later equations of each loop (couplers' B joints)
        assert res["n2"] == first["n2"] and res["n8"] == first["n8"], kernel
        assert len(res["n2"]) == 6 and len(res["n8"]) == 24
        # the self-stress of the Bricard loop reaches every one of its joints; efforts unique
        assert res["bricard_efforts_unique"], kernel
        assert not any(v for name, v in res["bricard_unique"].items() if name != "drive"), \
            (kernel, res["bricard_unique"])
        # the example passes its 14 flat positions and ends on the parallelogram branch
        status, t_end, tip = res["run"]
        assert status == "success" and t_end == 10.0, kernel
        assert tip == first["run"][2], kernel          # bit for bit: no BLAS in the decisions
