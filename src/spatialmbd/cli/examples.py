"""`spatialmbd examples`: list the example models or write them as model files."""
from __future__ import annotations

import inspect
import pathlib

from . import common


def cmd_examples(args) -> int:
    from ..models import EXAMPLES
    if args.name is None and args.write is None:
        width = max(len(n) for n in EXAMPLES)
        print("example models (write one with `spatialmbd examples NAME --write DIR`):")
        for name, (fn, _kw, analysis) in EXAMPLES.items():
            doc = (fn.__doc__ or "").strip().splitlines()[0] if fn.__doc__ else ""
            print(f"  {name:{width}s}  [{analysis.get('type', 'dynamic')}] {doc}")
        return 0
    names = [args.name] if args.name is not None else list(EXAMPLES)
    for name in names:
        if name not in EXAMPLES:
            raise common.UsageError(f"unknown example {name!r}; examples: " + ", ".join(EXAMPLES))
    if args.write is None:
        fn, kwargs, analysis = EXAMPLES[names[0]]
        print(f"{names[0]}: " + inspect.cleandoc(fn.__doc__ or ""))
        print(f"suggested analysis: {analysis}")
        print(f"write it as a model file with: spatialmbd examples {names[0]} --write DIR")
        return 0
    from ..io.modelfile import save_model
    outdir = pathlib.Path(args.write)
    outdir.mkdir(parents=True, exist_ok=True)
    for name in names:
        fn, kwargs, analysis = EXAMPLES[name]
        path = save_model(fn(**kwargs), outdir / f"{name}.{args.format}", analysis=analysis)
        if not args.quiet:
            print(f"wrote {path}")
    return 0


def add_parser(command) -> None:
    p = command("examples", "list the example models or write one as a model file",
                "Without NAME: list the example models. With NAME: describe it; with --write "
                "DIR: write it (with its suggested analysis) as DIR/NAME.yaml. --write without "
                "NAME writes them all.",
                """
                spatialmbd examples
                spatialmbd examples slider_crank
                spatialmbd examples pendulum_ch15 --write models/
                spatialmbd examples --write models/ --format json
                """)
    p.add_argument("name", nargs="?", metavar="NAME", help="example name")
    p.add_argument("--write", metavar="DIR", help="write the model file(s) into DIR")
    p.add_argument("--format", choices=("yaml", "json"), default="yaml",
                   help="model file format (default yaml)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=cmd_examples)
