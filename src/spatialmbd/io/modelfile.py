"""Model files: one versioned schema, written as YAML or JSON (see docs/model-file.md).

A model file holds everything the Python API can express except Python callables (user motion
laws and user forces): the bodies, joints, drivers, force elements and display shapes of a
:class:`~spatialmbd.model.ModelBuilder`, and an optional ``analysis`` section saying what to run.

Loading checks the whole file before anything is computed and reports every problem at once,
each with its place in the file (``bodies[2].inertia: ...``); the checks on values are the
builder's own (its methods are called inside ``try``), this module adds the checks that only
make sense for files: unknown keys, wrong types, missing keys, references to undeclared names.

Writing is exact: floats are written with ``repr`` precision, so model -> file -> model gives
bit-identical specs, initial state and constraint values.
"""
from __future__ import annotations

# The model-file package, split by job: the schema and the checks of values (.schema), the
# analysis section (.analysis), reading the text safely (.source), file -> builder (.reader),
# builder -> file (.writer). This module re-exports them: one import for readers and writers.
from .schema import (  # noqa: F401
    ANALYSIS_KEYS,
    ANALYSIS_TYPES,
    BODY_KEYS,
    DRIVER_KEYS,
    DYNAMIC_ONLY,
    ENGINEERING_TYPES,
    GEOMETRY_KEYS,
    JOINT_KEYS,
    JSON_SUFFIXES,
    ModelFileError,
    ORIENTATION_KEYS,
    RANGES,
    SCHEMA_VERSION,
    SHAPE_KEYS,
    SHAPE_REQUIRED,
    SINGLE_TIME_TYPES,
    TOP_KEYS,
    YAML_SUFFIXES,
    _BASE_DIR,
    _BODY_FIELDS,
    _BUILD_ERRORS,
    _COLOR,
    _EPS,
    _GEOMETRY_ORDER,
    _IDENT,
    _PLURAL,
    _Problems,
    _RANGE_KEYS,
    _color,
    _density_body,
    _describe,
    _finite,
    _is_number,
    _law,
    _list,
    _mapping,
    _matrix,
    _member,
    _mesh,
    _name,
    _number,
    _range_checks,
    _reference,
    _relabel,
    _render,
    _shape,
    _short,
    _string,
    _suggest,
    _vector,
    joint_keys)
from .analysis import (  # noqa: F401
    Analysis,
    _options,
    _parse_analysis)
from .source import (  # noqa: F401
    MAX_ALIASES,
    MAX_DEPTH,
    MAX_FILE_BYTES,
    MAX_INT_DIGITS,
    MAX_NODES,
    _BOOL_TAG,
    _FLOAT_RE,
    _FLOAT_TAG,
    _LimitError,
    _Loader,
    _char,
    _decode,
    _expanded_size,
    _line_column,
    _plain_input,
    _read,
    _read_json,
    _read_yaml,
    _too_deep,
    _walk)
from .reader import (  # noqa: F401
    _parse,
    _parse_outputs_section,
    _section,
    load_builder,
    load_model)
from .writer import model_to_dict, save_model, write_examples  # noqa: F401

__all__ = ["SCHEMA_VERSION", "ModelFileError", "Analysis", "load_model", "load_builder",
           "model_to_dict", "save_model", "write_examples"]
