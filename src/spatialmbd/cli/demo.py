"""`spatialmbd demo`: the chapter 15 study."""
from __future__ import annotations

import pathlib
import textwrap

from . import common


def cmd_demo(args) -> int:
    try:
        from ..study_ch15 import run_study
    except ImportError as exc:
        raise common.UsageError(f"the chapter 15 study is not available in this installation "
                                f"({exc})") from None
    from ..atomic import check_writable
    outdir = pathlib.Path(args.outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"cannot write into {outdir}: {exc.strerror or exc}") from exc
    check_writable(outdir / "table15_3.csv")      # before the study runs
    try:
        echo = None if args.quiet else (lambda line: print(line, flush=True))
        out = run_study(outdir, quick=args.quick, echo=echo)
    except RuntimeError as exc:                 # a method of the study failed to integrate
        common.err(f"error: the study failed: {exc}")
        return 1
    if not args.quiet:
        print()
        if isinstance(out, dict) and isinstance(out.get("report"), str):
            print(out["report"])
        elif isinstance(out, dict) and type(out).__str__ is dict.__str__:
            _print_mapping(out)
        else:
            print(out)
    if isinstance(out, dict) and out.get("passed") is False:
        common.err("error: some results of the study disagree with the exact solution beyond "
                   "their tolerance (marked FAILED in the report)")
        return 1
    return 0


def _print_mapping(out) -> None:
    if not isinstance(out, dict):
        if out is not None:
            print(out)
        return
    for key, value in out.items():
        if isinstance(value, str) and "\n" in value:
            print(f"{key}:")
            print(textwrap.indent(value, "  "))
        elif isinstance(value, (str, pathlib.PurePath, int, float, bool)) or value is None:
            print(f"{key}: {value}")
        elif hasattr(value, "to_string"):
            print(f"{key}:")
            print(textwrap.indent(value.to_string(), "  "))
        elif isinstance(value, (list, tuple)) and all(
                isinstance(v, (str, pathlib.PurePath)) for v in value):
            print(f"{key}: " + ", ".join(str(v) for v in value))


def add_parser(command) -> None:
    p = command("demo", "run the chapter 15 study (figure and table)",
                "Reproduce the study of the text's chapter 15: the simple pendulum with the "
                "standard, Baumgarte, penalty, augmented Lagrangian and projection methods; "
                "writes the constraint-violation figure and the table into DIR.",
                """
                spatialmbd demo --outdir ch15
                spatialmbd demo --quick
                """)
    p.add_argument("--outdir", default="ch15_study", metavar="DIR",
                   help="output directory (default ./ch15_study)")
    p.add_argument("--quick", action="store_true", help="shorter runs (a quick check)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_demo)
