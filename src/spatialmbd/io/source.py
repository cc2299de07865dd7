"""Reading a model file's text safely: size, nesting, alias and number limits, encodings, and
the line of every value (for located errors), for YAML and JSON."""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import yaml

from .schema import JSON_SUFFIXES, ModelFileError, YAML_SUFFIXES, _render


# ============================================================================ reading files
#: limits of what the reader accepts (see docs/reliability.md): file size in bytes, nesting
#: depth of lists/mappings, YAML aliases, values after alias expansion, digits of an integer
MAX_FILE_BYTES = 64 * 1024 * 1024
MAX_DEPTH = 64
MAX_ALIASES = 1000
MAX_NODES = 1_000_000
MAX_INT_DIGITS = 300


class _LimitError(Exception):
    """A reader limit was exceeded (turned into a ModelFileError with the line)."""

    def __init__(self, message, mark=None):
        super().__init__(message)
        self.mark = mark


class _Loader(yaml.SafeLoader):
    """SafeLoader reading floats as YAML 1.2 does (``1e-6`` is a number, not a string) and
    only true/false as booleans (not yes/no/on/off); with limits on nesting depth and aliases
    (a "billion laughs" document is refused, not expanded)."""

    _depth = 0
    _aliases = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise _LimitError(f"more than {MAX_ALIASES} YAML aliases (*name); a model "
                                  "file needs few, write the values out",
                                  self.peek_event().start_mark)
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _LimitError(f"lists/mappings nested more than {MAX_DEPTH} levels deep "
                                  "(a model file needs at most 6); check the brackets and the "
                                  "indentation", self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_yaml_int(self, node):
        digits = len(str(node.value).lstrip("+-").replace("_", ""))
        if digits > MAX_INT_DIGITS:
            raise yaml.constructor.ConstructorError(
                None, None, f"an integer with {digits} digits (the limit is "
                f"{MAX_INT_DIGITS}); write a number in range", node.start_mark)
        return super().construct_yaml_int(node)


_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)


_FLOAT_TAG = "tag:yaml.org,2002:float"
_BOOL_TAG = "tag:yaml.org,2002:bool"
_FLOAT_RE = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?
                        |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                        |[-+]?\.(?:inf|Inf|INF)
                        |\.(?:nan|NaN|NAN))$""", re.X)
_Loader.yaml_implicit_resolvers = {
    ch: [(tag, rx) for tag, rx in resolvers if tag not in (_FLOAT_TAG, _BOOL_TAG)]
    for ch, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver(_FLOAT_TAG, _FLOAT_RE, list("-+0123456789."))
_Loader.add_implicit_resolver(_BOOL_TAG, re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"),
                              list("tTfF"))


def _walk(node, path, lines, duplicates, active=(), count=None) -> None:
    """Line of every value (path -> 1-based line) and duplicate keys, from the YAML node tree
    (``active``: the nodes being walked, so that recursive aliases end; ``count``: values
    visited, aliases expanded, limited to MAX_NODES)."""
    if id(node) in active:
        raise _LimitError("a YAML alias refers to a list or mapping that contains it (a "
                          "recursive structure); write the values out", node.start_mark)
    count = [0] if count is None else count
    count[0] += 1
    if count[0] > MAX_NODES:
        raise _LimitError(f"the document holds more than {MAX_NODES:,} values once its "
                          "aliases are expanded", node.start_mark)
    active = active + (id(node),)
    if isinstance(node, yaml.MappingNode):
        seen = set()
        for knode, vnode in node.value:
            if not isinstance(knode, yaml.ScalarNode) or knode.value == "<<":
                continue
            key = knode.value
            where = path + (key,)
            if key in seen:
                duplicates.append((where, knode.start_mark.line + 1))
            seen.add(key)
            lines.setdefault(where, vnode.start_mark.line + 1)
            _walk(vnode, where, lines, duplicates, active, count)
    elif isinstance(node, yaml.SequenceNode):
        for k, item in enumerate(node.value):
            lines.setdefault(path + (k,), item.start_mark.line + 1)
            _walk(item, path + (k,), lines, duplicates, active, count)


def _expanded_size(node, memo: dict, active: set) -> int:
    """Number of values of the node tree with aliases expanded (memoised per node, so a
    "billion laughs" document costs its size, not its expansion); raises _LimitError above
    MAX_NODES or for a recursive alias."""
    key = id(node)
    if key in memo:
        return memo[key]
    if key in active:
        raise _LimitError("a YAML alias refers to a list or mapping that contains it (a "
                          "recursive structure); write the values out", node.start_mark)
    active.add(key)
    total = 1
    if isinstance(node, yaml.MappingNode):
        total += sum(_expanded_size(v, memo, active) for _, v in node.value)
    elif isinstance(node, yaml.SequenceNode):
        total += sum(_expanded_size(v, memo, active) for v in node.value)
    active.discard(key)
    if total > MAX_NODES:
        raise _LimitError(f"the document holds more than {MAX_NODES:,} values once its "
                          "aliases are expanded (a 'billion laughs' document?)",
                          node.start_mark)
    memo[key] = total
    return total


def _read_yaml(text: str, source):
    lines, duplicates = {}, []
    loader = None
    try:
        loader = _Loader(text)
        node = loader.get_single_node()
        if node is not None:
            _expanded_size(node, {}, set())
            _walk(node, (), lines, duplicates)
        data = loader.construct_document(node) if node is not None else None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        what = exc.problem or exc.context or "invalid YAML"
        if exc.context and exc.problem:
            what = f"{exc.problem} ({exc.context})"
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        raise ModelFileError([f"{where}YAML syntax error: {what}"], source) from None
    except _LimitError as exc:
        where = f"line {exc.mark.line + 1}, column {exc.mark.column + 1}: " if exc.mark else \
            "(top level): "
        raise ModelFileError([f"{where}{exc}"], source) from None
    except yaml.reader.ReaderError as exc:
        line, column = _line_column(text, exc.position)
        raise ModelFileError([f"line {line}, column {column}: the character "
                              f"{_char(exc.character)} is not allowed in a YAML file; remove "
                              "it (binary data or a wrong encoding?)"], source) from None
    except yaml.YAMLError as exc:
        raise ModelFileError([f"(top level): YAML error: {exc}"], source) from None
    except (RecursionError, MemoryError):
        raise ModelFileError([f"(top level): the document is nested too deeply or is too "
                              f"large to read (limits: {MAX_DEPTH} levels, "
                              f"{MAX_FILE_BYTES // 2 ** 20} MB)"], source) from None
    except (ValueError, OverflowError) as exc:          # e.g. Python's int-digit limit
        raise ModelFileError([f"(top level): a value cannot be read: {exc}"], source) \
            from None
    finally:
        if loader is not None:
            loader.dispose()
    return data, lines, duplicates


def _read_json(text: str, source):
    duplicates = []

    def pairs(items):
        out = {}
        for key, value in items:
            if key in out:
                duplicates.append(((key,), None))
            out[key] = value
        return out

    def parse_int(digits):
        if len(digits.lstrip("-")) > MAX_INT_DIGITS:
            raise _LimitError(f"an integer with {len(digits.lstrip('-'))} digits (the limit "
                              f"is {MAX_INT_DIGITS}); write a number in range")
        return int(digits)

    try:
        data = json.loads(text, object_pairs_hook=pairs, parse_int=parse_int)
    except json.JSONDecodeError as exc:
        raise ModelFileError([f"line {exc.lineno}, column {exc.colno}: JSON syntax error: "
                              f"{exc.msg}"], source) from None
    except _LimitError as exc:
        raise ModelFileError([f"(top level): {exc}"], source) from None
    except (RecursionError, MemoryError):
        raise ModelFileError([f"(top level): the document is nested too deeply or is too "
                              f"large to read (limits: {MAX_DEPTH} levels, "
                              f"{MAX_FILE_BYTES // 2 ** 20} MB)"], source) from None
    except (ValueError, OverflowError) as exc:
        raise ModelFileError([f"(top level): a value cannot be read: {exc}"], source) \
            from None
    deep = _too_deep(data)
    if deep is not None:
        raise ModelFileError([f"{_render(deep)}: lists/mappings nested more than {MAX_DEPTH} "
                              "levels deep (a model file needs at most 6); check the "
                              "brackets"], source)
    return data, {}, duplicates


def _too_deep(data):
    """The path of a value nested deeper than MAX_DEPTH, or None (iterative)."""
    stack = [(data, ())]
    while stack:
        value, path = stack.pop()
        if len(path) > MAX_DEPTH:
            return path[:MAX_DEPTH]
        if isinstance(value, dict):
            stack.extend((v, path + (str(k),)) for k, v in value.items())
        elif isinstance(value, (list, tuple)):
            stack.extend((v, path + (k,)) for k, v in enumerate(value))
    return None


def _line_column(text: str, position: int):
    before = text[:position]
    return before.count("\n") + 1, position - (before.rfind("\n") + 1) + 1


def _char(character) -> str:
    code = ord(character) if isinstance(character, str) and len(character) == 1 else \
        character if isinstance(character, int) else None
    return f"U+{code:04X}" if code is not None else repr(character)


def _decode(raw: bytes, source) -> str:
    """The text of a model file: UTF-8 (with or without a byte-order mark), or UTF-16 /
    UTF-32 with a byte-order mark; anything else is refused with what it looks like."""
    boms = ((b"\xef\xbb\xbf", "utf-8-sig", "UTF-8"), (b"\xff\xfe\x00\x00", "utf-32", "UTF-32"),
            (b"\x00\x00\xfe\xff", "utf-32", "UTF-32"), (b"\xff\xfe", "utf-16", "UTF-16"),
            (b"\xfe\xff", "utf-16", "UTF-16"))
    for bom, codec, label in boms:
        if raw.startswith(bom):
            try:
                return raw.decode(codec)
            except UnicodeDecodeError as exc:
                raise ModelFileError([f"byte {exc.start}: the file starts with a {label} "
                                      f"byte-order mark but is not valid {label} ({exc.reason})"
                                      "; save it as UTF-8"], source) from None
    head = raw[:4096]
    if head and head.count(0) > len(head) // 4:      # ASCII text in UTF-16/32 is valid UTF-8
        raise ModelFileError([f"line 1, column 1: the file has {raw.count(0):,} zero bytes; it "
                              "looks like UTF-16 or UTF-32 without a byte-order mark. Model "
                              "files must be UTF-8 (UTF-16 is read with a byte-order mark): "
                              "save the file as UTF-8"], source)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        head = raw[:4096]
        if head and head.count(0) > len(head) // 4:
            guess = "it looks like UTF-16 or UTF-32 without a byte-order mark"
        else:
            guess = "it looks like another encoding (e.g. Latin-1 or Windows-1252) or binary data"
        line = raw[:exc.start].count(b"\n") + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise ModelFileError([f"line {line}, column {column}: byte 0x{raw[exc.start]:02x} is not "
                              f"valid UTF-8; {guess}. Model files must be UTF-8 (UTF-16 is read "
                              "with a byte-order mark): save the file as UTF-8"], source) \
            from None


def _plain_input(value):
    """Python input (dicts with tuples / NumPy values) as the plain types a file gives; the
    numeric arrays of a mesh (``vertices``, ``faces``) stay arrays (checked as a mesh)."""
    if isinstance(value, dict):
        return {k: v if k in ("vertices", "faces") and isinstance(v, np.ndarray)
                and v.dtype.kind in "fiu" else _plain_input(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain_input(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain_input(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def _read(path_or_dict):
    """(data, source, lines, duplicates, default name) of a path or a dict."""
    if isinstance(path_or_dict, dict):
        deep = _too_deep(path_or_dict)
        if deep is not None:
            raise ModelFileError([f"{_render(deep)}: lists/mappings nested more than "
                                  f"{MAX_DEPTH} levels deep (or a structure that contains "
                                  "itself)"])
        return _plain_input(path_or_dict), None, {}, [], "model"
    if not isinstance(path_or_dict, (str, os.PathLike)):
        raise ModelFileError([f"(top level): expected a path (.yaml, .yml, .json) or a dict, "
                              f"not {type(path_or_dict).__name__}"])
    path = Path(path_or_dict)
    suffix = path.suffix.lower()
    if suffix not in YAML_SUFFIXES + JSON_SUFFIXES:
        raise ModelFileError([f"unsupported file extension {path.suffix!r}; use .yaml, .yml "
                              "or .json"], path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ModelFileError([f"(top level): the file is {size:,} bytes; the limit is "
                                  f"{MAX_FILE_BYTES:,} (io.source.MAX_FILE_BYTES)"], path)
        raw = path.read_bytes()
    except OSError as exc:
        raise ModelFileError([f"(top level): cannot read the file: {exc.strerror or exc}"],
                             path) from None
    text = _decode(raw, path)
    reader = _read_yaml if suffix in YAML_SUFFIXES else _read_json
    data, lines, duplicates = reader(text, path)
    return data, path, lines, duplicates, path.stem
