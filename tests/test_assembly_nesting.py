"""Nesting plates on sheets and unfolding nets: no overlaps, checked exactly; the nesting raster is bounded."""

from __future__ import annotations

import math
from xml.etree import ElementTree

import numpy as np
import pytest

from fabpat.assembly.kit.net import net_svg, unfold
from fabpat.assembly.place.nesting import Nesting, Placement, check_nesting, convex_distance, nest
from fabpat.assembly.surface.tiling import honeycomb_strip, truncated_icosahedron
from fabpat.errors import GeometryError
from fabpat.patterns.lattice import polygon_vertices

HEX, PENT = polygon_vertices(6, 36.0), polygon_vertices(5, 36.0)


def square(x: float, y: float, s: float = 1.0) -> np.ndarray:
    return np.array([[x, y], [x + s, y], [x + s, y + s], [x, y + s]])


def test_convex_distance() -> None:
    assert convex_distance(square(0, 0), square(3, 0)) == pytest.approx(2.0)
    assert convex_distance(square(0, 0), square(3, 3)) == pytest.approx(2 * math.sqrt(2))  # corner to corner
    assert convex_distance(square(0, 0), square(1, 0)) == pytest.approx(0.0)
    assert convex_distance(square(0, 0), square(0.5, 0.25)) < 0


def test_sphere_plates_nest_on_one_laser_bed() -> None:
    polys = [HEX] * 20 + [PENT] * 12
    n = nest(polys, 600.0, 400.0, 5.0, 3.0)
    assert n.n_sheets == 1 and len(n.placements) == 32
    assert check_nesting(n) >= 3.0


def test_small_sheets_spread_and_stay_inside() -> None:
    n = nest([HEX] * 5, 170.0, 90.0, 5.0, 3.0)
    assert n.n_sheets == 3  # two hexagons (72 mm wide) per 170 × 90 mm sheet
    check_nesting(n)
    for i in range(5):
        P = n.placed(i)
        assert P.min() >= 5.0 - 1e-9 and P[:, 0].max() <= 165.0 + 1e-9 and P[:, 1].max() <= 85.0 + 1e-9


def test_check_nesting_catches_overlaps_and_margins() -> None:
    good = nest([HEX] * 2, 200.0, 100.0, 5.0, 3.0)
    p0, p1 = good.placements
    bad = Nesting(200.0, 100.0, 5.0, 3.0, good.polygons, (p0, Placement(1, 0, p0.x + 40.0, p0.y, 0.0)))
    with pytest.raises(GeometryError, match="apart"):
        check_nesting(bad)
    out = Nesting(200.0, 100.0, 5.0, 3.0, good.polygons[:1], (Placement(0, 0, 20.0, 20.0, 0.0),))
    with pytest.raises(GeometryError, match="usable area"):
        check_nesting(out)


def test_too_large_item_is_refused() -> None:
    with pytest.raises(GeometryError, match="does not fit"):
        nest([HEX], 60.0, 60.0, 0.0, 0.0)


def test_truncated_icosahedron_net_has_no_overlaps_and_keeps_edges() -> None:
    t = truncated_icosahedron(37.6)
    net = unfold(t)
    assert net.overlaps() == []
    assert len(net.folds) == 31  # a spanning tree of 32 faces
    # every net face is congruent to its skeleton face: same edge length
    for P in net.polygons:
        assert np.allclose(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1), 37.6)
    # folded edges coincide in the net
    for k in net.folds:
        (fa, ia), (fb, ib) = t.edge_faces[k]
        A, B = net.polygons[fa], net.polygons[fb]
        ea = {tuple(np.round(A[ia], 6)), tuple(np.round(A[(ia + 1) % len(A)], 6))}
        eb = {tuple(np.round(B[ib], 6)), tuple(np.round(B[(ib + 1) % len(B)], 6))}
        assert ea == eb


def test_net_svg_labels_every_edge_twice() -> None:
    t = truncated_icosahedron(37.6)
    net = unfold(t)
    labels = [tuple(f"E{k + 1:02d}" for k in t.face_edges[f]) for f in range(32)]
    svg = net_svg(net, [f"F{f}" for f in range(32)], labels, "test")
    root = ElementTree.fromstring(svg.encode())
    ns = "{http://www.w3.org/2000/svg}"
    texts = [e.text for e in root.iter(f"{ns}text") if e.get("class") == "edge-label"]
    assert len(texts) == 180 and all(texts.count(f"E{k:02d}") == 2 for k in range(1, 91))
    assert len([e for e in root.iter(f"{ns}polygon")]) == 32
    assert len([e for e in root.iter(f"{ns}line")]) == 90


def test_strip_net_is_the_layout() -> None:
    net = unfold(honeycomb_strip(2, 5, 36.8))
    assert net.overlaps() == [] and net.min_gap() >= 36.8 - 1e-9


def used_height(n: Nesting, sheet: int) -> float:
    return max(float(n.placed(i)[:, 1].max()) for i in n.on_sheet(sheet))


def test_nesting_packs_the_sphere_and_the_strip_tighter() -> None:
    """One turn per polygon is tried as well as a free choice: point-up hexagons interlock. The sphere's
    32 plates used 272 mm of the 400 mm bed (a third of it empty) and now about 238 mm; a 250 × 210 mm
    print bed took 8 hexagons and now takes 9 (the graded strip: 30 plates, 4 beds either way)."""
    sphere = nest([HEX] * 20 + [PENT] * 12, 600.0, 400.0, 5.0, 3.0)
    assert sphere.n_sheets == 1 and used_height(sphere, 0) < 245.0
    assert check_nesting(sphere) >= 3.0
    beds = nest([HEX] * 30, 250.0, 210.0, 5.0, 3.0)
    assert [len(beds.on_sheet(s)) for s in range(beds.n_sheets)] == [9, 9, 9, 3]
    check_nesting(beds)
    assert beds.utilisation(0) == pytest.approx(9 * 3 * math.sqrt(3) / 2 * 36.0**2 / (250 * 210))


def test_nesting_raster_is_bounded() -> None:
    from fabpat.assembly.place.nesting import nest
    from fabpat.patterns.lattice import polygon_vertices

    with pytest.raises(GeometryError, match="raster nodes of a 9000 × 9000 mm sheet"):
        nest([polygon_vertices(6, 36.0)], 9000.0, 9000.0, 5.0, 3.0)
    assert len(nest([polygon_vertices(6, 36.0)], 200.0, 200.0, 5.0, 3.0).placements) == 1
