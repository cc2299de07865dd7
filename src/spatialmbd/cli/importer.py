"""`spatialmbd import`: an MJCF or URDF file -> a model file."""
from __future__ import annotations

import pathlib

from . import common


def cmd_import(args) -> int:
    src = pathlib.Path(args.input)
    if not src.is_file():
        raise common.UsageError(f"no such MJCF/URDF file: {args.input}")
    builder = common.import_file(src, lenient=args.lenient)
    from ..io.modelfile import save_model
    out = pathlib.Path(args.output or (src.stem + ".yaml"))
    if out.suffix.lower() not in (".yaml", ".yml", ".json"):
        raise common.UsageError(f"output file {str(out)!r}: the name must end in .yaml, .yml "
                                "or .json")
    save_model(builder, out, header=f"imported from {src.name} by spatialmbd import "
                                    "(MuJoCo's compiler)")
    if not args.quiet:
        print(f"{len(builder.bodies)} bodies, {len(builder.joints)} joints, "
              f"{len(builder.forces)} force elements: model written to {out}")
    return 0


def add_parser(command) -> None:
    p = command("import", "convert an MJCF or URDF file to a spatialmbd model file",
                "Read an MJCF (.xml) or URDF (.urdf) file with MuJoCo's compiler (optional "
                "extra: pip install 'spatialmbd[mjcf]') and write the equivalent model file: "
                "bodies with their mass properties, hinge/slide/ball joints as revolute/"
                "translational/spherical joints, connect/weld equalities as exact spherical/"
                "fixed joints. Features with no exact counterpart (tendons, actuators, joint "
                "couplings, contact pairs, ...) are an error naming them, or with --lenient a "
                "warning. `run`, `info` and `animate` also accept these files directly.",
                """
                spatialmbd import robot.urdf -o robot.yaml
                spatialmbd import scene.xml --lenient -o scene.yaml
                spatialmbd run four_bar.xml --t-end 2 -o four_bar.h5
                """)
    p.add_argument("input", metavar="FILE", help="MJCF (.xml) or URDF (.urdf) file")
    p.add_argument("-o", "--output", metavar="MODEL.yaml",
                   help="model file to write (.yaml, .yml or .json); default <stem>.yaml")
    p.add_argument("--lenient", action="store_true",
                   help="leave out features with no exact counterpart, with a warning")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but warnings")
    p.set_defaults(func=cmd_import)
