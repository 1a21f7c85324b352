"""Meshing of hand-made polygons (hexagon with a hole and thin necks) and interface tagging."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.lattice import polygon_vertices
from fabpat.mesh import interface_segments, mesh_polygons, solid_polygon_mesh, tag_segments


def _hex_with_hole_and_necks() -> list[np.ndarray]:
    """A 36 mm hexagon minus a hexagonal hole of circumradius 14 rotated by 30°, leaving 2–3 mm necks."""
    outer = polygon_vertices(6, 36.0)
    a = np.radians(np.arange(6) * 60.0)
    hole = np.c_[27.0 * np.cos(a), 27.0 * np.sin(a)][::-1]  # CW, corners 3.2 mm from the outer edges
    return [outer, hole]


def test_hexagon_with_hole_quality_area_orientation() -> None:
    loops = _hex_with_hole_and_necks()
    m = mesh_polygons(loops, 1.5, interfaces=interface_segments(6, 36.0))
    exact = 3 * np.sqrt(3) / 2 * 36.0**2 - 3 * np.sqrt(3) / 2 * 27.0**2
    assert m.areas.sum() == pytest.approx(exact, rel=1e-12)  # straight loops: exact area, hole removed
    assert np.all(m.areas > 0)  # counter-clockwise
    assert m.min_angle() >= 25.0 - 1e-9
    assert 1.2 < np.mean(m.edge_lengths()) < 1.8
    # no triangle covers the hole's centre region
    c = m.V[m.F].mean(axis=1)
    assert np.min(np.linalg.norm(c, axis=1)) > 20.0
    # every node is used; boundary sides subdivided to ≤ h
    assert np.unique(m.F).size == m.n_nodes
    assert m.V.dtype == np.float64 and m.F.dtype == np.int64


def test_interfaces_tagged_in_order_on_each_edge() -> None:
    m = solid_polygon_mesh(6, 36.0, 2.0)
    P = polygon_vertices(6, 36.0)
    for i, nodes in enumerate(m.interfaces):
        a, b = P[i], P[(i + 1) % 6]
        t = (b - a) / 36.0
        rel = m.V[nodes] - a
        assert np.all(np.abs(rel[:, 0] * t[1] - rel[:, 1] * t[0]) < 1e-6)  # on the edge line
        s = rel @ t
        assert np.all(np.diff(s) > 0)  # ordered counter-clockwise
        assert s[0] == pytest.approx(0.0, abs=1e-9) and s[-1] == pytest.approx(36.0)
        assert nodes.size == 19  # 36 mm cut into 18 sides of 2 mm


def test_interface_segment_geometry() -> None:
    segs = interface_segments(6, 36.0)
    for i, (p0, p1) in enumerate(segs):
        assert np.linalg.norm(p1 - p0) == pytest.approx(3.75)
        mid = 0.5 * (p0 + p1)
        ang = np.arctan2(mid[1], mid[0])
        assert np.isclose(np.cos(ang - (-np.pi / 2 + 2 * np.pi * i / 6)), 1.0)
    assert segs[0][1][0] > segs[0][0][0]  # edge 0 runs along +x


def test_tag_segments_tolerance() -> None:
    V = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 5e-7], [3.0, 1e-3], [-1.0, 0.0]])
    (idx,) = tag_segments(V, [(np.array([0.0, 0.0]), np.array([2.5, 0.0]))])
    assert idx.tolist() == [0, 1, 2]


def test_bad_input_raises() -> None:
    with pytest.raises(GeometryError):
        mesh_polygons([np.array([[0.0, 0.0], [1.0, 0.0]])], 0.5)


@pytest.mark.parametrize("weight", [0.1, 0.2, 0.5])
def test_filleted_pattern_interfaces_follow_the_fillet_weight(weight: float) -> None:
    # the interface segment is (edge/16)/(1 + w) either side of the midpoint: every mesh node on it
    # must be tagged, whatever w the outline was filleted with
    from fabpat.fillet import fillet_pattern
    from fabpat.library import get_pattern
    from fabpat.mesh import mesh_outline

    fp = fillet_pattern(get_pattern("0x0488"), weight)
    mesh = mesh_outline(fp.outline, 1.0, 6, 36.0, weight=weight)
    corners = polygon_vertices(6, 36.0)
    for i, nodes in enumerate(mesh.interfaces):
        a, b = corners[i], corners[(i + 1) % 6]
        t = (b - a) / np.linalg.norm(b - a)
        dist = np.abs((mesh.V - a) @ np.array([-t[1], t[0]]))
        on_edge = np.flatnonzero(dist < 1e-9)
        assert sorted(nodes.tolist()) == sorted(on_edge.tolist())
        span = (mesh.V[nodes] - 0.5 * (a + b)) @ t
        assert span.max() - span.min() == pytest.approx(2 * fp.interface_half_length, abs=1e-9)
