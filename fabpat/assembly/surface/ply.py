"""PLY (Stanford polygon file) reading for mesh tilings: vertices and polygon faces, every dialect
modelling and scanning programs write, read by plyfile (a well-kept reader of the whole format: ASCII and
both binary byte orders, any scalar and list types).

What a tiling needs is taken by name, wherever it stands:

* the ``vertex`` element's ``x``, ``y`` and ``z`` (any scalar type, in any order: normals, colours or
  texture coordinates before or after them are skipped);
* the ``face`` element's list ``vertex_indices`` or ``vertex_index`` (both spellings are in use; 0-based),
  any other property (a ``texcoord`` list, colours, flags) skipped;
* every other element (``edge``, ``material``, …) skipped.

meshio, which read PLY before, refuses the singular ``vertex_index`` and face texture-coordinate lists
with a bare tuple of type names; plyfile's own errors name a row and property in its words. Here each
problem is one :class:`~fabpat.errors.SpecError` line naming the file, what is wrong and what is accepted.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SpecError

if TYPE_CHECKING:  # pragma: no cover
    from plyfile import PlyData

FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")
#: the face element's vertex list, as programs spell it
INDEX_NAMES = ("vertex_indices", "vertex_index")

Faces = tuple[tuple[int, ...], ...]


def _fail(p: Path, why: str) -> SpecError:
    return SpecError(f"{p}: cannot read the tiling mesh as PLY: {why}")


def _header(p: Path, data: bytes) -> tuple[str, dict[str, int]]:
    """The header's format word and its elements' counts, read before plyfile reads the file: its message for
    a wrong format names a header line, not the formats accepted, and a face count too large to check is
    refused before any row is read."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _fail(p, "not a PLY file (it must start with 'ply' and its header end with 'end_header')")
    fmt, counts = None, {}
    for line in data[:end].decode("ascii", errors="replace").splitlines():
        words = line.split()
        if words and words[0] == "format":
            if len(words) < 2 or words[1] not in FORMATS:
                raise _fail(p, f"format {' '.join(words[1:2]) or '(none)'}: accepted {', '.join(FORMATS)}")
            fmt = words[1]
        elif len(words) == 3 and words[0] == "element" and words[2].isdigit():
            counts[words[1]] = int(words[2])
    if fmt is None:
        raise _fail(p, f"the header has no format line (format {' | '.join(FORMATS)} 1.0)")
    return fmt, counts


def _check_elements(p: Path, ply: PlyData) -> None:
    """The vertex element with scalar x, y, z and the face element with a vertex list, else one line."""
    names = {e.name: e for e in ply.elements}
    if "vertex" not in names:
        raise _fail(p, f"no vertex element (elements: {', '.join(names) or 'none'}); a tiling needs 'element vertex N' "
                    "with properties x, y, z")
    props = names["vertex"].properties
    scalars = {q.name for q in props if not hasattr(q, "len_dtype")}
    if not {"x", "y", "z"} <= scalars:
        got = ", ".join(q.name for q in props) or "nothing"
        raise _fail(p, f"the vertex element has no scalar x, y and z (it has {got}); accepted: x, y, z in any order, "
                    "other properties skipped")
    if "face" not in names:
        raise _fail(p, f"no face element (elements: {', '.join(names)}); a tiling needs 'element face N' with a "
                    "list vertex_indices (or vertex_index)")
    fprops = names["face"].properties
    if not any(q.name in INDEX_NAMES and hasattr(q, "len_dtype") for q in fprops):
        got = ", ".join(q.name for q in fprops) or "nothing"
        raise _fail(p, f"the face element has no list vertex_indices or vertex_index (it has {got}); accepted: one of "
                    "those, other properties skipped")


def read_ply(p: Path, check_faces: Callable[[int], None] | None = None) -> tuple[NDArray[np.float64], Faces]:
    """Vertices ``V`` (n, 3) float (the file's units, mm) and faces (0-based vertex loops, in file order) of
    PLY file ``p`` (module docstring). ``check_faces`` is called with the header's face count before any
    row is read (to refuse a mesh too large to check). Raises :class:`SpecError`, one line naming the file,
    what is wrong and what is accepted (or what ``check_faces`` raises)."""
    from plyfile import PlyData, PlyElementParseError, PlyHeaderParseError

    data = p.read_bytes()
    fmt, counts = _header(p, data)
    if check_faces is not None and "face" in counts:  # before reading them: the count stands in the header
        check_faces(counts["face"])
    try:
        ply = PlyData.read(io.BytesIO(data), mmap=False)
    except PlyElementParseError as e:
        short = ("missing or not a number (the data ends early or does not match the header)" if fmt == "ascii"
                 else "the data ends early (a truncated file, or a header that does not match it)")
        where = f"element {e.element.name} row {int(e.row) + 1} of {e.element.count}" if e.element else "data"
        raise _fail(p, f"{where}, property {e.prop.name if e.prop else '?'}: {short}") from None
    except PlyHeaderParseError as e:
        raise _fail(p, f"header: {e.message}") from None
    _check_elements(p, ply)
    v = ply["vertex"]
    V = np.column_stack([np.asarray(v[c], dtype=np.float64) for c in "xyz"]).reshape(-1, 3)
    f = ply["face"]
    name = next(n for n in INDEX_NAMES if n in {q.name for q in f.properties})
    faces = []
    for k, loop in enumerate(f[name]):
        arr = np.asarray(loop)
        if arr.dtype.kind == "f" and not np.array_equal(arr, np.round(arr)):
            raise _fail(p, f"face {k + 1}'s vertex list holds a number that is not an integer")
        faces.append(tuple(int(x) for x in arr))
    return V, tuple(faces)
