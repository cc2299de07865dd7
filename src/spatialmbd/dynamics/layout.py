"""The packed arrays of the compiled equations of motion, declared once.

Each field is declared once, as (name, buffer, ndim), in :data:`BODY_FIELDS`, :data:`CONS_FIELDS`,
:data:`SCHUR_FIELDS` (the main pack: model floats ``F``, integers ``I``, work ``W``) and
:data:`KFIELDS` (the penalty pack ``KI``, ``KW``); :func:`pack` lays them out (``I`` starts with a
header: offset and up to three dimensions per field) and :func:`field_view` reads one back in
Python. The compiled view functions (:func:`body_views`, :func:`cons_views`, :func:`schur_views`,
:func:`unpack_k`), which turn the buffers back into named tuples of views inside compiled code,
are generated from the same declarations (the way MuJoCo's ``mjxmacro.h`` declares each field
once): adding a field is one line here, with no offsets written by hand.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .. import jit
from ..jit import array_view, njit

#: (name, buffer, ndim) of every field: the bodies, the constraint rows, the pattern and work
#: arrays of S = D W D^T (the three views :data:`Body`, :data:`Cons` and :data:`Schur`)
BODY_FIELDS = (
    ("mass", "F", 1), ("Jl", "F", 3), ("Jl_inv", "F", 3), ("weight", "F", 2),
    ("r", "W", 2), ("A", "W", 3), ("rdot", "W", 2), ("omega", "W", 2),
    ("p", "W", 2), ("J", "W", 3), ("Jinv", "W", 3), ("g", "W", 1),
    ("v", "W", 1), ("vdot", "W", 1), ("t6", "W", 1), ("u6", "W", 1),
    ("q", "W", 2), ("g_power", "W", 1),
)
CONS_FIELDS = (
    ("kind", "I", 1), ("rows", "I", 1), ("bi", "I", 1), ("bj", "I", 1),
    ("coord", "I", 1), ("s_i", "F", 2), ("s_j", "F", 2), ("R_i", "F", 3),
    ("R_j", "F", 3), ("param", "F", 2), ("law", "W", 2), ("phi", "W", 1),
    ("D", "W", 2), ("nu", "W", 1), ("gamma", "W", 1), ("row_bi", "I", 1),
    ("row_bj", "I", 1), ("lam", "W", 1), ("rg", "W", 1), ("drv", "I", 1),
    # the rows of the multiplier solve: the constraint rows, then one row per armature
    # (forces.armature); D, gamma, lam, rg, row_bi and row_bj are their leading constraint
    # rows (PREFIX_OF). arm_k: the force-table instance of each armature, armature: its J
    ("D_all", "W", 2), ("gamma_all", "W", 1), ("lam_all", "W", 1), ("rg_all", "W", 1),
    ("row_bi_all", "I", 1), ("row_bj_all", "I", 1), ("arm_k", "I", 1),
)
SCHUR_FIELDS = (
    ("keep", "I", 1), ("inc_ptr", "I", 1), ("inc_row", "I", 1), ("inc_side", "I", 1),
    ("pair_ptr", "I", 1), ("pair_pos", "I", 1), ("wk", "W", 2), ("Cx", "W", 1),
    ("Lx", "W", 1), ("xs", "W", 1), ("ys", "W", 1), ("bs", "W", 1),
    ("S_Cp", "I", 1), ("S_Ci", "I", 1), ("S_Lp", "I", 1), ("S_Li", "I", 1),
    ("S_Rp", "I", 1), ("S_Rj", "I", 1), ("S_Rpos", "I", 1), ("S_perm", "I", 1),
    # per armature row (the last rows of keep): the position of its diagonal in Cx, its J
    ("arm_diag", "I", 1), ("armature", "F", 1),
)
#: the compiled force elements: their table (as the constraints' JointRows), per-instance
#: energy and power of one evaluation, and a (1, 12) scratch row
FORCE_FIELDS = (
    ("fkind", "I", 1), ("fbi", "I", 1), ("fbj", "I", 1), ("fs_i", "F", 2), ("fs_j", "F", 2),
    ("fR_i", "F", 3), ("fR_j", "F", 3), ("fparam", "F", 2), ("fcoord", "I", 1),
    ("flaw", "W", 2), ("fenergy", "W", 1), ("fpower", "W", 1), ("fscratch", "W", 2),
)
FIELDS = BODY_FIELDS + CONS_FIELDS + SCHUR_FIELDS + FORCE_FIELDS
#: fields that are the leading part of another (field -> the field it starts): they take no
#: room of their own, so every loop over the constraint rows sees exactly those
PREFIX_OF = {"D": "D_all", "gamma": "gamma_all", "lam": "lam_all", "rg": "rg_all",
             "row_bi": "row_bi_all", "row_bj": "row_bj_all"}
Body = namedtuple("Body", [f[0] for f in BODY_FIELDS])
Cons = namedtuple("Cons", [f[0] for f in CONS_FIELDS])
Schur = namedtuple("Schur", [f[0] for f in SCHUR_FIELDS])
Forces = namedtuple("Forces", [f[0] for f in FORCE_FIELDS])

#: fields of the penalty pack (K = M + alpha D^T D), kept apart so it can be added later
KFIELDS = (("blkpos", "I", 3), ("rowblk", "I", 2), ("K_Cp", "I", 1), ("K_Ci", "I", 1),
           ("K_Lp", "I", 1), ("K_Li", "I", 1), ("K_Rp", "I", 1), ("K_Rj", "I", 1),
           ("K_Rpos", "I", 1), ("K_perm", "I", 1),
           ("Kx", "W", 1), ("KLx", "W", 1), ("xk", "W", 1), ("yk", "W", 1), ("ck", "W", 1),
           ("dtc", "W", 1), ("old", "W", 1), ("rotor", "W", 1))   # rotor: the armatures' J
KSys = namedtuple("KSys", [f[0] for f in KFIELDS])


#: the views generated for each pack: (function, namedtuple, its fields, index of the first
#: field in the pack's header, buffer names in the generated code)
VIEWS = (("body_views", "Body", BODY_FIELDS, 0, ("F", "I", "W")),
         ("cons_views", "Cons", CONS_FIELDS, len(BODY_FIELDS), ("F", "I", "W")),
         ("schur_views", "Schur", SCHUR_FIELDS, len(BODY_FIELDS) + len(CONS_FIELDS),
          ("F", "I", "W")),
         ("force_views", "Forces", FORCE_FIELDS,
          len(BODY_FIELDS) + len(CONS_FIELDS) + len(SCHUR_FIELDS), ("F", "I", "W")),
         ("unpack_k", "KSys", KFIELDS, 0, ("KI", "KW")))


def pack(fields, arrays: dict):
    """(F, I, W): the arrays of ``fields`` in three flat buffers; I starts with the header
    (offset and three dimensions per field). A field of :data:`PREFIX_OF` is laid over the
    start of its parent (its array, which must be that start, is not copied)."""
    nf = len(fields)
    header = np.zeros(4 * nf, dtype=np.int64)
    chunks = {"F": [], "I": [], "W": []}
    sizes = {"F": 0, "I": 4 * nf, "W": 0}
    where = {}
    for k, (name, buf, ndim) in enumerate(fields):
        a = np.asarray(arrays[name])
        if a.ndim != ndim:
            raise ValueError(f"field {name}: expected {ndim} dimensions, got shape {a.shape}")
        header[4 * k + 1:4 * k + 1 + ndim] = a.shape
        if name in PREFIX_OF:
            continue
        header[4 * k] = where[name] = sizes[buf]
        chunks[buf].append(a.ravel())
        sizes[buf] += a.size
    for k, (name, buf, ndim) in enumerate(fields):
        if name in PREFIX_OF:
            parent = np.asarray(arrays[PREFIX_OF[name]])
            if np.asarray(arrays[name]).size > parent.size:
                raise ValueError(f"field {name} is longer than {PREFIX_OF[name]}")
            header[4 * k] = where[PREFIX_OF[name]]
    F = np.concatenate(chunks["F"]).astype(float) if chunks["F"] else np.zeros(0)
    I = np.concatenate([header] + chunks["I"]).astype(np.int64)
    W = np.concatenate(chunks["W"]).astype(float) if chunks["W"] else np.zeros(0)
    return np.ascontiguousarray(F), np.ascontiguousarray(I), np.ascontiguousarray(W)


def field_view(fields, F, I, W, name):
    """A NumPy view of one field (Python side)."""
    k = [f[0] for f in fields].index(name)
    _, buf, ndim = fields[k]
    o = I[4 * k]
    shape = tuple(int(x) for x in I[4 * k + 1:4 * k + 1 + ndim])
    B = {"F": F, "I": I, "W": W}[buf]
    return B[o:o + int(np.prod(shape))].reshape(shape)


@njit
def bare(B):
    """B itself, without reference counting (so passing it around costs no atomic updates)."""
    return array_view(B, 0, (B.size,))


def _views_source() -> str:
    """Source of the compiled view functions, generated from the field declarations: field k of
    a pack reads its offset at I[4 k] and its shape at I[4 k + 1 : 4 k + 1 + ndim]."""
    out = ['"""Generated by spatialmbd.dynamics.layout from its field declarations; do not '
           'edit."""',
           "from spatialmbd.dynamics.layout import Body, Cons, Forces, KSys, Schur, bare",
           "from spatialmbd.jit import array_view, njit", ""]
    for fname, tname, fields, first, bufs in VIEWS:
        names = {"F": bufs[0], "I": bufs[1], "W": bufs[-1]} if len(bufs) == 3 else \
            {"I": bufs[0], "W": bufs[1]}
        header = names["I"]                    # the integer buffer holds the header
        out += ["", "", "@njit(inline=\"always\")", f"def {fname}({', '.join(bufs)}):"]
        out.append(f"    {', '.join(bufs)} = {', '.join(f'bare({b})' for b in bufs)}")
        out.append(f"    return {tname}(")
        for k, (name, buf, ndim) in enumerate(fields):
            h = 4 * (first + k)
            shape = ", ".join(f"{header}[{h + 1 + d}]" for d in range(ndim))
            if ndim == 1:
                shape += ","
            out.append(f"        array_view({names[buf]}, {header}[{h}], ({shape})),  # {name}")
        out.append("    )")
    return "\n".join(out) + "\n"


_views = jit.generated_module("layout_views", _views_source())
body_views = _views.body_views
cons_views = _views.cons_views
schur_views = _views.schur_views
force_views = _views.force_views
unpack_k = _views.unpack_k
