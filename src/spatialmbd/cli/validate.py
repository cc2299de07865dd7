"""`spatialmbd validate`: the validation suite."""
from __future__ import annotations

import pathlib

from . import common


def cmd_validate(args) -> int:
    try:
        from ..validation import format_table, run_validation
    except ImportError as exc:
        raise common.UsageError(f"the validation suite is not available in this installation "
                                f"({exc})") from None

    def progress(case):
        if not args.quiet:
            print(f"{case.name}: {'pass' if case.passed else 'FAIL'} ({case.runtime:.1f} s)",
                  flush=True)

    if args.out is not None:                     # before the cases run
        from ..atomic import check_writable
        out = pathlib.Path(args.out)
        target = out if out.suffix.lower() in (".md", ".txt") else out / "validation.md"
        if target.parent.is_dir():              # (a missing folder is made by the writer)
            check_writable(target)
    try:
        cases = run_validation(full=args.full, out=args.out, cases=args.cases or None,
                               progress=progress, method=args.method)
    except ValueError as exc:
        raise common.UsageError(str(exc)) from None
    failed = [c for c in cases if not c.passed]
    if not args.quiet:
        print()
        print(format_table(cases))
    if failed:
        common.err(f"error: {len(failed)} of {len(cases)} validation case(s) failed: "
                   + ", ".join(c.name for c in failed))
        return 1
    if not args.quiet:
        print(f"all {len(cases)} validation cases passed")
    return 0


# ----------------------------------------------------------------------------------------------
# parser


def add_parser(command) -> None:
    p = command("validate", "run the validation suite",
                "Run the validation cases (closed-form solutions and reference data) and "
                "print a table; the exit status is 1 if any case fails.",
                """
                spatialmbd validate
                spatialmbd validate --full --out validation/
                spatialmbd validate heavy_top slider_crank_kinematics
                spatialmbd validate --method recursive
                """)
    p.add_argument("cases", nargs="*", metavar="CASE",
                   help="run only these cases (default: all; names in the table)")
    p.add_argument("--full", action="store_true",
                   help="the complete version (longer runs, every output instant)")
    p.add_argument("--out", metavar="PATH",
                   help="also write the table to PATH (a directory, or a .md/.txt file)")
    p.add_argument("--method", metavar="M",
                   help="run every case with method M where it applies (recursive: the tree "
                        "models with rk45), else the case's own; the note names the methods")
    p.add_argument("-q", "--quiet", action="store_true", help="print only failures")
    p.set_defaults(func=cmd_validate)
