"""`spatialmbd import`: an MJCF or URDF file -> a model file."""
from __future__ import annotations

import pathlib

from . import common


def cmd_import(args) -> int:
    src = pathlib.Path(args.input)
    if not src.is_file():
        raise common.UsageError(f"no such MJCF/URDF file: {args.input}")
    out = pathlib.Path(args.output or (src.stem + ".yaml"))
    if out.suffix.lower() not in (".yaml", ".yml", ".json"):
        raise common.UsageError(f"output file {str(out)!r}: the name must end in .yaml, .yml "
                                "or .json")
    if not (out.parent if str(out.parent) else pathlib.Path(".")).is_dir():
        raise common.UsageError(f"output file {str(out)!r}: directory {str(out.parent)!r} "
                                "does not exist")
    from ..atomic import check_writable
    check_writable(out)
    builder = common.import_file(src, strict=args.strict, verbose=args.verbose,
                                 quiet=args.quiet, keyframe=args.keyframe,
                                 contacts=args.contacts)
    from ..io.modelfile import save_model
    from ..io.sidecar import sidecar_path
    sidecar = sidecar_path(out)
    before = sidecar.stat().st_mtime_ns if sidecar.exists() else None
    save_model(builder, out, header=f"imported from {src.name} by spatialmbd import "
                                    "(MuJoCo's compiler)")
    if not args.quiet:
        meshes = ""
        if sidecar.exists() and sidecar.stat().st_mtime_ns != before:
            meshes = f" (meshes in {sidecar.name}, {sidecar.stat().st_size / 1e6:.2g} MB)"
        print(f"{len(builder.bodies)} bodies, {len(builder.joints)} joints, "
              f"{len(builder.forces)} force elements: model written to {out}{meshes}")
    return 0


def add_parser(command) -> None:
    p = command("import", "convert an MJCF or URDF file to a spatialmbd model file",
                "Read an MJCF (.xml) or URDF (.urdf) file with MuJoCo's compiler (optional "
                "extra: pip install 'spatialmbd[mjcf]') and write the equivalent model file: "
                "bodies with their mass properties, hinge/slide/ball joints as revolute/"
                "translational/spherical joints, connect/weld equalities as exact spherical/"
                "fixed joints; meshes go once each into <output stem>.meshes.npz next to it. "
                "What has no counterpart (tendons, actuators with dynamics, a ball joint's "
                "armature, contacts, ...) is left out and counted in one line (--verbose lists "
                "it; MuJoCo's soft limits and friction loss are approximated by force laws "
                "and listed the same way; --strict refuses the approximations and the "
                "features with no exact counterpart, exit status 2). "
                "`run`, `info`, `animate` and `plot` also accept these files directly, with "
                "the same options (docs/import.md).",
                """
                spatialmbd import robot.urdf -o robot.yaml
                spatialmbd import scene.xml --verbose -o scene.yaml
                spatialmbd import arm.xml --strict -o arm.yaml
                spatialmbd run four_bar.xml --t-end 2 -o four_bar.h5
                """)
    p.add_argument("input", metavar="FILE", help="MJCF (.xml) or URDF (.urdf) file")
    p.add_argument("-o", "--output", metavar="MODEL.yaml",
                   help="model file to write (.yaml, .yml or .json); default <stem>.yaml")
    common.add_import_options(p, model_files=False)
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but warnings")
    p.set_defaults(func=cmd_import)
