"""Meshing of hand-made polygons (hexagon with a hole and thin necks) and interface tagging; the element
estimate checked before meshing, and the mesh sizes the element-count and resolution checks suggest."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.patterns.lattice import polygon_vertices
from fabpat.simulation.mesh import interface_segments, mesh_polygons, solid_polygon_mesh, tag_segments


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
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline

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


# --- chord polygons that keep the area, and nested refinement ------------------------------------------


def _distance_to(loops: list[np.ndarray], X: np.ndarray) -> np.ndarray:
    """(m,) distance of points X to closed polylines (a reference flattening of the exact outline)."""
    from scipy.spatial import cKDTree

    from fabpat.simulation.mesh import _subdivide

    loops = [_subdivide(L, 0.02) for L in loops]  # short pieces: a point's own piece is among its nearest
    A = np.vstack(loops)
    D = np.vstack([np.roll(L, -1, axis=0) for L in loops]) - A
    _, near = cKDTree(A + 0.5 * D).query(X, k=16)
    a, d = A[near], D[near]
    s = np.clip(np.einsum("ijk,ijk->ij", X[:, None] - a, d) / np.einsum("ijk,ijk->ij", d, d), 0.0, 1.0)
    return np.linalg.norm(a + s[..., None] * d - X[:, None], axis=2).min(axis=1)


def _signed_area_of(loops: list[np.ndarray]) -> float:
    return sum(0.5 * float(np.sum(L[:, 0] * np.roll(L[:, 1], -1) - np.roll(L[:, 0], -1) * L[:, 1])) for L in loops)


@pytest.mark.parametrize("pid", ["0x4888", "0x2d08"])
def test_shifted_chords_keep_the_area_and_the_tolerance(pid: str) -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import _subdivide, flatten_outline

    outline = fillet_pattern(get_pattern(pid)).outline
    tol = 0.03
    shifted, plain = flatten_outline(outline, tol), outline.flatten(tol)
    exact = outline.area  # closed form (Green's theorem on the rational arcs)
    # chords on the arcs cut or fill every arc by ≈ 2/3·chord·sagitta; moved chords cancel that to second order
    assert abs(_signed_area_of(plain) - exact) > 0.3  # mm², e.g. 0x4888: +2.96 mm² at 0.03 mm
    assert abs(_signed_area_of(shifted) - exact) < 0.25 * abs(_signed_area_of(plain) - exact)
    # still within the tolerance of the exact outline, at the vertices and along the chords
    ref = [np.asarray(L) for L in outline.flatten(1e-6)]
    pts = np.vstack([_subdivide(L, 0.02) for L in shifted])
    assert _distance_to(ref, pts).max() <= tol


def test_refine_nested_splits_every_triangle_and_puts_new_boundary_nodes_on_the_outline() -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline, refine_nested

    outline = fillet_pattern(get_pattern("0x4888")).outline
    coarse = mesh_outline(outline, 2.0)
    fine = refine_nested(coarse, outline)
    m, n = coarse.n_elements, coarse.n_nodes
    sides = {tuple(sorted(e)) for t in coarse.F.tolist() for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert fine.n_elements == 4 * m and fine.n_nodes == n + len(sides)
    np.testing.assert_array_equal(fine.V[:n], coarse.V)  # nested: the coarse nodes keep their numbers
    # each coarse triangle is the union of its four children (the interior ones exactly)
    assert fine.areas.reshape(m, 4).sum(axis=1) == pytest.approx(coarse.areas, rel=0.02)
    assert (fine.areas > 0).all() and fine.min_angle() > 10.0
    # new boundary nodes lie on the exact outline; new interior nodes are side midpoints
    E = np.sort(np.concatenate([fine.F[:, [0, 1]], fine.F[:, [1, 2]], fine.F[:, [2, 0]]]), axis=1)
    u, c = np.unique(E, axis=0, return_counts=True)
    bnew = np.setdiff1d(np.unique(u[c == 1]), np.arange(n))
    ref = [np.asarray(L) for L in outline.flatten(1e-6)]
    assert len(bnew) > 100 and _distance_to(ref, fine.V[bnew]).max() < 2e-4
    off_curve = _distance_to(ref, 0.5 * (coarse.V[u[c == 1][:, 0] % n] + coarse.V[u[c == 1][:, 1] % n]))
    assert off_curve.max() > 1e-3  # the plain midpoints would not have been on it
    # interfaces: the coarse nodes with the midpoints between them, in order, as tagging finds them
    segs = [(a, b) for a, b in outline.polygon.interfaces]
    for got, tagged, old in zip(fine.interfaces, tag_segments(fine.V, segs), coarse.interfaces, strict=True):
        np.testing.assert_array_equal(got, tagged)
        assert len(got) == 2 * len(old) - 1


def test_nested_meshes_are_the_converged_pair() -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.convergence import CONVERGED_MESHES, nested_meshes

    (h1, coarse), (h2, fine) = nested_meshes(fillet_pattern(get_pattern("0x2d08")), CONVERGED_MESHES[0])
    assert (h1, h2) == CONVERGED_MESHES and fine.n_elements == 4 * coarse.n_elements
    with pytest.raises(GeometryError, match="finer mesh"):
        nested_meshes(fillet_pattern(get_pattern("0x2d08")), 2.0, max_elements=5000)


def test_mesh_limits_count_the_real_triangles_and_bad_tolerances_are_refused() -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import mesh_outline, refine_nested

    fp = fillet_pattern(get_pattern("0x4888"))
    m = mesh_outline(fp, 2.0)
    with pytest.raises(GeometryError, match="refining the mesh"):  # 4× the real count, not the estimate
        mesh_outline(fp, 2.0, refine=1, max_elements=4 * m.n_elements - 1)
    assert mesh_outline(fp, 2.0, refine=1, max_elements=4 * m.n_elements).n_elements == 4 * m.n_elements
    with pytest.raises(GeometryError, match="triangles, above the limit"):  # a fine boundary makes many more
        mesh_outline(fp, 2.0, flatten_tol=1e-4, max_elements=5000)
    for tol in (0.0, -1.0, 5.0, float("nan")):
        with pytest.raises(GeometryError, match="flatten_tol"):
            mesh_outline(fp, 2.0, flatten_tol=tol)
    assert refine_nested(m, fp).n_elements == 4 * m.n_elements  # a FilletedPattern refines along its outline
    with pytest.raises(GeometryError, match="refine_nested needs"):
        refine_nested(m, None)


def test_element_estimate_is_close_to_the_mesh() -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern
    from fabpat.simulation.mesh import estimate_elements, mesh_outline

    outline = fillet_pattern(get_pattern("0x2d88")).outline
    for h in (1.0, 2.0):
        n = mesh_outline(outline, h).n_elements
        est = estimate_elements(outline.area, outline.perimeter, h)
        assert 0.67 < est / n < 1.5, (h, est, n)


@pytest.mark.parametrize("pid", ["0x0488", "0x2d88"])
def test_suggested_h_passes_the_check_that_suggested_it(pid: str) -> None:
    import re

    import fabpat as api
    from fabpat.simulation.mesh import check_element_count, check_resolves

    fp = api.pattern(pid).fillet()
    m = fp.metrics
    with pytest.raises(GeometryError) as err:
        check_element_count(m.area, m.perimeter, 0.05, 50_000)
    low = float(re.search(r"use h ≥ ([0-9.e+-]+) mm", str(err.value)).group(1))
    check_element_count(m.area, m.perimeter, low, 50_000)  # the suggestion passes
    width = fp.min_width()
    with pytest.raises(GeometryError) as err:
        check_resolves(36.0, width)
    high = float(re.search(r"use h ≤ ([0-9.e+-]+) mm", str(err.value)).group(1))
    check_resolves(high, width)
    assert high > 0.99 * 2 * width  # and it is not needlessly small
