"""STEP AP214 (ISO 10303-214, ``AUTOMOTIVE_DESIGN``) export of the exact solid, in millimetres.

Written through OCCT's XDE document so the part carries a product name (pattern ID and parameters,
see :func:`fabpat.cad.part_name`). Rational Bézier edges are written as
``RATIONAL_B_SPLINE_CURVE`` with their weights (1, w, 1): a CAD program re-importing the file gets
the exact fillet, not a facetted approximation.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fabpat.errors import ExportError
from fabpat.io import atomic_outputs

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.exchange.registry import ExportSettings, Part

SCHEMA = "AP214IS"  # OCCT's name for the AP214 international standard schema
ORIGINATING_SYSTEM = "fabpat"


def check_timestamp(timestamp: str | None, what: str = "--timestamp") -> str | None:
    """The STEP header time stamp, normalised to ``YYYY-MM-DDThh:mm:ss`` (plus ``Z`` or ``±hh:mm`` when
    a zone is given), if ``timestamp`` is a valid ISO 8601 date or date-time (``2025-01-31``,
    ``2025-01-31T12:00:00``, ``2025-01-31 12:00``, ``20250131``, ``…Z``, ``…+01:00``); fractions of a
    second are dropped. :class:`ExportError` naming ``what`` otherwise.

    Checked before any work, so free text never reaches a file header; the normalised form is what the
    header gets (ISO 10303-21 §8.2.3 wants an ISO 8601 time_stamp, and every accepted spelling of one
    instant gives the same bytes). Parsed by :meth:`datetime.datetime.fromisoformat`.
    """
    from datetime import datetime, timedelta

    if timestamp is None:
        return None
    try:
        if not isinstance(timestamp, str) or not timestamp.isascii() or not timestamp.strip():
            raise ValueError
        t = datetime.fromisoformat(timestamp)
    except ValueError:
        raise ExportError(f"{what} {timestamp!r} is not an ISO 8601 date or time: give e.g. 2025-01-31 or "
                          "2025-01-31T12:00:00Z") from None
    text = t.strftime("%Y-%m-%dT%H:%M:%S")
    offset = t.utcoffset()
    if offset is not None:
        if offset == timedelta(0):
            return text + "Z"
        minutes = int(abs(offset.total_seconds())) // 60
        text += f"{'-' if offset < timedelta(0) else '+'}{minutes // 60:02d}:{minutes % 60:02d}"
    return text


def _quiet_occt() -> None:
    """Keep OCCT's transfer statistics off stdout (the CLI's stdout is for the user)."""
    from OCP.Message import Message, Message_Gravity

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)


def dump_step(shape: Any, path: str | os.PathLike[str], name: str, timestamp: str | None = None) -> None:
    """Write ``shape`` (a ``TopoDS_Shape`` or anything with ``.wrapped``) to ``path`` as-is.

    ``name`` is the product name (and the header's file name); ``timestamp`` (ISO 8601) fixes the
    header time stamp for reproducible files. Not atomic: use :func:`write_step` or call it on a
    temporary path from :func:`fabpat.io.atomic_outputs`. Raises :class:`ExportError`.
    """
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    check_timestamp(timestamp, "timestamp")
    shape = getattr(shape, "wrapped", shape)
    _quiet_occt()
    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 0.001)  # the value is metres per unit: the shape is in mm
    label = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main()).AddShape(shape, False)
    TDataStd_Name.Set_s(label, TCollection_ExtendedString(name))

    write_document(doc, path, name, timestamp)


def write_document(doc: Any, path: str | os.PathLike[str], name: str, timestamp: str | None = None) -> None:
    """Write an XDE document (a part or an assembly) to ``path`` as STEP AP214 in mm. Not atomic."""
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType
    from OCP.TCollection import TCollection_HAsciiString

    timestamp = check_timestamp(timestamp, "timestamp")
    _quiet_occt()
    # Interface_Static is global OCCT state: set everything we rely on before every write.
    Interface_Static.SetCVal_s("write.step.schema", SCHEMA)
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    writer = STEPCAFControl_Writer()
    writer.SetNameMode(True)
    if not writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs):
        raise ExportError(f"OCCT could not translate {name!r} to STEP")
    header = APIHeaderSection_MakeHeader(writer.ChangeWriter().Model())
    header.SetName(TCollection_HAsciiString(name))
    header.SetOriginatingSystem(TCollection_HAsciiString(ORIGINATING_SYSTEM))
    if timestamp is not None:
        header.SetTimeStamp(TCollection_HAsciiString(timestamp))
    if writer.Write(os.fsdecode(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        from fabpat.io import writer_failed

        raise writer_failed(path, "OCCT could not write the STEP file")


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part's solid to ``path`` (a temporary from ``atomic_outputs``)."""
    dump_step(part.solid, path, part.name, settings.timestamp)


def write_step(shape: Any, path: str | os.PathLike[str], name: str, timestamp: str | None = None) -> Path:
    """Write a solid to a STEP AP214 file (mm) atomically; returns the path written."""
    with atomic_outputs(path) as (tmp,):
        dump_step(shape, tmp, name, timestamp)
    return Path(path)
