"""The element reference of the model-file format, generated from the registries.

``python -m spatialmbd.io.elements_doc > docs/elements.md`` writes the page. A test checks
that the committed page is what this module generates, so the page always lists the joint
types, driver kinds, force elements, motion laws and output kinds that the installed package
accepts, with their keys.
"""
from __future__ import annotations

import dataclasses
import inspect
import sys

HEADER = """\
# Element reference (generated)

This page is generated from the element registries of spatialmbd by
`python -m spatialmbd.io.elements_doc > docs/elements.md`. Do not edit it by hand. The
model-file schema around these elements (bodies, orientation, analysis, ...) is described in
[model files](model-file.md), and the output requests in [outputs](outputs.md).
"""


def _first_paragraph(*objs) -> str:
    """The first paragraph of the first of ``objs`` that has a docstring of its own."""
    doc = next((inspect.cleandoc(o.__doc__) for o in objs if o is not None and o.__doc__), "")
    para = doc.split("\n\n", 1)[0]
    return " ".join(line.strip() for line in para.splitlines()).replace("|", "\\|")


def _joint_needs() -> dict:
    try:
        from ..model.compile import LOCAL_NAME, NEEDS
    except ImportError:                                            # pragma: no cover
        return {}
    return {name: (sorted(keys), sorted(LOCAL_NAME.get(k, k) for k in keys))
            for name, keys in NEEDS.items()}


def element_reference() -> str:
    """The Markdown text of docs/elements.md."""
    from ..constraints import DRIVER_TYPES, JOINT_TYPES
    from ..constraints.drivers import COORDINATES
    from ..forces import FORCE_TYPES
    from ..motion import LAWS
    from ..outputs import JOINT_COORDINATES, GENERIC_COORDINATES, KINDS, QUANTITIES

    needs = _joint_needs()
    lines = [HEADER, "## Joints (`joints:`)", "",
             "Each entry has `name`, `type`, `body_i`, `body_j` and the geometry: global keys "
             "(in the assembled configuration) or local ones (in body axes). The output "
             "columns are those of a `{type: joint}` request.", "",
             "| type | equations | global geometry | local geometry | drivers | output "
             "coordinates | description |", "|---|---|---|---|---|---|---|"]
    for name in sorted(JOINT_TYPES):
        cls = JOINT_TYPES[name]
        glob, local = needs.get(name, ([], []))
        module = sys.modules.get(cls.__module__)
        coords = JOINT_COORDINATES.get(name, GENERIC_COORDINATES)
        lines.append(f"| `{name}` | {cls.n_eq} ({', '.join(cls.eq_labels)}) | "
                     f"{', '.join(f'`{k}`' for k in glob)} | "
                     f"{', '.join(f'`{k}`' for k in local)} | "
                     f"{', '.join(cls.driver_kinds) or '–'} | "
                     f"{', '.join(f'`{c}`' for c in coords)} | "
                     f"{_first_paragraph(cls, module)} |")
    lines += ["", "## Drivers (`drivers:`)", "",
              "Each entry has `name`, `kind`, a motion `law`, and `joint` (angle, translation) "
              "or `body` and `coordinate` (coordinate: one of "
              + ", ".join(f"`{c}`" for c in COORDINATES) + ").", "",
              "| kind | prescribes |", "|---|---|"]
    what = {"angle": "the rotation angle of a revolute or cylindrical joint (rad)",
            "translation": "the translation along a translational or cylindrical joint (m)",
            "coordinate": "a body coordinate: x, y, z of r (m) or e0..e3 of p"}
    for name in DRIVER_TYPES:
        lines.append(f"| `{name}` | {what.get(name, _first_paragraph(DRIVER_TYPES[name]))} |")
    lines += ["", "## Motion laws (`law:`)", "",
              "A number (a constant) or a mapping `{type: ..., parameters}`.", "",
              "| type | parameters (defaults) | f(t) |", "|---|---|---|"]
    for kind, cls in LAWS.items():
        if kind == "user":
            continue
        params = ", ".join(
            f"`{f.name}`" + (f" ({f.default})" if f.default is not dataclasses.MISSING else "")
            for f in dataclasses.fields(cls))
        lines.append(f"| `{kind}` | {params} | {_first_paragraph(cls)} |")
    lines += ["", "## Force elements (`forces:`)", "",
              "Each entry has `name`, `type` and the parameters below. Output columns are "
              "those of a `{type: force}` request.", "",
              "| type | parameters | outputs | description |", "|---|---|---|---|"]
    for name in sorted(FORCE_TYPES):
        cls = FORCE_TYPES[name]
        module = sys.modules.get(cls.__module__)
        params = ", ".join(f"`{p}`" for p in getattr(cls, "allowed", ()))
        outs = ", ".join(f"`{q}` [{u}]" for q, u in QUANTITIES.get(name, {}).items())
        note = " (Python only: a callable cannot be written to a file)" if name == "user" \
            else ""
        lines.append(f"| `{name}` | {params} | {outs or '–'} | "
                     f"{_first_paragraph(cls, module)}{note} |")
    lines += ["", "## Output requests (`outputs:`)", "",
              "| type | columns `<prefix>.…` [unit] |", "|---|---|"]
    for kind in KINDS:
        if kind in ("joint", "force"):
            text = "see the joint and force tables above"
        else:
            text = ", ".join(f"`{q}` [{u}]" for q, u in QUANTITIES[kind].items())
        lines.append(f"| `{kind}` | {text} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":                                          # pragma: no cover
    sys.stdout.write(element_reference())
