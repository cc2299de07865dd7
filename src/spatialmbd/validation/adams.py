"""Reading the MSC ADAMS joint-test decks (.adm) and result tables of Project Chrono.

How a deck is read (the subset of the ADAMS/Solver data language these decks use):

* Statements start with ``NAME/id`` and continue on lines beginning with ``,``; ``!`` starts a
  comment. Keywords are ``KEY = v1, v2, ...`` (commas inside parentheses, as in a FUNCTION
  expression, do not separate); an angle with the suffix ``D`` is in degrees, otherwise
  radians.
* ``PART/id, GROUND`` is the ground; ``PART/id, MASS = m, CM = marker, IP = Ixx, Iyy, Izz``
  a body whose centre of mass is the ``CM`` marker and whose inertia is given in that marker's
  axes. No part here has its own ``QG``/``REULER``, so every part frame coincides with the
  global frame at t = 0 and marker data are global initial positions.
* ``MARKER/id, PART = p, QP = x, y, z, REULER = a, b, c``: origin QP and orientation by
  body-fixed 3-1-3 Euler angles, A = Rz(a) Rx(b) Rz(c) (columns: the marker axes in global
  components; the same matrix as the text's zxz Euler angles, Eq. 4.2).
* ``JOINT/id, TYPE, I = marker, J = marker`` (joint ``joint<id>``; I and J markers coincident):
  the I marker's part is our body i, the J marker's part our body j. REVOLUTE: point = I
  origin, axis = I z axis. SPHERICAL: point = I origin. HOOKE: point = I origin, cross axes =
  I x axis (on body i) and J y axis (on body j). TRANSLATIONAL (our "translational"; the I and
  J markers must be aligned): point = I origin, sliding axis = I z axis; ADAMS holds the
  markers' x and y axes as assembled, our joint holds the relative rotation as assembled -
  the same constraint. CYLINDRICAL (our "cylindrical"; the markers' z axes must coincide):
  point = I origin, axis = I z axis.
* ``GCON/id, I = marker, FUNCTION = DM(a, b) - L`` (constraint ``gcon<id>``): the distance of
  markers a and b, one of them the I marker, held at L - our "spherical_spherical" joint with
  point = the I marker's origin (body i: its part), point2 = the other marker's origin (body
  j), length = L. Other FUNCTION expressions are rejected.
* ``SFORCE/id, TRANSLATIONAL | ROTATIONAL, I, J, FUNCTION = ...`` (force ``sforce<id>``) with
  a linear spring-damper FUNCTION (:func:`_sforce`; a FUNCTION continued over ``,`` lines is
  joined): TRANSLATIONAL ``-k (DM(I,J) - L0) - c VR(I,J)`` is our "spring_damper" between the
  I marker's origin (body i) and the J marker's (body j); ROTATIONAL
  ``-k RTOD (AZ(I,J) - 0) - c RTOD WZ(I,J,J)`` our "rotational_spring_damper" about the
  revolute/cylindrical joint between the same parts whose axis is the J marker's z axis
  (aligned I and J markers, rest angle 0).
* ``ACCGRAV/ IGRAV, JGRAV, KGRAV``: gravity vector (missing components 0).
* Statements that would add other forces, motions or constraints (``UNSUPPORTED``:
  SPRINGDAMPER, VFORCE, MOTION, ...) are rejected with an error naming them; GRAPHICS, REQUEST,
  VARIABLE, OUTPUT and UNITS (SI in these decks) are ignored.

The body built for a part has its centre of mass at the CM marker and its body axes along the
CM marker's axes, so that ADAMS' output (``ORIENT(27, ..., cm, ground)``: Euler parameters of
the CM marker; displacements/velocities of the CM marker in ground axes) compares directly with
ours. The reaction ``JOINT(id, 0, 2..8, 0)`` (and, for the GCON, the request
``F, I = <I marker>, J = <other marker>, RM = <ground marker>``) is the force and torque that
the joint applies to the part of the I marker - here the ground - about the I marker (fixed:
for the translational and cylindrical joints the torque grows as the body slides away), in
ground axes: our ``force_i`` / ``moment_i`` (checked against every table: e.g. at release the
translational joint of Prismatic_Case02 pulls the ground with m g_n and a torque
(r_c - P) x m g_n).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..model import ModelBuilder
from ..rotations import A_from_euler_zxz, A_from_p

_NUM = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)([dD]?)$")


def _number(text: str) -> float:
    m = _NUM.match(text.strip())
    if not m:
        raise ValueError(f"not a number: {text!r}")
    value = float(m.group(1))
    return np.deg2rad(value) if m.group(2) else value


def _split_outside_parentheses(text: str, at) -> list[str]:
    """``text`` split before (``at(text, k)`` = "keep") or at (= "drop") the characters k
    outside parentheses for which ``at`` says so (None: no split there)."""
    items, depth, start = [], 0, 0
    for k, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif depth == 0:
            how = at(text, k)
            if how == "drop":
                items.append(text[start:k])
                start = k + 1
            elif how == "keep" and k > start:
                items.append(text[start:k])
                start = k
    items.append(text[start:])
    return items


def _split_commas(text: str) -> list[str]:
    """``text`` split at the commas outside parentheses (a FUNCTION expression such as
    ``DM(0202, 0102)-2`` stays one item)."""
    return _split_outside_parentheses(text, lambda s, k: "drop" if s[k] == "," else None)


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
        items = [s.strip() for s in _split_commas(rest)]
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
            elif key == "FUNCTION":
                # an expression continued on the next line (``, - 1.0*vr(204,205)``): the
                # continuation comma is not part of it
                st.keys[key][0] += " " + item
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
    forces: list = field(default_factory=list)   # SFORCE: dict(id, name, type, I, J, ...)

    @classmethod
    def read(cls, path) -> "Deck":
        path = Path(path)
        stmts = parse_statements(path.read_text())
        parts, markers, joints, forces = {}, {}, [], []
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
                joints.append(dict(id=st.id, name=f"joint{st.id}", type=st.words[0],
                                   I=int(st.keys["I"][0]), J=int(st.keys["J"][0])))
            elif st.name == "GCON":
                joints.append(_distance_gcon(path.name, st))
            elif st.name == "SFORCE":
                forces.append(_sforce(path.name, st))
            elif st.name in UNSUPPORTED:
                raise ValueError(f"{path.name}: {st.name}/{st.id} is not supported by this deck "
                                 "reader (PART, MARKER, JOINT REVOLUTE/SPHERICAL/HOOKE/"
                                 "TRANSLATIONAL/CYLINDRICAL, GCON DM(a, b) - L, SFORCE "
                                 "spring-dampers, ACCGRAV)")
            elif st.name == "ACCGRAV":
                for k, key in enumerate(("IGRAV", "JGRAV", "KGRAV")):
                    if key in st.keys:
                        gravity[k] = _number(st.keys[key][0])
        return cls(path.stem.replace("test_", ""), parts, markers, joints, gravity, forces)

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
            name = j["name"]
            if mi.part == mj.part:
                raise ValueError(f"{self.name} {name}: I and J markers are on the same part")
            if j["type"] == "DISTANCE":
                b.add_joint("spherical_spherical", name, bi, bj, point=mi.origin,
                            point2=mj.origin, length=j["length"])
                continue
            if np.linalg.norm(mi.origin - mj.origin) > 1e-9:
                raise ValueError(f"{self.name} {name}: I and J markers are not coincident; "
                                 "this deck reader supports coincident markers only")
            if j["type"] in ("TRANSLATIONAL", "CYLINDRICAL"):
                aligned = (np.abs(mi.A - mj.A).max() if j["type"] == "TRANSLATIONAL"
                           else np.linalg.norm(mi.A[:, 2] - mj.A[:, 2]))
                if aligned > 1e-9:
                    raise ValueError(f"{self.name} {name}: the I and J markers of the "
                                     f"{j['type']} joint are not aligned "
                                     f"({'axes' if j['type'] == 'TRANSLATIONAL' else 'z axes'})"
                                     "; this deck reader supports aligned markers only")
            if j["type"] == "REVOLUTE":
                b.add_joint("revolute", name, bi, bj, point=mi.origin, axis=mi.A[:, 2])
            elif j["type"] == "SPHERICAL":
                b.add_joint("spherical", name, bi, bj, point=mi.origin)
            elif j["type"] == "HOOKE":
                b.add_joint("universal", name, bi, bj, point=mi.origin, axis=mi.A[:, 0],
                            axis2=mj.A[:, 1])
            elif j["type"] == "TRANSLATIONAL":
                b.add_joint("translational", name, bi, bj, point=mi.origin, axis=mi.A[:, 2])
            elif j["type"] == "CYLINDRICAL":
                b.add_joint("cylindrical", name, bi, bj, point=mi.origin, axis=mi.A[:, 2])
            else:
                raise ValueError(f"{self.name} {name}: joint type {j['type']} is not supported "
                                 "by this deck reader (REVOLUTE, SPHERICAL, HOOKE, "
                                 "TRANSLATIONAL, CYLINDRICAL)")
        for f in self.forces:
            self._add_sforce(b, f)
        return b

    def _local(self, b: ModelBuilder, marker: Marker) -> np.ndarray:
        """A marker's origin in the body axes of its part (the ground: global)."""
        name = self.part_name(marker.part)
        if name == "ground":
            return marker.origin.copy()
        body = b.bodies[name]
        return A_from_p(body.p).T @ (marker.origin - body.r)

    def _add_sforce(self, b: ModelBuilder, f: dict) -> None:
        mi, mj = self.markers[f["I"]], self.markers[f["J"]]
        bi, bj = self.part_name(mi.part), self.part_name(mj.part)
        if mi.part == mj.part:
            raise ValueError(f"{self.name} {f['name']}: I and J markers are on the same part")
        if f["type"] == "TRANSLATIONAL":
            b.add_force("spring_damper", f["name"], body_i=bi, body_j=bj,
                        point_i=self._local(b, mi), point_j=self._local(b, mj),
                        stiffness=f["stiffness"], damping=f["damping"],
                        natural_length=f["length"],
                        nonlinear_stiffness=f.get("nonlinear_stiffness"))
            return
        # ROTATIONAL: about the z axis of the J marker, which must be the axis of a revolute or
        # cylindrical joint between the same two parts; AZ(I, J) = 0 as assembled (I and J
        # markers aligned) and a rest angle 0, so that AZ and our joint angle are the same
        # angle up to its sign, which a linear spring-damper about 0 does not see
        if f["angle"] != 0.0 or np.abs(mi.A - mj.A).max() > 1e-9:
            raise ValueError(f"{self.name} {f['name']}: a ROTATIONAL SFORCE is read only with "
                             "aligned I and J markers and the rest angle 0")
        b.add_force("rotational_spring_damper", f["name"], joint=self.sforce_joint(f)["name"],
                    stiffness=f["stiffness"], damping=f["damping"], rest_angle=0.0,
                    nonlinear_stiffness=f.get("nonlinear_stiffness"))

    def sforce_joint(self, f: dict) -> dict:
        """The revolute or cylindrical joint between the parts of a ROTATIONAL SFORCE whose
        axis (its I marker's z axis) is the SFORCE J marker's z axis, about which it acts."""
        mi, mj = self.markers[f["I"]], self.markers[f["J"]]
        for j in self.joints:
            ji, jj = self.markers[j["I"]], self.markers[j["J"]]
            if (j["type"] in ("REVOLUTE", "CYLINDRICAL") and {ji.part, jj.part} ==
                    {mi.part, mj.part}
                    and np.linalg.norm(np.cross(ji.A[:, 2], mj.A[:, 2])) < 1e-9):
                return j
        raise ValueError(f"{self.name} {f['name']}: a ROTATIONAL SFORCE is read only about the "
                         "axis of a revolute or cylindrical joint between the same parts")


#: Statements that would add forces, motions or constraints this reader does not model: a
#: deck holding one is rejected rather than read without it.
UNSUPPORTED = frozenset({"SPRINGDAMPER", "VFORCE", "VTORQUE", "GFORCE", "BUSHING",
                         "FIELD", "BEAM", "FRICTION", "JPRIM", "MOTION", "COUPLER", "GEAR",
                         "PTCV", "CVCV", "UCON", "DIFF", "GSE", "LSE", "TFSISO", "NFORCE",
                         "CONTACT", "FLEX_BODY", "POINT_MASS"})

_DM = re.compile(r"^DM\((\d+),(\d+)\)-((?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)$", re.IGNORECASE)


def _distance_gcon(filename: str, st: Statement) -> dict:
    """A ``GCON/id, I = m, FUNCTION = DM(a, b) - L`` statement (the distance between markers a
    and b held at L, one of them the I marker) as a joint dict of type DISTANCE: I the GCON's I
    marker, J the other one, length L."""
    func = "".join(st.keys.get("FUNCTION", [""])[0].split())
    m = _DM.match(func)
    if not m or "I" not in st.keys:
        raise ValueError(f"{filename}: GCON/{st.id} FUNCTION = {func!r} is not supported by this "
                         "deck reader (only DM(a, b) - L with the I marker a or b: a distance)")
    a, b, length = int(m.group(1)), int(m.group(2)), float(m.group(3))
    i = int(st.keys["I"][0])
    if i not in (a, b) or a == b or not length > 0:
        raise ValueError(f"{filename}: GCON/{st.id}: DM({a}, {b}) - {length} needs distinct "
                         "markers, one of them the I marker, and a length L > 0")
    return dict(id=st.id, name=f"gcon{st.id}", type="DISTANCE", I=i, J=b if a == i else a,
                length=length)


_F_NUM = r"(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?"
_TERM = re.compile(rf"^([+-]?)({_F_NUM})(\*rtod)?(?:\*(.+))?$")
_OPERANDS = {
    "spring": re.compile(rf"^\(dm\((\d+),(\d+)\)-({_F_NUM})\)$|^dm\((\d+),(\d+)\)()$"),
    "damper": re.compile(r"^vr\((\d+),(\d+)\)$"),
    "rot_spring": re.compile(rf"^\(az\((\d+),(\d+)\)-({_F_NUM})(\*dtor)?\)$"
                             r"|^az\((\d+),(\d+)\)()()$"),
    "rot_damper": re.compile(r"^wz\((\d+),(\d+),(\d+)\)$"),
}


def _terms(expr: str) -> list[str]:
    """A sum split into its terms at the signs outside parentheses (not an exponent's)."""
    def sign(e, k):
        exponent = e[k - 1] == "e" and k > 1 and e[k - 2] in "0123456789."
        return "keep" if e[k] in "+-" and not exponent else None
    return _split_outside_parentheses(expr, sign)


def _sforce(filename: str, st: Statement) -> dict:
    """An ``SFORCE/id, TRANSLATIONAL | ROTATIONAL, I = a, J = b, FUNCTION = ...`` statement with a
    linear spring-damper FUNCTION as a dict(id, name "sforce<id>", type, I, J, stiffness,
    damping, length | angle):

    * TRANSLATIONAL: ``- k*(DM(a,b) - L0) - c*VR(a,b) [+ 0]``, the force along the line of the
      markers, positive repulsive: our spring_damper (tension k (l - l0) + c ldot) with the same
      k, c, l0.
    * ROTATIONAL: ``- k[*RTOD]*(AZ(a,b) - a0[*DTOR]) - c[*RTOD]*WZ(a,b,b) [+ 0]``, the torque
      about the J marker's z axis; RTOD (180/pi) turns k and c into N m/rad and N m s/rad.

    Anything else (other functions, a preload, negative coefficients) is rejected."""
    func = "".join(st.keys.get("FUNCTION", [""])[0].split()).lower()
    kind = st.words[0] if st.words else ""

    def fail(why):
        raise ValueError(f"{filename}: SFORCE/{st.id} ({kind}) FUNCTION = {func!r} is not "
                         f"supported by this deck reader: {why}")
    if kind not in ("TRANSLATIONAL", "ROTATIONAL") or "I" not in st.keys or "J" not in st.keys:
        fail("only TRANSLATIONAL or ROTATIONAL with I and J markers")
    i, j = int(st.keys["I"][0]), int(st.keys["J"][0])
    rot = kind == "ROTATIONAL"
    out = dict(id=st.id, name=f"sforce{st.id}", type=kind, I=i, J=j, stiffness=0.0,
               damping=0.0, **({"angle": 0.0} if rot else {"length": None}))
    for term in _terms(func):
        m = _TERM.match(term)
        if not m:
            fail(f"term {term!r}")
        value = float(m.group(2)) * (180.0 / np.pi if m.group(3) else 1.0)
        if m.group(4) is None:
            if value != 0.0:
                fail("a constant force or torque (preload)")
            continue
        if m.group(1) != "-":
            fail(f"term {term!r}: a spring-damper term must be negative (restoring)")
        for what, pattern in _OPERANDS.items():
            o = pattern.match(m.group(4))
            if o is not None and what.startswith("rot_") == rot:
                break
        else:
            fail(f"term {term!r}")
        g = [x for x in o.groups()]
        a, bm = (int(g[0]), int(g[1])) if g[0] is not None else (int(g[3]), int(g[4]))
        if (a, bm) != (i, j) or (what == "rot_damper" and int(g[2]) != j):
            fail(f"term {term!r} does not measure I = {i} against J = {j}")
        if what == "spring":
            out["stiffness"] = value
            out["length"] = float(g[2]) if g[0] is not None else 0.0
        elif what == "rot_spring":
            out["stiffness"] = value
            if g[0] is not None:
                out["angle"] = float(g[2]) * (np.pi / 180.0 if g[3] else 1.0)
        else:
            out["damping"] = value
    if not rot and out["length"] is None:
        out["length"] = 0.0
    return out


#: Columns of each ADAMS result table.
QUANTITIES = ("Pos", "Vel", "Acc", "Quat", "Avel", "Aacc", "Rforce", "Rtorque")


def read_table(path) -> tuple[np.ndarray, np.ndarray, list]:
    """(t (n,), values (n, k), column names) of one ``<Case>_ADAMS_<Qty>.txt`` table."""
    lines = Path(path).read_text().splitlines()
    header = lines[2].split("\t")
    data = np.array([[float(x) for x in ln.split()] for ln in lines[3:] if ln.strip()])
    return data[:, 0], data[:, 1:], header[1:]
