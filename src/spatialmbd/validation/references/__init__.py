"""Derivation of the reference values stored in spatialmbd/validation/data/references.json.

``python -m spatialmbd.validation.references --write`` recomputes every derived value (closed
forms, the accuracy of the ADAMS tables against the exact solution) and writes the JSON file
with each value's provenance: source, how it was obtained, precision. The validation suite
reads the file; the tests check that the stored values still agree with the derivation.
Published values (the slider-crank energy, the Bricard mobility) are entered as published.

``tables`` holds the cases' data and the exact solutions and table accuracies derived from
them; ``values`` derives every stored value with its provenance.
"""
from __future__ import annotations

import argparse
import json

from .values import EXUDYN_HOW, derive
from .tables import (ADAMS_CASES, ALL_QUANTITIES, CHRONO_RMS_TOLERANCES, FREE_ASYMMETRIC,
                     FREE_SYMMETRIC, LINACT_TABLES, MODEL_CASES, REVSPH_TABLES, SPRING_CASES,
                     SPRING_TABLES, adams_accuracy, adams_deck, adams_exact, adams_pendulum,
                     exact_adams_quantities, model_case_entries, round_up, spring_table_fit)


def main(argv=None) -> int:
    from ..core import adams_dir, reference_dir
    parser = argparse.ArgumentParser(prog="python -m spatialmbd.validation.references",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--write", action="store_true", help="write references.json")
    args = parser.parse_args(argv)
    refs = derive(adams_dir())
    text = json.dumps(refs, indent=1, sort_keys=False)
    if args.write:
        path = reference_dir() / "references.json"
        path.write_text(text + "\n")
        print(f"wrote {path}")
    else:
        print(text)
    return 0


