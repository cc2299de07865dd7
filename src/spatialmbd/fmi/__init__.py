"""Co-simulation through the Functional Mock-up Interface (FMI 2.0, co-simulation): a model
exported as an FMU (:func:`.export.export_fmu`, ``spatialmbd fmu``) and an FMU driving a model's
actuators (:class:`.controller.FMUController`). docs/fmi.md. The packaging and the importer
are the optional extra ``spatialmbd[fmi]`` (pythonfmu, fmpy)."""
