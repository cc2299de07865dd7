"""`spatialmbd optimize`: choose parameters of a model file that minimise an output
(spatialmbd.design.optimize does the work).

    spatialmbd optimize model.yaml --objective 'rms(crank_drive.crank.mx)' \\
        --param bodies.crank.mass=0.2:0.05:2 --constraint 'final(slider.x) >= 0.2' -o best.yaml
"""
from __future__ import annotations

from . import common
from .identify import out_path, params_and_bounds


def add_parser(command) -> None:
    p = command("optimize", "choose model parameters that minimise an output (SLSQP)",
                "Minimise OBJECTIVE (an output reduction(column): peak, trough, rms, mean, "
                "max, final, ...; -OUTPUT maximises, written --objective=-OUTPUT; several "
                "--objective minimise the largest) over the parameters PATH of MODEL, subject to --constraint "
                "'OUTPUT >= VALUE' (or <=, ==), and write the optimised model file (-o) and "
                "a report.",
                """
                spatialmbd optimize pendulum_damped.yaml '--objective=-rms(pendulum.wx)' \\
                    --param forces.pivot_damper.damping=2:0.1:5 \\
                    --constraint 'rms(pendulum.wx) <= 2.45' --t-end 1 -o best.yaml
                spatialmbd optimize model.yaml --objective 'peak(drive.crank.mx)' \\
                    '--objective=-trough(drive.crank.mx)' --param bodies.rod.mass=0.5:0.1:2
                """)
    p.add_argument("model", metavar="MODEL", help="model file (.yaml, .yml or .json)")
    p.add_argument("--objective", action="append", required=True, metavar="OUTPUT",
                   help="what to minimise (repeatable: the largest is minimised)")
    p.add_argument("--param", "-p", action="append", required=True,
                   metavar="PATH[=START[:LOW:HIGH]]", help="a design parameter (repeatable)")
    p.add_argument("--constraint", action="append", metavar="'OUTPUT OP VALUE'",
                   help="a constraint, OP one of >=, <=, == (repeatable)")
    p.add_argument("--optimizer", default="SLSQP",
                   choices=("SLSQP", "trust-constr"), help="SciPy method (default SLSQP)")
    p.add_argument("--jacobian", default="auto", choices=("auto", "adjoint", "forward", "fd"),
                   help="adjoint, forward sensitivities or central differences (default "
                        "auto: docs/design.md)")
    common.add_analysis_options(p)
    p.add_argument("-o", "--out", metavar="FILE",
                   help="optimised model file .yaml/.json (default <model stem>_opt.yaml)")
    p.add_argument("--report", metavar="FILE", help="report text file (default next to -o)")
    p.add_argument("-q", "--quiet", action="store_true", help="no report on the terminal")
    p.set_defaults(func=cmd_optimize)


def cmd_optimize(args) -> int:
    import pathlib

    from ..design import optimize
    _, analysis = common.load(args.model)
    analysis, notes = common.apply_overrides(analysis, args)
    params, bounds = params_and_bounds(args.param)
    out = out_path(args, "_opt.yaml")
    objective = args.objective if len(args.objective) > 1 else args.objective[0]
    best = optimize(args.model, objective, params, constraints=args.constraint,
                    bounds=bounds, method=args.optimizer, analysis=analysis.to_dict(),
                    jacobian=args.jacobian)
    best.write_model(out)
    report = pathlib.Path(args.report) if args.report else out.with_suffix(".txt")
    report.write_text(best.report() + "\n", encoding="utf-8")
    if not args.quiet:
        for note in notes:
            print(f"note: {note}")
        print(best.report())
        print(f"optimised model written to {out}; report to {report}")
    return 0 if best.success else 1
