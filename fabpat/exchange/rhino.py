"""Rhino ``.3dm`` files (openNURBS, through the ``rhino3dm`` package), in millimetres.

One pattern (:func:`write`) gives a file with three layers:

* ``CUT``: one closed curve per loop of the outline (outer loop counter-clockwise, holes clockwise),
  each an exact degree-2 rational NURBS curve: every segment of the outline is one Bézier span of
  the curve (a line as a span with its middle control point at the midpoint, weight 1; a
  :class:`~fabpat.geometry.outline.RationalQuad` as its control points with weights (1, w, 1)), spans joined
  by double knots. Nothing is flattened: the file holds the outline of :mod:`fabpat.geometry.outline` exactly.
* ``PLATE``: the plate as a closed (capped) extrusion of those curves by the thickness, z ∈ [0, t].
* ``INTERFACE`` (hidden): the whole bow-tie arcs (P0, M, P0′) with weights (1, w, 1) whose halves
  the outline keeps, so the configured interface weight w is in the file as it is in STEP. The half
  arcs on ``CUT`` are in standard form, with middle weight √((1 + w)/2) (see :mod:`fabpat.geometry.fillet`).

Placed parts (:func:`write_assembly`, which an assembly kit calls with its parts,
:func:`fabpat.assembly.show.export.write_3dm`) give one file with a layer per part type (plate types by
their label, e.g. ``hex 0x0488``, and sleeve kinds, e.g. ``S-HH``), one block (instance definition)
per distinct part (:class:`Block`) and every placed part as a block instance named by its label (``H07``,
``SE42``) with its rigid transform. Plates are the exact extrusions above; sleeves, which fabpat models
only as OCCT solids, are meshes (the kit's within its ``mesh_tolerance``, mm).

The laser kerf is not applied here: the curves are the exact outline (Rhino's own ``Offset`` gives
an exact kerf offset), so the file does not depend on ``ExportSettings.kerf``.

Files are encoded in memory (``File3dm.Encode``) and then written, so they do not record the (temporary)
path they were written to. With a ``timestamp`` (ISO 8601, :func:`fabpat.exchange.part.check_timestamp`)
the same model gives the same bytes in every run (:func:`reproducible`): layer and object ids are
name-based UUIDs of the stamp and the layer's name or the object's place and name
(:func:`fabpat.exchange.stamp.stamp_uuid`); the ids rhino3dm draws at random for blocks and their
geometry (it offers no way to choose them) and the file's created / last-edited times (read-only in
rhino3dm, the clock's) are replaced in the encoded file (:mod:`fabpat.exchange.rhino_stamp`).
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError
from fabpat.geometry.outline import Line, Loop, Outline, RationalQuad

if TYPE_CHECKING:  # pragma: no cover
    import rhino3dm

    from fabpat.exchange.part import ExportSettings, Part

CUT_LAYER = "CUT"
PLATE_LAYER = "PLATE"
INTERFACE_LAYER = "INTERFACE"
FILE_VERSION = 7  # Rhino 7 file format: Rhino 7 and later open it


def _rhino() -> ModuleType:
    try:
        import rhino3dm
    except ImportError as e:  # pragma: no cover - rhino3dm is a dependency
        raise ExportError(f".3dm export needs the rhino3dm package ({e})") from e
    return rhino3dm


def loop_curve(loop: Loop | Sequence[Line | RationalQuad], z: float = 0.0) -> rhino3dm.NurbsCurve:
    """One closed degree-2 rational ``rhino3dm.NurbsCurve`` through the loop's segments, exactly.

    Segment k is the Bézier span on knots [k, k + 1]; its control points are (start, middle, end)
    with weights (1, 1, 1) for a line (middle = midpoint) and (1, w, 1) for a rational arc. Knots
    are doubled at every joint (C0 in the parametrisation, the geometry's own continuity kept), so
    the curve has 2k + 1 control points (first = last) and knots [0, 0, 1, 1, …, k, k]
    (openNURBS' convention without the superfluous end knots). Coordinates in mm, in the plane z.
    """
    r3 = _rhino()
    segments = loop.segments if isinstance(loop, Loop) else tuple(loop)
    if not segments:
        raise ExportError("cannot write an empty loop to .3dm")
    cvs: list[tuple[float, float, float]] = []  # (x, y, weight)
    for s in segments:
        if isinstance(s, RationalQuad):
            (x0, y0), (x1, y1) = s.P0, s.P1
            cvs += [(float(x0), float(y0), 1.0), (float(x1), float(y1), s.w)]
        else:
            mid = 0.5 * (s.p0 + s.p1)
            cvs += [(float(s.p0[0]), float(s.p0[1]), 1.0), (float(mid[0]), float(mid[1]), 1.0)]
    cvs.append(cvs[0])
    k = len(segments)
    curve = r3.NurbsCurve(3, True, 3, len(cvs))
    for i, (x, y, w) in enumerate(cvs):
        # rhino3dm sets control points in homogeneous form (w·x, w·y, w·z, w)
        curve.Points[i] = r3.Point4d(w * x, w * y, w * z, w)
    knots = [0.0, 0.0] + [float(j) for j in range(1, k) for _ in (0, 1)] + [float(k), float(k)]
    for i, t in enumerate(knots):
        curve.Knots[i] = t
    if not curve.IsValid:
        raise ExportError("openNURBS rejected an outline loop as a NURBS curve")
    return curve


def arc_curve(arc: RationalQuad) -> rhino3dm.NurbsCurve:
    """One open degree-2 rational ``rhino3dm.NurbsCurve`` of a single arc (weights (1, w, 1))."""
    r3 = _rhino()
    curve = r3.NurbsCurve(3, True, 3, 3)
    for i, (P, w) in enumerate(zip(arc.control_points, arc.weights, strict=True)):
        curve.Points[i] = r3.Point4d(w * float(P[0]), w * float(P[1]), 0.0, float(w))
    for i, t in enumerate((0.0, 0.0, 1.0, 1.0)):
        curve.Knots[i] = t
    return curve


def plate_extrusion(outline: Outline, thickness: float) -> rhino3dm.Extrusion:
    """The plate as a capped ``rhino3dm.Extrusion`` of the exact outline, z from 0 to ``thickness`` mm."""
    r3 = _rhino()
    plane = r3.Plane.WorldXY()  # profile coordinates = model x, y: holes can be added as they are
    ext = r3.Extrusion.CreateWithPlane(loop_curve(outline.outer), plane, float(thickness), True)
    if ext is None:
        raise ExportError("openNURBS could not extrude the outline")
    for hole in outline.holes:
        if not ext.AddInnerProfile(loop_curve(hole)):
            raise ExportError("openNURBS rejected a hole of the outline as an extrusion profile")
    if not (ext.IsValid and ext.IsSolid):
        raise ExportError("the .3dm extrusion of the outline is not a closed solid")
    return ext


def _new_file() -> rhino3dm.File3dm:
    r3 = _rhino()
    model = r3.File3dm()
    model.Settings.ModelUnitSystem = r3.UnitSystem.Millimeters
    model.Settings.ModelAbsoluteTolerance = 0.001  # mm: the exact geometry needs no looser one
    return model


class _Ids:
    """The ids of a model's layers and objects: with a time stamp name-based UUIDs, numbered in the order
    they are made (a name may repeat), so one model gets the same ids in every run; without one, None
    (openNURBS draws a fresh id)."""

    def __init__(self, timestamp: str | None) -> None:
        from fabpat.exchange.part import check_timestamp

        self.timestamp = check_timestamp(timestamp, "timestamp")
        self.count = 0

    def next(self, kind: str, name: str) -> uuid.UUID | None:
        """The id of the next ``kind`` (layer, object, block, …) called ``name``; None without a time stamp."""
        if self.timestamp is None:
            return None
        from fabpat.exchange.stamp import stamp_uuid

        self.count += 1
        return stamp_uuid(self.timestamp, "3dm", kind, str(self.count), name)


def _layer(model: rhino3dm.File3dm, name: str, colour: tuple[int, int, int], visible: bool = True,
           ids: _Ids | None = None) -> int:
    r3 = _rhino()
    layer = r3.Layer()
    layer.Name = name
    layer.Color = (*colour, 255)
    layer.Visible = visible
    if ids is not None and (u := ids.next("layer", name)) is not None:
        layer.Id = u
    return int(model.Layers.Add(layer))


def _attributes(layer: int, name: str | None = None, ids: _Ids | None = None) -> rhino3dm.ObjectAttributes:
    att = _rhino().ObjectAttributes()
    att.LayerIndex = layer
    if name:
        att.Name = name
    if ids is not None and (u := ids.next("object", name or "")) is not None:
        att.Id = u  # openNURBS keeps an id given here (unless the model already has it)
    return att


def encode(model: rhino3dm.File3dm, timestamp: str | None = None,
           ids: dict[uuid.UUID, uuid.UUID] | None = None) -> bytes:
    """The ``rhino3dm.File3dm`` as the bytes of a Rhino 7 ``.3dm`` file; with ``timestamp`` (ISO 8601)
    :func:`fabpat.exchange.rhino_stamp.reproducible` (``ids``: random ids to replace). Raises :class:`ExportError`."""
    import base64

    options = _rhino().File3dmWriteOptions()
    options.Version = FILE_VERSION
    text = model.Encode(options)
    if not text:
        raise ExportError("rhino3dm could not encode the .3dm file")
    data = base64.b64decode(text)
    if timestamp is None:
        return data
    from fabpat.exchange.rhino_stamp import reproducible

    return reproducible(data, timestamp, ids)


def _save(model: rhino3dm.File3dm, path: str | os.PathLike[str], timestamp: str | None = None,
          ids: dict[uuid.UUID, uuid.UUID] | None = None) -> None:
    data = encode(model, timestamp, ids)
    try:
        Path(path).write_bytes(data)
    except OSError as e:  # atomic_outputs names the target, not this temporary file
        from fabpat.io import writer_failed

        raise writer_failed(path, "cannot write the .3dm file", e) from e


def part_model(part: Part, *, timestamp: str | None = None) -> rhino3dm.File3dm:
    """A ``rhino3dm.File3dm`` of one part: ``CUT`` curves, ``PLATE`` extrusion, ``INTERFACE`` arcs. With
    ``timestamp`` (ISO 8601) the layers and objects get fixed ids (module docstring). Raises :class:`ExportError`."""
    ids = _Ids(timestamp)
    model = _new_file()
    cut = _layer(model, CUT_LAYER, (255, 0, 0), ids=ids)
    plate = _layer(model, PLATE_LAYER, (40, 40, 40), ids=ids)
    iface = _layer(model, INTERFACE_LAYER, (0, 0, 255), visible=False, ids=ids)
    label = part.label or part.name
    for i, loop in enumerate(part.outline.loops):
        model.Objects.AddCurve(loop_curve(loop),
                               _attributes(cut, f"{label} {'outer' if i == 0 else f'hole {i}'}", ids))
    model.Objects.AddExtrusion(plate_extrusion(part.outline, part.thickness), _attributes(plate, part.name, ids))
    for arc in part.support:
        model.Objects.AddCurve(arc_curve(arc), _attributes(iface, f"{label} interface arc", ids))
    return model


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part as a ``.3dm`` file (exact; of ``settings`` only ``timestamp`` matters,
    which makes the file byte-reproducible)."""
    _save(part_model(part, timestamp=settings.timestamp), path, settings.timestamp)


def _mesh(V: NDArray[np.float64], F: NDArray[np.int64]) -> rhino3dm.Mesh:
    r3 = _rhino()
    mesh = r3.Mesh()
    for x, y, z in V:
        mesh.Vertices.Add(float(x), float(y), float(z))
    for a, b, c in F:
        mesh.Faces.AddFace(int(a), int(b), int(c))
    mesh.Normals.ComputeNormals()
    mesh.Compact()
    return mesh


def _transform(T: NDArray[np.float64]) -> rhino3dm.Transform:
    xf = _rhino().Transform(1.0)
    for i in range(4):
        for j in range(4):
            setattr(xf, f"M{i}{j}", float(T[i, j]))
    return xf


@dataclass(frozen=True, eq=False)
class Block:
    """One distinct part of a ``.3dm`` assembly (:func:`write_assembly`): its layer and block ``key``
    (``"hex 0x0488"``, ``"S-HH"``), display ``name``, layer ``colour`` (r, g, b in 0–255) and its geometry:
    an exact plate, ``outline`` extruded by ``thickness`` (mm, its loops as curves too), or a ``mesh``
    (V (n, 3) mm, F (m, 3)) for a part fabpat models only as an OCCT solid (a sleeve)."""

    key: str
    name: str
    colour: tuple[int, int, int]
    outline: Outline | None = None
    thickness: float = 0.0
    mesh: tuple[NDArray[np.float64], NDArray[np.int64]] | None = None


def write_assembly(blocks: Sequence[Block], placed: Sequence[tuple[str, str, NDArray[np.float64]]],
                   path: str | os.PathLike[str], *, timestamp: str | None = None) -> None:
    """Placed parts as one ``.3dm``: a layer and a block (instance definition) per :class:`Block`, and one
    block instance per ``placed`` entry (label, block key, 4 × 4 rigid transform in mm), named by its label.

    With ``timestamp`` (ISO 8601) the file is byte-reproducible (module docstring). Raises
    :class:`ExportError` (also for a placed key that is no block's).
    """
    r3 = _rhino()
    ids = _Ids(timestamp)
    fixed: dict[uuid.UUID, uuid.UUID] = {}  # the ids rhino3dm drew for blocks and their geometry → fixed ones
    model = _new_file()
    ref: dict[str, uuid.UUID] = {}
    layers: dict[str, int] = {}
    for b in blocks:
        layers[b.key] = _layer(model, b.key, b.colour, ids=ids)
        att = _attributes(layers[b.key], b.name)  # rhino3dm gives block geometry ids of its own
        if b.outline is not None:
            geometry = [plate_extrusion(b.outline, b.thickness)] + [loop_curve(loop) for loop in b.outline.loops]
        elif b.mesh is not None:
            geometry = [_mesh(*b.mesh)]
        else:
            raise ExportError(f"block {b.key!r} has neither an outline nor a mesh")
        index = model.InstanceDefinitions.Add(b.name, b.key, "", "", r3.Point3d(0, 0, 0), tuple(geometry),
                                              tuple(att for _ in geometry))
        if index < 0:
            raise ExportError(f"openNURBS rejected the block of part {b.key!r}")
        block = model.InstanceDefinitions.FindIndex(index)
        ref[b.key] = block.Id
        for drawn in [block.Id, *block.GetObjectIds()]:
            if (u := ids.next("block", b.key)) is not None:
                fixed[drawn] = u
    for label, key, T in placed:
        if key not in ref:
            raise ExportError(f"placed part {label!r} is of part {key!r}, which no block defines")
        model.Objects.AddInstanceObject(r3.InstanceReference(ref[key], _transform(T)),
                                        _attributes(layers[key], label, ids))
    _save(model, path, ids.timestamp, fixed)
