"""The inside of an exported FMU: the pythonfmu slave that steps a :class:`.cosim.CoSimulation`.

An FMU written by :func:`.export.export_fmu` holds, under ``resources/``, the model file
(``model.yaml`` or ``model.json``), the interface (``spatialmbd_fmu.json``) and a two-line
script whose class is :class:`SpatialMBDSlave` (pythonfmu's loader instantiates the class it
finds in the script). The importing tool loads pythonfmu's binary, which runs this code in
the importer's Python: spatialmbd must be installed there (docs/fmi.md).

FMI 2.0 co-simulation life cycle:
    instantiate              the model file is read; parameters take their file values
    setReal(parameters)      model values by path (bodies.slider.mass, ...), before init
    exitInitializationMode   the model is compiled with the parameters, assembled at
                             start_time (the chapter 14 corrections) and the outputs evaluated
    setReal(inputs), doStep(t, h), getReal(outputs)    per communication step (inputs held)
"""
from __future__ import annotations

import json
from pathlib import Path

#: the interface file inside the FMU's resources
INTERFACE_FILE = "spatialmbd_fmu.json"


def hold_module_dict(namespace: dict) -> None:
    """One more reference to the FMU script's module dict; the script calls it at module level.

    pythonfmu's loader (PySlaveInstance.cpp, findClass, in 0.7.0 and on its main branch)
    executes the script again in the module's dict and then releases that dict, a borrowed
    reference, once per instantiation. A script that holds no other reference to its dict
    loses it: the second FMU instance in a process fails ("module has no attribute
    'SpatialMBDModel'"). The script's module-level call runs in each of those executions too,
    so every release is matched by the reference taken just before it."""
    import ctypes
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(namespace))


class SpatialMBDSlave:
    """A mixin of pythonfmu's Fmi2Slave (the script combines them): registers the interface's
    variables and runs the co-simulation."""

    def __init__(self, **kwargs):
        from pythonfmu import Fmi2Causality, Fmi2Variability, Real
        from pythonfmu.default_experiment import DefaultExperiment
        super().__init__(**kwargs)
        resources = Path(self.resources)
        spec = json.loads((resources / INTERFACE_FILE).read_text())
        self.spec = spec
        self.modelName = spec["identifier"]
        self.description = spec.get("description")
        self.author = "spatialmbd"
        self.model_path = resources / spec["model_file"]
        self.input_values = {n: float(v) for n, v in spec["inputs"].items()}
        self.parameter_values = {p: float(v) for p, v in spec["parameters"].items()}
        self.output_names = list(spec["outputs"])
        self.cosim = None
        self.default_experiment = DefaultExperiment(
            start_time=spec["start_time"], stop_time=spec.get("stop_time"),
            step_size=spec.get("step"), tolerance=spec.get("rtol"))
        self._values = [0.0] * len(self.output_names)
        fmi = spec.get("fmi_names", {})

        def setter(table, name):
            def set_value(value):
                table[name] = float(value)
            return set_value

        def getter(table, name):
            return lambda: table[name]
        for name in self.input_values:
            self.register_variable(Real(
                fmi.get(name, name), causality=Fmi2Causality.input,
                variability=Fmi2Variability.continuous,
                getter=getter(self.input_values, name), setter=setter(self.input_values, name),
                description="held over each communication step (zero-order hold)"),
                nested=False)
        for m, name in enumerate(self.output_names):
            self.register_variable(Real(
                fmi.get(name, name), causality=Fmi2Causality.output,
                variability=Fmi2Variability.continuous,
                getter=(lambda m=m: self._values[m]), setter=(lambda value: None)),
                nested=False)
        for name in self.parameter_values:
            self.register_variable(Real(
                fmi.get(name, name), causality=Fmi2Causality.parameter,
                variability=Fmi2Variability.fixed,
                getter=getter(self.parameter_values, name),
                setter=setter(self.parameter_values, name),
                description="model value by path (docs/model-file.md)"), nested=False)

    # ---------------------------------------------------------------- life cycle
    def exit_initialization_mode(self):
        self._build()

    def _build(self):
        from ..io import load_model
        from ..sweep.params import apply
        from .cosim import CoSimulation
        from .export import read_model_dict
        data = read_model_dict(self.model_path)
        data.pop("fmu", None)
        model, _ = load_model(apply(data, self.parameter_values))
        spec = self.spec
        self.cosim = CoSimulation(model, list(self.input_values), self.output_names,
                                  t0=float(spec["start_time"]), method=spec["method"],
                                  integrator=spec["integrator"], rtol=spec["rtol"],
                                  atol=spec["atol"], name=f"FMU {spec['identifier']!r}")
        self._held = self.cosim.held
        self._values = self.cosim.output_values()

    def _get_fmu_state(self) -> dict:
        """fmi2GetFMUstate: the inputs, the co-simulation's state (None before the first
        step) and the outputs, as JSON-compatible values."""
        return {"inputs": dict(self.input_values),
                "cosim": None if self.cosim is None else self.cosim.get_state(),
                "values": [float(x) for x in self._values]}

    def _set_fmu_state(self, state: dict) -> None:
        """fmi2SetFMUstate: back to a state of :meth:`_get_fmu_state`."""
        self.input_values.update({k: float(v) for k, v in state["inputs"].items()})
        if state["cosim"] is not None:
            if self.cosim is None:
                self._build()
            self.cosim.set_state(state["cosim"])
            self._values = self.cosim._values
        else:
            self._values = list(state["values"])

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.cosim is None:
            self._build()
        self._held[:] = list(self.input_values.values())
        try:
            self.cosim.do_step(current_time, step_size)
        except Exception as exc:  # noqa: BLE001 - reported through the FMI logger, fmi2Error
            from pythonfmu import Fmi2Status
            self.log(f"{type(exc).__name__}: {exc}", Fmi2Status.error, "logStatusError")
            self.error = exc
            return False
        self._values = self.cosim._values
        return True
