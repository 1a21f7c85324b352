"""STEP AP214 (ISO 10303-214, ``AUTOMOTIVE_DESIGN``) export of the exact solid, in millimetres.

Written through OCCT's XDE document so the part carries a product name (pattern ID and parameters,
see :func:`fabpat.exchange.cad.part_name`). Rational Bézier edges are written as
``RATIONAL_B_SPLINE_CURVE`` with their weights (1, w, 1): a CAD program re-importing the file gets
the exact fillet, not a facetted approximation.

Names are written as ISO 10303-21 strings (§6.4.3, :func:`step_string`): printable ASCII as it is,
every other character as a ``\\X2\\…\\X0\\`` (or ``\\X4\\…\\X0\\``) hexadecimal group, so
the file is printable ASCII and a reader decodes the name back; control characters are refused.
With a ``timestamp`` the file is byte-reproducible: OCCT's header fields other than the name and time
are constants of its version, the colour blocks of an assembly, which OCCT writes in an order
that changes from run to run, are put in a fixed one, and its occurrence ids start at 1 however many
assemblies the process wrote before (:mod:`fabpat.exchange.step_order`).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from fabpat.errors import ExportError
from fabpat.exchange.part import check_printable, check_timestamp  # noqa: F401 - also this module's API
from fabpat.exchange.step_order import renumber_occurrences, sort_trailing_styles
from fabpat.io import atomic_outputs

if TYPE_CHECKING:  # pragma: no cover - OCP has no stubs: mypy sees its classes as unchecked
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document

    from fabpat.exchange.cad import ShapeLike
    from fabpat.exchange.part import ExportSettings, Part

SCHEMA = "AP214IS"  # OCCT's name for the AP214 international standard schema
ORIGINATING_SYSTEM = "fabpat"


def step_string(text: str, what: str = "name") -> str:
    """``text`` as the contents of an ISO 10303-21 string (ISO 10303-21:2016 §6.4.3, "Strings").

    Printable ASCII (U+0020–U+007E) but the reverse solidus is kept as it is (OCCT's writer doubles
    the apostrophe); every other character is encoded: a run of characters of the Basic Multilingual
    Plane as ``\\X2\\`` + four hexadecimal digits each + ``\\X0\\``, characters above U+FFFF as
    ``\\X4\\`` + eight digits each + ``\\X0\\``. The reverse solidus itself
    goes in an ``\\X2\\`` group too, so no text of the user's can read as a directive. Raises
    :class:`ExportError` naming ``what`` for a control character (U+0000–U+001F, U+007F–U+009F), which
    a string may not hold: ``"Kuppel ü"`` → ``"Kuppel \\X2\\00FC\\X0\\"``.
    """
    check_printable(text, what)
    out: list[str] = []
    group = ""  # the directive of the open hexadecimal group: "X2", "X4" or none

    def switch(to: str) -> None:
        nonlocal group
        if group != to:
            if group:
                out.append("\\X0\\")
            if to:
                out.append(f"\\{to}\\")
            group = to

    for c in text:
        code = ord(c)
        if 0x20 <= code <= 0x7E and c != "\\":
            switch("")
            out.append(c)
        elif code <= 0xFFFF:
            switch("X2")
            out.append(f"{code:04X}")
        else:
            switch("X4")
            out.append(f"{code:08X}")
    switch("")
    return "".join(out)


def _quiet_occt() -> None:
    """Keep OCCT's transfer statistics off stdout (the CLI's stdout is for the user)."""
    from OCP.Message import Message, Message_Gravity

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)


def dump_step(shape: ShapeLike, path: str | os.PathLike[str], name: str, timestamp: str | None = None) -> None:
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
    step_string(name, "the STEP product name")  # before OCCT, which cuts a name at a NUL
    shape = getattr(shape, "wrapped", shape)
    _quiet_occt()
    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 0.001)  # the value is metres per unit: the shape is in mm
    label = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main()).AddShape(shape, False)
    TDataStd_Name.Set_s(label, TCollection_ExtendedString(name, True))  # True: the str's UTF-8 decoded

    write_document(doc, path, name, timestamp)


def _text(name: TCollection_ExtendedString) -> str:
    """The text of a ``TCollection_ExtendedString``. One made from a Python str without the multi-byte
    flag holds the str's UTF-8 bytes one per character (``"ü"`` → ``"Ã¼"``); such a string is decoded
    back, so a name reaches the file as the caller wrote it, whichever way it was stored."""
    text: str = name.ToExtString()
    if any(ord(c) > 0x7F for c in text) and all(ord(c) < 0x100 for c in text):
        try:
            return text.encode("latin-1").decode("utf-8")
        except UnicodeDecodeError:  # real Latin-1 text
            pass
    return text


@contextlib.contextmanager
def _names_encoded(doc: TDocStd_Document) -> Iterator[None]:
    """Every ``TDataStd_Name`` in the document as its :func:`step_string` for the block (the transfer and
    the write), then as it was: the caller's document is left unchanged."""
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDF import TDF_ChildIterator

    changed = []
    try:
        it = TDF_ChildIterator(doc.Main(), True)  # True: every level, the whole tree
        while it.More():
            label, attr = it.Value(), TDataStd_Name()
            if label.FindAttribute(TDataStd_Name.GetID_s(), attr):  # attr: a copy (OCP), so Set_s below
                before = TCollection_ExtendedString(attr.Get())
                text = _text(before)
                TDataStd_Name.Set_s(label, TCollection_ExtendedString(step_string(text, f"the STEP name {text!r}")))
                changed.append((label, before))
            it.Next()
        yield
    finally:
        for label, before in changed:
            TDataStd_Name.Set_s(label, before)


def write_document(doc: TDocStd_Document, path: str | os.PathLike[str], name: str,
                   timestamp: str | None = None) -> None:
    """Write an XDE document (a part or an assembly) to ``path`` as STEP AP214 in mm. Not atomic.

    Every name in the document and ``name`` (the header's file name) are written as ISO 10303-21
    strings (:func:`step_string`); :class:`ExportError` for one with a control character. With
    ``timestamp`` the same document gives the same bytes in every run (module docstring)."""
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
    with _names_encoded(doc):  # the whole write: OCCT reads the names in Transfer or in Write
        if not writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs):
            raise ExportError(f"OCCT could not translate {name!r} to STEP")
        header = APIHeaderSection_MakeHeader(writer.ChangeWriter().Model())
        header.SetName(TCollection_HAsciiString(step_string(name, "the STEP file name")))
        header.SetOriginatingSystem(TCollection_HAsciiString(ORIGINATING_SYSTEM))
        if timestamp is not None:
            header.SetTimeStamp(TCollection_HAsciiString(timestamp))
        status = writer.Write(os.fsdecode(path))
    from fabpat.io import writer_failed

    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise writer_failed(path, "OCCT could not write the STEP file")
    try:  # OCCT orders an assembly's colours by memory address and numbers occurrences per process
        sort_trailing_styles(path)
        renumber_occurrences(path)
    except OSError as e:
        raise writer_failed(path, "could not rewrite the STEP file", e) from e


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part's solid to ``path`` (a temporary from ``atomic_outputs``)."""
    dump_step(part.solid, path, part.name, settings.timestamp)


def write_step(shape: ShapeLike, path: str | os.PathLike[str], name: str, timestamp: str | None = None) -> Path:
    """Write a solid to a STEP AP214 file (mm) atomically; returns the path written."""
    with atomic_outputs(path) as (tmp,):
        dump_step(shape, tmp, name, timestamp)
    return Path(path)
