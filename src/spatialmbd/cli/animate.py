"""`spatialmbd animate`: an offline HTML animation of a results file or a model file."""
from __future__ import annotations

import pathlib

from . import common


def cmd_animate(args) -> int:
    from ..animation import write_animation
    src = pathlib.Path(args.input)
    outs = common.output_paths(args, src.stem, ".html", (".html", ".htm"))
    status = 0
    if src.suffix.lower() in (".h5", ".hdf5", ".hdf"):
        if not src.exists():
            raise common.UsageError(f"no such results file: {args.input}")
        from ..io.results_io import load_results
        results = load_results(src)
        model = None
        name = (results.model_dict or {}).get("name") if isinstance(results.model_dict, dict) \
            else None
        title = args.title or f"spatialmbd: {name or src.stem}"
    elif src.suffix.lower() == ".csv":
        raise common.UsageError(f"{args.input}: a CSV table holds no geometry; animate an "
                                "HDF5 results file (`spatialmbd run MODEL -o out.h5`) or the "
                                "model file")
    else:
        model, analysis = common.load(args.input, **common.import_options(args, args.input))
        analysis, notes = common.apply_overrides(analysis, args)
        if not args.quiet:
            for note in notes:
                print(f"note: {note}")
        results, wall, warning_texts = common.run_analysis(model, analysis,
                                                           progress=not args.quiet)
        if not args.quiet:
            print(common.summary(results, wall, warning_texts))
        if results.status != "success":
            status = 1
        title = args.title or f"spatialmbd: {model.name}"
    for out in outs:
        write_animation(results, out, model=model, title=title, max_frames=args.max_frames,
                        reactions=getattr(args, "reactions", False),
                        renderer=getattr(args, "renderer", "auto"))
        if not args.quiet:
            print(f"animation written to {out}")
    if status:
        common.err(f"error: the analysis failed; the animation shows the motion up to "
                   f"t = {results.t[-1] if len(results.t) else float('nan'):.6g} s. "
                   f"{results.message}")
    return status


def add_parser(command) -> None:
    p = command("animate", "write an offline HTML animation",
                "Write a self-contained HTML animation (no network needed) of an HDF5 results "
                "file, or of a model file, whose analysis is run first (the analysis options "
                "apply then). Default output: <input stem>.html in the current directory.",
                """
                spatialmbd animate pendulum.h5 -o pendulum.html
                spatialmbd animate four_bar.yaml --t-end 2 -o four_bar.html
                """)
    p.add_argument("input", metavar="RESULTS_OR_MODEL",
                   help="HDF5 results file (.h5) or model file")
    p.add_argument("-o", "--output", action="append", metavar="FILE.html",
                   help="HTML file to write")
    p.add_argument("--max-frames", type=int, default=1000, metavar="N",
                   help="at most N frames, evenly spread (default 1000)")
    p.add_argument("--title", help="page title")
    p.add_argument("--renderer", choices=("auto", "canvas"), default="auto",
                   help="auto: WebGL (three.js embedded) with the Canvas renderer as fallback; "
                        "canvas: Canvas only, a much smaller page")
    p.add_argument("--reactions", action="store_true",
                   help="draw the joint reaction forces as arrows (model files only)")
    common.add_analysis_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    common.add_import_options(p)
    p.set_defaults(func=cmd_animate)
