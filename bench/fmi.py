"""Co-simulation overhead per communication step: an exported FMU stepped by fmpy against the
same integration done directly.

The slider-crank of tests/fmi/test_fmu.py (motor on the crank; input: its torque, outputs:
A.angle, A.angle_rate, D.translation, slider.x) is stepped N times with a fixed communication
step h, the torque changing every step:

    direct    CoSimulation.do_step in Python (the integration alone is timed inside it:
              ``integration_time``, the integrator's integrate() call from t to t + h)
    FMU       fmpy's FMU2Slave: setReal(input), doStep, getReal(outputs) through pythonfmu's
              binary, which calls the same CoSimulation

overhead per step = (FMU wall time - the integration time inside that same run) / N:
everything the co-simulation adds to the integration (the FMI calls, the Python slave, holding
the input, evaluating the outputs). The FMU runs in this process, so its CoSimulation (and the
integration time it records) is found among the live objects after the run. Best of
``--repeat`` runs (the machine may be shared).

    python bench/fmi.py                 # -> bench/results/fmi.md
    python bench/fmi.py --steps 500 --h 1e-3 --rtol 1e-8
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests" / "fmi"))


def torque(t):
    return 0.3 * np.sin(8.0 * t) + 0.1


def direct(model, steps, h, rtol):
    from spatialmbd.fmi.cosim import CoSimulation
    outputs = ["A.angle", "A.angle_rate", "D.translation", "slider.x"]
    sim = CoSimulation(model, ["drive"], outputs, rtol=rtol, atol=rtol * 1e-2)
    start = time.perf_counter()
    for k in range(steps):
        t = k * h
        sim.set_input("drive", torque(t))
        sim.do_step(t, h)
        sim.output_values()
    return time.perf_counter() - start, sim.integration_time, sim.output_values()


def through_fmu(path, steps, h):
    import fmpy
    from fmpy.fmi2 import FMU2Slave
    md = fmpy.read_model_description(str(path))
    unzipped = fmpy.extract(str(path))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    outs = [refs[n] for n in ("A.angle", "A.angle_rate", "D.translation", "slider.x")]
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    drive = [refs["drive"]]
    start = time.perf_counter()
    for k in range(steps):
        t = k * h
        fmu.setReal(drive, [torque(t)])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        values = fmu.getReal(outs)
    wall = time.perf_counter() - start
    import gc
    from spatialmbd.fmi.cosim import CoSimulation
    inside = [o for o in gc.get_objects() if isinstance(o, CoSimulation)
              and o.name.startswith("FMU") and o.steps == steps]
    assert len(inside) == 1, "the FMU's CoSimulation was not found"
    integration = inside[0].integration_time
    fmu.terminate()
    fmu.freeInstance()
    del inside
    gc.collect()
    return wall, integration, np.array(values)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--h", type=float, default=1e-3)
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", default=str(HERE / "results" / "fmi.md"))
    args = parser.parse_args(argv)
    import yaml
    from test_fmu import CRANK, crank_model
    from spatialmbd.fmi.export import export_fmu
    model = crank_model()
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "crank_motor.yaml"
        data = yaml.safe_load(CRANK)
        data["fmu"].update(rtol=args.rtol, atol=args.rtol * 1e-2)
        src.write_text(yaml.safe_dump(data))
        fmu = export_fmu(src, Path(tmp) / "crank_motor.fmu")
        direct(model, 5, args.h, args.rtol)                 # compile / warm up
        through_fmu(fmu, 5, args.h)
        rows = []
        for _ in range(args.repeat):
            wall_d, integ_d, final_d = direct(model, args.steps, args.h, args.rtol)
            wall_f, integ, final_f = through_fmu(fmu, args.steps, args.h)
            rows.append((wall_d - integ_d, integ, wall_f, np.abs(final_d - final_f).max()))
    python, integ, wall_f, diff = min(rows, key=lambda r: r[2] - r[1])
    n = args.steps
    per = lambda x: 1e6 * x / n                                           # noqa: E731
    text = f"""# Co-simulation overhead per communication step (bench/fmi.py)

Slider-crank with a motor (tests/fmi/test_fmu.py), {n} communication steps of h = {args.h:g} s,
rk45 rtol {args.rtol:g} atol {args.rtol * 1e-2:g}, projection method; the torque input changes
every step; 4 outputs (A.angle, A.angle_rate, D.translation, slider.x). Best of {args.repeat}.

| per communication step | us |
|---|---|
| integration (the integrator's integrate() from t to t + h, restarted) | {per(integ):.1f} |
| through the FMU (fmpy setReal, doStep, getReal; pythonfmu; the slave) | {per(wall_f):.1f} |
| **overhead beyond the integration (FMU - its integration)** | **{per(wall_f - integ):.1f}** |
| CoSimulation alone, without FMI (a direct run in Python, beyond its integration) | {per(python):.1f} |

Final outputs, FMU - direct: {diff:.2g} (the same computation).
"""
    Path(args.out).write_text(text)
    print(text)


if __name__ == "__main__":
    main()
