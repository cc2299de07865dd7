"""`spatialmbd fmu`: a model file -> an FMI 2.0 co-simulation FMU (spatialmbd.fmi.export)."""
from __future__ import annotations

import pathlib

from . import common


def add_parser(command) -> None:
    p = command("fmu", "export a model file as an FMI 2.0 co-simulation FMU",
                "Write an FMU (FMI 2.0, co-simulation; optional extra: pip install "
                "'spatialmbd[fmi]') whose inputs are point_force/torque magnitudes or actuator "
                "commands (element names), whose outputs are result columns (<body>.x, "
                "<joint>.angle, <joint>.angle_rate, ...) and whose parameters are model values "
                "by path (bodies.<name>.mass, ...). They default to the model file's fmu: "
                "section; --input/--output/--parameter replace it. Each doStep restarts the "
                "integrator (with error control) at the communication point, inputs held. The "
                "FMU embeds the model file and runs spatialmbd in the importing tool's Python: "
                "spatialmbd must be installed there (docs/fmi.md).",
                """
                spatialmbd fmu crank.yaml -o crank.fmu
                spatialmbd fmu crank.yaml --input drive --output A.angle --output slider.x \\
                    --parameter bodies.slider.mass --step 1e-3 -o crank.fmu
                """)
    p.add_argument("model", metavar="MODEL", help="model file (.yaml, .yml or .json)")
    p.add_argument("-o", "--out", metavar="FILE.fmu", help="FMU to write (default "
                   "<model stem>.fmu)")
    p.add_argument("--input", action="append", metavar="ELEMENT",
                   help="an input: a point_force/torque/actuator name (repeatable)")
    p.add_argument("--output", action="append", metavar="COLUMN",
                   help="an output: a result column (repeatable)")
    p.add_argument("--parameter", action="append", metavar="PATH",
                   help="a parameter: a model value by path (repeatable)")
    p.add_argument("--step", type=float, metavar="S", help="suggested communication step (s)")
    p.add_argument("--stop-time", type=float, metavar="S", help="default stop time (s)")
    p.add_argument("--method", help="method inside doStep (default projection)")
    p.add_argument("--integrator", help="integrator inside doStep (default rk45)")
    p.add_argument("--rtol", type=float, help="relative tolerance (default 1e-8)")
    p.add_argument("--atol", type=float, help="absolute tolerance (default 1e-10)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_fmu)


def cmd_fmu(args) -> int:
    from ..fmi.export import export_fmu
    src = pathlib.Path(args.model)
    common.load(args.model)                      # the whole file checked, problems listed
    out = pathlib.Path(args.out or (src.stem + ".fmu"))
    written = export_fmu(src, out, inputs=args.input, outputs=args.output,
                         parameters=args.parameter, step=args.step, stop_time=args.stop_time,
                         method=args.method, integrator=args.integrator, rtol=args.rtol,
                         atol=args.atol)
    if not args.quiet:
        import zipfile
        from xml.etree import ElementTree
        with zipfile.ZipFile(written) as fmu:
            root = ElementTree.fromstring(fmu.read("modelDescription.xml"))
        counts = {}
        for v in root.iter("ScalarVariable"):
            kind = v.get("causality", "local")
            counts[kind] = counts.get(kind, 0) + 1
        print(f"FMU (FMI 2.0 co-simulation) written to {written}: {counts.get('input', 0)} "
              f"input(s), {counts.get('output', 0)} output(s), "
              f"{counts.get('parameter', 0)} parameter(s)")
    return 0
