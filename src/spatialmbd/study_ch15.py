"""The demonstrative example of the text's chapter 15: the simple pendulum solved with the
standard (Lagrange multipliers), Baumgarte, penalty and augmented Lagrangian methods (and the
projection method of this library), Fig. 15.2 and Table 15.3, plus a check of the physics
against the exact large-amplitude solution.

Run ``python -m spatialmbd.study_ch15 [outdir] [--quick]``, or call :func:`run_study`.

Geometry (Table 15.1 gives only the length 1.0 m, the mass 7.02 kg and the inertias
(0.5855265, 0.0010530, 0.5855265) kg m^2, those of a 1 m solid cylinder along body y; ERRATA):
the pivot is at one end, at the global origin, the revolute axis is global x, the pendulum
starts at rest in the horizontal xy-plane along +y (centre of mass at (0, 0.5, 0)), gravity
9.81 m/s^2 along -z (models.pendulum_ch15).

Settings (Table 15.2): adaptive Runge-Kutta 5(4) (Dormand-Prince, "rk45", the ode45 of the text),
rtol 1e-6, atol 1e-9, output every 0.02 s, 10 s; Baumgarte alpha = beta = 5; penalty
alpha = 1e7, omega = 10, mu = 1; augmented Lagrangian with the same penalty parameters. As in
the text no initial-condition correction is applied (the initial conditions are consistent).

Physics check: the body is a physical pendulum about x with I_O = I_xx + m d^2 (d = 0.5 m),
released from theta0 = pi/2 (angle from the downward vertical):
    sin(theta/2) = k sn(K(k^2) - omega0 t | k^2), k = sin(theta0/2), omega0^2 = m g d / I_O,
    period T = 4 sqrt(I_O / (m g d)) K(k^2)        (scipy's ellipk takes m = k^2),
and the joint reaction on the body R = m a_c - m g (a_c from theta, theta', theta'').
Tolerances derived from rtol: every accepted step commits a local error of at most
rtol |y| + atol per component, so after N accepted steps the global error of a quantity of
size ``scale`` is bounded by N (rtol scale + atol) when errors accumulate linearly; the
perturbation growth of the pendulum (G, computed from the exact solution and reported) is
more than compensated by the fifth-order propagated solution (the 5(4) estimate bounds the
fourth-order one). The reaction tolerance follows from the angle and rate tolerances through
dR = m d ((omega0^2 + theta'^2) d theta + 2 |theta'| d theta').
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from . import models
from .rotations import A_from_p
from .simulate import simulate
from .validation.core import hermite_crossings
from .validation.exact import PhysicalPendulum

#: Table 15.2 of the text.
SETTINGS = dict(t_end=10.0, output_step=0.02, integrator="rk45", rtol=1e-6, atol=1e-9)
BAUMGARTE = dict(alpha=5.0, beta=5.0)
PENALTY = dict(alpha=1e7, omega=10.0, mu=1.0)

#: (key, label, method options, text's Table 15.3 function evaluations, time in s)
METHODS = [
    ("standard", "Standard", {}, 1639, 6.3),
    ("baumgarte", "Baumgarte", BAUMGARTE, 2401, 10.7),
    ("penalty", "Penalty", PENALTY, 3769, 17.2),
    ("augmented_lagrangian", "Augmented Lagrangian", dict(PENALTY, project=False), 3769, 17.6),
    ("projection", "Projection (not in the text)", {}, None, None),
]

GEOMETRY = ("Pendulum (Table 15.1; geometry assumed, ERRATA): 1.0 m solid cylinder along body y, "
            "m = 7.02 kg, centroidal inertia (0.5855265, 0.0010530, 0.5855265) kg m^2; pivot at "
            "one end at the origin, revolute axis global x; released at rest along +y "
            "(centre of mass (0, 0.5, 0), d = 0.5 m), gravity 9.81 m/s^2 along -z.")

#: The methods whose multipliers satisfy D vdot = gamma exactly at every state: their reaction
#: must equal the exact reaction evaluated at the simulated state up to round-off.
EXACT_MULTIPLIER_METHODS = ("standard", "projection")


class StudyReport(dict):
    """The study's results (a dict) that prints as a readable report."""

    def __str__(self) -> str:
        return self["report"]


def exact_pendulum(builder=None) -> PhysicalPendulum:
    b = builder or models.pendulum_ch15()
    body = b.bodies["pendulum"]
    joint = b.joints["pivot"]
    return PhysicalPendulum(body.mass, body.inertia, body.r, A_from_p(body.p),
                            joint.geometry["point"], joint.geometry["axis"], b.gravity)


def _physics(res, pend: PhysicalPendulum, key: str, reac) -> dict:
    """Errors of one run against the exact solution, with rtol-derived tolerances."""
    rtol, atol = SETTINGS["rtol"], SETTINGS["atol"]
    t = res.t
    ex = pend.motion(t)
    A = A_from_p(res.q[:, 0, 3:])
    theta = pend.angle_of(A)
    theta_dot = res.v[:, 0, 3:] @ pend.w
    n_steps = int(res.counters["steps"])
    thd_max = float(np.abs(ex.theta_dot).max())
    tol_theta = n_steps * (rtol * 1.0 + atol)               # Euler parameters are of size 1
    tol_thd = n_steps * (rtol * thd_max + atol)
    md = pend.m * pend.d
    tol_force = md * ((pend.omega0**2 + thd_max**2) * tol_theta + 2 * thd_max * tol_thd)
    err_theta = float(np.abs(theta - ex.theta).max())
    err_thd = float(np.abs(theta_dot - ex.theta_dot).max())
    err_force = float(np.abs(reac.force_j - ex.force_on_body).max())
    err_moment = float(np.abs(reac.moment_j - ex.moment_on_body).max())
    err_r = float(np.abs(res.body("pendulum")["r"] - ex.r).max())
    # the reaction at the simulated state (isolates the multipliers from integration error)
    at_state = pend.motion_at(t, theta, theta_dot)
    err_force_state = float(np.abs(reac.force_j - at_state.force_on_body).max())
    # action = reaction
    err_newton3 = float(np.abs(reac.force_i + reac.force_j).max())
    # period from the zero crossings of theta (cubic Hermite on theta, theta')
    tc = hermite_crossings(t, theta, theta_dot)
    tc_exact = pend.crossing_times(t[-1])
    n = min(len(tc), len(tc_exact))
    tol_tc = tol_theta / thd_max
    err_tc = float(np.abs(tc[:n] - tc_exact[:n]).max()) if n else np.nan
    if n >= 2:
        period = 2.0 * (tc[n - 1] - tc[0]) / (n - 1)       # crossings every half period
        tol_period = 2.0 * 2.0 * tol_tc / (n - 1)
    else:
        period, tol_period = np.nan, np.nan
    energy = res.energy()["total"]
    checks = {
        "angle": (err_theta, tol_theta),
        "angular rate": (err_thd, tol_thd),
        "reaction force (trajectory)": (err_force, tol_force),
        "crossing times": (err_tc, tol_tc),
        "period": (abs(period - pend.period), tol_period),
        "reaction moment": (err_moment, 1e-9 * float(np.abs(ex.force_on_body).max())),
        "action = reaction": (err_newton3, 1e-12 * float(np.abs(ex.force_on_body).max())),
    }
    if key in EXACT_MULTIPLIER_METHODS:
        checks["reaction force (at state)"] = (err_force_state,
                                               1e-9 * float(np.abs(ex.force_on_body).max()))
    return dict(errors=dict(angle=err_theta, angular_rate=err_thd, centre_of_mass=err_r,
                            reaction_force=err_force, reaction_force_at_state=err_force_state,
                            reaction_moment=err_moment, crossing_times=err_tc,
                            period=abs(period - pend.period),
                            energy_drift=float(np.abs(energy - energy[0]).max())),
                period=period, n_crossings=n, checks=checks,
                passed=bool(all(e <= tol for e, tol in checks.values())))


def _figure(outdir: Path, runs: dict, t_end: float) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    floor = 1e-32
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for key, run in runs.items():
        ax.semilogy(run["t"], np.maximum(run["phi_squared"], floor), label=run["label"], lw=1.2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(r"$\Phi^T\Phi$ (m$^2$)")
    ax.set_xlim(0, t_end)
    ax.set_title(r"Simple pendulum: constraint violation $\Phi^T\Phi$ (cf. Fig. 15.2)"
                 f"\n(values below {floor:g} drawn at {floor:g})", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = outdir / "fig15_2_constraint_violation.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _physics_figure(outdir: Path, runs: dict, pend: PhysicalPendulum) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
    for key, run in runs.items():
        a1.semilogy(run["t"], np.maximum(np.abs(run["theta_error"]), 1e-16), label=run["label"],
                    lw=1)
        a2.semilogy(run["t"], np.maximum(run["force_error"], 1e-16), lw=1)
    a1.set_ylabel("|angle error| (rad)")
    a2.set_ylabel("|reaction force error| (N)")
    a2.set_xlabel("time (s)")
    a1.set_title(f"Against the exact solution (period T = {pend.period:.9f} s)", fontsize=10)
    a1.legend(fontsize=8)
    for a in (a1, a2):
        a.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path = outdir / "pendulum_exact_errors.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _tables(outdir: Path, rows: list) -> tuple[Path, Path, str]:
    head = ["method", "function evaluations", "wall time (s)", "steps", "rejected",
            "max Phi^T Phi", "text: function evaluations", "text: time (s)"]
    csv_path = outdir / "table15_3.csv"
    with open(csv_path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        for r in rows:
            w.writerow([r["label"], r["nfev"], f"{r['wall_time']:.3f}", r["steps"], r["rejected"],
                        f"{r['max_phi_squared']:.3e}", "" if r["text_nfev"] is None
                        else r["text_nfev"], "" if r["text_time"] is None else r["text_time"]])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append(f"| {r['label']} | {r['nfev']} | {r['wall_time']:.2f} | {r['steps']} | "
                     f"{r['rejected']} | {r['max_phi_squared']:.2e} | "
                     f"{'-' if r['text_nfev'] is None else r['text_nfev']} | "
                     f"{'-' if r['text_time'] is None else r['text_time']} |")
    md = "\n".join(lines)
    md_path = outdir / "table15_3.md"
    md_path.write_text("Table 15.3 (function evaluations and time consumed), ours beside the "
                       "text's.\n\n" + md + "\n")
    return csv_path, md_path, md


_INTERPRETED_NOTE = ("; INTERPRETED: this run did not wait for the compiled kernels, so its "
                     "wall times are not representative -- run it again once they are built")


def _jit_enabled() -> bool:
    from . import jit
    return jit.ENABLED


def run_study(outdir, quick: bool = False, methods=None, echo=None) -> StudyReport:
    """Run the chapter 15 study; write the figure and tables to ``outdir``.

    quick=True simulates 2 s instead of 10 s (for CI). ``methods``: a subset of the method
    keys (default all five). echo: called with a line of text as each method's run finishes
    (its figures, before the full report). Returns a :class:`StudyReport` (dict; ``print``
    it).
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    t_end = 2.0 if quick else SETTINGS["t_end"]
    builder = models.pendulum_ch15()
    model = builder.compile()
    pend = exact_pendulum(builder)
    runs, rows, physics = {}, [], {}
    for key, label, options, text_nfev, text_time in METHODS:
        if methods is not None and key not in methods:
            continue
        # warm-up (compilation and caches of a first call), so that the timed run measures
        # the integration alone
        simulate(model, 2 * SETTINGS["output_step"], method=key, method_options=options,
                 integrator=SETTINGS["integrator"], rtol=SETTINGS["rtol"],
                 atol=SETTINGS["atol"], output_step=SETTINGS["output_step"],
                 correct_initial=False)
        start = time.perf_counter()
        res = simulate(model, t_end, method=key, method_options=options,
                       integrator=SETTINGS["integrator"], rtol=SETTINGS["rtol"],
                       atol=SETTINGS["atol"], output_step=SETTINGS["output_step"],
                       correct_initial=False)
        total = time.perf_counter() - start
        if not res.success:
            raise RuntimeError(f"{label}: {res.message}")
        viol = res.constraint_violation()
        reac = res.reactions()["pivot"]
        phys = _physics(res, pend, key, reac)
        physics[key] = phys
        ex = pend.motion(res.t)
        theta = pend.angle_of(A_from_p(res.q[:, 0, 3:]))
        runs[key] = dict(label=label, t=res.t, phi_squared=viol["phi_squared"],
                         theta_error=theta - ex.theta,
                         force_error=np.linalg.norm(reac.force_j
                                                    - ex.force_on_body, axis=1))
        rows.append(dict(key=key, label=label, nfev=int(res.counters["nfev"]),
                         steps=int(res.counters["steps"]),
                         rejected=int(res.counters["rejected"]), wall_time=res.wall_time,
                         total_time=total, max_phi_squared=float(viol["phi_squared"].max()),
                         final_phi_squared=float(viol["phi_squared"][-1]),
                         text_nfev=None if quick else text_nfev,
                         text_time=None if quick else text_time))
        if echo is not None:
            r = rows[-1]
            echo(f"{label}: {r['nfev']} function evaluations, {r['steps']} steps, max "
                 f"Phi^T Phi {r['max_phi_squared']:.3g}, angle error "
                 f"{phys['checks']['angle'][0]:.2e} rad against the exact solution"
                 + ("" if quick or text_nfev is None else f" (text: {text_nfev} evaluations)"))
    fig = _figure(outdir, runs, t_end)
    fig2 = _physics_figure(outdir, runs, pend)
    csv_path, md_path, md = _tables(outdir, rows)
    growth = pend.amplification(t_end)

    lines = ["Chapter 15 study: simple pendulum" + (" (quick: 2 s)" if quick else ""), "",
             GEOMETRY,
             f"Settings (Table 15.2): {SETTINGS['integrator']} (Dormand-Prince 5(4)), rtol "
             f"{SETTINGS['rtol']:g}, atol {SETTINGS['atol']:g}, output every "
             f"{SETTINGS['output_step']} s, {t_end:g} s; Baumgarte alpha = beta = 5; penalty "
             "and augmented Lagrangian alpha = 1e7, omega = 10, mu = 1.", "",
             "Table 15.3 (ours; the text's figures beside; wall time = integration only, "
             "after a warm-up run" + (_INTERPRETED_NOTE if not _jit_enabled() else "") + "):",
             md,
             "", f"Exact solution: I_O = {pend.I_O:.7f} kg m^2, omega0 = {pend.omega0:.9f} rad/s, "
             f"period T = 4 K(1/2) / omega0 = {pend.period:.9f} s; perturbation growth over "
             f"the run G = {growth:.3g}.",
             "Max errors against it (tolerance = rtol-derived bound, see module docstring):"]
    for key, phys in physics.items():
        label = next(r["label"] for r in rows if r["key"] == key)
        lines.append(f"  {label}: " + ", ".join(
            f"{name} {err:.2e} (tol {tol:.1e})" for name, (err, tol) in phys["checks"].items())
            + ("" if phys["passed"] else "  ** FAILED **"))
        if np.isfinite(phys["period"]):
            lines.append(f"      period from {phys['n_crossings']} zero crossings "
                         f"{phys['period']:.9f} s, energy drift "
                         f"{phys['errors']['energy_drift']:.2e} J")
    lines += ["", f"Figure: {fig}", f"Figure: {fig2}", f"Tables: {csv_path}, {md_path}"]
    return StudyReport(
        report="\n".join(lines), geometry=GEOMETRY, settings=dict(SETTINGS, t_end=t_end),
        table=rows, physics=physics, exact=dict(I_O=pend.I_O, omega0=pend.omega0,
                                                period=pend.period, amplification=growth),
        figure=str(fig), physics_figure=str(fig2), csv=str(csv_path), markdown=str(md_path),
        passed=all(p["passed"] for p in physics.values()))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("outdir", nargs="?", default="study_ch15")
    parser.add_argument("--quick", action="store_true", help="2 s instead of 10 s")
    args = parser.parse_args(argv)
    report = run_study(args.outdir, quick=args.quick)
    print(report)
    return 0 if report["passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
