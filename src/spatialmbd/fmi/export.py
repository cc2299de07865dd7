"""Export a model as an FMI 2.0 co-simulation FMU (pythonfmu; extra ``spatialmbd[fmi]``).

    export_fmu("crank.yaml", "crank.fmu", inputs=["drive"], outputs=["A.angle", "slider.x"],
               parameters=["bodies.slider.mass"])
    spatialmbd fmu crank.yaml -o crank.fmu

inputs, outputs and parameters default to the model file's ``fmu:`` section (docs/fmi.md):
inputs are point_force / torque magnitudes or actuator commands (element names), outputs result
columns (``<body>.x``, ``<joint>.angle``, ...: :mod:`.cosim`), parameters model values by path
(as sweeps name them, :mod:`spatialmbd.sweep.params`). Every name is checked against the model
before anything is written; a wrong one is a ModelError naming it and the choices.

The FMU embeds the model file and runs spatialmbd in the importing tool's Python (pythonfmu's
binary embeds no interpreter of its own): spatialmbd must be installed there.
"""
from __future__ import annotations

import json
import re
import shutil
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree

from ..errors import ModelError
from .slave import INTERFACE_FILE

#: the defaults of the co-simulation settings (the ``fmu:`` section may override them)
DEFAULTS = dict(start_time=0.0, stop_time=None, step=None, method="projection",
                integrator="rk45", rtol=1e-8, atol=1e-10)

SCRIPT = '''"""pythonfmu entry point of a spatialmbd FMU (spatialmbd must be installed)."""
from pythonfmu import Fmi2Slave

from spatialmbd.fmi.slave import SpatialMBDSlave, hold_module_dict

hold_module_dict(globals())          # pythonfmu's loader releases this dict once per instance


class SpatialMBDModel(SpatialMBDSlave, Fmi2Slave):
    """A spatialmbd model, co-simulated (resources/spatialmbd_fmu.json)."""
'''


def read_model_dict(path) -> dict:
    """The plain dictionary of a model file (.yaml/.yml/.json)."""
    path = Path(path)
    text = path.read_text()
    if path.suffix.lower() == ".json":
        return json.loads(text)
    import yaml
    return yaml.safe_load(text)


def _require_pythonfmu():
    try:
        from pythonfmu.builder import FmuBuilder
    except ImportError:
        raise ModelError("FMU export needs pythonfmu: pip install 'spatialmbd[fmi]'") from None
    return FmuBuilder


def _model_source(model_or_path, work: Path):
    """(model file written into ``work``, its dict) of a path, a dict or a Model/builder (a
    Model or builder is written as a model file: what a file cannot hold, e.g. user forces,
    is refused by the writer, naming it)."""
    from ..io.writer import model_to_dict
    if isinstance(model_or_path, (str, Path)):
        src = Path(model_or_path)
        if not src.is_file():
            raise ModelError(f"model file {str(src)!r} does not exist")
        data = read_model_dict(src)
        if not isinstance(data, dict):
            raise ModelError(f"model file {str(src)!r}: not a model file (expected a mapping)")
        target = work / ("model.json" if src.suffix.lower() == ".json" else "model.yaml")
        shutil.copyfile(src, target)
        return target, data
    data = model_or_path if isinstance(model_or_path, dict) else model_to_dict(model_or_path)
    target = work / "model.json"
    target.write_text(json.dumps(data))
    return target, data


def _identifier(name: str) -> str:
    """A C identifier for the FMU's modelIdentifier (the binary's name)."""
    ident = re.sub(r"\W", "_", str(name or "model"))
    return ident if re.match(r"[A-Za-z_]", ident) else f"m_{ident}"


def fmi_name(path: str) -> str:
    """The FMI 2.0 structured name of a model path: list indices become [k] (0-based, as in the
    path: bodies.link.inertia.0 -> bodies.link.inertia[0]), names that are not identifiers are
    quoted ('link-1')."""
    out = ""
    for token in str(path).split("."):
        if token.isdigit() and out:
            out += f"[{int(token)}]"
        else:
            part = token if re.fullmatch(r"[A-Za-z_]\w*", token) else \
                "'" + token.replace("\\", "\\\\").replace("'", "\\'") + "'"
            out += ("." if out else "") + part
    return out


def interface(data: dict, inputs=None, outputs=None, parameters=None, **settings) -> dict:
    """The interface of the FMU: the ``fmu:`` section of ``data`` overridden by the arguments,
    every name checked against the model (ModelError naming it). Returns the JSON-ready spec."""
    from ..io import load_model
    from ..sweep.params import get_path
    from .cosim import CoSimulation, check_step
    section = dict(data.get("fmu") or {})
    spec = dict(DEFAULTS)
    spec.update({k: v for k, v in section.items() if k in DEFAULTS})
    spec.update({k: v for k, v in settings.items() if v is not None})
    inputs = list(section.get("inputs", []) if inputs is None else inputs)
    outputs = list(section.get("outputs", []) if outputs is None else outputs)
    parameters = list(section.get("parameters", []) if parameters is None else parameters)
    if not outputs:
        raise ModelError("FMU export: no outputs; name result columns (e.g. A.angle, "
                         "slider.x) with outputs=[...], --output or the model file's fmu: "
                         "section")
    for kind, names in (("input", inputs), ("output", outputs), ("parameter", parameters)):
        seen = set()
        for n in names:
            if not isinstance(n, str) or not n:
                raise ModelError(f"FMU export: {kind} {n!r} is not a name")
            if n in seen:
                raise ModelError(f"FMU export: {kind} {n!r} is named twice")
            seen.add(n)
    clash = set(inputs) & set(outputs) | set(inputs) & set(parameters) | \
        set(outputs) & set(parameters)
    if clash:
        raise ModelError(f"FMU export: {sorted(clash)[0]!r} is named as two kinds of variable "
                         "(inputs, outputs and parameters need distinct names)")
    if spec["step"] is not None:
        spec["step"] = check_step(spec["step"], "FMU export")
    plain = {k: v for k, v in data.items() if k != "fmu"}
    params = {}
    for p in parameters:
        if p.startswith("analysis."):
            raise ModelError(f"FMU export: parameter {p!r}: the analysis settings are the "
                             "importer's (step, stop time); give model values")
        try:
            value = get_path(plain, p)
        except ModelError as exc:
            raise ModelError(f"FMU export: {exc}") from None
        except (KeyError, IndexError, TypeError):
            raise ModelError(f"FMU export: parameter {p!r} is not a value of the model file "
                             "(paths as in sweeps: bodies.<name>.mass, forces.<name>.stiffness, "
                             "gravity.2, ...)") from None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ModelError(f"FMU export: parameter {p!r} is {value!r}, not a number (a "
                             "vector: name one component, e.g. {p}.0)".replace("{p}", p))
        params[p] = float(value)
    model, _ = load_model(plain)
    sim = CoSimulation(model, inputs, outputs, t0=float(spec["start_time"]),
                       method=spec["method"], integrator=spec["integrator"],
                       rtol=float(spec["rtol"]), atol=float(spec["atol"]), name="FMU export")
    names = [fmi_name(n) for n in list(inputs) + list(outputs) + list(params)]
    if len(set(names)) != len(names):
        raise ModelError(f"FMU export: two variables share the FMI name "
                         f"{next(n for n in names if names.count(n) > 1)!r}")
    spec.update(inputs={n: sim.get_input(n) for n in inputs}, outputs=outputs,
                parameters=params,
                fmi_names=dict(zip(list(inputs) + list(outputs) + list(params), names)),
                identifier=_identifier(data.get("name")),
                description=f"spatialmbd model {data.get('name', 'model')!r}, co-simulation")
    return spec


def export_fmu(model_or_path, path, inputs=None, outputs=None, parameters=None, *,
               start_time=None, stop_time=None, step=None, method=None, integrator=None,
               rtol=None, atol=None) -> Path:
    """Write an FMI 2.0 co-simulation FMU of a model (module docstring) to ``path``.

    model_or_path: a model file (.yaml/.yml/.json), a model dictionary or a Model.
    start_time, stop_time, step (s): the default experiment (step: the suggested
    communication step); method, integrator, rtol, atol: the integration inside each doStep
    (default projection, rk45, 1e-8, 1e-10). Returns the path written."""
    builder = _require_pythonfmu()
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise ModelError(f"FMU file {str(path)!r}: the name must end in .fmu")
    if not (path.parent if str(path.parent) else Path(".")).is_dir():
        raise ModelError(f"FMU file {str(path)!r}: directory {str(path.parent)!r} does not "
                         "exist")
    with tempfile.TemporaryDirectory(prefix="spatialmbd_fmu_") as tmp:
        work = Path(tmp)
        model_file, data = _model_source(model_or_path, work)
        spec = interface(data, inputs, outputs, parameters, start_time=start_time,
                         stop_time=stop_time, step=step, method=method, integrator=integrator,
                         rtol=rtol, atol=atol)
        spec["model_file"] = model_file.name
        (work / INTERFACE_FILE).write_text(json.dumps(spec, indent=1))
        script = work / "spatialmbd_slave.py"
        script.write_text(SCRIPT)
        build = work / "build"
        build.mkdir()
        # the state can be saved and restored (fmi2Get/SetFMUstate) and serialized (JSON)
        written = builder.build_FMU(script, dest=build, project_files=[model_file,
                                                                       work / INTERFACE_FILE],
                                    canGetAndSetFMUstate=True, canSerializeFMUstate=True)
        _add_initial_unknowns(Path(written), path)
    return path


def _add_initial_unknowns(src: Path, dest: Path) -> None:
    """Copy the FMU, listing its outputs (initial "calculated") under
    ModelStructure/InitialUnknowns as FMI 2.0 requires (pythonfmu leaves the list out)."""
    with zipfile.ZipFile(src) as zin:
        root = ElementTree.fromstring(zin.read("modelDescription.xml"))
        structure = root.find("ModelStructure")
        outputs = structure.find("Outputs")
        if outputs is not None and structure.find("InitialUnknowns") is None:
            initial = ElementTree.SubElement(structure, "InitialUnknowns")
            for unknown in outputs.findall("Unknown"):
                ElementTree.SubElement(initial, "Unknown", dict(index=unknown.get("index")))
        ElementTree.indent(root)
        xml = ElementTree.tostring(root, encoding="UTF-8", xml_declaration=True)
        with zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = xml if item.filename == "modelDescription.xml" else zin.read(item)
                zout.writestr(item, data)
