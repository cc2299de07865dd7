"""`spatialmbd info`: bodies, joints, drivers, forces, analysis and mobility of a model."""
from __future__ import annotations

import pathlib
import textwrap

from . import common


def cmd_info(args) -> int:
    from ..kinematics import mobility
    model, analysis = common.load(args.model, **common.import_options(args, args.model))
    state = model.builder_state
    g = model.gravity
    lines = [f"model {model.name!r} ({args.model})",
             f"gravity: ({g[0]:.6g}, {g[1]:.6g}, {g[2]:.6g}) m/s^2",
             f"bodies ({model.nb}):"]
    for k, name in enumerate(model.body_names):
        r = model.q0[k, :3]
        lines.append(f"  {name:16s} mass {model.mass[k]:.6g} kg, centre of mass at "
                     f"({r[0]:.6g}, {r[1]:.6g}, {r[2]:.6g}) m")
    joints = state.get("joints", {})
    lines.append(f"joints ({len(model.joint_names)}):")
    types = {n: grp.name for grp in model.constraint_groups for n in grp.names}
    in_file_order = [n for n in joints if n in types] + \
        [n for n in model.joint_names if n not in joints]
    for name in in_file_order:
        spec = joints.get(name)
        between = f"{spec.body_i} - {spec.body_j}" if spec is not None else ""
        lines.append(f"  {name:16s} {types[name]:22s} {between}")
    drivers = state.get("drivers", {})
    lines.append(f"drivers ({len(model.driver_names)}):")
    for name in model.driver_names:
        spec = drivers.get(name)
        if spec is None:
            lines.append(f"  {name}")
        elif spec.kind == "coordinate":
            lines.append(f"  {name:16s} coordinate {spec.coordinate} of {spec.body}")
        else:
            lines.append(f"  {name:16s} {spec.kind} of joint {spec.joint}")
    forces = state.get("forces", {})
    lines.append(f"forces ({len(forces)}):")
    for name, spec in forces.items():
        lines.append(f"  {name:16s} {spec.type}")
    lines.append("analysis: " + _describe_analysis(analysis))
    requests = getattr(analysis, "outputs", None)
    if requests:
        from ..outputs import parse_outputs
        lines.append("outputs: " + ", ".join(
            f"{r.kind} {r.of}" if r.of else r.kind for r in parse_outputs(model, requests)))
    if pathlib.Path(args.model).suffix.lower() in (".yaml", ".yml", ".json"):
        from ..io.external import external_files
        outside = external_files(args.model)
        if outside:
            lines.append(f"files outside the model's folder ({len(outside)}; refused with "
                         "--no-external-files):")
            lines += [f"  {place}: {real}" for place, real in outside]
    lines += output_columns(model, requests)
    lines.append("mobility:")
    lines.append(textwrap.indent(mobility(model).report(), "  "))
    print("\n".join(lines))
    return 0


def output_columns(model, requests=None) -> list:
    """Lines naming the columns of a dynamic run (the sweep outputs' and tables' columns,
    ``reduction(column)``), grouped by prefix: ``  pendulum.{x|y|z|...}``."""
    from ..sweep.checks import column_names
    groups: dict = {}
    for name in column_names(model, requests or ()):
        prefix, _, last = name.rpartition(".")
        groups.setdefault(prefix, []).append(last)
    lines = ["output columns (sweep outputs, tables):"]
    for prefix, lasts in groups.items():
        lines.append(f"  {prefix}.{{{'|'.join(lasts)}}}" if prefix else f"  {'|'.join(lasts)}")
    return lines


def _describe_analysis(analysis) -> str:
    if analysis is None:
        return "none"
    parts = [str(getattr(analysis, "type", "?"))]
    if parts[0] in ("static", "modal"):                     # one time, no integration
        parts.append(f"at t = {getattr(analysis, 'time', 0.0):g} s")
        if getattr(analysis, "steady", False):
            rate = getattr(analysis, "frame_rate", None)
            parts.append("about the initial steady motion"
                         + (f", frame turning at {rate} rad/s" if rate else ""))
        return ", ".join(parts)
    for key, label in (("t_end", "t_end"), ("output_step", "output step")):
        value = getattr(analysis, key, None)
        if value is not None:
            parts.append(f"{label} {value:g} s")
    if str(parts[0]).lower() == "dynamic":
        for key in ("method", "integrator"):
            value = common.name_of(getattr(analysis, key, None))
            if value:
                opts = getattr(analysis, f"{key}_options", None)
                parts.append(f"{key} {value}" + (f" {opts}" if opts else ""))
        for key in ("step", "rtol", "atol"):
            value = getattr(analysis, key, None)
            if value is not None:
                parts.append(f"{key} {value:g}")
    return ", ".join(parts)


def add_parser(command) -> None:
    p = command("info", "describe a model: bodies, joints, drivers, forces, DoF",
                "Print the bodies, joints, drivers and force elements of MODEL, its analysis, "
                "the Gruebler-Kutzbach count of degrees of freedom next to the numerical one "
                "(rank of the constraint Jacobian at the initial configuration), and the "
                "redundant constraint equations with their joints.",
                """
                spatialmbd info four_bar.yaml
                """)
    p.add_argument("model", metavar="MODEL", help="model file")
    common.add_import_options(p)
    p.set_defaults(func=cmd_info)
