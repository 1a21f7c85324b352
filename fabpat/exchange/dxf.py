"""DXF for laser cutting, CNC and CAD: the outline's loops on layer ``CUT``, the pattern ID on ``ENGRAVE``.

Coordinates in millimetres (``$INSUNITS`` = 4, mm; DXF R12 has no units variable, so R12 files are
mm by convention only). ``$EXTMIN``/``$EXTMAX`` and the active viewport are set to the drawing's
extents (:mod:`ezdxf.bbox`), so viewers open zoomed onto the part. The part lies as ``origin`` says
(:mod:`fabpat.exchange.origin`: lower-left corner 1 mm from (0, 0) by default).

Curve modes (``curves``):

* ``"arcs"`` (default): every rational arc fitted by circular arcs within ``tolerance`` mm (G1
  biarcs from :func:`fabpat.geometry.conics.fit_arcs`). Lines stay exact.
* ``"spline"``: exact: rational degree-2 SPLINEs (3 control points, weights (1, w, 1), knots
  (0, 0, 0, 1, 1, 1)) for the curved segments and a LINE per straight segment, loops head to tail
  (outer counter-clockwise, holes clockwise). LibreCAD 2.2 and Inkscape 1.2 ignore SPLINE weights and
  draw the parabola of the control points, so an arc that parabola leaves more than ``tolerance`` mm
  away is written as its own halves, quarters, … (:func:`fabpat.exchange.dxf_splines.readable_arcs`):
  still exactly the arc for a reader that honours weights, and within ``tolerance`` for one that does
  not. Parabolic arcs (w = 1) are one non-rational SPLINE, as they were.
* ``"lines"``: polylines within ``tolerance`` mm (exact chord test of
  :func:`fabpat.geometry.curves.flatten_quad`).

Entities (``entities``) for ``"arcs"`` and ``"lines"``:

* ``"polyline"``: one closed LWPOLYLINE per loop, arcs as bulges (R12: POLYLINE/VERTEX) — for
  laser software that fills or orders closed shapes. Default from R2000 on.
* ``"segments"``: one LINE or ARC entity per piece — what every reader takes (OpenSCAD ignores
  bulges and draws chords). Default, and the only choice, with R12 (OpenSCAD imports R12
  POLYLINEs as nothing) and with ``"spline"`` (one entity per segment by design).

Kerf: ``kerf`` > 0 offsets every loop by kerf / 2 into the void (the outer loop grows, holes shrink),
so a beam that removes kerf / 2 on each side of the path leaves the part at its nominal size. The
offset is OCCT's ``BRepOffsetAPI_MakeOffset`` with arc joins (robust to loops that merge or holes
that vanish), applied to the fitted arcs in ``"arcs"`` / ``"lines"`` mode (an offset of lines and
circles is exact lines and circles) and to the exact face in ``"spline"`` mode: there lines stay
LINEs, circular joins become ARCs, and the offset of a rational arc, which is no rational curve of
any degree, becomes a cubic (degree-3) non-rational SPLINE within ``tolerance`` mm (OCCT's
``GeomConvert_ApproxCurve``; cubic is the highest degree LibreCAD and Inkscape read).

Cut order: each part's holes are written before its outer loop (:func:`fabpat.exchange.contours.cut_order`):
laser software cuts in file order, and a part cut free first can shift before its holes are cut.

The label (:func:`fabpat.exchange.labels.place_label`) is a TEXT with its default alignment, so its
first point is where the text starts, inside the part; a part with no room for a 1 mm label has none.

Reproducible files: with a ``timestamp`` (ISO 8601, :func:`fabpat.exchange.part.check_timestamp`) the same
drawing gives the same bytes in every run (:func:`stamp_document`): the header's dates ``$TDCREATE``,
``$TDUPDATE`` (the stamp's own wall time) and ``$TDUCREATE``, ``$TDUUPDATE`` (UTC) are its Julian date,
the editing timers ``$TDINDWG`` and ``$TDUSRTIMER`` are zero, ``$FINGERPRINTGUID`` and ``$VERSIONGUID``
are name-based UUIDs of the stamp and the drawing's name (:func:`fabpat.exchange.stamp.stamp_uuid`), and
ezdxf's ``CREATED_BY_EZDXF`` / ``WRITTEN_BY_EZDXF`` markers read ``<ezdxf version> @ <stamp>``. Without
it ezdxf writes the clock's time and fresh GUIDs.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, Unpack

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError
from fabpat.exchange.contours import BulgeLoop, bulge_loops, cut_order, offset_bulge_loops
from fabpat.exchange.dxf_splines import (  # noqa: F401 - the spline pieces, also importable from here
    MAX_SPLINE_DEGREE,
    Piece,
    SplinePiece,
    offset_spline_pieces,
    readable_arcs,
    spline_pieces,
    weightless_error,
)
from fabpat.exchange.origin import DEFAULT_ORIGIN, check_origin, origin_shift, translated
from fabpat.geometry.outline import Line, Loop, Outline
from fabpat.io import atomic_outputs

if TYPE_CHECKING:  # pragma: no cover
    import uuid

    from ezdxf.document import Drawing
    from ezdxf.layouts import BaseLayout

    from fabpat.exchange.part import ExportSettings, Part


class DxfOptions(TypedDict, total=False):
    """The drawing options of :func:`dxf_document` (module docstring; mm), as keywords of
    :func:`dump_dxf` and :func:`write_dxf`."""

    curves: str
    tolerance: float
    kerf: float
    dxf_version: str
    entities: str | None
    origin: str

CURVE_MODES = ("arcs", "spline", "lines")
ENTITY_MODES = ("polyline", "segments")
DXF_VERSIONS = ("R12", "R2000", "R2004", "R2007", "R2010", "R2013", "R2018")
DEFAULT_VERSION = "R2010"
DEFAULT_TOLERANCE = 0.01  # mm: largest distance between the written curves and the exact outline
CUT_LAYER, ENGRAVE_LAYER = "CUT", "ENGRAVE"
CUT_COLOR, ENGRAVE_COLOR = 1, 5  # ACI red / blue: the usual laser-software convention


def entity_mode(curves: str, dxf_version: str, entities: str | None) -> str:
    """The entity mode actually written: ``entities``, or its default for the curve mode and version."""
    if entities is None:
        return "segments" if curves == "spline" or dxf_version == "R12" else "polyline"
    return entities


def check_options(curves: str, tolerance: float, kerf: float, dxf_version: str, entities: str | None = None,
                  origin: str = DEFAULT_ORIGIN) -> None:
    """Raise :class:`ExportError` for an option the DXF writer cannot honour."""
    if curves not in CURVE_MODES:
        raise ExportError(f"unknown curve mode {curves!r}: choose one of {', '.join(CURVE_MODES)}")
    if dxf_version not in DXF_VERSIONS:
        raise ExportError(f"unknown DXF version {dxf_version!r}: choose one of {', '.join(DXF_VERSIONS)}")
    if entities is not None and entities not in ENTITY_MODES:
        raise ExportError(f"unknown DXF entity mode {entities!r}: choose one of {', '.join(ENTITY_MODES)}")
    if curves == "spline" and dxf_version == "R12":
        raise ExportError("DXF R12 has no SPLINE entity: use --curves arcs or lines, or a newer version")
    if curves == "spline" and entities == "polyline":
        raise ExportError("--curves spline writes one entity per segment: use --dxf-entities segments")
    if dxf_version == "R12" and entities == "polyline":
        raise ExportError("DXF R12 polylines import as nothing in OpenSCAD: R12 takes --dxf-entities segments")
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise ExportError(f"curve tolerance must be > 0 mm, got {tolerance:g}")
    if not (kerf >= 0 and math.isfinite(kerf)):
        raise ExportError(f"kerf must be ≥ 0 mm, got {kerf:g}")
    check_origin(origin)


def polyline(loop: Loop, tol: float) -> NDArray[np.float64]:
    """(m, 2) closed polyline within ``tol`` mm of the loop (last point not repeated)."""
    from fabpat.geometry.curves import flatten_quad

    pts: list[NDArray[np.float64]] = []
    for seg in loop.segments:
        if isinstance(seg, Line):
            pts.append(seg.p0[None])
        else:
            pts.append(np.asarray(flatten_quad(seg.control_points, seg.w, tol))[:-1])
    return np.vstack(pts)


def set_extents(doc: Drawing) -> None:
    """$EXTMIN/$EXTMAX and the active viewport from the model space's extents (ezdxf's bbox module).

    ezdxf's :func:`ezdxf.appsettings.update_extents` uses the fast (control-point) bounds; the exact
    mode is used here, so the header bounds the entities tightly.
    """
    from ezdxf import bbox, zoom

    msp = doc.modelspace()
    ext = bbox.extents(msp, fast=False)
    if not ext.has_data:
        return
    doc.header["$EXTMIN"] = ext.extmin
    doc.header["$EXTMAX"] = ext.extmax
    msp.dxf.extmin, msp.dxf.extmax = ext.extmin, ext.extmax  # ezdxf copies these into the header on save
    zoom.center(msp, ext.center, ext.size)


def _add_piece(msp: BaseLayout, p: Piece, attribs: Mapping[str, object]) -> None:
    from ezdxf.math import bulge_to_arc

    if isinstance(p, SplinePiece):
        if np.all(p.weights == 1.0):
            msp.add_open_spline(p.control.tolist(), p.degree, p.knots.tolist(), dxfattribs=attribs)
        else:
            msp.add_rational_spline(p.control.tolist(), p.weights.tolist(), p.degree, p.knots.tolist(),
                                    dxfattribs=attribs)
    elif isinstance(p, tuple):
        s, e, b = p
        if b == 0.0:
            msp.add_line(tuple(s), tuple(e), dxfattribs=attribs)
            return
        c, a0, a1, r = bulge_to_arc(tuple(s), tuple(e), b)  # counter-clockwise from a0 to a1
        msp.add_arc(c, r, math.degrees(a0), math.degrees(a1), dxfattribs=attribs)
    else:
        msp.add_line(tuple(p[0]), tuple(p[1]), dxfattribs=attribs)


def _bulge_pieces(lp: BulgeLoop) -> list[Piece]:
    E = np.roll(lp.V, -1, axis=0)
    return [(s, e, float(b)) for s, e, b in zip(lp.V, E, lp.bulges, strict=True)]


def add_bulge_segments(msp: BaseLayout, V: NDArray[np.float64], bulges: NDArray[np.float64],
                       attribs: Mapping[str, object]) -> None:
    """Add the closed bulge loop (vertices ``V`` (n, 2) mm, ``bulges`` (n,)) as one LINE or ARC per piece."""
    E = np.roll(V, -1, axis=0)
    for s, e, b in zip(V, E, bulges, strict=True):
        _add_piece(msp, (s, e, float(b)), attribs)


def dxf_document(
    outline: Outline,
    label: str | None = None,
    *,
    curves: str = "arcs",
    tolerance: float = DEFAULT_TOLERANCE,
    kerf: float = 0.0,
    dxf_version: str = DEFAULT_VERSION,
    entities: str | None = None,
    origin: str = DEFAULT_ORIGIN,
) -> Drawing:
    """The ezdxf ``Drawing`` of the outline (see the module docstring for the options, all mm)."""
    import ezdxf

    from fabpat.exchange.labels import place_label

    check_options(curves, tolerance, kerf, dxf_version, entities, origin)
    mode = entity_mode(curves, dxf_version, entities)
    outline = translated(outline, origin_shift(outline, kerf, origin))
    ezdxf_log = logging.getLogger("ezdxf")
    level = ezdxf_log.level
    if dxf_version == "R12":  # R12 has no $INSUNITS; ezdxf would log that on every new document
        ezdxf_log.setLevel(logging.ERROR)
    try:
        doc = ezdxf.new(dxf_version, units=ezdxf.units.MM)  # $INSUNITS = 4 and $MEASUREMENT = 1 (metric)
    finally:
        ezdxf_log.setLevel(level)
    doc.layers.add(CUT_LAYER, color=CUT_COLOR)
    doc.layers.add(ENGRAVE_LAYER, color=ENGRAVE_COLOR)
    msp = doc.modelspace()
    cut = {"layer": CUT_LAYER}

    def add_closed(points: list[tuple[float, float, float]]) -> None:
        if dxf_version == "R12":
            msp.add_polyline2d(points, format="xyb", close=True, dxfattribs=cut)
        else:
            msp.add_lwpolyline(points, format="xyb", close=True, dxfattribs=cut)

    half = 0.5 * kerf
    if curves == "spline":
        exact = spline_pieces(outline, tolerance) if half == 0 else offset_spline_pieces(outline, half, tolerance)
        for pieces in cut_order(exact):
            for p in pieces:
                _add_piece(msp, p, cut)
    elif curves == "arcs":
        loops = bulge_loops(outline, tolerance)
        for lp in cut_order(offset_bulge_loops(loops, half) if half > 0 else loops):
            if mode == "polyline":
                add_closed([(float(x), float(y), float(b)) for (x, y), b in zip(lp.V, lp.bulges, strict=True)])
            else:
                for p in _bulge_pieces(lp):
                    _add_piece(msp, p, cut)
    else:
        if half > 0:  # offset the arc fit, then flatten: fit and flattening get half the tolerance each
            grown = offset_bulge_loops(bulge_loops(outline, 0.5 * tolerance), half)
            polys = [lp.flatten(0.5 * tolerance) for lp in grown]
        else:
            polys = [polyline(lp, tolerance) for lp in outline.loops]
        for P in cut_order(polys):
            if mode == "polyline":
                add_closed([(float(x), float(y), 0.0) for x, y in P])
            else:
                for a, b in zip(P, np.roll(P, -1, axis=0), strict=True):
                    msp.add_line(tuple(a), tuple(b), dxfattribs=cut)
    placed = place_label(outline, label) if label else None
    if placed is not None:
        msp.add_text(placed.text, height=placed.height, rotation=placed.angle,
                     dxfattribs={"layer": ENGRAVE_LAYER, "insert": placed.start})
    set_extents(doc)
    return doc


def stamp_document(doc: Drawing, timestamp: str, name: str) -> None:
    """Give the ezdxf drawing ``doc`` the dates and identifiers of ``timestamp`` (ISO 8601) and ``name`` (what the
    drawing is, e.g. its file name: two drawings of one stamp get different GUIDs when their names differ), now
    and when it is saved, so that saving it gives the same bytes in every run (module docstring).

    ezdxf rewrites ``$TDUPDATE``, ``$VERSIONGUID`` and its ``WRITTEN_BY_EZDXF`` marker from the clock in
    ``Drawing._update_metadata`` on every save. Its only switch against that,
    ``ezdxf.options.write_fixed_meta_data_for_testing``, is global (every drawing of the process, and
    fixed to 2000-01-01), so this wraps the method of this one drawing instead: ezdxf's own update runs
    first (the handle seed, the code page) and the stamp's values are put back after it. ezdxf also adds
    some CLASSES (those of the entity types in use) in the order of a set of strings, which changes from
    process to process (hash randomisation): the wrapped method also sorts the CLASSES section by name
    (its order carries no meaning; entities name their class). Raises
    :class:`ExportError` for a bad ``timestamp`` or an ezdxf without that method (nothing then could keep
    the file reproducible)."""
    import ezdxf
    from ezdxf.document import CREATED_BY_EZDXF, WRITTEN_BY_EZDXF
    from ezdxf.tools.juliandate import juliandate

    from fabpat.exchange.part import check_timestamp
    from fabpat.exchange.stamp import stamp_time, stamp_uuid, utc_time

    text = check_timestamp(timestamp, "timestamp")
    update = getattr(doc, "_update_metadata", None)
    if not callable(update):
        raise ExportError(f"ezdxf {ezdxf.__version__} has no Drawing._update_metadata: fabpat cannot write "
                          "a reproducible DXF with it; write without --timestamp")
    local = juliandate(stamp_time(timestamp).replace(tzinfo=None))  # AutoCAD: $TDCREATE is local time
    universal = juliandate(utc_time(timestamp))
    header = {"$TDCREATE": local, "$TDUPDATE": local, "$TDUCREATE": universal, "$TDUUPDATE": universal,
              "$TDINDWG": 0.0, "$TDUSRTIMER": 0.0,  # days spent editing: none, the file was generated
              "$FINGERPRINTGUID": _dxf_guid(stamp_uuid(timestamp, "DXF fingerprint", name)),
              "$VERSIONGUID": _dxf_guid(stamp_uuid(timestamp, "DXF version", name))}
    marker = f"{ezdxf.__version__} @ {text}"  # ezdxf's own form, "<version> @ <ISO time>"

    def stamp() -> None:
        for key, value in header.items():
            doc.header[key] = value
        doc.ezdxf_metadata()[WRITTEN_BY_EZDXF] = marker

    def update_then_stamp() -> None:
        update()  # runs after ezdxf has added every class it will write
        stamp()
        classes = doc.classes.classes  # {(name, C++ class name): DXFClass}, written in this order
        ordered = sorted(classes.items(), key=lambda kv: kv[0])
        classes.clear()
        classes.update(ordered)

    stamp()
    doc.ezdxf_metadata()[CREATED_BY_EZDXF] = marker
    object.__setattr__(doc, "_update_metadata", update_then_stamp)  # this drawing only: see the docstring


def _dxf_guid(u: uuid.UUID) -> str:
    """A GUID as DXF writes it (``$FINGERPRINTGUID``): upper case in braces."""
    return "{" + str(u).upper() + "}"


def save_document(doc: Drawing, path: str | os.PathLike[str], timestamp: str | None = None, name: str = "") -> None:
    """Save the ezdxf drawing ``doc`` to ``path`` (not atomic); with ``timestamp`` (ISO 8601) first
    :func:`stamp_document` with ``name``, so the file is byte-reproducible. Raises :class:`ExportError`
    (a bad ``timestamp``, or :func:`fabpat.io.writer_failed` naming ``path`` for an OSError)."""
    if timestamp is not None:
        stamp_document(doc, timestamp, name)
    try:
        doc.saveas(os.fsdecode(path))
    except OSError as e:  # a full disk: atomic_outputs names the target (not this temporary file) and the cause
        from fabpat.io import writer_failed

        raise writer_failed(path, "cannot write the DXF file", e) from e


def dump_dxf(outline: Outline, path: str | os.PathLike[str], label: str | None = None, *,
             timestamp: str | None = None, name: str | None = None, **options: Unpack[DxfOptions]) -> None:
    """Write :func:`dxf_document` to ``path`` (not atomic; see :func:`write_dxf`). ``timestamp`` (ISO 8601)
    makes the file byte-reproducible; ``name`` (default ``label``) goes into its GUIDs (:func:`stamp_document`).
    Raises :class:`ExportError`, :class:`GeometryError`."""
    from fabpat.exchange.part import check_timestamp

    check_timestamp(timestamp, "timestamp")  # before the drawing is made
    doc = dxf_document(outline, label, **options)
    save_document(doc, path, timestamp, (label or "") if name is None else name)


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part's outline with the settings' curve mode, tolerance and kerf; with
    ``settings.timestamp`` byte-reproducible (its GUIDs from the part's name)."""
    dump_dxf(
        part.outline,
        path,
        part.label,
        timestamp=settings.timestamp,
        name=part.name,
        curves=settings.curves,
        tolerance=settings.curve_tolerance,
        kerf=settings.kerf,
        dxf_version=settings.dxf_version,
        entities=settings.dxf_entities,
        origin=settings.origin,
    )


def write_dxf(outline: Outline, path: str | os.PathLike[str], label: str | None = None, *,
              timestamp: str | None = None, name: str | None = None, **options: Unpack[DxfOptions]) -> Path:
    """Write the outline as DXF atomically; ``options`` as for :func:`dxf_document`, ``timestamp`` and
    ``name`` as for :func:`dump_dxf`. Returns the path. Raises :class:`ExportError`, :class:`GeometryError`."""
    from fabpat.exchange.part import check_timestamp

    check_timestamp(timestamp, "timestamp")
    check_options(
        options.get("curves", "arcs"),
        options.get("tolerance", DEFAULT_TOLERANCE),
        options.get("kerf", 0.0),
        options.get("dxf_version", DEFAULT_VERSION),
        options.get("entities"),
        options.get("origin", DEFAULT_ORIGIN),
    )
    with atomic_outputs(path) as (tmp,):
        dump_dxf(outline, tmp, label, timestamp=timestamp, name=name, **options)
    return Path(path)
