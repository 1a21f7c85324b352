"""3MF (3D Manufacturing Format, core spec 1.3) of the meshed solid, in millimetres.

A small writer of our own (a zip with three XML parts) rather than trimesh's exporter, which needs
lxml and networkx and costs ≈ 1 s to import. The mesh comes from :func:`triangulate`
(welded, outward CCW triangles), so slicers see one closed, consistently oriented object carrying
the part name (pattern ID and parameters).

With a ``timestamp`` (ISO 8601, :func:`fabpat.exchange.part.check_timestamp`) the package is
byte-reproducible: the model holds no identifier or time of its own, and every ZIP member gets the
stamp's time (UTC) as its date instead of the clock's (:func:`fabpat.exchange.stamp.zip_date_time`:
ZIP dates cannot be before 1980, so an earlier stamp gives 1980-01-01).
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import escape, quoteattr

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError, GeometryError
from fabpat.exchange.cad import DEFAULT_ANGULAR, DEFAULT_CHORD, ShapeLike, mesh
from fabpat.io import atomic_outputs

if TYPE_CHECKING:  # pragma: no cover
    from OCP.TopoDS import TopoDS_Shape

    from fabpat.exchange.part import ExportSettings, Part

_CONTENT_TYPES = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
    '<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
    '<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>'
    "</Types>"
)
_RELS = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
    '<Relationship Target="/3D/3dmodel.model" Id="rel0" '
    'Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>'
    "</Relationships>"
)


def triangulate(
    shape: TopoDS_Shape, tolerance: float, angular: float = DEFAULT_ANGULAR
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mesh the shape and return ``V`` (n, 3) float mm, ``F`` (m, 3) int, outward CCW, welded.

    Faces share their boundary nodes (BRepMesh discretises each edge once), so welding coincident
    points gives a closed, consistently oriented surface.
    """
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    mesh(shape, tolerance, angular)
    Vs: list[NDArray[np.float64]] = []
    Fs: list[NDArray[np.int64]] = []
    offset = 0
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        face = TopoDS.Face(explorer.Current())
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(face, loc)
        if tri is None:
            raise GeometryError("a face has no triangulation")
        trsf = loc.Transformation()
        nodes = np.array(
            [tri.Node(i).Transformed(trsf).Coord() for i in range(1, tri.NbNodes() + 1)], dtype=np.float64
        )
        tris = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)], dtype=np.int64) - 1
        if face.Orientation() == TopAbs_REVERSED:
            tris = tris[:, ::-1]  # the face uses its surface reversed: flip to keep normals outward
        Vs.append(nodes)
        Fs.append(tris + offset)
        offset += len(nodes)
        explorer.Next()
    V = np.vstack(Vs)
    F = np.vstack(Fs)
    # Weld: nodes of one edge are computed once per edge, so equal points are bit-identical up to
    # rounding of the location transform; 1e-9 mm rounding merges them without merging neighbours.
    key = np.round(V / 1e-9).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    F = inverse.reshape(-1)[F]
    F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])]
    return V[first], F


def model_xml(V: NDArray[np.float64], F: NDArray[np.int64], name: str) -> str:
    """The ``3D/3dmodel.model`` part for one mesh object: ``V`` (n, 3) mm, ``F`` (m, 3) int."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise ExportError("3MF needs a non-empty triangle mesh")
    # 1e-6 mm is far below any printer's resolution and keeps the file small.
    verts = "".join(f'<vertex x="{x:.6f}" y="{y:.6f}" z="{z:.6f}"/>' for x, y, z in V.tolist())
    tris = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in F.tolist())
    title = quoteattr(name)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<model unit="millimeter" xml:lang="en-US" '
        'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">'
        f'<metadata name="Title">{escape(name)}</metadata>'
        '<metadata name="Application">fabpat</metadata>'
        f'<resources><object id="1" type="model" name={title}><mesh>'
        f"<vertices>{verts}</vertices><triangles>{tris}</triangles>"
        '</mesh></object></resources><build><item objectid="1"/></build></model>'
    )


def dump_3mf(V: NDArray[np.float64], F: NDArray[np.int64], path: str | os.PathLike[str], name: str,
             timestamp: str | None = None) -> None:
    """Write a triangle mesh (``V`` (n, 3) float mm, ``F`` (m, 3) int) as a 3MF package to ``path`` (not atomic).

    ``timestamp`` (ISO 8601): the ZIP members' date, for a byte-reproducible file (module docstring); without
    it they carry the time of writing. Raises :class:`ExportError` (an empty mesh, a bad ``timestamp``)."""
    from fabpat.exchange.part import check_timestamp

    timestamp = check_timestamp(timestamp, "timestamp")
    members = (("[Content_Types].xml", _CONTENT_TYPES), ("_rels/.rels", _RELS),
               ("3D/3dmodel.model", model_xml(V, F, name)))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for member, text in members:
            if timestamp is None:
                z.writestr(member, text)  # dated now
                continue
            from fabpat.exchange.stamp import zip_date_time

            info = zipfile.ZipInfo(member, date_time=zip_date_time(timestamp))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o600 << 16  # what writestr gives a member named by a str: one file for both paths
            z.writestr(info, text)
    Path(path).write_bytes(buf.getvalue())


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part's solid meshed at ``settings.mesh_tolerance`` mm, dated ``settings.timestamp``."""
    V, F = triangulate(part.solid, settings.mesh_tolerance, settings.angular_tolerance)
    dump_3mf(V, F, path, part.name, settings.timestamp)


def write_3mf(
    shape: ShapeLike,
    path: str | os.PathLike[str],
    name: str,
    tolerance: float = DEFAULT_CHORD,
    angular: float = DEFAULT_ANGULAR,
    *,
    timestamp: str | None = None,
) -> Path:
    """Mesh a solid within ``tolerance`` mm (``angular`` rad) and write it as 3MF atomically; returns the path.
    ``timestamp`` (ISO 8601) makes the file byte-reproducible (module docstring). Raises :class:`ExportError`,
    :class:`GeometryError` (a face without triangulation)."""
    from fabpat.exchange.part import check_timestamp

    check_timestamp(timestamp, "timestamp")  # before the meshing
    V, F = triangulate(getattr(shape, "wrapped", shape), tolerance, angular)
    with atomic_outputs(path) as (tmp,):
        dump_3mf(V, F, tmp, name, timestamp)
    return Path(path)
