"""The exact B-rep: outline → face → solid (OpenCASCADE's own errors raised as GeometryError), and the
hand-made outlines the exchange tests share.

The outlines here have closed-form areas and perimeters computed in this file, independently of
fabpat.geometry.curves / fabpat.geometry.outline, so every writer's read-back is checked against numbers that no
fabpat code produced.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.exchange import cad
from fabpat.exchange.threemf import triangulate
from fabpat.geometry.outline import Line, Loop, Outline, RationalQuad

# ------------------------------------------------------------------------------ shared test shapes

BOWTIE_W = 0.2  # the paper's interface weight


def rounded_square(half: float = 10.0, r: float = 3.0) -> Outline:
    """Square of side 2·half, corners rounded by quarter circles of radius r (w = cos 45°)."""
    w = math.cos(math.pi / 4)
    s = half
    return Outline(Loop([
        Line((-s + r, -s), (s - r, -s)), RationalQuad((s - r, -s), (s, -s), (s, -s + r), w),
        Line((s, -s + r), (s, s - r)), RationalQuad((s, s - r), (s, s), (s - r, s), w),
        Line((s - r, s), (-s + r, s)), RationalQuad((-s + r, s), (-s, s), (-s, s - r), w),
        Line((-s, s - r), (-s, -s + r)), RationalQuad((-s, -s + r), (-s, -s), (-s + r, -s), w),
    ]))


def rounded_square_area(half: float = 10.0, r: float = 3.0) -> float:
    return (2 * half) ** 2 - (4 - math.pi) * r**2


def rounded_square_perimeter(half: float = 10.0, r: float = 3.0) -> float:
    return 4 * (2 * half - 2 * r) + 2 * math.pi * r


def hexagon_with_hole(a: float = 36.0, h: float = 10.0) -> Outline:
    """Regular hexagon of edge a (CCW) with a centred square hole of side h (CW)."""
    P = [(a * math.cos(k * math.pi / 3), a * math.sin(k * math.pi / 3)) for k in range(6)]
    Q = [(-h / 2, -h / 2), (-h / 2, h / 2), (h / 2, h / 2), (h / 2, -h / 2)]
    return Outline(Loop([Line(P[k], P[(k + 1) % 6]) for k in range(6)]),
                   [Loop([Line(Q[k], Q[(k + 1) % 4]) for k in range(4)])])


def hexagon_with_hole_area(a: float = 36.0, h: float = 10.0) -> float:
    return 1.5 * math.sqrt(3) * a * a - h * h


def bowtie(a: float = 4.5, w: float = BOWTIE_W) -> Outline:
    """Two equilateral triangles (side 2a) touching apex to apex at the origin, bridged on both
    sides by a bow-tie arc P0 = mid-side, P1 = apex (weight w), P2 = mirror of P0 — the interface
    joint of the notes. With a = 4.5 mm and w = 0.2 the neck is 2a/(1 + w) = 7.5 mm … at the apex
    the arcs pass a/(1 + w) = 3.75 mm from it on each side."""
    h = a * math.sqrt(3)
    return Outline(Loop([
        Line((-a, -h), (a, -h)), Line((a, -h), (a / 2, -h / 2)),
        RationalQuad((a / 2, -h / 2), (0, 0), (a / 2, h / 2), w),
        Line((a / 2, h / 2), (a, h)), Line((a, h), (-a, h)), Line((-a, h), (-a / 2, h / 2)),
        RationalQuad((-a / 2, h / 2), (0, 0), (-a / 2, -h / 2), w),
        Line((-a / 2, -h / 2), (-a, -h)),
    ]))


def conic_segment_ratio(w: float) -> float:
    """Area between a (1, w, 1) conic arc and its chord over its control triangle's area (w < 1).

    Every such arc is an affine image of a circular arc of half-angle α = arccos w; the circular
    segment R²(α − sin α cos α) over the triangle R² sin³α / cos α.
    """
    alpha = math.acos(w)
    return (alpha - math.sin(alpha) * math.cos(alpha)) * math.cos(alpha) / math.sin(alpha) ** 3


def bowtie_area(a: float = 4.5, w: float = BOWTIE_W) -> float:
    h = a * math.sqrt(3)
    chord_polygon = np.array([(-a, -h), (a, -h), (a / 2, -h / 2), (a / 2, h / 2), (a, h), (-a, h),
                              (-a / 2, h / 2), (-a / 2, -h / 2)])
    x, y = chord_polygon.T
    polygon = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    triangle = 0.5 * h * (a / 2)  # control triangle (P0, apex, P2): base h, height a/2
    return polygon - 2 * triangle * conic_segment_ratio(w)  # both arcs bend into the material


SHAPES = {
    "rounded_square": (rounded_square, rounded_square_area),
    "hexagon_with_hole": (hexagon_with_hole, hexagon_with_hole_area),
    "bowtie": (bowtie, bowtie_area),
}


def edge_curves(shape: object) -> list[object]:
    """``BRepAdaptor_Curve`` of every edge of an OCP shape (or build123d shape)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    ex = TopExp_Explorer(getattr(shape, "wrapped", shape), TopAbs_EDGE)
    while ex.More():
        out.append(BRepAdaptor_Curve(TopoDS.Edge(ex.Current())))
        ex.Next()
    return out


def curve_weights(c: object) -> list[float]:
    """Weights of a Bézier/B-spline edge curve ([] for other curve types)."""
    from OCP.GeomAbs import GeomAbs_CurveType as T

    kind = c.GetType()  # type: ignore[attr-defined]
    if kind == T.GeomAbs_BezierCurve:
        g = c.Bezier()  # type: ignore[attr-defined]
    elif kind == T.GeomAbs_BSplineCurve:
        g = c.BSpline()  # type: ignore[attr-defined]
    else:
        return []
    return [g.Weight(i) for i in range(1, g.NbPoles() + 1)] if g.IsRational() else [1.0] * g.NbPoles()


# ------------------------------------------------------------------------------------------ tests


def test_ocp_and_build123d_import_smoke() -> None:
    """A clobbered OCP (e.g. cadquery's wheel installed over build123d's) must fail loudly here."""
    import build123d
    from OCP.BRepCheck import BRepCheck_Analyzer  # noqa: F401
    from OCP.STEPCAFControl import STEPCAFControl_Writer  # noqa: F401

    assert build123d.__version__ == "0.13.0"
    box = build123d.Box(1, 2, 3)
    assert box.is_valid and box.volume == pytest.approx(6.0, rel=1e-12)


@pytest.mark.parametrize("name", list(SHAPES))
def test_closed_form_areas_agree_with_exact_outline(name: str) -> None:
    make, area = SHAPES[name]
    assert make().area == pytest.approx(area(), rel=1e-12)


@pytest.mark.parametrize("name", list(SHAPES))
def test_solid_is_valid_with_exact_volume(name: str) -> None:
    make, area = SHAPES[name]
    solid = cad.make_solid(make(), 2.0)
    cad.check_valid(solid)
    assert cad.volume(solid) == pytest.approx(2.0 * area(), rel=1e-9)


def test_face_edges_are_exact_lines_and_rational_beziers() -> None:
    from OCP.GeomAbs import GeomAbs_CurveType as T

    face = cad.make_face(bowtie())
    curves = edge_curves(face)
    kinds = sorted(c.GetType().name for c in curves)  # type: ignore[attr-defined]
    assert kinds == ["GeomAbs_BezierCurve"] * 2 + ["GeomAbs_Line"] * 6  # one edge per segment
    beziers = [c for c in curves if c.GetType() == T.GeomAbs_BezierCurve]  # type: ignore[attr-defined]
    assert all(curve_weights(c) == pytest.approx([1.0, BOWTIE_W, 1.0]) for c in beziers)


def test_same_geometry_as_build123d_make_bezier() -> None:
    from build123d import Edge

    seg = bowtie().outer.segments[2]
    ours = cad.outline_face(bowtie()).edges()
    ref = Edge.make_bezier(*[(*p, 0.0) for p in seg.control_points], weights=[1.0, seg.w, 1.0])
    match = [e for e in ours if (e.center() - ref.center()).length < 1e-9]
    assert len(match) == 1
    for t in np.linspace(0, 1, 7):
        assert (match[0].position_at(t) - ref.position_at(t)).length < 1e-9


def test_pattern_solid_build123d_wrapper() -> None:
    solid = cad.pattern_solid(rounded_square(), 3.0, name="fabpat test")
    assert solid.is_valid and solid.label == "fabpat test"
    bb = solid.bounding_box()
    assert (bb.min.Z, bb.max.Z) == pytest.approx((0.0, 3.0), abs=1e-6)
    assert cad.volume(solid) == pytest.approx(3.0 * rounded_square_area(), rel=1e-9)


def test_loop_orientation_does_not_matter() -> None:
    o = hexagon_with_hole()
    flipped = Outline(o.outer.reversed(), [h.reversed() for h in o.holes])
    assert cad.volume(cad.make_solid(flipped)) == pytest.approx(2 * hexagon_with_hole_area(), rel=1e-12)


def test_bad_outlines_raise_geometry_error() -> None:
    square = [Line((0, 0), (1, 0)), Line((1, 0), (1, 1)), Line((1, 1), (0, 1)), Line((0, 1), (0, 0))]
    with pytest.raises(GeometryError, match="not closed"):
        cad.make_face(Outline(Loop(square[:3])))
    with pytest.raises(GeometryError, match="thickness"):
        cad.make_solid(Outline(Loop(square)), 0.0)
    figure8 = [Line((0, 0), (1, 1)), Line((1, 1), (1, 0)), Line((1, 0), (0, 1)), Line((0, 1), (0, 0))]
    with pytest.raises(GeometryError, match="valid"):
        cad.make_solid(Outline(Loop(figure8)))


def test_support_arc_keeps_configured_weight() -> None:
    """An outline segment that is half of a bow-tie arc is built on the whole arc (weights 1, w, 1)."""
    from fabpat.geometry.curves import split_quad

    full = RationalQuad((4, -4), (0, 0), (4, 4), BOWTIE_W)
    (PL, wl), (PR, wr) = split_quad(full.control_points, full.w)
    half = RationalQuad(*PL, wl)  # (4, -4) → the arc's apex, standard weight √((1 + w)/2)
    apex = PL[2]
    o = Outline(Loop([half, Line(apex, (10, apex[1])), Line((10, apex[1]), (10, -4)), Line((10, -4), (4, -4))]))
    plain = cad.make_solid(o)
    supported = cad.make_solid(o, support=[full])
    assert cad.volume(supported) == pytest.approx(cad.volume(plain), rel=1e-9)
    weights = [w for c in edge_curves(supported) for w in curve_weights(c)]
    assert BOWTIE_W in weights and wl == pytest.approx(math.sqrt(0.6))


def test_triangulation_is_closed_and_within_tolerance() -> None:
    trimesh = pytest.importorskip("trimesh")
    V, F = triangulate(cad.make_solid(rounded_square()), 0.01)
    m = trimesh.Trimesh(V, F, process=False)
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    exact = 2 * rounded_square_area()
    # Chords inside convex arcs: the mesh is smaller, by at most arc length × tolerance × thickness.
    assert 0 < exact - m.volume <= 2 * math.pi * 3.0 * 0.01 * 2.0


@pytest.mark.parametrize("pattern_id, sides", [("0x0488", 6), ("0xd488", 5)])
def test_library_pattern_solid_volume(pattern_id: str, sides: int) -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import enumerate_library

    fp = fillet_pattern(enumerate_library(sides, 2).pattern(pattern_id), BOWTIE_W)
    support = [a for pair in fp.interface_arcs for a in pair]
    solid = cad.make_solid(fp.outline, 2.0, support)
    assert cad.volume(solid) == pytest.approx(2.0 * fp.outline.area, rel=1e-6)
    on_support = [c for c in edge_curves(solid) if BOWTIE_W in curve_weights(c)]
    assert len(on_support) >= 2 * sides  # every interface half, on top and bottom faces


def test_occt_errors_become_geometry_errors() -> None:
    from fabpat.exchange.cad import make_solid, mesh
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    outline = fillet_pattern(get_pattern("0x2d88")).outline
    with pytest.raises(GeometryError, match="OpenCASCADE"):
        make_solid(outline, 1e-9)  # Standard_ConstructionError inside OCCT
    solid = make_solid(outline, 2.0)
    with pytest.raises(GeometryError, match="Standard_NumericError"):
        mesh(solid, 1e-9)
