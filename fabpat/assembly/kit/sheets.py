"""Laser sheets (or print-bed layouts) of an assembly's plates: one DXF per sheet.

Each plate's exact outline is fitted by circular arcs within the spec's ``output.curve_tolerance``
(default 0.01 mm; :func:`fabpat.exchange.contours.bulge_loops`),
offset by kerf/2 into the void when a kerf is given, turned and moved to its nested place, and written
as closed LWPOLYLINEs with bulges on layer ``CUT`` (a rigid motion keeps every bulge; laser software
fills and orders closed shapes), or, with ``[sheet] dxf_entities = "segments"``, as one LINE or ARC
per piece (OpenSCAD ignores bulges and would cut chords). Layer ``ENGRAVE`` carries, inside the solid
sub-triangle that every pattern has at each interface, the label of the sleeve joint on that edge and
the plate's own label, written along the edge (a central label would often fall on a void: many patterns are open in the
middle). Labels are left-aligned TEXT, so their first point is where they start, for readers that
ignore alignment. Layer ``SHEET`` outlines the bed; it is a non-plotting layer (DXF plot flag 0),
and ``[sheet] border = false`` leaves it out (OpenSCAD, for one, imports every layer as geometry).
$EXTMIN/$EXTMAX are the drawing's extents.
"""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.nesting import Nesting, nest
from fabpat.assembly.place.placement import Assembly, PlateType
from fabpat.assembly.place.shaped import ShapedPlateType, is_shaped, shaped_kerf
from fabpat.assembly.spec.sheet import sheet_of

if TYPE_CHECKING:
    from ezdxf.document import Drawing

    from fabpat.exchange.contours import BulgeLoop
    from fabpat.geometry.fillet import FilletedPattern

SHEET_LAYER = "SHEET"
SHEET_COLOR = 8  # ACI grey: reference only, not cut
EDGE_LABEL_HEIGHT = 1.4  # mm: largest label height (capped by the sub-triangle's size)
LABEL_CLEARANCE = 0.25  # mm between a label's box and the sub-triangle's sides
LINE_GAP = 0.3  # mm between the joint label line and the plate label line


def plate_polygon(pt: PlateType, edge: float) -> NDArray[np.float64]:
    """(n, 2) polygon that contains the plate (the plate's frame, mm): the regular n-gon of ``edge`` or a
    shaped plate's own (:func:`fabpat.assembly.place.shaped.plate_corners`)."""
    from fabpat.assembly.place.shaped import plate_corners

    return plate_corners(pt, edge)


def nest_plates(assembly: Assembly) -> Nesting:
    """Nest every plate of the assembly (one item per plate, in plate order) on the spec's sheets.

    The polygons grow by kerf/2, since the cut path of a plate lies that far outside it.
    """
    s = sheet_of(assembly.spec)
    polys = []
    for p in assembly.plates:
        P = plate_polygon(p.type, assembly.plate_edge)
        if is_shaped(p.type):
            P = shaped_kerf(P, s.kerf if s is not None else 0.0)
        elif s.kerf > 0:
            apothem = assembly.plate_edge / (2 * math.tan(math.pi / p.type.sides))
            P = P * (1.0 + 0.5 * s.kerf / apothem)  # similar polygon whose edges lie kerf/2 further out
        polys.append(P)
    return nest(polys, s.width, s.height, s.margin, s.spacing)


def edge_label_spots(pt: PlateType, edge: float, chars: int = 3
                     ) -> list[tuple[NDArray[np.float64], NDArray[np.float64] | None, float, float]]:
    """Per polygon edge: (joint label centre (2,), plate label centre (2,) or None, angle rad, height mm).

    Plate frame. Every pattern has a solid sub-triangle at each interface (apex at the edge midpoint,
    top side one edge row = apothem / 2**depth in, of width b = edge / 2**depth): at depth d from the
    edge it is k·d wide, k = b / row. Two lines of ``chars`` characters (box CHAR_WIDTH·chars·h
    wide, baseline along the edge) fit when the lower one starts at d1 = (a h + 2c) / k (its
    narrower, lower edge is wide enough; a = CHAR_WIDTH·chars, c = LABEL_CLEARANCE) and the upper
    one ends at d1 + 2h + LINE_GAP ≤ row − c: h = (row − c − LINE_GAP − 2c/k) / (a/k + 2), at most
    EDGE_LABEL_HEIGHT. If that is below MIN_TEXT_HEIGHT the plate label is left out and the joint
    label alone gets h = (row − 2c − 2c/k) / (a/k + 1); if even that is too small, no labels ([]).
    """
    from fabpat.exchange.labels import CHAR_WIDTH, MIN_TEXT_HEIGHT

    if isinstance(pt, ShapedPlateType):
        return shaped_label_spots(pt, chars)
    n, depth = pt.sides, pt.depth
    apothem = edge / (2 * math.tan(math.pi / n))
    row = apothem / 2**depth
    k = (edge / 2**depth) / row
    a, c = CHAR_WIDTH * chars, LABEL_CLEARANCE
    two = min(EDGE_LABEL_HEIGHT, (row - c - LINE_GAP - 2 * c / k) / (a / k + 2))
    one = min(EDGE_LABEL_HEIGHT, (row - 2 * c - 2 * c / k) / (a / k + 1))
    if two >= MIN_TEXT_HEIGHT:
        h, both = two, True
    elif one >= MIN_TEXT_HEIGHT:
        h, both = one, False
    else:
        return []
    d1 = (a * h + 2 * c) / k
    out = []
    for i in range(n):
        t = -math.pi / 2 + 2 * math.pi * i / n  # direction of edge i's midpoint
        u = np.array([math.cos(t), math.sin(t)])
        own = (apothem - (d1 + 1.5 * h + LINE_GAP)) * u if both else None
        out.append(((apothem - (d1 + 0.5 * h)) * u, own, 2 * math.pi * i / n, h))
    return out


def _label_heights(row: float, k: float, chars: int) -> tuple[float, float]:
    """(height of two label lines, of one line) mm that fit a solid sub-triangle of height ``row`` mm whose
    width grows by ``k`` per mm from its apex, ``chars`` characters a line (:func:`edge_label_spots`)."""
    from fabpat.exchange.labels import CHAR_WIDTH

    a, c = CHAR_WIDTH * chars, LABEL_CLEARANCE
    return (min(EDGE_LABEL_HEIGHT, (row - c - LINE_GAP - 2 * c / k) / (a / k + 2)),
            min(EDGE_LABEL_HEIGHT, (row - 2 * c - 2 * c / k) / (a / k + 1)))


def shaped_label_spots(pt: ShapedPlateType, chars: int = 3
                       ) -> list[tuple[NDArray[np.float64], NDArray[np.float64] | None, float, float]]:
    """:func:`edge_label_spots` of a shaped plate (:mod:`fabpat.geometry.shaped`): its solid sub-triangle at
    edge i is isosceles, apex at the edge's midpoint M_i, top side one lattice row in (the distance a_i of the
    fans' apex, the vertex centroid, from the edge, over 2**depth) and L_i / 2**depth wide, so each edge gets
    the regular layout with apothem a_i and edge L_i, along its own direction; one height for every edge,
    the smallest that fits all. [] when some edge has no room for a label."""
    from fabpat.exchange.labels import CHAR_WIDTH, MIN_TEXT_HEIGHT

    P = pt.polygon
    centre, N = P.mean(axis=0), 2**pt.depth
    rows = []
    for i in range(len(P)):
        a, b = P[i], P[(i + 1) % len(P)]
        t = (b - a) / np.linalg.norm(b - a)
        u = np.array([t[1], -t[0]])  # outward, square to the edge
        apothem = float((0.5 * (a + b) - centre) @ u)
        k = float(np.linalg.norm(b - a)) / apothem  # the sub-triangle's width over its height
        rows.append((0.5 * (a + b), u, math.atan2(t[1], t[0]), k, *_label_heights(apothem / N, k, chars)))
    two, one = min(r[4] for r in rows), min(r[5] for r in rows)
    if two < MIN_TEXT_HEIGHT and one < MIN_TEXT_HEIGHT:
        return []
    both = two >= MIN_TEXT_HEIGHT
    h = two if both else one
    out = []
    for M, u, angle, k, *_ in rows:
        d1 = (CHAR_WIDTH * chars * h + 2 * LABEL_CLEARANCE) / k
        own = M - (d1 + 1.5 * h + LINE_GAP) * u if both else None
        out.append((M - (d1 + 0.5 * h) * u, own, angle, h))
    return out


def sheet_document(assembly: Assembly, nesting: Nesting, sheet: int,
                   filleted: dict[PlateType, FilletedPattern]) -> Drawing:
    """The ezdxf drawing of one sheet (mm; layers CUT, ENGRAVE, SHEET)."""
    import ezdxf

    from fabpat.exchange.contours import bulge_loops, cut_order, offset_bulge_loops
    from fabpat.exchange.dxf import CUT_COLOR, CUT_LAYER, ENGRAVE_COLOR, ENGRAVE_LAYER, add_bulge_segments, set_extents
    from fabpat.exchange.labels import label_at

    bed = sheet_of(assembly.spec)
    kerf = bed.kerf
    segments = bed.dxf_entities == "segments"
    doc = ezdxf.new("R2010", units=ezdxf.units.MM)
    doc.layers.add(CUT_LAYER, color=CUT_COLOR)
    doc.layers.add(ENGRAVE_LAYER, color=ENGRAVE_COLOR)
    msp = doc.modelspace()
    W, H = nesting.width, nesting.height
    if bed.border:
        layer = doc.layers.add(SHEET_LAYER, color=SHEET_COLOR)
        layer.dxf.plot = 0  # reference only: never plotted or cut
        msp.add_lwpolyline([(0, 0), (W, 0), (W, H), (0, H)], close=True, dxfattribs={"layer": SHEET_LAYER})
    chars = max(len(t) for p in assembly.plates for t in (p.label, *p.edge_labels))
    loops_of: dict[PlateType, list[BulgeLoop]] = {}
    for item in nesting.on_sheet(sheet):
        plate = assembly.plates[item]
        pt = plate.type
        if pt not in loops_of:
            loops = bulge_loops(filleted[pt].outline, assembly.spec.curve_tolerance)
            loops_of[pt] = cut_order(offset_bulge_loops(loops, 0.5 * kerf) if kerf > 0 else loops)
        place = nesting.placements[item]
        for lp in loops_of[pt]:
            V = place.apply(lp.V)
            if segments:
                add_bulge_segments(msp, V, lp.bulges, {"layer": CUT_LAYER})
                continue
            msp.add_lwpolyline([(float(x), float(y), float(b)) for (x, y), b in zip(V, lp.bulges, strict=True)],
                               format="xyb", close=True, dxfattribs={"layer": CUT_LAYER})
        deg = math.degrees(place.angle)
        # [] where no label fits the interface triangles (a depth-3 plate's are a quarter of depth 2's): the plate
        # is cut unlabelled, as the nets and the BOM still name it
        spots = edge_label_spots(pt, assembly.plate_edge, chars) or []
        for (joint, own, ang, h), label in zip(spots, plate.edge_labels if spots else [], strict=True):
            for text, pos in ((label, joint), (plate.label, own)):
                if not text or pos is None:
                    continue
                q = place.apply(pos[None])[0]
                placed = label_at(text, q, deg + math.degrees(ang), h)
                msp.add_text(text, height=h, rotation=placed.angle,
                             dxfattribs={"layer": ENGRAVE_LAYER, "insert": placed.start})
    set_extents(doc)
    return doc


def write_sheets(assembly: Assembly, nesting: Nesting, folder: os.PathLike[str] | str,
                 filleted: dict[PlateType, FilletedPattern], timestamp: str | None = None) -> list[str]:
    """Write ``sheet-01.dxf`` … into ``folder``; returns the file names. With ``timestamp`` (ISO 8601) each
    file is byte-reproducible (:func:`fabpat.exchange.dxf.stamp_document`, its GUIDs from the spec's name
    and the file's). Raises :class:`ExportError` (a bad ``timestamp``; an OSError, naming the file)."""
    from fabpat.exchange.dxf import save_document

    names = []
    digits = max(2, len(str(nesting.n_sheets)))
    for s in range(nesting.n_sheets):
        name = f"sheet-{s + 1:0{digits}d}.dxf"
        # assemble names its --out folder and a full disk (save_document: writer_failed)
        save_document(sheet_document(assembly, nesting, s, filleted), os.path.join(folder, name), timestamp,
                      f"{assembly.spec.name}/sheets/{name}")
        names.append(name)
    return names


def read_sheet(path: os.PathLike[str] | str, tolerance: float = 0.05) -> tuple[list[NDArray[np.float64]], list[str]]:
    """Re-read a sheet DXF: (closed CUT loops flattened within ``tolerance`` mm, ENGRAVE texts)."""
    import ezdxf
    from ezdxf import path as dxfpath

    doc = ezdxf.readfile(os.fspath(path))
    loops, texts = [], []
    for e in doc.modelspace():
        layer = e.dxf.layer
        if e.dxftype() == "LWPOLYLINE" and layer == "CUT":
            pts = np.array([(v.x, v.y) for v in dxfpath.make_path(e).flattening(tolerance)])
            loops.append(pts[:-1] if np.allclose(pts[0], pts[-1]) else pts)
        elif e.dxftype() == "TEXT" and layer == "ENGRAVE":
            texts.append(e.dxf.text)
    return loops, texts
