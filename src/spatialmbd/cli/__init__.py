"""The ``spatialmbd`` command: a thin layer over the public API.

    spatialmbd run MODEL [options]        run the analysis of a model file, write the results
    spatialmbd info MODEL                 bodies, joints, drivers, forces, degrees of freedom
    spatialmbd plot RESULTS -y Q -o FIG   plots from a results file (--x: against any column)
    spatialmbd animate IN -o FILE.html    offline HTML animation (results file or model file)
    spatialmbd import FILE.xml -o M.yaml  MJCF / URDF -> model file (extra spatialmbd[mjcf])
    spatialmbd examples [NAME]            list the example models, or write one as a model file
    spatialmbd demo                       the chapter 15 study (figure and table)
    spatialmbd validate [--full]          the validation suite
    spatialmbd sweep MODEL --param P=V    a parameter sweep (serial, processes or Dask)
    spatialmbd fmu MODEL -o M.fmu         an FMI 2.0 co-simulation FMU (extra spatialmbd[fmi])
    spatialmbd identify MODEL --data CSV  fit parameters to measurements (least squares)
    spatialmbd optimize MODEL --objective O   choose parameters that minimise an output

Exit status: 0 success; 1 the analysis (or a validation case) failed, partial results are
still written; 2 bad input (unreadable or invalid model file, unknown names, bad options);
130 interrupted. User errors are reported in one line each, without a Python traceback
(``--debug`` shows it).
"""
from __future__ import annotations

import argparse
import sys
import time
from typing import Optional, Sequence

from .. import __version__
from ..errors import ModelError, SpatialMBDError
from . import (animate, common, demo, examples, fmu, identify, importer, info, optimize,
               plot, run, sweep, validate, warmup)
from .common import UsageError

PROG = "spatialmbd"
__all__ = ["main", "build_parser", "UsageError", "PROG"]
#: the commands in the order of ``spatialmbd --help``; each module adds its own sub-parser
COMMAND_MODULES = (run, info, plot, animate, importer, examples, demo, validate, warmup, sweep,
                   fmu, identify, optimize)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG, formatter_class=common.Formatter,
        description="Kinematics and dynamics of spatial rigid multibody systems "
                    "(body coordinates, Euler parameters).",
        epilog=common.epilog("""
            spatialmbd examples                         # list the example models
            spatialmbd examples pendulum_ch15 --write . # write pendulum_ch15.yaml
            spatialmbd info pendulum_ch15.yaml          # bodies, joints, degrees of freedom
            spatialmbd run pendulum_ch15.yaml -o pendulum.h5
            spatialmbd plot pendulum.h5 -y pendulum.z energy.error -o pendulum.png
            spatialmbd animate pendulum.h5 -o pendulum.html
            spatialmbd <command> --help                 # options of a command

            exit status: 0 success, 1 analysis failed (partial results written),
            2 bad input (model file, names, options), 130 interrupted
            """))
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show Python tracebacks for errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def command(name, help_text, description, epilog):
        p = sub.add_parser(name, help=help_text, description=description,
                           epilog=common.epilog(epilog), formatter_class=common.Formatter)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show Python tracebacks for errors")
        return p

    for module in COMMAND_MODULES:
        module.add_parser(command)
    return parser


# ----------------------------------------------------------------------------------------------
# entry point
# ----------------------------------------------------------------------------------------------
#: commands that may compile kernels on their first run (they get the compile notice)
_COMPUTING = (run.cmd_run, demo.cmd_demo, validate.cmd_validate)


#: environment variable set in the interpreted child of a cold start (see :func:`_race`)
INTERPRETED_ENV = "SPATIALMBD_INTERPRETED"
#: exit status of an interpreted child that met an internal error (the compiled run decides)
INTERPRETED_FAILED = 3
#: the background compile of a cold start
WARMUP_ARGV = [sys.executable, "-m", "spatialmbd", "warmup", "--quiet"]


def _cold(args) -> bool:
    """Whether this command should race (see :func:`_race`): a computing command, a cold
    compile cache, Numba enabled, not already the interpreted child, not switched off with
    SPATIALMBD_NO_RACE=1."""
    import os
    if getattr(args, "func", None) not in _COMPUTING or os.environ.get(INTERPRETED_ENV) or \
            os.environ.get("SPATIALMBD_NO_RACE"):
        return False
    from .. import jit
    return jit.ENABLED and not jit.cache_is_warm()


def _race(argv, args) -> int:
    """First run on a machine (cold compile cache): compile the kernels in a background
    process (``spatialmbd warmup``) and meanwhile run this command in a child process with the
    kernels interpreted (``NUMBA_DISABLE_JIT=1``: the same functions as plain Python, one to
    two orders of magnitude slower). Whichever finishes first wins: a small model's result
    comes from the interpreted run in seconds; for a large one, once the compiled kernels are
    ready the interpreted run is stopped and the command runs compiled. The background compile
    always completes, so the next run starts at once."""
    import os
    import subprocess
    quiet = getattr(args, "quiet", False)
    start = time.perf_counter()

    def say(text):
        if not quiet:
            print(text, file=sys.stderr, flush=True)

    from .. import jit
    devnull = subprocess.DEVNULL
    warm = subprocess.Popen(WARMUP_ARGV, stdin=devnull, stdout=devnull, stderr=devnull,
                            start_new_session=True)
    say("first run on this machine: compiling the numerical kernels in the background (about "
        "a minute, once); meanwhile this run uses them interpreted, and switches to the "
        "compiled ones if they are ready first")
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", **{INTERPRETED_ENV: "1"})
    child = subprocess.Popen([sys.executable, "-m", "spatialmbd", *argv], env=env)
    try:
        while True:
            code = child.poll()
            if code is not None and code != INTERPRETED_FAILED:
                if warm.poll() is None:
                    say("(the compiled kernels are still being built in the background for "
                        "the next run)")
                return code
            if code == INTERPRETED_FAILED:
                say("the interpreted run could not finish; waiting for the compiled kernels")
                warm.wait()
                break
            if warm.poll() not in (None, 0) and not jit.cache_is_warm():
                return child.wait()                    # no compiled kernels: keep interpreting
            if jit.cache_is_warm():
                child.terminate()
                child.wait()
                say(f"compiled kernels ready after {time.perf_counter() - start:.0f} s: "
                    "running compiled")
                break
            time.sleep(0.05)
    except KeyboardInterrupt:
        child.wait()                                   # it has written its partial results
        raise
    return args.func(args)


def _exit_now(code: int) -> None:
    """End the process at once after Ctrl-C: the atexit handlers run and the streams are
    flushed, but the interpreter's teardown of its modules (about a second with the compiled
    kernels loaded) is skipped, so that Ctrl-C ends the command within a second."""
    import atexit
    import os
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # noqa: BLE001 - a closed stream: nothing to flush
                pass
        os._exit(code)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the command line ``argv`` (default sys.argv[1:]); return the exit status."""
    import os
    from_command_line = argv is None
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:                       # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    debug = getattr(args, "debug", False)
    file_error = common.model_file_error()
    try:
        if _cold(args):
            return _race(argv, args)
        if getattr(args, "func", None) in _COMPUTING and not getattr(args, "quiet", False):
            from ..jit import compile_notice
            with compile_notice():
                return args.func(args)
        return args.func(args)
    except KeyboardInterrupt as exc:
        if debug:
            raise
        common.err(f"interrupted {exc}" if str(exc) else "interrupted")
        if from_command_line:
            _exit_now(130)
        return 130
    except Exception as exc:  # noqa: BLE001 - turned into messages and exit statuses below
        if debug:
            raise
        if file_error and isinstance(exc, file_error):
            problems = list(getattr(exc, "problems", None) or [str(exc)])
            lines = list(getattr(exc, "lines", None) or [])
            lines += [None] * (len(problems) - len(lines))
            source = getattr(exc, "source", None) or getattr(exc, "heading", None)
            n = len(problems)
            common.err(f"error: {source or 'model file'}: {n} problem{'s' if n != 1 else ''}:")
            for problem, line in zip(problems, lines):
                common.err(f"  {problem}" + (f"  (line {line})" if line else ""))
            return 2
        if isinstance(exc, (common.UsageError, ModelError, FileNotFoundError, IsADirectoryError,
                            ValueError)):
            common.err(f"error: {exc}")
            return 2
        if isinstance(exc, SpatialMBDError):
            common.err(f"error: the analysis failed: {exc}")
            return 1
        if isinstance(exc, OSError):
            common.err(f"error: {exc}")
            return 2
        if os.environ.get(INTERPRETED_ENV):         # the compiled run of the parent decides
            return INTERPRETED_FAILED
        raise


if __name__ == "__main__":                                          # pragma: no cover
    sys.exit(main())
