"""Kit sheets of the truncated icosahedron read the way a maker's programs read them.

TEXT is placed by its first point (readers that ignore alignment codes), so each label's first
point and its box (ezdxf's own text measurement) must lie on its plate's material, found here
from the CUT loops alone (inside an odd number of loops). The bed outline is on a non-plotting
layer, and ``[sheet] border = false`` leaves it out (OpenSCAD imports every layer as geometry).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fabpat.assembly.kit.build import plan
from fabpat.assembly.kit.sheets import nest_plates, sheet_document
from fabpat.assembly.place.parts import PartLibrary
from fabpat.assembly.spec.load import parse_spec

SPHERE = {
    "tiling": {"kind": "truncated-icosahedron", "edge": 36.0},
    "patterns": {"hexagon": "0x0488", "pentagon": "0x0508"},
    "plates": {"process": "laser"},
    "sheet": {"width": 600.0, "height": 400.0},
}


@pytest.fixture(scope="module")
def sheet():  # noqa: ANN201
    lib = PartLibrary(*plan(parse_spec(SPHERE)))
    asm = lib.assembly
    nesting = nest_plates(asm)
    assert nesting.n_sheets == 1
    return lib, nesting, sheet_document(asm, nesting, 0, lib.filleted)


def cut_polygons(doc) -> list[np.ndarray]:  # noqa: ANN001
    from ezdxf import path as dxfpath

    return [np.array([(v.x, v.y) for v in dxfpath.make_path(e).flattening(0.005)])
            for e in doc.modelspace().query('LWPOLYLINE[layer=="CUT"]')]


def on_material(polys: list[np.ndarray], X: np.ndarray) -> np.ndarray:
    from matplotlib.path import Path as MPath

    count = np.zeros(len(X), dtype=int)
    for P in polys:
        count += MPath(P).contains_points(X)
    return count % 2 == 1


def test_every_label_starts_on_its_plate(sheet) -> None:  # noqa: ANN001
    from ezdxf.tools.text_size import text_size

    _, _, doc = sheet
    polys = cut_polygons(doc)
    texts = doc.modelspace().query("TEXT")
    assert len(texts) == 360  # 180 plate edges × (joint label + plate label)
    for e in texts:
        assert e.dxf.layer == "ENGRAVE" and e.dxf.halign == 0 and e.dxf.valign == 0
        assert e.dxf.height >= 1.0  # fabpat's own minimum (pentagon labels were 0.991 mm)
        s, a, size = np.array(e.dxf.insert)[:2], math.radians(e.dxf.rotation), text_size(e)
        u, v = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        box = np.array([s, s + size.width * u, s + size.width * u + size.cap_height * v, s + size.cap_height * v])
        assert on_material(polys, box).all(), e.dxf.text


def test_bed_outline_is_not_plotted_and_extents_are_set(sheet) -> None:  # noqa: ANN001
    lib, nesting, doc = sheet
    assert doc.layers.get("SHEET").dxf.plot == 0
    (border,) = doc.modelspace().query('LWPOLYLINE[layer=="SHEET"]')
    assert [tuple(p) for p in border.get_points("xy")] == [(0, 0), (600, 0), (600, 400), (0, 400)]
    assert np.array(doc.header["$EXTMIN"])[:2] == pytest.approx([0, 0])
    assert np.array(doc.header["$EXTMAX"])[:2] == pytest.approx([600, 400])
    spec = lib.assembly.spec
    bare = dataclasses.replace(spec, sheet=dataclasses.replace(spec.sheet, border=False))
    doc = sheet_document(dataclasses.replace(lib.assembly, spec=bare), nesting, 0, lib.filleted)
    assert "SHEET" not in doc.layers and not doc.modelspace().query('*[layer=="SHEET"]')
    P = np.vstack(cut_polygons(doc))
    lo, hi = np.array(doc.header["$EXTMIN"])[:2], np.array(doc.header["$EXTMAX"])[:2]
    assert P.min(axis=0) == pytest.approx(lo, abs=0.01) and P.max(axis=0) == pytest.approx(hi, abs=0.01)


STRIP = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
         "patterns": {"groups": ["0x2508", "0x0488"], "group_columns": 1},
         "sheet": {"width": 170.0, "height": 90.0, "dxf_entities": "segments"}}


def line_arc_area(doc) -> float:  # noqa: ANN001
    """Material area (mm²) of the CUT layer's LINE and ARC entities, chained into loops head to tail.

    Each loop's signed area is the shoelace sum of its pieces' chords plus, for each ARC, its circular
    segment (r²/2)(θ − sin θ), positive when the loop runs the arc counter-clockwise (DXF's own sense);
    a loop inside an odd number of other loops is a hole.
    """
    from matplotlib.path import Path as MPath
    from scipy.spatial import cKDTree

    pieces = []  # (start, end, segment area when run start → end, points along the piece)
    for e in doc.modelspace().query('*[layer=="CUT"]'):
        if e.dxftype() == "LINE":
            s, t = np.array(e.dxf.start)[:2], np.array(e.dxf.end)[:2]
            pieces.append((s, t, 0.0, np.array([s, t])))
        else:
            assert e.dxftype() == "ARC", e.dxftype()
            c, r = np.array(e.dxf.center)[:2], e.dxf.radius
            a0, a1 = math.radians(e.dxf.start_angle), math.radians(e.dxf.end_angle)
            th = (a1 - a0) % (2 * math.pi)
            a = np.linspace(a0, a0 + th, 33)
            P = c + r * np.column_stack([np.cos(a), np.sin(a)])
            pieces.append((P[0], P[-1], 0.5 * r * r * (th - math.sin(th)), P))
    ends = np.array([p[k] for p in pieces for k in (0, 1)])
    tree = cKDTree(ends)
    used = np.zeros(len(pieces), dtype=bool)
    loops = []
    for first in range(len(pieces)):
        if used[first]:
            continue
        used[first] = True
        s, t, seg, P = pieces[first]
        area, pts, start, here = 0.5 * (s[0] * t[1] - s[1] * t[0]) + seg, [P], s, t
        while np.linalg.norm(here - start) > 1e-6:
            (j,) = [j for j in tree.query_ball_point(here, 1e-6) if not used[j // 2]]
            used[j // 2] = True
            s, t, seg, P = pieces[j // 2]
            if j % 2:  # run backwards
                s, t, seg, P = t, s, -seg, P[::-1]
            area += 0.5 * (s[0] * t[1] - s[1] * t[0]) + seg
            pts.append(P)
            here = t
        loops.append((abs(area), np.vstack(pts)))
    total = 0.0
    for i, (a, P) in enumerate(loops):
        depth = sum(MPath(Q).contains_point(P[0]) for k, (_, Q) in enumerate(loops) if k != i)
        total += -a if depth % 2 else a
    return total


def test_segment_sheets_are_line_and_arc_with_the_exact_area() -> None:
    lib = PartLibrary(*plan(parse_spec(STRIP)))
    asm = lib.assembly
    assert asm.spec.sheet.dxf_entities == "segments"
    nesting = nest_plates(asm)
    doc = sheet_document(asm, nesting, 0, lib.filleted)
    kinds = {e.dxftype() for e in doc.modelspace().query('*[layer=="CUT"]')}
    assert kinds == {"LINE", "ARC"}
    assert doc.modelspace().query("TEXT")  # labels as before
    outlines = [lib.filleted[asm.plates[i].type].outline for i in nesting.on_sheet(0)]
    assert len(outlines) == 2
    exact = sum(o.area for o in outlines)
    slack = sum(o.perimeter for o in outlines) * asm.spec.curve_tolerance
    assert abs(line_arc_area(doc) - exact) <= slack, (line_arc_area(doc), exact, slack)


def test_sheet_dxf_entities_key() -> None:
    from fabpat.errors import SpecError

    spec = {k: v for k, v in STRIP.items() if k != "sheet"} | {"sheet": {"width": 170.0, "height": 90.0}}
    assert parse_spec(spec).sheet.dxf_entities == "polyline"
    with pytest.raises(SpecError, match="sheet.dxf_entities .*polyline, segments"):
        parse_spec(spec | {"sheet": {"width": 170.0, "height": 90.0, "dxf_entities": "lines"}})
