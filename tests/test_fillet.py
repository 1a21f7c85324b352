"""Filleting: every library pattern gets a valid exact outline; each lookup-table entry checked by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.geometry.fillet import (
    HEXAGON_STAR_TABLE,
    fillet_pattern,
    fillet_solid,
    interface_half_length,
    vertex_stars,
)
from fabpat.geometry.outline import Line, RationalQuad
from fabpat.patterns.library import enumerate_library

# --- tiny hand-made stars -------------------------------------------------------------------------


def star(labels: str, angles_deg: list[float] | None = None, r: float = 9.0):
    """A vertex at the origin with len(labels) triangles around it; S = solid, V = void."""
    k = len(labels)
    angles = np.radians(angles_deg if angles_deg else [360.0 / k] * k)
    dirs = np.concatenate([[0.0], np.cumsum(angles)[:-1]])
    V = np.vstack([[0.0, 0.0], r * np.stack([np.cos(dirs), np.sin(dirs)], axis=1)])
    F = np.array([[0, 1 + i, 1 + (i + 1) % k] for i in range(k)])
    solid = np.array([c == "S" for c in labels])
    return V, F, solid


def arcs_at(outline, p) -> list[RationalQuad]:
    return [
        s for loop in outline.loops for s in loop.segments if isinstance(s, RationalQuad) and np.allclose(s.P1, p)
    ]


def _cross(u: np.ndarray, v: np.ndarray) -> float:
    return float(u[0] * v[1] - u[1] * v[0])


def inside_any(P: np.ndarray, V: np.ndarray, F: np.ndarray) -> bool:
    """Is P in the closed union of the triangles (boundary included)?"""
    for f in F:
        a, b, c = V[f]
        if min(_cross(b - a, P - a), _cross(c - b, P - b), _cross(a - c, P - c)) > -1e-12:
            return True
    return False


# Written by hand from the rule in the notes, not from the code's table: arcs at the centre vertex
# and whether each arc adds material (its midpoint lies in a void triangle) or removes it (in a solid one).
HAND = {
    "SVVVVV": (1, "removes"),  # sharp 60° convex corner: rounded
    "SSVVVV": (1, "removes"),  # sharp 120° convex corner: rounded
    "SSSSVV": (1, "adds"),  # 120° concave corner: filled
    "SSSSSV": (1, "adds"),  # 60° concave notch: filled
    "SSSVVV": (0, None),  # straight: nothing
    "SVSVVV": (1, "adds"),  # 60° void bridged, 180° void stays straight
    "SVVSVV": (2, "adds"),
    "SSVVSV": (2, "adds"),
    "SSVSVV": (2, "adds"),
    "SVSVSV": (3, "adds"),
    "SSSVSV": (2, "adds"),
    "SSVSSV": (2, "adds"),
}


def test_table_has_the_papers_configurations() -> None:
    kinds = [kind for _, kind, _ in HEXAGON_STAR_TABLE]
    assert len(HEXAGON_STAR_TABLE) == 14
    assert kinds.count("non-manifold") == 7 and kinds.count("sharp") == 4
    assert {labels for labels, kind, _ in HEXAGON_STAR_TABLE if kind in ("sharp", "non-manifold", "straight")} == set(
        HAND
    )


@pytest.mark.parametrize("labels", sorted(HAND))
def test_hand_made_star(labels: str) -> None:
    V, F, solid = star(labels)
    outline, _ = fillet_solid(V, F[solid])  # raises unless one outer loop: the star stays one piece
    arcs = arcs_at(outline, V[0])
    n_arcs, effect = HAND[labels]
    assert len(arcs) == n_arcs
    for arc in arcs:
        assert arc.w == 1.0
        mid = arc.point(0.5)
        in_solid = inside_any(mid, V, F[solid])
        assert in_solid == (effect == "removes")
        # the arc lies in the vertex's refined star: it ends at midpoints of edges incident to it
        assert np.linalg.norm(arc.P0) == pytest.approx(4.5) and np.linalg.norm(arc.P2) == pytest.approx(4.5)
    outline.validate(1e-3)


def test_reflex_void_at_a_non_manifold_vertex_rounds_the_convex_side() -> None:
    # pentagon-lattice star: solid 54°, void 54°, solid 54°, void 198° (three triangles of 66°)
    V, F, solid = star("SVSVVV", [54, 54, 54, 66, 66, 66])
    outline, _ = fillet_solid(V, F[solid])
    arcs = arcs_at(outline, V[0])
    assert len(arcs) == 2
    dist = sorted(np.linalg.norm(a.point(0.5)) for a in arcs)
    # the rounding arc passes closer to the vertex than the bridge, so a band of material joins the runs
    assert dist[0] < dist[1]
    rep = outline.validate(1e-3)
    assert rep.min_width > 0.5


def test_interface_star_gives_the_standard_segment() -> None:
    # a lone solid triangle touching the line y = 0 with its apex at the origin (an interface vertex)
    V = np.array([[0.0, 0.0], [4.5, 9 * math.sqrt(3) / 2], [-4.5, 9 * math.sqrt(3) / 2]])
    F = np.array([[0, 1, 2]])
    w = 0.3
    outline, bowties = fillet_solid(V, F, {0: np.array([-1.0, 0.0])}, w)
    on_edge = [
        s for s in outline.outer.segments if isinstance(s, Line) and abs(s.p0[1]) < 1e-12 and abs(s.p1[1]) < 1e-12
    ]
    assert len(on_edge) == 1
    d = (9 / 4) / (1 + w)  # projection of the side midpoint lies a quarter edge from M
    assert np.linalg.norm(on_edge[0].p1 - on_edge[0].p0) == pytest.approx(2 * d)
    assert all(b.w == w for b in bowties[0])


# --- the whole library ----------------------------------------------------------------------------


@pytest.fixture(scope="module", params=[5, 6])
def filleted(request):
    lib = enumerate_library(request.param, 2)
    return request.param, [fillet_pattern(p) for p in lib.patterns()]


def test_every_pattern_fillets_into_one_valid_piece(filleted) -> None:
    sides, fps = filleted
    assert len(fps) == 430
    for fp in fps:
        rep = fp.validate(2e-2, raise_on_error=False, width=False)
        assert rep.ok, (fp.pattern.id, rep.problems)
        assert rep.g1_exempt_joints == 2 * sides  # only the interface corners are exempt
        assert fp.outline.outer.signed_area > 0 and all(h.signed_area < 0 for h in fp.outline.holes)


def test_no_problematic_vertex_is_left(filleted) -> None:
    _, fps = filleted
    for fp in fps[::11]:
        problematic = [s.vertex for s in vertex_stars(fp.pattern) if s.kind != "straight"]
        for v in problematic:
            P = fp.pattern.V[v]
            arcs = arcs_at(fp.outline, P)
            interface_arcs = [a for pair in fp.interface_arcs for a in pair if np.allclose(a.P1, P)]
            assert arcs or interface_arcs, (fp.pattern.id, v)
            # no outline point stays on a problematic vertex (pinched or sharp)
            pts = np.vstack(fp.outline.flatten(0.01))
            assert np.min(np.linalg.norm(pts - P, axis=1)) > 0.05


def _segment_keys(segments, R: np.ndarray) -> set:
    keys = set()
    for s in segments:
        pts = [s.start, s.end] + ([s.P1] if isinstance(s, RationalQuad) else [])
        w = s.w if isinstance(s, RationalQuad) else 0.0
        keys.add((tuple(np.round(np.concatenate([p @ R.T for p in pts]), 6) + 0.0), round(w, 9)))
    return keys


def test_rotational_symmetry(filleted) -> None:
    """Rotating the exact outline by 2π/n maps every segment onto a segment of the outline."""
    sides, fps = filleted
    a = 2 * math.pi / sides
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    for fp in fps[::7]:
        segs = [s for loop in fp.outline.loops for s in loop.segments]
        assert _segment_keys(segs, R) == _segment_keys(segs, np.eye(2)), fp.pattern.id


def test_interface_segment_is_identical_for_every_pattern(filleted) -> None:
    sides, fps = filleted
    d = interface_half_length(36.0, 2, 0.2)
    assert d == pytest.approx(1.875)
    corners = fps[0].polygon_edges()
    for fp in fps:
        for a, b in corners:
            t = (b - a) / np.linalg.norm(b - a)
            n = np.array([t[1], -t[0]])  # outward normal
            on = [
                s
                for s in fp.outline.outer.segments
                if isinstance(s, Line) and abs((s.p0 - a) @ n) < 1e-9 and abs((s.p1 - a) @ n) < 1e-9
            ]
            assert len(on) == 1
            seg = on[0]
            assert np.allclose((seg.p0 + seg.p1) / 2, (a + b) / 2, atol=1e-9)
            assert np.linalg.norm(seg.p1 - seg.p0) == pytest.approx(2 * 1.875, abs=1e-9)
            # nothing else of the outline reaches the edge line
            pts = np.vstack(fp.outline.flatten(1e-3))
            off = (pts - a) @ n
            assert off.max() < 1e-9
            assert np.sum(off > -1e-9) == 2


def test_arcs_are_exact(filleted) -> None:
    _, fps = filleted
    fp = fps[37]
    t = np.linspace(0, 1, 11)
    for s in [s for s in fp.outline.outer.segments if isinstance(s, RationalQuad)][:20]:
        # independent evaluation of the rational quadratic from its stored data
        b = np.stack([(1 - t) ** 2, 2 * t * (1 - t) * s.w, t**2], axis=1)
        expect = (b @ s.control_points) / b.sum(axis=1)[:, None]
        assert np.allclose(s.point(t), expect, atol=1e-12)
    # the interface halves lie on the full bow-tie arcs, whose middle weight is the configured w
    for into, out_of in fp.interface_arcs:
        assert into.w == out_of.w == 0.2
        tt = np.linspace(0, 1, 200_001)
        for full in (into, out_of):
            b = np.stack([(1 - tt) ** 2, 2 * tt * (1 - tt) * full.w, tt**2], axis=1)
            curve = (b @ full.control_points) / b.sum(axis=1)[:, None]
            halves = [
                s for s in fp.outline.outer.segments if isinstance(s, RationalQuad) and s.w != 1.0
            ]
            near = [h for h in halves if np.allclose(h.P0, full.P0) or np.allclose(h.P2, full.P2)]
            assert len(near) == 1
            samples = near[0].point(np.linspace(0, 1, 9))
            gap = np.min(np.linalg.norm(curve[None] - samples[:, None], axis=2), axis=1)
            assert gap.max() < 1e-4


def test_weight_is_a_parameter() -> None:
    p = enumerate_library(6, 2).pattern("0x2d88")
    for w in (0.1, 0.5, 1.0):
        fp = fillet_pattern(p, w)
        assert fp.interface_half_length == pytest.approx(36 / 16 / (1 + w))
        fp.validate(2e-2, width=False)


def _local_change(arc_pieces: list, vertex: np.ndarray) -> float:
    """Signed area between a piece of the outline and the lattice corner it replaces (added > 0)."""
    from fabpat.geometry.outline import Loop

    first, last = arc_pieces[0].start, arc_pieces[-1].end
    return Loop((*arc_pieces, Line(last, vertex), Line(vertex, first))).signed_area


def test_area_change_is_explained_by_the_arcs(filleted) -> None:
    """Outline area − lattice area = Σ over arcs of the area between the arc and its corner."""
    sides, fps = filleted
    change = []
    for fp in fps[::5]:
        segs = fp.outline.outer.segments + tuple(s for h in fp.outline.holes for s in h.segments)
        interior = [s for s in segs if isinstance(s, RationalQuad) and s.w == 1.0]
        explained = sum(_local_change([a], a.P1) for a in interior)
        for into, _ in fp.interface_arcs:
            M = into.P1
            near = 4.6  # mm: just over half a sub-triangle edge, the reach of M's refined star
            pieces = [
                s
                for s in fp.outline.outer.segments
                if np.linalg.norm(s.start - M) < near and np.linalg.norm(s.end - M) < near
            ]
            k = next(i for i, s in enumerate(pieces) if isinstance(s, RationalQuad) and np.allclose(s.P0, into.P0))
            explained += _local_change(pieces[k : k + 3], M)
        delta = fp.outline.area - fp.pattern.metrics.area
        assert delta == pytest.approx(explained, abs=1e-9 * fp.pattern.metrics.area)
        change.append(delta / fp.pattern.metrics.area)
    # bridges and fills add material, rounding removes a little: the net change is positive and
    # stays below a quarter of the area (distribution reported in the README)
    assert 0 < min(change) and max(change) < 0.25


def test_star_table_figure() -> None:
    from xml.etree import ElementTree

    from fabpat.views.pictures import star_table_svg

    root = ElementTree.fromstring(star_table_svg())
    texts = [e.text for e in root.iter() if e.tag.endswith("text")]
    assert len(texts) == 12 and sum("non-manifold" in t for t in texts) == 7
    assert sum(e.tag.endswith("path") for e in root.iter()) == 12


def test_closed_form_halves_match_de_casteljau() -> None:
    from fabpat.geometry.curves import split_quad
    from fabpat.geometry.fillet import _halves
    from fabpat.geometry.outline import RationalQuad

    for w in (0.05, 0.2, 1.0, 3.0):
        arc = RationalQuad([0.3, -1.0], [1.0, 2.0], [2.5, 0.2], w)
        mine = _halves(arc)
        ref = split_quad(arc.control_points, w, 0.5)
        for half, (P, wr) in zip(mine, ref, strict=True):
            assert np.allclose(half.control_points, P, atol=1e-14) and half.w == pytest.approx(wr, rel=1e-14)


@pytest.mark.parametrize("sides", [3, 5, 6])
def test_min_width_from_one_fan_sector_equals_whole_boundary(sides: int) -> None:
    # FilletedPattern.validate declares the n-fold symmetry and casts rays from one fan sector only;
    # the result must equal casting from the whole boundary
    for p in enumerate_library(sides, 2).patterns()[::37]:
        fp = fillet_pattern(p)
        sector = fp.validate(1e-2)
        full = fp.outline.validate(1e-2, g1_exempt_lines=fp.polygon_edges())
        assert sector.ok and full.ok
        assert sector.min_width == pytest.approx(full.min_width, abs=1e-9)
