"""MuJoCo's compiler, wrapped: every failure becomes one located ModelError, and MuJoCo writes
no log file (``MUJOCO_LOG.TXT``) anywhere.

Before compiling, the XML text is checked for what MuJoCo either accepts silently or fails on
without saying where: numbers that are not finite (a NaN ``<inertial><origin>`` in a URDF is
otherwise read as 0) and empty numeric attributes (an empty ``anchor`` makes MuJoCo's compiler
raise "Caught an unknown exception!").
"""
from __future__ import annotations

import contextlib
import math
import pathlib
import xml.parsers.expat

from ...errors import ModelError

#: attributes that hold numbers in MJCF and URDF (checked for NaN, inf and emptiness)
NUMERIC_ATTRIBUTES = frozenset("""
    pos quat axisangle xyaxes zaxis euler xyz rpy anchor axis range size fromto mass
    diaginertia fullinertia inertia value ixx ixy ixz iyy iyz izz radius length scale
    lower upper effort velocity damping friction stiffness armature frictionloss springref
    ref density gravity timestep polycoef relpose solref solimp margin gap gear ctrlrange
    forcerange kp kv ipos iquat""".split())


def mujoco_module():
    try:
        import mujoco
    except ImportError:
        raise ModelError("importing MJCF/URDF needs MuJoCo's compiler: pip install "
                         "'spatialmbd[mjcf]'") from None
    return mujoco


@contextlib.contextmanager
def no_log_file(mujoco):
    """MuJoCo's log (MUJOCO_LOG.TXT in the working folder, on errors and warnings) switched
    off for the duration; the previous setting is restored."""
    config = getattr(mujoco, "MjLogConfig", None)
    if config is None:                                      # older MuJoCo: a silent warning
        previous = mujoco.get_mju_user_warning() if hasattr(mujoco, "get_mju_user_warning") \
            else None
        if hasattr(mujoco, "set_mju_user_warning"):
            mujoco.set_mju_user_warning(lambda message: None)
        try:
            yield
        finally:
            if hasattr(mujoco, "set_mju_user_warning"):
                mujoco.set_mju_user_warning(previous)
        return
    saved = config()
    saved.get()
    quiet = config()
    quiet.get()
    quiet.logto_file = False
    quiet.logto_console = False
    quiet.set()
    try:
        yield
    finally:
        saved.set()


def _is_xml_text(source) -> bool:
    return isinstance(source, str) and source.lstrip().startswith("<")


def _suspect_values(text: str, label: str) -> list:
    """Located problems of numeric attributes in the XML ``text``: not finite, or empty."""
    problems = []
    parser = xml.parsers.expat.ParserCreate()
    stack: list = []

    def start(tag, attributes):
        stack.append((tag, attributes.get("name") or attributes.get("link")))
        where = f"{label}, line {parser.CurrentLineNumber}: <{tag}"
        owner = next((f" of {t} {n!r}" for t, n in reversed(stack) if n), "")
        for key, value in attributes.items():
            if key not in NUMERIC_ATTRIBUTES:
                continue
            tokens = value.split()
            if not tokens:
                problems.append(f"{where} {key}=\"{value}\">{owner}: empty; give numbers or "
                                "leave the attribute out")
                continue
            for token in tokens:
                try:
                    number = float(token)
                except ValueError:
                    continue                 # MuJoCo names the unreadable ones itself
                if not math.isfinite(number):
                    problems.append(f"{where} {key}=\"{value}\">{owner}: {token} is not a "
                                    "finite number")
                    break

    def end(tag):
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(text, True)
    except xml.parsers.expat.ExpatError as exc:
        problems.append(f"{label}: not well-formed XML ({exc})")
    return problems


def source_text(source) -> tuple:
    """(XML text or None, label for messages, path or None) of a path or XML text."""
    if _is_xml_text(source):
        return source, "the XML", None
    path = pathlib.Path(source)
    if not path.is_file():
        raise ModelError(f"no such MJCF/URDF file: {source}")
    try:
        return path.read_text(encoding="utf-8", errors="replace"), str(path), path
    except OSError as exc:
        raise ModelError(f"{path}: cannot be read ({exc.strerror or exc})") from None


def compile_model(source) -> tuple:
    """(mujoco.MjModel, file stem or None, XML text) of a path or XML text; ModelError with
    one line per problem, located, on any failure of the check or of MuJoCo's compiler."""
    mujoco = mujoco_module()
    text, label, path = source_text(source)
    problems = _suspect_values(text, label)
    if problems:
        raise ModelError("; ".join(problems))
    try:
        with no_log_file(mujoco):
            if path is not None:
                model = mujoco.MjModel.from_xml_path(str(path.resolve()))
            else:
                model = mujoco.MjModel.from_xml_string(text)
    except Exception as exc:  # noqa: BLE001 - MuJoCo raises ValueError, RuntimeError, ...
        message = " ".join(str(exc).split()) or type(exc).__name__
        if "unknown exception" in message.lower():
            message = (f"the compiler failed without saying where ({type(exc).__name__}: "
                       f"{message}); check the file's attributes (empty or malformed values)")
        raise ModelError(f"MuJoCo could not compile {label}: {message}") from None
    return model, (path.stem if path is not None else None), text


def run_forward(mujoco, model, keyframe=None):
    """MjData at qpos0 (or at the keyframe named ``keyframe``: its qpos, qvel and ctrl) after
    mj_forward, without MuJoCo's log file; failures as ModelError."""
    key = -1
    if keyframe is not None:
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, str(keyframe))
        if key < 0:
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or f"#{k}"
                     for k in range(model.nkey)]
            raise ModelError(f"keyframe {keyframe!r}: the file has no keyframe of that name "
                             f"(keyframes: {', '.join(names) or 'none'})")
    try:
        with no_log_file(mujoco):
            data = mujoco.MjData(model)
            if key >= 0:
                mujoco.mj_resetDataKeyframe(model, data, key)
            mujoco.mj_forward(model, data)
    except Exception as exc:  # noqa: BLE001
        raise ModelError(f"MuJoCo could not evaluate the model at its reference configuration: "
                         f"{' '.join(str(exc).split()) or type(exc).__name__}") from None
    return data
