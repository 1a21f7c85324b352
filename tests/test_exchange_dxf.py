"""DXF read back with ezdxf: audit, layers, units, closed loops, enclosed areas, extents and labels.

Areas of bulge polylines are computed here from the bulges (chord polygon + exact circular
segments), of ARC entities from their centre, radius and angles, and of SPLINE entities by an
independent NURBS evaluation of their control points, weights and knots (scipy's B-spline in
homogeneous coordinates, Gauss–Legendre quadrature per knot span). Loops of LINE/ARC/SPLINE
entities are chained here by their end points. Nothing below uses fabpat to read.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest

from fabpat.errors import ExportError
from fabpat.exchange.dxf import write_dxf
from fabpat.geometry.outline import Line
from tests.test_cad import BOWTIE_W, SHAPES, bowtie, bowtie_area, hexagon_with_hole, rounded_square

ezdxf = pytest.importorskip("ezdxf")
TOL = 0.01


def bulge_area(points: list[tuple[float, float, float]]) -> float:
    """Signed area of a closed polyline with bulges: shoelace + Σ sign(b) R²/2 (θ − sin θ)."""
    P = np.array([(x, y) for x, y, _ in points])
    b = np.array([bb for _, _, bb in points])
    E = np.roll(P, -1, axis=0)
    area = 0.5 * float(np.sum(P[:, 0] * E[:, 1] - P[:, 1] * E[:, 0]))
    for (s, e, bulge) in zip(P, E, b, strict=True):
        if bulge == 0:
            continue
        theta = 4 * math.atan(abs(bulge))
        R = math.dist(s, e) / (2 * math.sin(theta / 2))
        area += math.copysign(0.5 * R * R * (theta - math.sin(theta)), bulge)
    return area


def cut_loops(doc) -> list[list[tuple[float, float, float]]]:  # noqa: ANN001
    """(x, y, bulge) of every closed polyline on layer CUT (LWPOLYLINE or R12 POLYLINE)."""
    loops = []
    for e in doc.modelspace().query("LWPOLYLINE POLYLINE"):
        assert e.dxf.layer == "CUT" and (e.closed if e.dxftype() == "LWPOLYLINE" else e.is_closed)
        if e.dxftype() == "LWPOLYLINE":
            loops.append([tuple(p) for p in e.get_points("xyb")])
        else:
            loops.append([(v.dxf.location.x, v.dxf.location.y, v.dxf.bulge) for v in e.vertices])
    return loops


def read(path: Path):  # noqa: ANN201
    doc = ezdxf.readfile(path)
    auditor = doc.audit()
    assert not auditor.has_errors, [str(e) for e in auditor.errors]
    assert {"CUT", "ENGRAVE"} <= {layer.dxf.name for layer in doc.layers}
    return doc


# -- independent readers of LINE / ARC / SPLINE entities --------------------------------------------


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


Piece = tuple[np.ndarray, np.ndarray, float]  # start, end, ∫ (x dy − y dx) / 2 from start to end


def spline_piece(e) -> Piece:  # noqa: ANN001
    """Start, end and exact area term of a SPLINE from its DXF data alone (weights and knots)."""
    from scipy.interpolate import BSpline

    k = e.dxf.degree
    P = np.array(e.control_points)[:, :2]
    W = np.array(e.weights) if len(e.weights) else np.ones(len(P))
    t = np.array(e.knots)
    H = BSpline(t, np.column_stack([P * W[:, None], W]), k)
    dH = H.derivative()
    x, wq = np.polynomial.legendre.leggauss(24)
    total = 0.0
    spans = np.unique(t[k:len(t) - k])
    for a, b in zip(spans[:-1], spans[1:], strict=True):
        u = 0.5 * (b - a) * x + 0.5 * (a + b)
        h, dh = H(u), dH(u)
        # C = h[:2] / h[2]; x y' − y x' = (hx dhy − hy dhx) / h3² (the h3' terms cancel)
        total += 0.5 * (b - a) * float(np.sum(wq * 0.5 * (h[:, 0] * dh[:, 1] - h[:, 1] * dh[:, 0]) / h[:, 2] ** 2))
    ends = H(np.array([t[k], t[-k - 1]]))
    return ends[0, :2] / ends[0, 2], ends[1, :2] / ends[1, 2], total


def arc_piece(e) -> Piece:  # noqa: ANN001
    """A DXF ARC runs counter-clockwise from start_angle to end_angle (degrees)."""
    c, r = np.array(e.dxf.center)[:2], e.dxf.radius
    a0, a1 = math.radians(e.dxf.start_angle), math.radians(e.dxf.end_angle)
    sweep = (a1 - a0) % (2 * math.pi)
    s = c + r * np.array([math.cos(a0), math.sin(a0)])
    t = c + r * np.array([math.cos(a0 + sweep), math.sin(a0 + sweep)])
    return s, t, 0.5 * (float(cross(c, t - s)) + r * r * sweep)


def line_piece(e) -> Piece:  # noqa: ANN001
    s, t = np.array(e.dxf.start)[:2], np.array(e.dxf.end)[:2]
    return s, t, 0.5 * float(cross(s, t))


def entity_pieces(doc) -> list[Piece]:  # noqa: ANN001
    out = []
    for e in doc.modelspace().query("LINE ARC SPLINE"):
        assert e.dxf.layer == "CUT"
        out.append({"LINE": line_piece, "ARC": arc_piece, "SPLINE": spline_piece}[e.dxftype()](e))
    return out


def chain(pieces: list[Piece], directed: bool, atol: float = 1e-6) -> list[float]:
    """Signed areas of the closed loops the pieces form, joined end to start (``directed``) or
    either way round (ARCs always run counter-clockwise, so a clockwise hole uses them reversed)."""
    S = np.array([p[0] for p in pieces])
    E = np.array([p[1] for p in pieces])
    used = np.zeros(len(pieces), dtype=bool)
    areas = []
    while not used.all():
        i = int(np.argmin(used))
        used[i] = True
        s0, end, area = pieces[i]
        while not np.allclose(end, s0, atol=atol):
            forward = np.flatnonzero(~used & np.all(np.abs(S - end) <= atol, axis=1))
            backward = [] if directed else np.flatnonzero(~used & np.all(np.abs(E - end) <= atol, axis=1))
            assert len(forward) or len(backward), f"open chain at {end}"
            if len(forward):
                j = int(forward[0])
                end, area = pieces[j][1], area + pieces[j][2]
            else:
                j = int(backward[0])
                end, area = pieces[j][0], area - pieces[j][2]
            used[j] = True
        areas.append(area)
    return areas


def solid_area(areas: list[float]) -> float:
    a = sorted((abs(x) for x in areas), reverse=True)
    return a[0] - sum(a[1:])


# -- tests ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("curves", ["arcs", "lines"])
@pytest.mark.parametrize("name", list(SHAPES))
def test_polyline_entities_enclose_the_outline_area(tmp_path: Path, name: str, curves: str) -> None:
    make, area = SHAPES[name]
    outline = make()
    path = write_dxf(outline, tmp_path / "p.dxf", "0x0488", curves=curves, tolerance=TOL)
    doc = read(path)
    assert doc.dxfversion == "AC1024" and doc.header["$INSUNITS"] == 4  # R2010, millimetres
    loops = cut_loops(doc)
    assert len(loops) == len(outline.loops) and not doc.modelspace().query("LINE ARC")
    if curves == "lines":
        assert all(b == 0 for lp in loops for _, _, b in lp)
    areas = [bulge_area(lp) for lp in loops]
    assert areas[-1] > 0 and all(a < 0 for a in areas[:-1])  # holes CW first (cut order), then the outer CCW
    # Every point of the written curves lies within TOL of the outline: |ΔA| ≤ perimeter × TOL.
    assert abs(sum(areas) - area()) <= outline.perimeter * TOL
    (text,) = doc.modelspace().query("TEXT")
    assert text.dxf.text == "0x0488" and text.dxf.layer == "ENGRAVE"


@pytest.mark.parametrize("version", ["R2010", "R12"])
@pytest.mark.parametrize("curves", ["arcs", "lines"])
@pytest.mark.parametrize("name", list(SHAPES))
def test_line_and_arc_entities(tmp_path: Path, name: str, curves: str, version: str) -> None:
    """LINE + ARC (what OpenSCAD and Inkscape read): R12's only choice, R2010's with entities="segments"."""
    make, area = SHAPES[name]
    outline = make()
    options = {"entities": "segments"} if version == "R2010" else {}
    doc = read(write_dxf(outline, tmp_path / "s.dxf", curves=curves, tolerance=TOL, dxf_version=version, **options))
    assert doc.dxfversion == ("AC1009" if version == "R12" else "AC1024")
    msp = doc.modelspace()
    assert not msp.query("LWPOLYLINE POLYLINE SPLINE")
    curved = any(not isinstance(s, Line) for lp in outline.loops for s in lp.segments)
    assert (len(msp.query("ARC")) > 0) == (curves == "arcs" and curved)
    areas = chain(entity_pieces(doc), directed=False)
    assert len(areas) == len(outline.loops)
    assert abs(solid_area(areas) - area()) <= outline.perimeter * TOL


def test_circular_corners_are_written_as_exact_arcs(tmp_path: Path) -> None:
    doc = read(write_dxf(rounded_square(), tmp_path / "r.dxf"))
    (loop,) = cut_loops(doc)
    assert len(loop) == 8 and sorted(b for *_, b in loop)[-4:] == pytest.approx([math.tan(math.pi / 8)] * 4)
    assert bulge_area(loop) == pytest.approx(400 - (4 - math.pi) * 9, rel=1e-12)
    doc = read(write_dxf(rounded_square(), tmp_path / "a.dxf", dxf_version="R12"))
    assert [e.dxf.radius for e in doc.modelspace().query("ARC")] == pytest.approx([3.0] * 4, rel=1e-12)
    assert solid_area(chain(entity_pieces(doc), directed=False)) == pytest.approx(400 - (4 - math.pi) * 9, rel=1e-12)


@pytest.mark.parametrize("name", list(SHAPES))
def test_spline_mode_writes_exact_degree_two_pieces(tmp_path: Path, name: str) -> None:
    make, area = SHAPES[name]
    outline = make()
    doc = read(write_dxf(outline, tmp_path / "s.dxf", "id", curves="spline"))
    msp = doc.modelspace()
    segs = [s for lp in outline.loops for s in lp.segments]
    curved = [s for s in segs if not (isinstance(s, Line) or s.is_straight)]
    splines = msp.query("SPLINE")
    # every straight segment one LINE; every arc one SPLINE or more (split for readers that ignore weights)
    assert len(splines) >= len(curved) and len(msp.query("LINE")) == len(segs) - len(curved)
    assert not msp.query("LWPOLYLINE ARC")
    for e in splines:
        assert e.dxf.degree == 2 and len(e.control_points) == 3 and list(e.knots) == [0, 0, 0, 1, 1, 1]
        assert e.dxf.flags & 4  # rational
        assert e.weights[0] == e.weights[2] == 1.0
    # Pieces run head to tail; the area comes from the SPLINE data alone.
    areas = chain(entity_pieces(doc), directed=True)
    assert len(areas) == len(outline.loops) and areas[-1] > 0 and all(a < 0 for a in areas[:-1])  # holes first
    assert solid_area(areas) == pytest.approx(area(), rel=1e-6)


def test_spline_mode_splits_an_arc_into_its_own_halves(tmp_path: Path) -> None:
    """The bow-tie's w = 0.2 arcs, 4.5 mm across, read without weights 0.3 mm off: each is written as its
    halves, quarters, … in standard form, middle weights √((1 + w)/2) per split, ends on the arc's ends."""
    outline = bowtie()
    doc = read(write_dxf(outline, tmp_path / "s.dxf", "id", curves="spline", origin="centre"))
    splines = doc.modelspace().query("SPLINE")
    curved = [s for s in outline.outer.segments if not isinstance(s, Line)]
    assert len(splines) > len(curved)
    chain_w = [BOWTIE_W]
    for _ in range(12):
        chain_w.append(math.sqrt((1 + chain_w[-1]) / 2))
    for e in splines:
        assert min(abs(e.weights[1] - w) for w in chain_w) < 1e-12
    ends = {tuple(np.round(np.array(e.control_points)[i, :2], 9)) for e in splines for i in (0, 2)}
    for seg in curved:  # each arc's two ends are ends of its pieces
        assert {tuple(np.round(seg.start, 9)), tuple(np.round(seg.end, 9))} <= ends
    assert solid_area(chain(entity_pieces(doc), directed=True)) == pytest.approx(bowtie_area(), rel=1e-9)


@pytest.mark.parametrize("curves", ["arcs", "lines", "spline"])
def test_kerf_grows_area_by_perimeter_times_half_kerf(tmp_path: Path, curves: str) -> None:
    kerf = 0.2
    outline = hexagon_with_hole()
    doc = read(write_dxf(outline, tmp_path / "k.dxf", curves=curves, kerf=kerf))
    if curves == "spline":
        msp = doc.modelspace()
        assert all(e.dxf.degree <= 3 for e in msp.query("SPLINE"))
        total = solid_area(chain(entity_pieces(doc), directed=False))
    else:
        total = sum(bulge_area(lp) for lp in cut_loops(doc))
    d = kerf / 2
    # Outer hexagon: + P_out·d + π d² (six arc joins of radius d); square hole (10 mm) shrinks to
    # (10 − 2d)²: together A + P·d + (π − 4) d², exactly.
    exact = outline.area + outline.perimeter * d + (math.pi - 4) * d * d
    bound = {"arcs": 1e-9, "lines": outline.perimeter * TOL, "spline": 1e-9}[curves]
    assert total == pytest.approx(exact, abs=bound)


def test_spline_kerf_on_curves_keeps_degree_at_most_three(tmp_path: Path) -> None:
    d = 0.05
    outline = bowtie()
    doc = read(write_dxf(outline, tmp_path / "b.dxf", curves="spline", kerf=2 * d))
    splines = doc.modelspace().query("SPLINE")
    assert splines and all(e.dxf.degree <= 3 for e in splines)
    P = outline.perimeter
    total = solid_area(chain(entity_pieces(doc), directed=True))
    # ≈ P·d; corners add or remove O(d²) and the cubic fit at most P·TOL.
    assert total - bowtie_area() == pytest.approx(P * d, abs=P * TOL + 8 * d * d)


def test_kerf_on_curved_outline(tmp_path: Path) -> None:
    d = 0.05
    doc = read(write_dxf(bowtie(), tmp_path / "b.dxf", kerf=2 * d))
    (loop,) = cut_loops(doc)
    P = bowtie().perimeter
    # ≈ P·d; corners add or remove O(d²) and the arc fit at most P·TOL.
    assert bulge_area(loop) - bowtie_area() == pytest.approx(P * d, abs=P * TOL + 8 * d * d)


def sample_points(doc) -> np.ndarray:  # noqa: ANN001
    """Points on every CUT entity: vertices, arc and spline samples (ezdxf's own flattening)."""
    from ezdxf import path as dxfpath

    pts = []
    for e in doc.modelspace().query("LINE ARC SPLINE LWPOLYLINE POLYLINE"):
        pts += [(v.x, v.y) for v in dxfpath.make_path(e).flattening(0.001)]
    return np.array(pts)


@pytest.mark.parametrize("options", [{}, {"dxf_version": "R12"}, {"curves": "spline"},
                                     {"curves": "spline", "kerf": 0.2}, {"entities": "segments", "origin": "centre"}])
def test_header_extents_bound_the_entities(tmp_path: Path, options: dict) -> None:
    doc = read(write_dxf(hexagon_with_hole(), tmp_path / "e.dxf", "0x0488", **options))
    lo, hi = np.array(doc.header["$EXTMIN"])[:2], np.array(doc.header["$EXTMAX"])[:2]
    P = sample_points(doc)
    assert np.all(P >= lo - 1e-6) and np.all(P <= hi + 1e-6)
    # Tight: the label lies on the part, so the extents are the cut path's box.
    assert np.allclose(P.min(axis=0), lo, atol=0.01) and np.allclose(P.max(axis=0), hi, atol=0.01)
    (text,) = doc.modelspace().query("TEXT")
    assert np.all(np.array(text.dxf.insert)[:2] >= lo) and np.all(np.array(text.dxf.insert)[:2] <= hi)


@pytest.mark.parametrize("curves", ["arcs", "spline"])
def test_origin_corner_and_centre(tmp_path: Path, curves: str) -> None:
    outline, kerf = hexagon_with_hole(), 0.2
    corner = sample_points(read(write_dxf(outline, tmp_path / "c.dxf", curves=curves, kerf=kerf)))
    assert corner.min(axis=0) == pytest.approx([1.0, 1.0], abs=TOL)  # 1 mm from (0, 0): on any laser bed
    centre = sample_points(read(write_dxf(outline, tmp_path / "m.dxf", curves=curves, kerf=kerf, origin="centre")))
    lo, hi = outline.bbox
    assert centre.min(axis=0) == pytest.approx(lo - kerf / 2, abs=TOL)
    assert centre.max(axis=0) == pytest.approx(hi + kerf / 2, abs=TOL)


def material_polygons(doc) -> list[np.ndarray]:  # noqa: ANN001
    """The CUT loops as closed polygons (ezdxf flattening within 1 µm), largest first."""
    from ezdxf import path as dxfpath

    paths = [dxfpath.make_path(e) for e in doc.modelspace().query("LWPOLYLINE POLYLINE")]
    polys = [np.array([(v.x, v.y) for v in p.flattening(0.001)]) for p in paths]
    return sorted(polys, key=lambda P: -abs(float(cross(P[:-1], P[1:]).sum())))


def on_material(polys: list[np.ndarray], X: np.ndarray) -> np.ndarray:
    from matplotlib.path import Path as MPath

    inside = MPath(polys[0]).contains_points(X)
    for hole in polys[1:]:
        inside &= ~MPath(hole).contains_points(X)
    return inside


@functools.cache
def library_outline(pattern_id: str, sides: int):  # noqa: ANN201
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import enumerate_library

    return fillet_pattern(enumerate_library(sides, 2).pattern(pattern_id, 36.0), 0.2).outline


@pytest.mark.parametrize(("pattern_id", "sides"), [("0x0488", 6), ("0x2508", 6), ("0x0488", 5), ("0x2d88", 6)])
def test_text_starts_at_its_first_point_on_the_part(tmp_path: Path, pattern_id: str, sides: int) -> None:
    """Readers that ignore TEXT alignment place it by its first point: that point, and the text's box
    as ezdxf measures it, lie on the material — also on lacy parts (0x0488), once labelled below."""
    from ezdxf.tools.text_size import text_size

    doc = read(write_dxf(library_outline(pattern_id, sides), tmp_path / "t.dxf", pattern_id))
    (text,) = doc.modelspace().query("TEXT")
    assert text.dxf.halign == 0 and text.dxf.valign == 0  # left, baseline: the insert is where it starts
    assert 1.0 <= text.dxf.height <= 3.0
    polys = material_polygons(doc)
    size = text_size(text)
    a = math.radians(text.dxf.rotation)
    u, v = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    s = np.array(text.dxf.insert)[:2]
    box = np.array([s, s + size.width * u, s + size.width * u + size.cap_height * v, s + size.cap_height * v])
    assert on_material(polys, s[None])[0]
    assert on_material(polys, box).all()


def test_label_lies_on_the_material_when_it_fits(tmp_path: Path) -> None:
    doc = read(write_dxf(hexagon_with_hole(), tmp_path / "t.dxf", "0x0488", origin="centre"))
    (text,) = doc.modelspace().query("TEXT")
    p = text.dxf.insert
    assert on_material(material_polygons(doc), np.array([[p.x, p.y]]))[0]
    assert text.dxf.height == 3.0  # a solid hexagon has room for the largest label


@pytest.mark.parametrize(
    "options, words",
    [({"curves": "spline", "dxf_version": "R12"}, "R12"), ({"curves": "bezier"}, "curve mode"),
     ({"kerf": -0.1}, "kerf"), ({"tolerance": 0.0}, "tolerance"), ({"dxf_version": "R13"}, "version"),
     ({"entities": "polyline", "dxf_version": "R12"}, "R12"), ({"entities": "blocks"}, "entity mode"),
     ({"curves": "spline", "entities": "polyline"}, "segments"), ({"origin": "middle"}, "origin")],
)
def test_bad_options_raise_and_write_nothing(tmp_path: Path, options: dict[str, object], words: str) -> None:
    with pytest.raises(ExportError, match=words):
        write_dxf(bowtie(), tmp_path / "x.dxf", **options)
    assert list(tmp_path.iterdir()) == []
