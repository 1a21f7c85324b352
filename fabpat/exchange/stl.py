"""Binary STL of the solid, triangulated with a chord tolerance in millimetres.

The solid is meshed by ``BRepMesh_IncrementalMesh(shape, tolerance_mm, False, angular, True)`` (an
absolute tolerance: build123d's ``export_stl`` takes a tolerance relative to the shape size) and
written by OCCT's ``StlAPI_Writer`` in binary mode. Faces share their edge discretisation, so the
triangles form a closed, consistently oriented surface (checked in the tests with trimesh).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from fabpat.exchange.cad import DEFAULT_ANGULAR, DEFAULT_CHORD, ShapeLike, mesh
from fabpat.io import atomic_outputs, writer_failed

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.exchange.part import ExportSettings, Part

DEFAULT_TOLERANCE = DEFAULT_CHORD  # mm: max distance between a facet and the exact surface (chord height)


def dump_stl(
    shape: ShapeLike, path: str | os.PathLike[str], tolerance: float = DEFAULT_TOLERANCE,
    angular: float = DEFAULT_ANGULAR,
) -> None:
    """Mesh ``shape`` (``TopoDS_Shape`` or build123d shape) within ``tolerance`` mm and write it.

    Not atomic (see :func:`write_stl`). Raises :class:`fabpat.io.WriteFailed` (an :class:`ExportError`)
    if OCCT cannot write the file, ``ENOSPC`` when the disk is full (see :func:`fabpat.io.writer_failed`).
    """
    from OCP.StlAPI import StlAPI_Writer

    shape = getattr(shape, "wrapped", shape)
    mesh(shape, tolerance, angular)
    writer = StlAPI_Writer()
    writer.ASCIIMode = False
    if not writer.Write(shape, os.fsdecode(path)):
        raise writer_failed(path, "OCCT could not write the STL file")


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part's solid as binary STL at ``settings.mesh_tolerance`` mm."""
    dump_stl(part.solid, path, settings.mesh_tolerance, settings.angular_tolerance)


def write_stl(
    shape: ShapeLike, path: str | os.PathLike[str], tolerance: float = DEFAULT_TOLERANCE,
    angular: float = DEFAULT_ANGULAR,
) -> Path:
    """Write a solid to a binary STL file (mm) atomically; returns the path written."""
    with atomic_outputs(path) as (tmp,):
        dump_stl(shape, tmp, tolerance, angular)
    return Path(path)
