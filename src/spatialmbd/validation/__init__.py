"""Validation suite: spatialmbd against published results, closed-form solutions and invariants.

    from spatialmbd.validation import run_validation, format_table
    results = run_validation()            # short version (CI); full=True for the complete one
    print(format_table(results))

Cases (:mod:`.cases`): the MSC ADAMS joint tests of Project Chrono (revolute, spherical and
universal pendulums, translational and cylindrical joints, distance constraints, a
translational and a torsional spring-damper; without a deck, the revolute-spherical
composite joint and a prismatic joint driven by a linear actuator, their models rebuilt from
Chrono's unit tests: positions,
velocities, accelerations, Euler parameters, angular velocity and acceleration, reaction force
and torque at every one of the 501 output instants), the
torque-free symmetric and asymmetric rigid bodies, a heavy symmetric top in steady precession,
the slider-crank kinematics, IFToMM benchmarks A01 (simple pendulum), A02 (N-four-bar through
its singular configurations), A03 (Andrews' squeezer, three closed loops), A04 (Bricard, redundant constraints), A05 (stiff flyball
governor, implicit integrator) and the spatial slider-crank energy, a spatial double pendulum
and a 6-DoF robot arm with compliant joints (invariants).

Every reference value carries its provenance (source, how obtained, precision) in
spatialmbd/validation/data/references.json and data/adams/PROVENANCE.md (package data); each check states how
its tolerance was derived.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Optional

from .core import CaseResult, Check, reference_dir

__all__ = ["run_validation", "format_table", "CaseResult", "Check", "CASE_NAMES",
           "reference_dir"]


def _cases():
    from .cases import CASES
    return CASES


CASE_NAMES = ("adams_revolute_case01", "adams_revolute_case02", "adams_spherical_case01",
              "adams_spherical_case02", "adams_universal_case01", "adams_universal_case02",
              "adams_universal_case03", "adams_prismatic_case01", "adams_prismatic_case02",
              "adams_prismatic_case03", "adams_cylindrical_case01", "adams_cylindrical_case02",
              "adams_cylindrical_case03", "adams_distance_case01", "adams_distance_case02",
              "adams_distance_case03", "adams_transpring_case02", "adams_rotspring_case01",
              "adams_rotspring_case02",
              "adams_revspherical_case01", "adams_revspherical_case02",
              "adams_linactuator_case01", "adams_linactuator_case02",
              "adams_transpring_case01", "adams_transpringcb_case01",
              "adams_transpringcb_case02", "adams_transpringcb_case03",
              "adams_transpringcb_case04",
              "free_symmetric", "free_asymmetric", "heavy_top", "heavy_top_nutation",
              "slider_crank_kinematics",
              "iftomm_a01", "iftomm_a02", "iftomm_a03", "iftomm_a04", "iftomm_a05",
              "spatial_slider_crank", "meijaard_bicycle", "iftomm_bicycle",
              "basu_mandal_bicycle",
              "double_pendulum", "robot_arm", "hertz_impact", "cam_follower")


def run_validation(full: bool = False, out=None, cases: Optional[Iterable[str]] = None,
                   progress=None, method: Optional[str] = None) -> list[CaseResult]:
    """Run the validation cases (all, or the names in ``cases``); short version unless
    ``full``. ``out``: a directory (or file name ending in .md/.txt) to write the table to.
    ``progress``: a callable(CaseResult) called after each case (e.g. print). ``method``: run
    every case with this method where it applies (the recursive method: tree models with the
    rk45 integrator), the case's own method elsewhere; each case notes the methods that ran.
    Returns the list of CaseResult (a failing case is reported, not raised)."""
    from .cases import common as case_module      # the method of the whole suite
    from .cases import run_case
    names = list(cases) if cases is not None else list(CASE_NAMES)
    unknown = [n for n in names if n not in _cases()]
    if unknown:
        raise ValueError(f"unknown validation case(s) {unknown}; choose from {CASE_NAMES}")
    if method is not None:
        from ..dynamics.base import METHODS
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; choose from {sorted(METHODS)}")
    results = []
    case_module.METHOD = method
    try:
        for name in names:
            case_module.METHODS_USED.clear()
            res = run_case(name, full)
            if method is not None:
                res.notes.append("method(s): " + (", ".join(dict.fromkeys(
                    case_module.METHODS_USED)) or "none (no dynamic run)"))
            results.append(res)
            if progress is not None:
                progress(res)
    finally:
        case_module.METHOD = None
    if out is not None:
        out = Path(out)
        if out.suffix.lower() in (".md", ".txt"):
            out.parent.mkdir(parents=True, exist_ok=True)
            path = out
        else:
            out.mkdir(parents=True, exist_ok=True)
            path = out / ("validation_full.md" if full else "validation.md")
        from ..atomic import atomic_write
        with atomic_write(path) as tmp:
            tmp.write_text(format_table(results, markdown=path.suffix == ".md") + "\n")
    return results


def _fmt(x) -> str:
    if isinstance(x, (int,)) or (isinstance(x, float) and x.is_integer() and abs(x) < 1e6):
        return f"{x:.0f}" if float(x).is_integer() else f"{x:.6g}"
    try:
        return f"{x:.6g}"
    except (TypeError, ValueError):
        return str(x)


def format_table(results, markdown: bool = False, details: bool = True) -> str:
    """A table with one row per case and quantity: reference value, ours, error, tolerance,
    pass/fail (for time histories: the values at the worst instant, the max error over all
    instants, RMS in the note), then the provenance of every case's references."""
    head = ["case", "quantity", "reference", "ours", "error", "tolerance", "pass", "note"]
    rows = []
    for r in results:
        if r.error:
            rows.append([r.name, "(case failed to run)", "", "", "", "", "FAIL", r.error])
            continue
        for c in r.checks:
            rows.append([r.name, c.quantity + (f" [{c.unit}]" if c.unit else ""),
                         _fmt(c.reference), _fmt(c.ours), f"{c.error:.3g}",
                         f"{c.tolerance:.3g}", "pass" if c.passed else "FAIL", c.note])
    n_pass = sum(r.passed for r in results)
    total_time = sum(r.runtime for r in results)
    summary = (f"{n_pass}/{len(results)} cases passed, "
               f"{sum(c.passed for r in results for c in r.checks)}/"
               f"{sum(len(r.checks) for r in results)} checks, {total_time:.1f} s")
    lines = []
    if markdown:
        lines.append("| " + " | ".join(head) + " |")
        lines.append("|" + "---|" * len(head))
        for row in rows:
            lines.append("| " + " | ".join(str(x).replace("|", "/") for x in row) + " |")
    else:
        widths = [max(len(str(row[k])) for row in rows + [head]) for k in range(len(head) - 1)]
        widths = [min(w, 44) for w in widths]
        fmt = "  ".join(f"{{:{'<' if k < 2 else '>'}{w}}}" for k, w in enumerate(widths))
        lines.append(fmt.format(*head[:-1]) + "  note")
        for row in rows:
            cells = [str(x)[:w] for x, w in zip(row[:-1], widths)]
            lines.append(fmt.format(*cells) + "  " + str(row[-1]))
    lines.append("")
    lines.append(summary)
    if details:
        lines.append("")
        lines.append("Cases, references and tolerances:")
        previous = None
        for r in results:
            lines.append(f"- {r.name} ({'pass' if r.passed else 'FAIL'}, {r.runtime:.1f} s): "
                         f"{r.description}")
            if r.provenance and r.provenance == previous:
                lines.append("    reference: as above")
            elif r.provenance:
                lines.append(f"    reference: {r.provenance}")
            previous = r.provenance
            bases = []
            for c in r.checks:
                if c.basis and c.basis not in bases:
                    bases.append(c.basis)
            for b in bases:
                lines.append(f"    tolerance: {b}")
            for n in r.notes:
                lines.append(f"    note: {n}")
    return "\n".join(lines)


def main(argv=None) -> int:
    import argparse
    parser = argparse.ArgumentParser(description="Run the spatialmbd validation suite")
    parser.add_argument("--full", action="store_true", help="the complete (slow) version")
    parser.add_argument("--out", help="directory or .md/.txt file for the table")
    parser.add_argument("--method", help="run every case with this method where it applies "
                        "(e.g. recursive: the tree models with rk45), else the case's own")
    parser.add_argument("cases", nargs="*", help=f"a subset of {', '.join(CASE_NAMES)}")
    args = parser.parse_args(argv)
    results = run_validation(full=args.full, out=args.out, cases=args.cases or None,
                             method=args.method,
                             progress=lambda r: print(f"{r.name}: "
                                                      f"{'pass' if r.passed else 'FAIL'} "
                                                      f"({r.runtime:.1f} s)", flush=True))
    print()
    print(format_table(results))
    return 0 if all(r.passed for r in results) else 1
