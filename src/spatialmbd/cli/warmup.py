"""`spatialmbd warmup`: compile every numerical kernel into the on-disk cache."""
from __future__ import annotations


def _warm_batch():
    from .. import models
    from ..io import Analysis
    from ..sweep.batch import simulate_batch
    pendulum = models.pendulum_ch15().compile()
    for integrator in ("rk45", "rk4"):
        simulate_batch([pendulum], Analysis(t_end=1e-3, output_step=1e-3, method="standard",
                                            integrator=integrator, step=1e-3 if integrator ==
                                            "rk4" else None))
    simulate_batch([pendulum], Analysis(t_end=1e-3, output_step=1e-3, method="recursive"))
    import numpy as np
    from ..sweep.outputs import period
    period(np.linspace(0.0, 1.0, 5), np.linspace(-1.0, 1.0, 5))       # compiled crossings


def cmd_warmup(args) -> int:
    """Compile every kernel now (each method, the integrators' fused stages, kinematics, the
    force elements), so that later runs start at once."""
    import time
    from ..jit import cache_is_warm, compile_notice, mark_warm, warmup_lock
    from .. import models
    from ..kinematics import kinematic_analysis
    from ..simulate import simulate
    start = time.perf_counter()
    warm = cache_is_warm()
    steps = [("kinematics", lambda: kinematic_analysis(
        models.slider_crank(crank_speed=6.0).compile(), [0.0, 0.01]))]
    fly = models.flyball_governor().compile()
    for method in ("standard", "baumgarte", "penalty", "augmented_lagrangian", "projection"):
        steps.append((f"dynamics, {method}", lambda m=method: simulate(
            fly, 1e-3, method=m, integrator="rk45", output_step=1e-3)))
    chain = models.chain(2, "revolute").compile()
    steps.append(("dynamics, recursive", lambda: simulate(chain, 1e-3, method="recursive",
                                                          output_step=1e-3)))
    steps.append(("fixed-step and implicit integrators", lambda: [
        simulate(fly, 2e-3, integrator=i, step=1e-3) for i in ("rk4", "bdf4")]))
    # dop853's own kernels (error norm, dense output) for the runs the Python driver takes
    # (events, a first_step, ...); its compiled loops are rk45's, already warm
    steps.append(("dop853 stepper", lambda: simulate(
        fly, 2e-3, integrator="dop853", integrator_options=dict(first_step=1e-4),
        output_step=1e-3)))
    steps.append(("batch engine of sweeps", _warm_batch))                  # issue 15
    with warmup_lock(), compile_notice(force=not warm and not args.quiet, every=10.0):
        for k, (what, run) in enumerate(steps):
            if not args.quiet:
                print(f"[{k + 1}/{len(steps)}] {what}", flush=True)
            run()
        mark_warm()
    if not args.quiet:
        print(f"ready in {time.perf_counter() - start:.1f} s"
              + (" (the cache was already warm)" if warm else ""))
    return 0


def add_parser(command) -> None:
    p = command("warmup", "compile the numerical kernels now (once per machine)",
                "Compile every numerical kernel (all methods, integrators, kinematics, force "
                "elements) into the on-disk cache, with progress, so that later runs start at "
                "once. Otherwise this happens on the first run, which then says so.",
                """
                spatialmbd warmup
                """)
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_warmup)
