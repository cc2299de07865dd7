#!/usr/bin/env python
"""A 29-joint humanoid with joint limits, rotor inertia, joint friction and position servos:
spatialmbd against MuJoCo, in one run, at equal accuracy.

    OPENBLAS_NUM_THREADS=1 python bench/humanoid_g1.py --xml PATH/TO/g1_29dof.xml

The model is Unitree's G1 (29 hinge joints; the file ``unitree_robots/g1/g1_29dof.xml`` of the
public repository ``unitreerobotics/unitree_mujoco``, with its meshes folder next to it). The
bench changes it, for both codes alike, through MuJoCo's ``MjSpec`` and writes the result to
a temporary folder:

* the base is fixed (the free joint of the pelvis is removed), so gravity loads every joint;
* contact is disabled (this bench is about the joints, not the feet);
* each torque motor becomes a position servo, kp = 100 N m/rad, kv = 5 N m s/rad, with the
  joint's ``actuatorfrcrange`` moved onto the actuator's force range (the importer maps
  actuator force ranges; it leaves joint actuator force ranges out);
* a keyframe ``step`` commands every joint to 0.3 rad (clipped 0.1 rad inside its range) from
  the zero pose: a servo step response against gravity, armature 0.01 kg m^2, damping 0.05,
  friction loss 0.1-0.2 N m and the joint limits all kept from the file.

Accuracy: each code against its own converged solution of the model (spatialmbd: dop853 at
rtol 1e-11; MuJoCo: RK4 at h = 2.5e-6 s, whose agreement with h = 5e-6 s is printed), as the
largest distance between a body's centre of mass at t = 1 s (MuJoCo's ``xipos``) and that
reference. The two references are
compared too: they differ by the friction-loss and limit models (MuJoCo's soft constraints
against our regularized Coulomb friction and compliant limits, docs/import.md).

Timing: minimum of 3 repetitions of the integration alone (spatialmbd's
``Results.wall_time``; MuJoCo's ``mj_step(m, d, n)`` loop in C), after a warm-up run. The
machine is shared and noisy: ratios within ~1.5x are not conclusive.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

KP, KV, TARGET = 100.0, 5.0, 0.3


def servo_variant(xml: Path, out: Path) -> Path:
    """Write the bench's variant of the humanoid (see the module docstring) to ``out``."""
    import mujoco
    spec = mujoco.MjSpec.from_file(str(xml))
    spec.meshdir = str((xml.parent / (spec.meshdir or "")).resolve())
    root = spec.worldbody.first_body()
    for j in list(root.joints):
        if j.type == mujoco.mjtJoint.mjJNT_FREE:
            spec.delete(j)
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    targets = []
    for a in spec.actuators:
        joint = spec.joint(a.target)
        lo, hi = joint.range
        force_range = np.array(joint.actfrcrange, dtype=float)
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
        a.set_to_position(kp=KP, kv=KV)
        a.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
        if force_range[1] > force_range[0]:
            a.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            a.forcerange = force_range
        targets.append(float(np.clip(TARGET, lo + 0.1, hi - 0.1)))
    spec.add_key(name="step", ctrl=targets)
    spec.compile()
    out.write_text(spec.to_xml())
    return out


def mujoco_runs(xml: Path, names, steps, integrators=("RK4", "IMPLICITFAST")):
    """MuJoCo's runs; positions of the bodies ``names`` (spatialmbd's order)."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(xml))
    key = m.key("step").id
    ids = [m.body(name).id for name in names]

    def run(h, integ="RK4"):
        m.opt.timestep = h
        m.opt.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + integ)
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, key)
        t0 = time.perf_counter()
        mujoco.mj_step(m, d, int(round(1.0 / h)))
        return d.xipos[ids].copy(), time.perf_counter() - t0

    ref, _ = run(2.5e-6)
    half, _ = run(5e-6)
    limits = limit_activity(m, key)
    rows = []
    for integ in integrators:
        for h in steps:
            x, _ = run(h, integ)
            wall = min(run(h, integ)[1] for _ in range(3))
            rows.append(dict(code="MuJoCo", setting=f"{integ} h={h:g}",
                             error=float(np.linalg.norm(x - ref, axis=1).max()), wall=wall,
                             steps=int(round(1.0 / h))))
    return rows, ref, float(np.linalg.norm(half - ref, axis=1).max()), limits


def limit_activity(m, key) -> int:
    """Largest number of joint-limit constraints MuJoCo has active at once (RK4, 1e-4 s)."""
    import mujoco
    m.opt.timestep = 1e-4
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, key)
    most = 0
    for _ in range(10000):
        mujoco.mj_step(m, d)
        most = max(most, int(np.sum(d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)))
    return most


def spatialmbd_runs(xml: Path, rtols, integrators=("rk45", "dop853")):
    from spatialmbd.importers import import_mjcf
    from spatialmbd.simulate import simulate
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # the import's summary of approximations
        model = import_mjcf(str(xml), keyframe="step").compile()
    print(f"spatialmbd: {model.nb} bodies", flush=True)
    names = list(model.body_names)

    def origins(res):
        return res.q[-1, :, :3]

    ref = simulate(model, 1.0, integrator="dop853", rtol=1e-11, atol=1e-13, output_step=0.01)
    rows = []
    for integ in integrators:
        for rtol in rtols:
            simulate(model, 1.0, integrator=integ, rtol=rtol, output_step=0.01)   # warm-up
            best = None
            for _ in range(3):
                res = simulate(model, 1.0, integrator=integ, rtol=rtol, output_step=0.01)
                if best is None or res.wall_time < best.wall_time:
                    best = res
            rows.append(dict(code="spatialmbd", setting=f"{integ} rtol={rtol:g}",
                             error=float(np.linalg.norm(origins(best) - origins(ref),
                                                        axis=1).max()),
                             wall=float(best.wall_time),
                             steps=int(best.counters.get("steps", 0))))
    return rows, origins(ref), names, ref


def cross_check(xml: Path, names, times=(0.1, 1.0)) -> dict:
    """Largest centre-of-mass difference between the two codes' converged runs (spatialmbd
    dop853 at rtol 1e-10, MuJoCo RK4 at 1e-5 s) at ``times``, with the file's friction loss and
    with friction loss 0: what of the difference the friction-loss model makes."""
    import re
    import mujoco
    from spatialmbd.importers import import_mjcf
    from spatialmbd.simulate import simulate
    out = {}
    for label, text in (("friction loss kept", xml.read_text()),
                        ("friction loss 0", re.sub(r'frictionloss="[^"]*"', 'frictionloss="0"',
                                                   xml.read_text()))):
        variant = xml.with_name(f"cross_{len(out)}.xml")
        variant.write_text(text)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = import_mjcf(str(variant), keyframe="step").compile()
        m = mujoco.MjModel.from_xml_path(str(variant))
        ids = [m.body(name).id for name in names]
        for T in times:
            m.opt.timestep = 1e-5
            d = mujoco.MjData(m)
            mujoco.mj_resetDataKeyframe(m, d, m.key("step").id)
            mujoco.mj_step(m, d, int(round(T / 1e-5)))
            res = simulate(model, T, integrator="dop853", rtol=1e-10, output_step=T / 10)
            out[(label, T)] = float(np.linalg.norm(res.q[-1, :, :3] - d.xipos[ids],
                                                   axis=1).max())
    return out


def cheapest(rows, error):
    ok = [r for r in rows if r["error"] <= error]
    return min(ok, key=lambda r: r["wall"]) if ok else None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--xml", required=True, type=Path,
                    help="g1_29dof.xml of unitreerobotics/unitree_mujoco (meshes next to it)")
    ap.add_argument("-o", default=str(Path(__file__).parent / "results" / "humanoid_g1.md"))
    args = ap.parse_args(argv)
    if not args.xml.is_file():
        print(f"humanoid bench: no file {args.xml}: give --xml the path of g1_29dof.xml",
              file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        xml = servo_variant(args.xml, Path(tmp) / "g1_servo.xml")
        ours, our_ref, names, _ = spatialmbd_runs(xml, [1e-4, 1e-5, 1e-6, 1e-7, 1e-8])
        theirs, mj_ref, mj_self, limits = mujoco_runs(
            xml, names, [1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5])
        cross_table = cross_check(xml, names)
    cross = float(np.linalg.norm(our_ref - mj_ref, axis=1).max())
    lines = ["# A 29-joint humanoid (Unitree G1) with limits, armature, friction and servos",
             "", f"Measured {time.strftime('%Y-%m-%d')} by `bench/humanoid_g1.py` (see its "
             "docstring for the model and the measures). 1 s simulated, fixed base, servo step "
             "to 0.3 rad on all 29 joints. Load average at the end: "
             + ", ".join(f"{x:.1f}" for x in os.getloadavg()) + " (2 cores).", "",
             f"- MuJoCo's reference (RK4, h = 2.5e-6 s) against h = 5e-6 s: {mj_self:.2e} m "
             "(its constraint solver's tolerance bounds how far RK4 converges).",
             f"- spatialmbd's reference against MuJoCo's: {cross:.2e} m (friction loss and "
             "limit models differ, docs/import.md).",
             "- the same, converged runs of both codes, with and without the friction loss: "
             + "; ".join(f"{label}, t = {T:g} s: {v:.1e} m"
                         for (label, T), v in cross_table.items()) + ".",
             f"- joint limits active at once in MuJoCo's run: at most {limits}.", "",
             "| code | setting | steps | wall (s) | error (m) |", "|---|---|---|---|---|"]
    for r in ours + theirs:
        lines.append(f"| {r['code']} | {r['setting']} | {r['steps']} | {r['wall']:.4f} | "
                     f"{r['error']:.2e} |")
    lines += ["", "Ratios (spatialmbd wall / MuJoCo wall, MuJoCo at its cheapest setting with "
              "an error at most spatialmbd's):", ""]
    for r in ours:
        peer = cheapest(theirs, r["error"])
        ratio = f"{r['wall'] / peer['wall']:.2f}x ({peer['setting']})" if peer else \
            "MuJoCo reaches no setting this accurate here"
        lines.append(f"- spatialmbd {r['setting']} (error {r['error']:.1e} m): {ratio}")
    text = "\n".join(lines) + "\n"
    print(text)
    Path(args.o).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
