"""The catalogue of element types, generated from the live registries.

:func:`element_types` lists every registered joint, driver and force-element type with what it
declares (inputs, parameters with units, equations); :func:`markdown` renders the table that
docs/elements.md holds (``python -m spatialmbd.catalog > docs/elements.md``; a test checks the
file is current). Types registered from user code appear as soon as they are registered.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ElementInfo:
    family: str            # "joint", "driver" or "force"
    name: str
    aliases: tuple
    summary: str
    inputs: tuple          # geometric inputs (joints) or parameter keywords (forces)
    parameters: tuple      # (name, unit, doc) of the numeric parameters
    equations: tuple       # equation labels (constraints); () for forces


def element_types() -> list[ElementInfo]:
    from .constraints import DRIVER_TYPES, JOINT_TYPES
    from .forces import FORCE_TYPES
    out = []
    from .constraints.couplers import COUPLER_TYPES
    for family, table in (("joint", JOINT_TYPES), ("driver", DRIVER_TYPES),
                          ("coupler", COUPLER_TYPES)):
        for name in sorted(table):
            cls = table[name]
            out.append(ElementInfo(family, name, tuple(cls.aliases), cls.doc(),
                                   tuple(sorted(cls.inputs)),
                                   tuple((p.name, p.unit, p.doc) for p in cls.parameters),
                                   tuple(cls.eq_labels)))
    for name in sorted(FORCE_TYPES):
        cls = FORCE_TYPES[name]
        req = set(cls.required)
        keys = tuple(k + ("" if k in req else " (optional)") for k in cls.parameters)
        out.append(ElementInfo("force", name, (), cls.doc(), keys, (), ()))
    return out


def markdown() -> str:
    lines = ["# Element types", "",
             "Generated from the element registry by `python -m spatialmbd.catalog` (do not "
             "edit; `tests/test_catalog.py` checks it is current). How to add a type: "
             "[architecture.md](architecture.md).", ""]
    titles = {"joint": "Joints and basic constraints", "driver": "Drivers",
              "coupler": "Couplers (between two joints: `add_coupler`, `couplers:`)",
              "force": "Force elements"}
    for family in ("joint", "driver", "coupler", "force"):
        rows = [e for e in element_types() if e.family == family]
        lines += [f"## {titles[family]}", ""]
        if family == "force":
            lines += ["| type | keywords | description |", "|---|---|---|"]
            for e in rows:
                lines.append(f"| `{e.name}` | {', '.join(e.inputs)} | {e.summary} |")
        else:
            lines += ["| type | equations | inputs | parameters | description |",
                      "|---|---|---|---|---|"]
            for e in rows:
                name = f"`{e.name}`" + (f" (alias {', '.join(e.aliases)})" if e.aliases else "")
                params = "; ".join(f"{p} ({u}): {d}" for p, u, d in e.parameters) or "-"
                lines.append(f"| {name} | {len(e.equations)}: {', '.join(e.equations)} | "
                             f"{', '.join(e.inputs) or '-'} | {params} | {e.summary} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":                   # pragma: no cover
    print(markdown(), end="")
