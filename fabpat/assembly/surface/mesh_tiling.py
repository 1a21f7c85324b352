"""Tilings read from a polygon-mesh file: ``[tiling] kind = "mesh"`` (paper §3, §6: "a target surface
approximated as a polygon mesh with (almost) regular faces").

Each face of the mesh carries one plate (a regular polygon of 3 … 12 sides), each edge shared by two
faces one sleeve; an edge of one face is a free plate interface. :func:`read_polygon_mesh` reads the
file, :func:`mesh_tiling` checks it and returns the :class:`~fabpat.assembly.surface.tiling.Tiling` whose faces
the plates are placed on (:mod:`fabpat.assembly.place.placement`), scaled so that its edge is the plate
edge.

**Formats**, all read here, keeping polygon faces and their order (trimesh triangulates them): PLY
(ASCII or binary, :mod:`fabpat.assembly.surface.ply`: ``x``, ``y``, ``z`` and ``vertex_indices`` or
``vertex_index`` by name, anything else skipped; meshio refused several dialects with cryptic
messages), OBJ and OFF (meshio reads only triangles from OFF, and refuses the OBJ files modelling
programs write, texture coordinates and normals in other numbers than the vertices, as Blender writes
them); both are a few line kinds, and only ``v`` and ``f`` lines (OBJ; negative indices count back from
the last vertex, "1/2/3" groups give their vertex) or the counts, vertex and face lines (OFF) carry the
polygon mesh. Coincident vertices (closer than
:data:`WELD` × the mesh's size) are merged first: exporters that split vertices per face (for normals
or texture seams) write the same surface.

**Checks**, each a one-line :class:`~fabpat.errors.SpecError` naming the face or edge (numbered from 1
in file order, as OBJ numbers its vertices), before any work:

* every face has 3 … 12 distinct vertices, every vertex index exists;
* no edge is shared by more than two faces (non-manifold), two faces sharing an edge run along it in
  opposite directions (consistent orientation), and the faces form one piece (a piece without a
  sleeve to the rest would float);
* every edge is within ``tolerance`` mm of the mean edge length, every face within ``tolerance`` mm
  of its best-fit plane and of the regular polygon of that edge (a plate is a regular polygon: a face
  that is not one leaves gaps at its sleeves);
* every fold is convex (the interior angle between two faces at most 180°: fabpat's sleeves join
  convex folds, :class:`~fabpat.assembly.place.sleeve.Sleeve`).

``tolerance`` defaults to :data:`DEFAULT_TOLERANCE` (0.01 mm, after scaling to the plate edge): below
what a 0.4 mm nozzle or a laser resolves, and far above the 6 to 9 significant digits a mesh file
carries. **Orientation**: a closed mesh is turned so that its faces' loops run counter-clockwise seen
from outside (positive enclosed volume); an open one so that its folds are convex — the side a
curved surface bulges to is its outside.
"""

from __future__ import annotations

import math
import numbers
import os
import re
import stat
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.surface.tiling import Tiling, weld
from fabpat.errors import FabpatError, SpecError
from fabpat.geometry.polygons import newell_normal
from fabpat.validate import FLOAT_RESOLUTION

MESH_SUFFIXES = (".obj", ".ply", ".off")
#: largest mesh file read (bytes): a tiling of plates a few cm across has at most thousands of faces
MAX_MESH_BYTES = 64 * 1024 * 1024
MIN_SIDES, MAX_SIDES = 3, 12
#: mm: default ``tiling.tolerance`` (module docstring)
DEFAULT_TOLERANCE = 0.01
FITS = ("exact", "best")
#: default tolerance of ``fit = "best"``, relative to the edge: a face's corners may be this far from the
#: regular polygon's (the planar realization of GP(2, 0) needs 0.11: its edges span ±10.6 %)
BEST_FIT_TOLERANCE = 0.2
#: the range of ``tiling.tolerance``: from MIN_TOLERANCE mm to MAX_TOLERANCE × the edge. Relative, as the
#: best fit's default is: at any edge the default lies inside it (a fixed 10 mm bound was below the
#: default 0.2 × edge for edges over 50 mm), and a corner half an edge from its regular polygon's makes
#: a face of another shape (the built-in kinds are checked at this bound too)
MIN_TOLERANCE, MAX_TOLERANCE = 1e-6, 0.5
#: rad: a fold flatter than this is flat (round-off of a planar mesh), neither convex nor concave
FLAT_FOLD = 1e-6
#: most faces (plates) of a tiling mesh, counted before any check: the largest built-in surface (the
#: 30 × 30 hexagon tube) has 900 plates, and at h = 3 mm a plate is ~500 elements of ~62 kB in the solve
#: (fabpat.assembly.solve.sizing), so 2 000 plates are ~60 GB; a 160 000-face scan was still in its checks
#: after 300 s
MAX_MESH_FACES = 2000
#: largest coordinate magnitude (in the file's units) a mesh may hold, and the smallest mean edge:
#: lengths, areas and volumes (cubes of coordinates) must stay inside float64 (1e±308) with room
MAX_COORDINATE, MIN_MEAN_EDGE = 1e100, 1e-100

Faces = tuple[tuple[int, ...], ...]


def read_polygon_mesh(path: str | os.PathLike[str]) -> tuple[NDArray[np.float64], Faces]:
    """Vertices ``V`` (n, 3) float (the file's units, mm) and polygon faces (vertex loops, 0-based) of an
    OBJ, PLY or OFF file, faces in file order.

    Raises :class:`SpecError` (one line naming the file) if ``path`` is not a file name, the file is
    missing, not a regular file (a folder, FIFO or device), larger than :data:`MAX_MESH_BYTES`, of another
    suffix or unreadable, has more than :data:`MAX_MESH_FACES` faces or coordinates beyond
    :data:`MAX_COORDINATE` (:func:`check_scale`).
    """
    from fabpat.validate import check_path

    p = Path(check_path(path, "the tiling mesh", error=SpecError))
    suffix = p.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise SpecError(f"{p}: a tiling mesh must be an OBJ, PLY or OFF file ({', '.join(MESH_SUFFIXES)}), "
                        f"not {suffix or 'a file without suffix'}")
    try:
        st = p.stat()
    except OSError as e:
        raise SpecError(f"{p}: cannot read the tiling mesh: {e.strerror or e}") from None
    if not stat.S_ISREG(st.st_mode):
        raise SpecError(f"{p}: the tiling mesh is not a regular file")
    if st.st_size > MAX_MESH_BYTES:
        raise SpecError(f"{p}: the tiling mesh is {st.st_size} bytes, more than {MAX_MESH_BYTES}: not a tiling")
    from fabpat.assembly.surface.ply import read_ply

    def ply(q: Path) -> tuple[NDArray[np.float64], Faces]:  # the face count of its header checked first
        return read_ply(q, lambda count: check_face_count(count, str(q)))

    readers = {".off": _read_off, ".obj": _read_obj, ".ply": ply}
    try:
        V, faces = readers[suffix](p)
    except SpecError:
        raise
    except (OSError, UnicodeError, ValueError, MemoryError) as e:  # the readers' own problems are SpecErrors
        why = "not a valid file" if not str(e) else str(e)
        raise SpecError(f"{p}: cannot read the tiling mesh as {suffix[1:].upper()}: {why}") from None
    if not faces:
        raise SpecError(f"{p}: the tiling mesh has no faces")
    check_face_count(len(faces), str(p))
    if V.ndim != 2 or V.shape[1] != 3 or not np.isfinite(V).all():
        raise SpecError(f"{p}: the tiling mesh's vertices must be finite 3-D points")
    check_scale(V, faces, str(p))
    return _welded(V, faces)


def check_face_count(count: int, source: str) -> None:
    """Refuse (SpecError) a mesh of more than :data:`MAX_MESH_FACES` faces, before any check of them."""
    if count > MAX_MESH_FACES:
        raise SpecError(f"{source}: the tiling mesh has {count} faces, more than the {MAX_MESH_FACES} plates an "
                        "assembly can solve (each face is a plate of ~500 mesh elements): give a coarser mesh")


def check_scale(V: NDArray[np.float64], faces: Faces, source: str, *, what: str = "the tiling mesh",
                hint: str = " (tiling.edge sets the plate edge whatever the file's unit)",
                error: type[FabpatError] = SpecError) -> None:
    """Refuse (``error``, SpecError by default, one line) a mesh ``V`` (n, 3) whose used vertices' coordinates
    are beyond :data:`MAX_COORDINATE` in magnitude, or whose faces' mean edge is below :data:`MIN_MEAN_EDGE`
    (0 is refused later, by name): its lengths, areas and volumes would overflow or underflow float64, and
    every check after it would report a wrong reason (vertices welded into one, "visits a vertex twice"); nor
    a mean edge under :data:`~fabpat.validate.FLOAT_RESOLUTION` × the largest coordinate (unresolved).
    Computed without a floating-point warning. ``what`` and ``hint`` word the message (a design's target mesh
    is checked too)."""
    used = sorted({int(i) for f in faces for i in f if isinstance(i, int | np.integer) and 0 <= i < len(V)})
    if not used:
        return
    big = float(np.abs(V[used]).max())
    if big > MAX_COORDINATE:
        raise error(f"{source}: {what} has a coordinate of {big:.3g}: beyond {MAX_COORDINATE:g} (in any "
                    f"unit) its lengths, areas and volumes do not fit in floating point; rescale the mesh{hint}")
    loops = [[int(i) for i in f] for f in faces if len(f) >= 2 and all(isinstance(i, int | np.integer)
                                                                       and 0 <= i < len(V) for i in f)]
    if not loops:
        return
    ends = np.array([(a, b) for f in loops for a, b in zip(f, f[1:] + f[:1], strict=True)])
    d = V[ends[:, 1]] - V[ends[:, 0]]
    top = float(np.abs(d).max())  # scaled by the largest difference: no square underflows or overflows
    mean = float((np.linalg.norm(d / top, axis=1) * top).mean()) if top > 0 else 0.0
    if 0.0 < mean < MIN_MEAN_EDGE:
        raise error(f"{source}: {what}'s mean edge is {mean:.3g}: below {MIN_MEAN_EDGE:g} (in any unit) "
                    f"its lengths, areas and volumes do not fit in floating point; rescale the mesh{hint}")
    if 0.0 < mean < FLOAT_RESOLUTION * big:
        raise error(f"{source}: {what}'s mean edge is {mean:.3g} but it lies {big:.3g} from the origin: "
                        f"floating point does not resolve edges under {FLOAT_RESOLUTION:g} × that; move the mesh "
                        "near the origin")


#: coincident vertices: closer than this fraction of the mesh's bounding-box diagonal
WELD = 1e-9


def _welded(V: NDArray[np.float64], faces: Faces) -> tuple[NDArray[np.float64], Faces]:
    """Merge coincident vertices (the first of each group kept, order of first appearance); faces renumbered."""
    used = sorted({i for f in faces for i in f if 0 <= i < len(V)})
    if not used:
        return V, faces
    size = float(np.linalg.norm(np.ptp(V[used], axis=0))) or 1.0
    U, new = weld(V, WELD * size)
    if len(U) == len(V):
        return V, faces
    return U, tuple(tuple(int(new[i]) if 0 <= i < len(V) else i for i in f) for f in faces)


def _read_obj(p: Path) -> tuple[NDArray[np.float64], Faces]:
    """Wavefront OBJ: ``v x y z [w | r g b]`` and ``f a b c …`` lines (``a/t/n`` groups give their vertex;
    negative indices count back from the last vertex so far); every other line kind is ignored."""
    verts: list[tuple[float, float, float]] = []
    faces: list[tuple[int, ...]] = []
    text = p.read_text(encoding="utf-8-sig", errors="replace")
    check_face_count(len(re.findall(r"^[ \t]*f\s", text, re.MULTILINE)), str(p))  # counted before they are read
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        try:
            if words[0] == "v":
                verts.append((float(words[1]), float(words[2]), float(words[3])))
            elif words[0] == "f":
                ids = [int(w.split("/")[0]) for w in words[1:]]
                faces.append(tuple(i - 1 if i > 0 else len(verts) + i if i < 0 else -1 for i in ids))
        except (ValueError, IndexError):
            raise SpecError(f"{p}: line {number} is not an OBJ vertex or face line: {line.strip()[:60]!r}") from None
    return np.array(verts, dtype=np.float64).reshape(-1, 3), tuple(faces)


def _read_off(p: Path) -> tuple[NDArray[np.float64], Faces]:
    """OFF (Geomview): "OFF", then "nv nf ne", nv lines "x y z", nf lines "k i1 … ik" (0-based; '#'
    comments). Colour values after a face's indices are ignored."""
    rows = (w for w in (ln.split("#", 1)[0].split() for ln in
                        p.read_text(encoding="utf-8-sig", errors="replace").splitlines()) if w)
    first = next(rows, None)
    if first is None or not first[0].upper().endswith("OFF"):
        raise SpecError(f"{p}: not an OFF file (its first line must be OFF)")
    try:  # a file of only "OFF" has no counts line: broken, as a short one
        head = first[1:] or next(rows, [])  # counts on the OFF line itself, or on the next
        nv, nf = int(head[0]), int(head[1])
        if nv < 0 or nf < 0:
            raise ValueError
        check_face_count(nf, str(p))  # before the other lines are split: the count stands in the header
        body = list(rows)
        V = np.array([[float(x) for x in body[i][:3]] for i in range(nv)])
        faces = tuple(tuple(int(x) for x in body[nv + j][1:1 + int(body[nv + j][0])]) for j in range(nf))
        if any(len(f) != int(body[nv + j][0]) for j, f in enumerate(faces)):
            raise IndexError
    except SpecError:
        raise
    except (ValueError, IndexError):
        raise SpecError(f"{p}: broken OFF file (counts, vertex or face lines)") from None
    return V.reshape(-1, 3), faces


def mesh_tiling(V: NDArray[np.float64], faces: Faces, *, tolerance: float | None = None,
                edge: float | None = None, source: str = "<mesh>", fit: str = "exact", name: str = "mesh",
                flat: bool = False, plates: str = "regular") -> Tiling:
    """The checked tiling of mesh ``V`` (n, 3) mm, ``faces`` (vertex loops, 0-based), named ``name``.

    ``edge`` (mm): scale the mesh so that its mean edge length is ``edge`` (default: the mesh's own).
    Every check of the module docstring is made at that scale with ``tolerance`` mm; the first problem
    raises :class:`SpecError` naming ``source``, the face or edge (from 1) and the value found. The
    loops are turned to the module's orientation; faces and their first vertices keep the file's order.
    ``fit``: "exact" (plates on the faces; ``tolerance`` default :data:`DEFAULT_TOLERANCE`) or "best"
    (plates at their faces' best fit, the closure takes up the rest: ``tolerance`` default
    :data:`BEST_FIT_TOLERANCE` × the edge; the tiling is ``best_fit``). ``tolerance`` must lie in
    [:data:`MIN_TOLERANCE` mm, :data:`MAX_TOLERANCE` × the edge] (SpecError otherwise). ``flat`` (a one-piece
    panel, :mod:`fabpat.assembly.surface.panel_mesh`): after the faces' checks, every vertex must also lie within
    ``tolerance`` of the best-fit plane of all of them (:func:`check_flat`), instead of the folds being convex.
    ``plates = "shaped"`` (each plate its face's own polygon): the faces' edges may differ and the faces need
    only be planar and almost regular (:func:`fabpat.assembly.surface.shaped.check_shaped_faces`).
    """
    if not isinstance(fit, str) or fit not in FITS:
        raise SpecError(f"{source}: fit = {fit!r}: choose one of {', '.join(FITS)}")
    V, faces = _mesh_arrays(V, faces, source)
    edge, tolerance = (_length(v, name, source) for v, name in ((edge, "edge"), (tolerance, "tolerance")))
    check_scale(V, faces, source)
    loops = _check_faces(V, faces, source)
    edges = _check_edges(loops, source)
    ends = np.array(list(edges), dtype=np.int64)
    lengths = np.linalg.norm(V[ends[:, 1]] - V[ends[:, 0]], axis=1)
    mean = float(lengths.mean())
    if not mean > 0.0:
        raise SpecError(f"{source}: the tiling mesh's edges have zero length")
    scale = edge / mean if edge is not None else 1.0
    V, lengths = V * scale, lengths * scale
    e = float(lengths.mean())
    if tolerance is None:
        tolerance = DEFAULT_TOLERANCE if fit == "exact" else BEST_FIT_TOLERANCE * e
    if not MIN_TOLERANCE <= tolerance <= MAX_TOLERANCE * e * (1.0 + 1e-12):
        raise SpecError(f"{source}: tiling.tolerance = {tolerance:g} mm must be in [{MIN_TOLERANCE:g}, "
                        f"{MAX_TOLERANCE:g} × the edge = {MAX_TOLERANCE * e:.4g}] mm (edge {e:.4g} mm; the default is "
                        f"{DEFAULT_TOLERANCE:g} mm for fit = \"exact\", {BEST_FIT_TOLERANCE:g} × the edge for "
                        "fit = \"best\")")
    if plates == "shaped":  # no edge or regular-polygon check: each plate takes its face's polygon
        from fabpat.assembly.surface.shaped import check_shaped_faces

        check_shaped_faces(V, loops, tolerance, source)
        tiling = _oriented(Tiling(name, V, loops, best_fit=fit == "best"), source)
        _check_convex(tiling, source)
        return tiling
    k = int(np.argmax(np.abs(lengths - e)))
    if abs(lengths[k] - e) > tolerance:
        a, b = ends[k]
        raise SpecError(f"{source}: the edge between vertices {a + 1} and {b + 1} is {lengths[k]:.4f} mm long, "
                        f"{abs(lengths[k] - e):.3g} mm from the mean edge {e:.4f} mm (tiling.tolerance = "
                        f"{tolerance:g} mm): the plates are regular polygons of one edge")
    for f, loop in enumerate(loops):
        _check_regular(V[list(loop)], e, tolerance, f"{source}: face {f + 1}")
    if flat:  # before the folds: a curved mesh is told it is not flat, not that one of its folds is concave
        check_flat(V, loops, tolerance, source)
        return Tiling(name, V, loops)
    tiling = _oriented(Tiling(name, V, loops, best_fit=fit == "best"), source)
    _check_convex(tiling, source)
    return tiling


def _mesh_arrays(V: object, faces: object, source: str) -> tuple[NDArray[np.float64], Faces]:
    """``V`` as an (n, 3) array of finite floats and ``faces`` as a tuple of index tuples (at most
    :data:`MAX_MESH_FACES`), or SpecError naming what they are instead (None, a string, a number)."""
    try:
        A = np.asarray(V, dtype=np.float64)
    except (TypeError, ValueError):
        A = np.empty((0, 0))
    if isinstance(V, str | bytes) or A.ndim != 2 or A.shape[1:] != (3,) or not np.isfinite(A).all():
        raise SpecError(f"{source}: the vertices must be an (n, 3) array of finite numbers (mm), got "
                        f"{type(V).__name__}{' of shape ' + str(A.shape) if A.ndim else ''}")
    if isinstance(faces, str | bytes) or not isinstance(faces, Sequence | np.ndarray):
        raise SpecError(f"{source}: the faces must be a sequence of vertex loops, got {type(faces).__name__}")
    check_face_count(len(faces), source)
    out = []
    for f, loop in enumerate(faces):
        if isinstance(loop, str | bytes) or not isinstance(loop, Sequence | np.ndarray):
            raise SpecError(f"{source}: face {f + 1} must be a loop of vertex indices, got {type(loop).__name__}")
        bad = [i for i in loop if isinstance(i, bool) or not isinstance(i, numbers.Integral)]
        if bad:  # int(1.5) would quietly name vertex 1
            raise SpecError(f"{source}: face {f + 1} names vertex {bad[0]!r}: a vertex index is an integer")
        out.append(tuple(int(i) for i in loop))
    return A, tuple(out)


def _length(value: object, name: str, source: str) -> float | None:
    """``edge`` or ``tolerance`` (mm) as a float, None as None; SpecError for what is not a finite number."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        raise SpecError(f"{source}: {name} must be a finite number of mm (or None), got {value!r}")
    if name == "edge" and not float(value) > 0:
        raise SpecError(f"{source}: edge must be a positive number of mm, got {value!r}")
    return float(value)


def check_flat(V: NDArray[np.float64], loops: Faces, tolerance: float, source: str) -> None:
    """Refuse (SpecError, one line) a mesh whose used vertices do not all lie within ``tolerance`` mm of their
    best-fit plane (least squares: the plane through their mean normal to the smallest principal axis), or
    one without a boundary (a flat mesh that closes up lies on itself)."""
    used = sorted({i for loop in loops for i in loop})
    P = V[used] - V[used].mean(axis=0)
    normal = np.linalg.svd(P, full_matrices=False)[2][-1]
    off = np.abs(P @ normal)
    k = int(off.argmax())
    if off[k] > tolerance:
        raise SpecError(f"{source}: a panel must be flat: vertex {used[k] + 1} is {off[k]:.3g} mm off the plane of the "
                        f"mesh's vertices (tiling.tolerance = {tolerance:g} mm); a curved surface is tiling.kind = "
                        "\"mesh\" (plates joined by sleeves)")
    edges: dict[tuple[int, int], int] = {}
    for loop in loops:
        for a, b in zip(loop, loop[1:] + loop[:1], strict=True):
            edges[min(a, b), max(a, b)] = edges.get((min(a, b), max(a, b)), 0) + 1
    if all(c == 2 for c in edges.values()):
        raise SpecError(f"{source}: a panel's mesh must have a boundary (every edge of this one is shared by two "
                        "faces: a flat mesh that closes up lies on itself)")


def _check_faces(V: NDArray[np.float64], faces: Faces, source: str) -> Faces:
    """The faces as int tuples, each of 3 … 12 distinct, existing vertices."""
    out = []
    for f, loop in enumerate(faces):
        if not MIN_SIDES <= len(loop) <= MAX_SIDES:
            raise SpecError(f"{source}: face {f + 1} has {len(loop)} vertices: a plate is a polygon of "
                            f"{MIN_SIDES} to {MAX_SIDES} sides")
        bad = [i for i in loop if not 0 <= int(i) < len(V)]
        if bad:
            raise SpecError(f"{source}: face {f + 1} names vertex {int(bad[0]) + 1}, but the mesh has {len(V)}")
        if len(set(loop)) != len(loop):
            raise SpecError(f"{source}: face {f + 1} visits a vertex twice")
        out.append(tuple(int(i) for i in loop))
    return tuple(out)


def _check_edges(loops: Faces, source: str) -> dict[tuple[int, int], list[tuple[int, bool]]]:
    """Edge (low, high) → [(face, runs low → high)]; refuses non-manifold edges, inconsistent
    orientation and a mesh in several pieces."""
    edges: dict[tuple[int, int], list[tuple[int, bool]]] = {}
    for f, loop in enumerate(loops):
        for i, a in enumerate(loop):
            b = loop[(i + 1) % len(loop)]
            edges.setdefault((min(a, b), max(a, b)), []).append((f, a < b))
    for (a, b), users in edges.items():
        if len(users) > 2:
            raise SpecError(f"{source}: the edge between vertices {a + 1} and {b + 1} is shared by {len(users)} "
                            f"faces ({', '.join(str(f + 1) for f, _ in users)}): a sleeve joins two plates "
                            "(non-manifold mesh)")
        if len(users) == 2 and users[0][1] == users[1][1]:
            raise SpecError(f"{source}: faces {users[0][0] + 1} and {users[1][0] + 1} run the same way along the "
                            f"edge between vertices {a + 1} and {b + 1}: orient every face the same way "
                            "(inconsistent orientation)")
    parent = list(range(len(loops)))

    def root(f: int) -> int:
        while parent[f] != f:
            parent[f] = parent[parent[f]]
            f = parent[f]
        return f

    for users in edges.values():
        if len(users) == 2:
            parent[root(users[0][0])] = root(users[1][0])
    apart = [f for f in range(len(loops)) if root(f) != root(0)]
    if apart:
        raise SpecError(f"{source}: face {apart[0] + 1} shares no chain of edges with face 1: the mesh is in "
                        "several pieces, each would float apart (give one piece per file)")
    return edges


def regular_deviation(P: NDArray[np.float64], edge: float) -> tuple[float, int, float, int]:
    """How far a face (its corners P (n, 3), mm, in order around it) is from a regular polygon of
    ``edge`` mm: (largest distance of a corner from the face's best-fit plane, that corner (from 0),
    largest distance of a corner from the regular polygon best superposed on it in that plane, that
    corner), mm. Raises :class:`SpecError` ("has no area") for a face of zero area."""
    n = len(P)
    c = P.mean(axis=0)
    normal = newell_normal(P - c)  # the loop's turning sense
    size = float(np.linalg.norm(normal))
    if size <= 0.0:
        raise SpecError("has no area")
    normal /= size
    off = np.abs((P - c) @ normal)
    u = P[0] - c - ((P[0] - c) @ normal) * normal
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    z = (P - c) @ u + 1j * ((P - c) @ v)
    turn = np.exp(2j * math.pi * np.arange(n) / n)
    radius = edge / (2.0 * math.sin(math.pi / n))  # circumradius of the regular n-gon
    phase = np.sum(z / turn)  # best rotation of the ideal polygon onto the corners (least squares)
    ideal = radius * turn * (phase / abs(phase) if abs(phase) > 0 else 1.0)
    dev = np.abs(z - ideal)
    return float(off.max()), int(off.argmax()), float(dev.max()), int(dev.argmax())


def _check_regular(P: NDArray[np.float64], edge: float, tolerance: float, where: str) -> None:
    """Refuse a face (its corners P (n, 3)) farther than ``tolerance`` mm from its best-fit plane or from
    the regular polygon of ``edge`` best superposed on it in that plane (:func:`regular_deviation`)."""
    n = len(P)
    try:
        off, i, dev, j = regular_deviation(P, edge)
    except SpecError as e:
        raise SpecError(f"{where} {e}") from None
    if off > tolerance:
        raise SpecError(f"{where} is not planar: its corner {i + 1} is {off:.3g} mm off the face's plane "
                        f"(tiling.tolerance = {tolerance:g} mm)")
    if dev > tolerance:
        raise SpecError(f"{where} is not a regular {n}-gon of edge {edge:.4f} mm: its corner {j + 1} is "
                        f"{dev:.3g} mm from the regular polygon's (tiling.tolerance = {tolerance:g} mm; corners "
                        "in order around the face)")


def _fold(t: Tiling, k: int) -> float:
    """Signed fold angle (rad) of interior edge k: positive convex (outer normals turn away), negative concave."""
    (fa, ia), (fb, _) = t.edge_faces[k]
    loop = t.faces[fa]
    a, b = t.V[loop[ia]], t.V[loop[(ia + 1) % len(loop)]]
    na, nb = t.normals[fa], t.normals[fb]
    s = float(np.cross(na, nb) @ (b - a) / np.linalg.norm(b - a))
    return math.atan2(s, float(na @ nb))


def _oriented(t: Tiling, source: str) -> Tiling:
    """``t`` with every loop reversed (first vertex kept) when it is inside out (module docstring)."""
    closed = t.boundary_edges.size == 0
    if closed:
        c = t.V[list(t.faces[0])].mean(axis=0)
        volume = sum(float(np.linalg.det(np.stack([t.V[loop[0]] - c, t.V[loop[i]] - c, t.V[loop[i + 1]] - c])))
                     for loop in t.faces for i in range(1, len(loop) - 1))
        flip = volume < 0.0
    else:
        folds = [_fold(t, int(k)) for k in t.interior_edges]
        flip = sum(f < -FLAT_FOLD for f in folds) > sum(f > FLAT_FOLD for f in folds)
    if not flip:
        return t
    return Tiling(t.name, t.V, tuple((loop[0], *reversed(loop[1:])) for loop in t.faces), t.grid, t.best_fit)


def _check_convex(t: Tiling, source: str) -> None:
    """Refuse a concave fold (interior angle over 180°)."""
    for k in t.interior_edges:
        fold = _fold(t, int(k))
        if fold < -FLAT_FOLD:
            a, b = t.edges[k]
            raise SpecError(f"{source}: the fold at the edge between vertices {a + 1} and {b + 1} is concave (interior "
                            f"angle {180.0 + math.degrees(-fold):.2f}°): sleeves join convex folds, up to 180°")


def write_obj(tiling: Tiling) -> bytes:
    """The tiling as OBJ bytes (polygon faces, vertices as Python writes floats: every digit), through meshio."""
    import tempfile

    import meshio

    by_size: list[tuple[str, list[tuple[int, ...]]]] = []
    for loop in tiling.faces:  # one cell block per run of faces of one size: meshio writes blocks in order
        kind = {3: "triangle", 4: "quad"}.get(len(loop), "polygon")
        if not by_size or len(by_size[-1][1][0]) != len(loop):
            by_size.append((kind, []))
        by_size[-1][1].append(loop)
    mesh = meshio.Mesh(tiling.V, [(k, np.array(f)) for k, f in by_size])
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "tiling.obj"
        meshio.write(path, mesh)  # floats as repr: every digit kept
        return path.read_bytes()
