"""PLY (Stanford polygon file) reading for mesh tilings: vertices and polygon faces, every dialect
modelling and scanning programs write.

A PLY file is a header of ``element NAME COUNT`` lines, each followed by its ``property TYPE NAME`` and
``property list COUNT_TYPE ITEM_TYPE NAME`` lines, then the elements' rows in that order, as text
(``format ascii 1.0``) or packed binary (``binary_little_endian 1.0``, ``binary_big_endian 1.0``).
What a tiling needs is read by name, wherever it stands:

* the ``vertex`` element's ``x``, ``y`` and ``z`` (any scalar type, in any order: normals, colours or
  texture coordinates before or after them are skipped);
* the ``face`` element's list ``vertex_indices`` or ``vertex_index`` (both spellings are in use; 0-based),
  any other property (a ``texcoord`` list, colours, flags) skipped;
* every other element (``edge``, ``material``, …) skipped.

meshio, which read PLY before, refuses the singular ``vertex_index`` and face texture-coordinate lists
with a bare tuple of type names, and vertices whose normals come first with "need at least one array to
concatenate". Here each problem is one :class:`~fabpat.errors.SpecError` line naming the file, what is
wrong and what is accepted.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SpecError

#: PLY scalar type names (both spellings of the format) → struct code
TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
         "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
         "double": "d", "float64": "d"}
FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
#: the face element's vertex list, as programs spell it
INDEX_NAMES = ("vertex_indices", "vertex_index")

Faces = tuple[tuple[int, ...], ...]
#: one property: (name, scalar code or None for a list, list count code, list item code)
Prop = tuple[str, str, str, str]


def _fail(p: Path, why: str) -> SpecError:
    return SpecError(f"{p}: cannot read the tiling mesh as PLY: {why}")


def _header(p: Path, data: bytes) -> tuple[str, list[tuple[str, int, list[Prop]]], int]:
    """(format, [(element, count, properties)], offset of the first data byte)."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _fail(p, "not a PLY file (it must start with 'ply' and its header end with 'end_header')")
    stop = data.find(b"\n", end)
    start = len(data) if stop < 0 else stop + 1
    lines = data[:end].decode("ascii", errors="replace").splitlines()[1:]
    fmt = None
    elements: list[tuple[str, int, list[Prop]]] = []
    for line in lines:
        words = line.split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "format":
            if len(words) < 2 or words[1] not in FORMATS:
                raise _fail(p, f"format {' '.join(words[1:2]) or '(none)'}: accepted {', '.join(FORMATS)}")
            fmt = words[1]
        elif words[0] == "element":
            if len(words) != 3 or not words[2].isdigit():
                raise _fail(p, f"header line {line.strip()!r}: an element line is 'element NAME COUNT'")
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                raise _fail(p, f"header line {line.strip()!r} comes before any element line")
            if len(words) == 5 and words[1] == "list":
                codes = [TYPES.get(w) for w in words[2:4]]
                if None in codes:
                    raise _fail(p, f"property list types {words[2]} {words[3]}: accepted {', '.join(TYPES)}")
                elements[-1][2].append((words[4], "", str(codes[0]), str(codes[1])))
            elif len(words) == 3 and words[1] in TYPES:
                elements[-1][2].append((words[2], TYPES[words[1]], "", ""))
            else:
                raise _fail(p, f"header line {line.strip()!r}: a property is 'property TYPE NAME' or 'property list "
                            f"COUNT_TYPE ITEM_TYPE NAME', TYPE one of {', '.join(TYPES)}")
        else:
            raise _fail(p, f"header line {line.strip()!r}: expected format, element, property or comment")
    if fmt is None:
        raise _fail(p, f"the header has no format line (format {' | '.join(FORMATS)} 1.0)")
    return fmt, elements, start


def _check_elements(p: Path, elements: list[tuple[str, int, list[Prop]]]) -> None:
    names = {name: props for name, _, props in elements}
    if "vertex" not in names:
        raise _fail(p, f"no vertex element (elements: {', '.join(names) or 'none'}); a tiling needs 'element vertex N' "
                    "with properties x, y, z")
    got = [q[0] for q in names["vertex"]]
    if not {"x", "y", "z"} <= {q[0] for q in names["vertex"] if q[1]}:
        raise _fail(p, f"the vertex element has no scalar x, y and z (it has {', '.join(got) or 'nothing'}); accepted: "
                    "x, y, z in any order, other properties skipped")
    if "face" not in names:
        raise _fail(p, f"no face element (elements: {', '.join(names)}); a tiling needs 'element face N' with a "
                    "list vertex_indices (or vertex_index)")
    lists = [q[0] for q in names["face"] if not q[1]]
    if not any(n in lists for n in INDEX_NAMES):
        got = ", ".join(q[0] for q in names["face"]) or "nothing"
        raise _fail(p, f"the face element has no list vertex_indices or vertex_index (it has {got}); accepted: one of "
                    "those, other properties skipped")


Rows = dict[str, list[list[list[float]]]]


class _Words:
    """Reads an ASCII body's numbers in turn; what it raises means the data ended or is not a number."""

    short = "missing or not a number (the data ends early or does not match the header)"
    errors = (IndexError, ValueError)

    def __init__(self, text: bytes) -> None:
        self.words, self.at = text.split(), 0

    def scalar(self, code: str) -> list[float]:
        self.at += 1
        return [float(self.words[self.at - 1])]

    def sequence(self, ccode: str, icode: str) -> list[float]:
        k = int(self.words[self.at])
        values = [float(w) for w in self.words[self.at + 1:self.at + 1 + k]]
        if k < 0 or len(values) != k:
            raise IndexError
        self.at += 1 + k
        return values


class _Bytes:
    """Reads a binary body's values in turn (``order``: struct's byte-order character)."""

    short = "the data ends early (a truncated file, or a header that does not match it)"
    errors = (struct.error,)

    def __init__(self, data: bytes, order: str) -> None:
        self.data, self.order, self.at = data, order, 0

    def _take(self, code: str, k: int = 1) -> tuple[float, ...]:
        values = struct.unpack_from(f"{self.order}{k}{code}", self.data, self.at)
        self.at += k * struct.calcsize(code)
        return values

    def scalar(self, code: str) -> list[float]:
        return [float(self._take(code)[0])]

    def sequence(self, ccode: str, icode: str) -> list[float]:
        return [float(v) for v in self._take(icode, int(self._take(ccode)[0]))]


def _rows(p: Path, body: _Words | _Bytes, elements: list[tuple[str, int, list[Prop]]]) -> Rows:
    """Every element's rows, each a list of its properties' values (a scalar as a 1-list)."""
    out: Rows = {}
    for name, count, props in elements:
        rows = []
        for r in range(count):
            row = []
            for prop, code, ccode, icode in props:
                try:
                    row.append(body.scalar(code) if code else body.sequence(ccode, icode))
                except body.errors:
                    raise _fail(p, f"element {name} row {r + 1} of {count}, property {prop}: {body.short}") from None
            rows.append(row)
        out[name] = rows
    return out


def read_ply(p: Path, check_faces: Callable[[int], None] | None = None) -> tuple[NDArray[np.float64], Faces]:
    """Vertices ``V`` (n, 3) float (the file's units, mm) and faces (0-based vertex loops, in file order) of
    PLY file ``p`` (module docstring). ``check_faces`` is called with the header's face count before any
    row is read (to refuse a mesh too large to check). Raises :class:`SpecError`, one line naming the file,
    what is wrong and what is accepted (or what ``check_faces`` raises)."""
    data = p.read_bytes()
    fmt, elements, start = _header(p, data)
    _check_elements(p, elements)
    if check_faces is not None:  # before reading them: the count stands in the header
        check_faces(next(count for name, count, _ in elements if name == "face"))
    body = data[start:]
    rows = _rows(p, _Words(body) if fmt == "ascii" else _Bytes(body, FORMATS[fmt]), elements)
    props = {name: [q[0] for q in ps] for name, _, ps in elements}
    vp = props["vertex"]
    ix, iy, iz = vp.index("x"), vp.index("y"), vp.index("z")
    V = np.array([[row[ix][0], row[iy][0], row[iz][0]] for row in rows["vertex"]], dtype=np.float64).reshape(-1, 3)
    fp = props["face"]
    k = fp.index(next(n for n in INDEX_NAMES if n in fp))
    faces = []
    for f, row in enumerate(rows["face"]):
        loop = row[k]
        if any(v != int(v) for v in loop):
            raise _fail(p, f"face {f + 1}'s vertex list holds a number that is not an integer")
        faces.append(tuple(int(v) for v in loop))
    return V, tuple(faces)
