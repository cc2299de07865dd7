"""Reading the MSC ADAMS joint-test decks (.adm) and result tables of Project Chrono.

How a deck is read (the subset of the ADAMS/Solver data language these decks use):

* Statements start with ``NAME/id`` and continue on lines beginning with ``,``; ``!`` starts a
  comment. Keywords are ``KEY = v1, v2, ...``; an angle with the suffix ``D`` is in degrees,
  otherwise radians.
* ``PART/id, GROUND`` is the ground; ``PART/id, MASS = m, CM = marker, IP = Ixx, Iyy, Izz``
  a body whose centre of mass is the ``CM`` marker and whose inertia is given in that marker's
  axes. No part here has its own ``QG``/``REULER``, so every part frame coincides with the
  global frame at t = 0 and marker data are global initial positions.
* ``MARKER/id, PART = p, QP = x, y, z, REULER = a, b, c``: origin QP and orientation by
  body-fixed 3-1-3 Euler angles, A = Rz(a) Rx(b) Rz(c) (columns: the marker axes in global
  components; the same matrix as the text's zxz Euler angles, Eq. 4.2).
* ``JOINT/id, TYPE, I = marker, J = marker``: the I marker's part is our body i, the J marker's
  part our body j. REVOLUTE: point = I origin, axis = I z axis. SPHERICAL: point = I origin.
  HOOKE: point = I origin, cross axes = I x axis (on body i) and J y axis (on body j).
* ``ACCGRAV/ IGRAV, JGRAV, KGRAV``: gravity vector (missing components 0).

The body built for a part has its centre of mass at the CM marker and its body axes along the
CM marker's axes, so that ADAMS' output (``ORIENT(27, ..., cm, ground)``: Euler parameters of
the CM marker; displacements/velocities of the CM marker in ground axes) compares directly with
ours. The reaction ``JOINT(id, 0, 2..8, 0)`` is the force and torque that the joint applies
to the part of the I marker - here the ground - at the I marker, in ground axes: our
``force_i`` / ``moment_i``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..model import ModelBuilder
from ..rotations import A_from_euler_zxz

_NUM = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)([dD]?)$")


def _number(text: str) -> float:
    m = _NUM.match(text.strip())
    if not m:
        raise ValueError(f"not a number: {text!r}")
    value = float(m.group(1))
    return np.deg2rad(value) if m.group(2) else value


@dataclass
class Statement:
    name: str
    id: int
    words: list = field(default_factory=list)      # flags such as GROUND, REVOLUTE
    keys: dict = field(default_factory=dict)       # KEY -> list of strings


def parse_statements(text: str) -> list[Statement]:
    """The statements of an .adm deck (comments removed, continuation lines joined)."""
    logical: list[str] = []
    for raw in text.splitlines():
        line = raw.split("!", 1)[0].rstrip()
        if not line.strip():
            continue
        if line.lstrip().startswith(","):
            if logical:
                logical[-1] += line
            continue
        logical.append(line)
    out = []
    for line in logical:
        head, _, rest = line.partition("/")
        if not rest and "/" not in line:
            continue                                     # title line, END
        name = head.strip().upper()
        items = [s.strip() for s in rest.split(",")]
        first = items[0] if items else ""
        try:
            sid = int(first)
            items = items[1:]
        except ValueError:
            sid = 0
        st = Statement(name, sid)
        key = None
        for item in items:
            if not item:
                continue
            if "=" in item:
                key, _, value = item.partition("=")
                key = key.strip().upper()
                st.keys[key] = [value.strip()]
            elif key is not None and _NUM.match(item):
                st.keys[key].append(item)
            else:
                st.words.append(item.upper())
                key = None
        out.append(st)
    return out


@dataclass
class Marker:
    id: int
    part: int
    origin: np.ndarray
    A: np.ndarray


@dataclass
class Deck:
    """The parts, markers, joints and gravity of one deck."""

    name: str
    parts: dict           # id -> dict(ground, mass, cm, ip)
    markers: dict         # id -> Marker
    joints: list          # dict(id, type, I, J)
    gravity: np.ndarray

    @classmethod
    def read(cls, path) -> "Deck":
        path = Path(path)
        stmts = parse_statements(path.read_text())
        parts, markers, joints = {}, {}, []
        gravity = np.zeros(3)
        for st in stmts:
            if st.name == "PART":
                if "GROUND" in st.words:
                    parts[st.id] = dict(ground=True)
                else:
                    ip = [_number(x) for x in st.keys["IP"]]
                    if len(ip) > 3 and any(abs(x) > 0 for x in ip[3:]):
                        raise ValueError(f"{path.name}: PART/{st.id} has products of inertia, which this "
                                         "deck reader does not support")
                    if "QG" in st.keys or "REULER" in st.keys:
                        raise ValueError(f"{path.name}: PART/{st.id} has its own frame (QG/REULER), "
                                         "which this deck reader does not support")
                    parts[st.id] = dict(ground=False, mass=_number(st.keys["MASS"][0]),
                                        cm=int(st.keys["CM"][0]), ip=np.array(ip[:3]))
            elif st.name == "MARKER":
                qp = np.array([_number(x) for x in st.keys.get("QP", ["0", "0", "0"])])
                ang = np.array([_number(x) for x in st.keys.get("REULER", ["0", "0", "0"])])
                markers[st.id] = Marker(st.id, int(st.keys["PART"][0]), qp,
                                        A_from_euler_zxz(ang))
            elif st.name == "JOINT":
                joints.append(dict(id=st.id, type=st.words[0], I=int(st.keys["I"][0]),
                                   J=int(st.keys["J"][0])))
            elif st.name == "ACCGRAV":
                for k, key in enumerate(("IGRAV", "JGRAV", "KGRAV")):
                    if key in st.keys:
                        gravity[k] = _number(st.keys[key][0])
        return cls(path.stem.replace("test_", ""), parts, markers, joints, gravity)

    def part_name(self, pid: int) -> str:
        return "ground" if self.parts[pid]["ground"] else f"part{pid:02d}"

    def builder(self) -> ModelBuilder:
        """A ModelBuilder of the deck (bodies at rest, as the decks give no initial velocity)."""
        b = ModelBuilder(self.name, gravity=self.gravity)
        for pid, part in self.parts.items():
            if part["ground"]:
                continue
            cm = self.markers[part["cm"]]
            b.add_body(self.part_name(pid), part["mass"], part["ip"], r=cm.origin, A=cm.A)
        for j in self.joints:
            mi, mj = self.markers[j["I"]], self.markers[j["J"]]
            bi, bj = self.part_name(mi.part), self.part_name(mj.part)
            name = f"joint{j['id']}"
            if np.linalg.norm(mi.origin - mj.origin) > 1e-9:
                raise ValueError(f"{self.name} {name}: I and J markers are not coincident; "
                                 "this deck reader supports coincident markers only")
            if j["type"] == "REVOLUTE":
                b.add_joint("revolute", name, bi, bj, point=mi.origin, axis=mi.A[:, 2])
            elif j["type"] == "SPHERICAL":
                b.add_joint("spherical", name, bi, bj, point=mi.origin)
            elif j["type"] == "HOOKE":
                b.add_joint("universal", name, bi, bj, point=mi.origin, axis=mi.A[:, 0],
                            axis2=mj.A[:, 1])
            else:
                raise ValueError(f"{self.name} {name}: joint type {j['type']} is not supported "
                                 "by this deck reader (REVOLUTE, SPHERICAL, HOOKE)")
        return b


#: Columns of each ADAMS result table.
QUANTITIES = ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce", "Rtorque")


def read_table(path) -> tuple[np.ndarray, np.ndarray, list]:
    """(t (n,), values (n, k), column names) of one ``<Case>_ADAMS_<Qty>.txt`` table."""
    lines = Path(path).read_text().splitlines()
    header = lines[2].split("\t")
    data = np.array([[float(x) for x in ln.split()] for ln in lines[3:] if ln.strip()])
    return data[:, 0], data[:, 1:], header[1:]
