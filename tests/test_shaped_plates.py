"""Shaped plates: a pattern in its face's own polygon (fabpat.geometry.shaped)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.geometry.fillet import fillet_pattern
from fabpat.geometry.outline import Line, Outline, RationalQuad
from fabpat.geometry.shaped import MAX_IRREGULARITY, ShapedPattern, irregularity, shape_pattern
from fabpat.patterns.lattice import polygon_vertices
from fabpat.patterns.library import pattern
from fabpat.patterns.variation import Variation

W = 0.2
# An affine image of the regular hexagon (stretched 12 % along a tilted axis, sheared), then moved:
# 5.4 % edge and 5.6° angle deviation, and no circumcircle, so the interface points do slide.
AFFINE = np.array([[1.10, 0.09], [0.02, 0.95]])
HEXAGON = polygon_vertices(6, 36.0) @ AFFINE.T + np.array([4.0, -3.0])


def _edges(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Midpoints, unit tangents and lengths of a polygon's edges."""
    E = np.roll(P, -1, axis=0) - P
    L = np.hypot(E[:, 0], E[:, 1])
    return (P + np.roll(P, -1, axis=0)) / 2, E / L[:, None], L


@pytest.fixture(scope="module")
def shaped() -> ShapedPattern:
    return shape_pattern(pattern("0x0488"), HEXAGON, W)


def _same_outline(a: Outline, b: Outline) -> float:
    """Largest difference (mm, or in a weight) between two outlines with the same pieces in the same order."""
    worst = 0.0
    for la, lb in zip(a.loops, b.loops, strict=True):
        assert len(la.segments) == len(lb.segments)
        for x, y in zip(la.segments, lb.segments, strict=True):
            assert type(x) is type(y)
            if isinstance(x, Line):
                worst = max(worst, np.abs(x.p0 - y.p0).max(), np.abs(x.p1 - y.p1).max())
            else:
                worst = max(worst, np.abs(x.control_points - y.control_points).max(), abs(x.w - y.w))
    return float(worst)


@pytest.mark.parametrize("pattern_id, sides", [("0x0488", 6), ("0x0688", 6), ("0x0488", 4), ("0xd488", 5)])
def test_the_regular_polygon_gives_the_regular_outline(pattern_id: str, sides: int) -> None:
    p = pattern(pattern_id, sides=sides)
    regular = fillet_pattern(p, W)
    s = shape_pattern(p, polygon_vertices(sides, p.edge), W)
    assert _same_outline(regular.outline, s.outline) <= 1e-12
    assert np.abs(s.interface_segments - regular.interface_segments).max() <= 1e-12
    assert np.abs(s.centre).max() <= 1e-12
    assert s.edge == pytest.approx(36.0, abs=1e-12) and s.irregularity == pytest.approx((0.0, 0.0), abs=1e-12)


def test_every_curve_is_a_rational_quadratic_with_the_fillets_weights(shaped: ShapedPattern) -> None:
    segs = [s for loop in shaped.outline.loops for s in loop.segments]
    assert all(isinstance(s, Line | RationalQuad) for s in segs)
    half = math.sqrt((1 + W) / 2)  # the standard-form weight of a half of a (1, w, 1) bow-tie
    weights = sorted({round(s.w, 12) for s in segs if isinstance(s, RationalQuad)})
    assert weights == [round(half, 12), 1.0]
    interface_halves = [s for s in segs if isinstance(s, RationalQuad) and abs(s.w - half) < 1e-12]
    assert len(interface_halves) == 2 * 6
    assert all(abs(a.w - W) < 1e-15 and abs(b.w - W) < 1e-15 for a, b in shaped.interface_arcs)


def test_the_bridge_weight_of_a_variation_is_kept() -> None:
    s = shape_pattern(pattern("0x0488"), HEXAGON, W, Variation(bridge_weight=0.5))
    weights = {round(seg.w, 12) for loop in s.outline.loops for seg in loop.segments if isinstance(seg, RationalQuad)}
    assert 0.5 in weights and s.variation.bridge_weight == 0.5


def test_the_exact_area_is_the_limit_of_the_sampled_areas(shaped: ShapedPattern) -> None:
    # A chord within tol of its arc changes the enclosed area by at most tol × its length, so the
    # shoelace area of the flattened loops is within tol × perimeter of the exact area.
    for tol in (1e-2, 1e-4):
        loops = shaped.outline.flatten(tol)
        sampled = _area(loops[0]) - sum(_area(P) for P in loops[1:])
        assert abs(sampled - shaped.outline.area) <= tol * shaped.outline.perimeter
    assert shaped.outline.area == pytest.approx(sampled, rel=1e-5)


def test_interfaces_are_centred_on_the_edge_midpoints_and_scale_with_the_edge(shaped: ShapedPattern) -> None:
    M, T, L = _edges(HEXAGON)
    seg = shaped.interface_segments
    assert np.abs(seg.mean(axis=1) - M).max() <= 1e-12
    d = L / 16 / (1 + W)  # depth 2: a quarter of the sub-edge, over 1 + w (fillet module docstring)
    assert np.abs(seg[:, 0] - (M - d[:, None] * T)).max() <= 1e-12
    assert np.abs(seg[:, 1] - (M + d[:, None] * T)).max() <= 1e-12
    assert np.abs(shaped.interface_half_lengths - d).max() <= 1e-12
    assert np.abs(shaped.outline.polygon.interfaces - seg).max() == 0.0


def test_two_plates_sharing_an_edge_share_its_interface_segment() -> None:
    # A second face across edge 2 of HEXAGON: its mirror image, then two of its own corners moved, so
    # its centre and its slices differ from the first face's everywhere.
    a, b = HEXAGON[2], HEXAGON[3]
    t = (b - a) / np.linalg.norm(b - a)
    rel = HEXAGON - a
    mirror = a + 2 * np.outer(rel @ t, t) - rel
    other = mirror[::-1].copy()  # counter-clockwise again; the shared edge runs from b to a
    shared = [k for k, q in enumerate(other) if min(np.abs(q - a).max(), np.abs(q - b).max()) < 1e-12]
    moved = [k for k in range(6) if k not in shared][1:3]
    other[moved] += np.array([[1.5, -0.8], [-0.6, 1.2]])
    first = shape_pattern(pattern("0x0488"), HEXAGON, W)
    second = shape_pattern(pattern("0x0688"), other, W)
    assert np.abs(first.centre - second.centre).max() > 1.0
    k = next(i for i in range(6) if np.abs(other[i] - b).max() < 1e-12)  # the second face's edge b → a
    assert np.abs(first.interface_segments[2] - second.interface_segments[k][::-1]).max() <= 1e-12


def test_two_lattice_points_per_edge_slide_along_it_and_nothing_else_moves() -> None:
    from fabpat.geometry.shaped import _centre_interfaces, _mapped_vertices
    from fabpat.geometry.stars import _interface_vertices

    p = pattern("0x0488")
    c = HEXAGON.mean(axis=0)
    M, T, L = _edges(HEXAGON)
    sigma = np.einsum("ij,ij->i", c - HEXAGON, T) / L  # the centre's foot on each edge
    assert np.abs(sigma - 0.5).max() > 0.02  # so the affine images alone would put the interfaces off-centre
    topo = p.topology
    fan, (i, j) = topo.point_fan, topo.point_ij.T
    affine = c + (i[:, None] * (HEXAGON[fan] - c) + j[:, None] * (HEXAGON[(fan + 1) % 6] - c)) / 4
    assert np.abs(_mapped_vertices(p, HEXAGON, c) - affine).max() <= 1e-12
    V = _centre_interfaces(affine, p, _interface_vertices(p), T, L)
    moved = np.flatnonzero(np.abs(V - affine).max(axis=1) > 0)
    assert len(moved) == 12 and set(zip(i[moved], j[moved], strict=True)) == {(2, 1), (1, 2)}
    shift = V[moved] - affine[moved]
    assert np.abs(shift[:, 0] * T[fan[moved], 1] - shift[:, 1] * T[fan[moved], 0]).max() <= 1e-12  # along the edge
    expected = (0.5 - sigma[fan[moved]]) * L[fan[moved]] / 4  # (½ − σ) L / N
    assert np.abs(np.einsum("ij,ij->i", shift, T[fan[moved]]) - expected).max() <= 1e-12


def test_depth_one_slides_the_spoke_points_for_both_their_edges() -> None:
    p = pattern("0xa", sides=6)
    s = shape_pattern(p, HEXAGON, W)
    M, T, L = _edges(HEXAGON)
    d = L / 8 / (1 + W)  # depth 1: a quarter of the sub-edge L/2, over 1 + w
    assert np.abs(s.interface_segments[:, 0] - (M - d[:, None] * T)).max() <= 1e-12
    assert np.abs(s.interface_segments[:, 1] - (M + d[:, None] * T)).max() <= 1e-12
    s.validate()


def test_a_shaped_step_solid_is_valid_with_the_exact_volume(shaped: ShapedPattern, tmp_path: Path) -> None:
    from fabpat.exchange import cad

    solid = cad.make_solid(shaped.outline, 2.0, shaped.support_arcs)
    cad.check_valid(solid, "shaped plate")  # BRepCheck_Analyzer
    assert cad.volume(solid) == pytest.approx(2.0 * shaped.outline.area, rel=1e-6)
    text = shaped.export(tmp_path / "s.step", thickness=2.0).read_text()
    assert "RATIONAL_B_SPLINE_CURVE((1.,0.2,1.))" in text  # the bow-ties keep their weight w in the file


def _dense(P: np.ndarray, step: float = 1e-3) -> np.ndarray:
    """The closed polyline P resampled with points at most ``step`` mm apart along it."""
    A, B = P, np.roll(P, -1, axis=0)
    k = np.maximum(1, np.ceil(np.linalg.norm(B - A, axis=1) / step).astype(int))
    edge = np.repeat(np.arange(len(P)), k)
    t = (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)) / k[edge]
    return A[edge] + t[:, None] * (B - A)[edge]


def _distances(X: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Distance (mm) from each point of X to the closed polyline P, to 0.5 µm (its points 1 µm apart)."""
    from scipy.spatial import cKDTree

    return cKDTree(_dense(P)).query(X)[0]


def test_the_dxf_reads_back_as_the_outline_within_its_tolerance(shaped: ShapedPattern, tmp_path: Path) -> None:
    ezdxf = pytest.importorskip("ezdxf")
    from ezdxf import path as dxfpath

    doc = ezdxf.readfile(shaped.export(tmp_path / "s.dxf", curve_tolerance=0.01, origin="centre"))
    assert not doc.audit().has_errors
    polys = [np.array([(v.x, v.y) for v in dxfpath.make_path(e).flattening(0.001)])[:-1]
             for e in doc.modelspace().query("LWPOLYLINE POLYLINE")]
    exact = shaped.outline.flatten(1e-4)
    assert len(polys) == len(exact)
    for P, Q in zip(sorted(polys, key=_area), sorted(exact, key=_area), strict=True):  # loops paired by size
        assert _distances(P, Q).max() <= 0.01 + 1e-3  # DXF tolerance, plus the two flattenings (1 µm, 0.1 µm)
        assert _distances(Q, P).max() <= 0.01 + 1e-3


def _area(P: np.ndarray) -> float:
    """Enclosed area (mm², unsigned) of a closed polyline (shoelace)."""
    return abs(0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1])))


def test_a_shaped_plate_meshes_for_the_shell_solver(shaped: ShapedPattern) -> None:
    from fabpat.simulation.mesh import mesh_outline

    mesh = mesh_outline(shaped, h=3.0)
    assert len(mesh.interfaces) == 6
    for (p, q), nodes in zip(shaped.interface_segments, mesh.interfaces, strict=True):
        X = mesh.V[nodes]
        t = (q - p) / np.linalg.norm(q - p)
        assert np.abs((X - p) @ np.array([-t[1], t[0]])).max() <= 1e-9  # on the segment's line
        s = (X - p) @ t
        assert s.min() == pytest.approx(0.0, abs=1e-9) and s.max() == pytest.approx(np.linalg.norm(q - p), abs=1e-9)


def test_irregularity_of_known_shapes() -> None:
    assert irregularity(polygon_vertices(7, 10.0)) == pytest.approx((0.0, 0.0), abs=1e-12)
    rectangle = [[0, 0], [2, 0], [2, 1], [0, 1]]  # mean edge 1.5: edges 1/3 off; every angle 90°
    assert irregularity(rectangle) == pytest.approx((1 / 3, 0.0), abs=1e-12)
    rhombus = [[0, 0], [1, 0], [1.5, math.sqrt(3) / 2], [0.5, math.sqrt(3) / 2]]  # 60° and 120° for 90°
    assert irregularity(rhombus) == pytest.approx((0.0, math.pi / 6), abs=1e-12)


def test_an_affine_image_of_the_regular_polygon_maps_every_slice_by_that_one_map() -> None:
    from fabpat.geometry.shaped import _mapped_vertices

    p = pattern("0x0488")
    s = shape_pattern(p, HEXAGON, W)
    assert np.abs(s.centre - [4.0, -3.0]).max() <= 1e-12  # the image of the regular centre
    image = p.V @ AFFINE.T + np.array([4.0, -3.0])  # p is in the regular hexagon of edge 36 mm
    assert np.abs(_mapped_vertices(p, HEXAGON, s.centre) - image).max() <= 1e-12


def test_a_too_irregular_polygon_is_refused_naming_the_deviation_and_the_limit() -> None:
    # Stretched 60 % along its flat edges: those become 57.6 mm, the four slanted ones 36 √(0.8² + 0.75)
    # = 42.44 mm (mean 47.49 mm, so 21.3 % off); the slanted edges rise at atan(0.866 / 0.8) = 47.27°,
    # so the side corners are 94.54°, 25.5° below the hexagon's 120°.
    long = polygon_vertices(6, 36.0) * np.array([1.6, 1.0])
    assert MAX_IRREGULARITY[0] < 0.213
    with pytest.raises(GeometryError, match=r"an edge deviates 21\.3 % from the mean edge \(limit "
                       rf"{100 * MAX_IRREGULARITY[0]:.1f} %\)"):
        shape_pattern(pattern("0x0488"), long, W)
    with pytest.raises(GeometryError, match=r"a corner deviates 25\.5° from the regular angle \(limit 10\.0°\)"):
        shape_pattern(pattern("0x0488"), long, W, tolerance=(1.0, math.radians(10)))


def test_a_polygon_whose_centroid_falls_beside_an_edge_is_refused() -> None:
    # A regular octagon stretched 60 % along x: the foot of its centre on a slanted edge next to a flat
    # one falls outside that edge (its obtuse corners), and that is refused whatever the tolerance.
    octagon = polygon_vertices(8, 36.0) * np.array([1.6, 1.0])
    with pytest.raises(GeometryError, match=r"foot on edge \d lies outside the edge \(at -?[01]\.\d{3} of it"):
        shape_pattern(pattern("0x0488", sides=8), octagon, W, tolerance=(1.0, math.pi))


@pytest.mark.parametrize("polygon, words", [
    (polygon_vertices(6, 36.0)[::-1], "counter-clockwise"),
    (polygon_vertices(5, 36.0), "polygon has 5 corners"),
    ([[0, 0], [1, 0]], "n ≥ 3"),
    ([[0, 0], [1, 0], [float("nan"), 1]], "finite"),
    ("hexagon", "(n, 2) array"),
])
def test_bad_polygons_are_refused(polygon: object, words: str) -> None:
    with pytest.raises(GeometryError, match=re.escape(words)):
        shape_pattern(pattern("0x0488"), polygon, W)
