"""An FMU as a sampled controller (fmpy; extra ``spatialmbd[fmi]``).

    ctl = FMUController("pi.fmu", inputs_from={"angle": "drive.coordinate"},
                        outputs_to={"torque": "drive"}, step=1e-3,
                        parameters={"kp": 2.0})
    simulate(model, t_end=2.0, method="projection", controllers=[ctl])

The FMU (FMI 2.0 co-simulation) is run at a fixed communication step h with zero-order hold,
through the sampled-controller machinery (:mod:`spatialmbd.forces.actuators.controller`): at
each sample t_k = t0 + k h the FMU's inputs are set from the joint coordinates of the named
actuators (``<actuator>.coordinate`` or ``<actuator>.coordinate_rate``; a bare actuator name is
its coordinate), the FMU advances doStep(t_k, h), and its outputs after the step are the
commands the actuators hold over [t_k, t_k + h). The integrator lands on every t_k and restarts
there. A new run (a sample time not after the last one) starts a fresh FMU instance.

Bad input -- an FMU file that does not exist or is not co-simulation, a variable name the FMU
does not have, a step that is not positive, an FMU without a binary for this platform -- is a
ModelError naming the item.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analyses.run import register_controller
from ..errors import ModelError
from ..forces.actuators.controller import SampledController
from .cosim import check_step

MEASURED = ("coordinate", "coordinate_rate")


def _fmpy():
    try:
        import fmpy
    except ImportError:
        raise ModelError("FMU import needs fmpy: pip install 'spatialmbd[fmi]'") from None
    return fmpy


def check_fmu(path, who="FMU"):
    """The model description of a co-simulation FMU with a binary for this platform (fmpy);
    ModelError naming the file and what is wrong."""
    fmpy = _fmpy()
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{who}: FMU file {str(path)!r} does not exist")
    try:
        md = fmpy.read_model_description(str(path))
    except Exception as exc:  # noqa: BLE001 - fmpy raises several types on a broken file
        raise ModelError(f"{who}: {str(path)!r} is not a readable FMU ({exc})") from None
    if md.coSimulation is None:
        raise ModelError(f"{who}: {str(path)!r} is not a co-simulation FMU (model exchange "
                         "only); export it for co-simulation")
    platforms = fmpy.supported_platforms(str(path))
    if fmpy.platform not in platforms:
        binaries = [p for p in platforms if p not in ("c-code", "source")]
        sources = " (and C sources: compile it for this platform)" \
            if "c-code" in platforms else ""
        raise ModelError(f"{who}: {str(path)!r} has no binary for this platform "
                         f"({fmpy.platform}); its binaries: {', '.join(binaries) or 'none'}"
                         f"{sources}")
    return md


class FMUController(SampledController):
    """A co-simulation FMU driving actuator commands (module docstring).

    path: the .fmu; inputs_from: {FMU input: "<actuator>.coordinate" | "<actuator>.
    coordinate_rate" | "<actuator>"}; outputs_to: {FMU output: actuator name}; step:
    communication step h (s); parameters: {FMU variable: value} set before initialisation."""

    def __init__(self, path, inputs_from: dict, outputs_to: dict, step: float,
                 parameters: dict | None = None, name: str | None = None):
        self.path = Path(path)
        who = name or f"FMU {self.path.name!r}"
        step = check_step(step, who)
        md = check_fmu(self.path, who)
        variables = {v.name: v for v in md.modelVariables}
        if not isinstance(inputs_from, dict) or not isinstance(outputs_to, dict) or \
                not outputs_to:
            raise ModelError(f"{who}: inputs_from and outputs_to are mappings {{FMU variable: "
                             f"actuator}} (outputs_to at least one), got {inputs_from!r}, "
                             f"{outputs_to!r}")
        for kind, names in (("input", inputs_from), ("output", outputs_to)):
            for n in names:
                v = variables.get(n)
                if v is None or v.causality != kind:
                    have = [w.name for w in md.modelVariables if w.causality == kind]
                    raise ModelError(f"{who}: {n!r} is not an {kind} of the FMU ({kind}s: "
                                     f"{', '.join(have) or 'none'})")
        for n in parameters or {}:
            if n not in variables:
                raise ModelError(f"{who}: parameter {n!r} is not a variable of the FMU "
                                 f"(variables: {', '.join(variables)})")
        measured = []                              # (actuator, 0 coordinate | 1 rate)
        for n, target in inputs_from.items():
            actuator, _, what = str(target).partition(".")
            what = what or "coordinate"
            if what not in MEASURED:
                raise ModelError(f"{who}: input {n!r} <- {target!r}: give "
                                 f"'<actuator>.coordinate' or '<actuator>.coordinate_rate'")
            measured.append((actuator, MEASURED.index(what)))
        sensed = list(dict.fromkeys(a for a, _ in measured))
        super().__init__(self._sample, actuators=list(outputs_to.values()), rate=1.0 / step,
                         inputs=sensed or None, name=who)
        self.step = step
        self.model_description = md
        self._in_refs = [variables[n].valueReference for n in inputs_from]
        n_in = len(self.inputs)
        self._in_index = [sensed.index(a) + n_in * k for a, k in measured]
        self._out_refs = [variables[n].valueReference for n in outputs_to]
        self._parameters = {variables[n].valueReference: float(v)
                            for n, v in (parameters or {}).items()}
        self._fmu = None
        self._unzipped = None
        self._t_last = None

    # ------------------------------------------------------------------ the FMU instance
    def _start(self, t0: float):
        from fmpy import extract
        from fmpy.fmi2 import FMU2Slave
        self.close()
        if self._unzipped is None:
            self._unzipped = extract(str(self.path))
        md = self.model_description
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=self._unzipped,
                        modelIdentifier=md.coSimulation.modelIdentifier,
                        instanceName=self.name)
        fmu.instantiate()
        fmu.setupExperiment(startTime=t0)
        if self._parameters:
            fmu.setReal(list(self._parameters), list(self._parameters.values()))
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        self._fmu = fmu

    def _sample(self, t, y):
        if self._fmu is None or self._t_last is None or t <= self._t_last:
            self._start(t)                          # a new run
        self._t_last = t
        fmu = self._fmu
        if self._in_refs:
            fmu.setReal(self._in_refs, [float(y[i]) for i in self._in_index])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=self.step)
        return np.asarray(fmu.getReal(self._out_refs), dtype=float)

    def close(self) -> None:
        """Terminate and free the FMU instance (a later run starts a new one)."""
        if self._fmu is not None:
            fmu, self._fmu = self._fmu, None
            try:
                fmu.terminate()
            finally:
                fmu.freeInstance()

    def __del__(self):                                             # pragma: no cover
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


def _from_spec(spec: dict) -> FMUController:
    """An FMUController from an ``analysis.controllers`` entry of a model file (type fmu)."""
    return FMUController(spec["file"], dict(spec.get("inputs_from") or {}),
                         dict(spec.get("outputs_to") or {}), spec["step"],
                         parameters=dict(spec.get("parameters") or {}) or None,
                         name=spec.get("name"))


register_controller("fmu", _from_spec)
