"""Outline metrics and validation on small hand-made outlines, against closed forms; the segment estimate
checked before flattening.

Expected values are textbook formulas or test-local computations (explicit curve formula, dense
shoelace), never outputs of the code under test.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from fabpat.errors import GeometryError
from fabpat.geometry.outline import Line, Loop, Outline, OutlineReport, RationalQuad
from fabpat.patterns.metrics import RegionMetrics

# ------------------------------------------------------------------------------ test-local helpers


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def fillet(prev, corner, nxt, r: float) -> RationalQuad:
    """Circular fillet of radius r at a polygon corner.

    Interior angle α between the edges: tangent length r / tan(α/2), opening angle π − α, so the
    weight is cos((π − α)/2) = sin(α/2).
    """
    prev, corner, nxt = (np.asarray(p, float) for p in (prev, corner, nxt))
    u, v = unit(prev - corner), unit(nxt - corner)
    alpha = math.acos(float(np.clip(u @ v, -1, 1)))
    L = r / math.tan(alpha / 2)
    return RationalQuad(corner + u * L, corner, corner + v * L, math.sin(alpha / 2))


def rounded_polygon(V, radii) -> Loop:
    """Polygon V (k, 2) with a circular fillet of radius radii[i] (0: sharp) at corner i."""
    V = np.asarray(V, float)
    k = len(V)
    arcs = [fillet(V[i - 1], V[i], V[(i + 1) % k], r) if r > 0 else None for i, r in enumerate(radii)]
    segs: list = []
    for i in range(k):
        a = arcs[i]
        start = V[i] if a is None else a.P2
        if a is not None:
            segs.append(a)
        nxt = arcs[(i + 1) % k]
        end = V[(i + 1) % k] if nxt is None else nxt.P0
        segs.append(Line(start, end))
    # rotate so the loop starts with a line (not required, just tidy)
    return Loop(tuple(segs))


def square(s: float, c=(0.0, 0.0), ccw: bool = True) -> Loop:
    h = s / 2
    V = np.array([[-h, -h], [h, -h], [h, h], [-h, h]]) + c
    if not ccw:
        V = V[::-1]
    return Loop(tuple(Line(V[i], V[(i + 1) % 4]) for i in range(4)))


def polygon(V) -> Loop:
    V = np.asarray(V, float)
    return Loop(tuple(Line(V[i], V[(i + 1) % len(V)]) for i in range(len(V))))


def disc(R: float, c=(0.0, 0.0)) -> Loop:
    c = np.asarray(c, float)
    segs = []
    w = math.cos(math.pi / 4)
    for k in range(4):
        a0, a1 = k * math.pi / 2, (k + 1) * math.pi / 2
        p0 = c + R * np.array([math.cos(a0), math.sin(a0)])
        p2 = c + R * np.array([math.cos(a1), math.sin(a1)])
        p1 = c + R * np.array([math.cos(a0) + math.cos(a1), math.sin(a0) + math.sin(a1)])
        segs.append(RationalQuad(p0, p1, p2, w))
    return Loop(tuple(segs))


def rq(P: np.ndarray, w: float, t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, float)[:, None]
    b0, b1, b2 = (1 - t) ** 2, 2 * w * t * (1 - t), t**2
    return (b0 * P[0] + b1 * P[1] + b2 * P[2]) / (b0 + b1 + b2)


def dense_boundary(loop: Loop, n: int = 100_000) -> np.ndarray:
    """Dense closed polygon of a loop, using the explicit curve formula (not the code under test)."""
    pts = []
    for s in loop.segments:
        if isinstance(s, Line):
            pts.append(np.asarray(s.p0)[None])
        else:
            P = np.stack([s.P0, s.P1, s.P2])
            pts.append(rq(P, s.w, np.linspace(0, 1, n, endpoint=False)))
    return np.vstack(pts)


def shoelace(V: np.ndarray) -> float:
    x, y = V[:, 0], V[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def rounded_square_closed_forms(s: float, r: float) -> tuple[float, float, float]:
    """Area, perimeter, polar moment about the centre of an s × s square with 4 corners of radius r."""
    area = s * s - (4 - math.pi) * r * r
    perimeter = 4 * s - 8 * r + 2 * math.pi * r
    # corner piece = r × r square minus a quarter disc, both about the origin (parallel axes)
    q = s / 2 - r / 2
    J_sq = r**4 / 6 + r * r * 2 * q * q
    c = s / 2 - r
    J_qd = math.pi * r**4 / 8 + 2 * (c * r**3 / 3 + c * r**3 / 3) + math.pi * r * r / 4 * 2 * c * c
    return area, perimeter, s**4 / 6 - 4 * (J_sq - J_qd)


# --------------------------------------------------------------------------------- the fixtures

BOWTIE_W = 0.2
A_TRI, B_TRI = 9 * math.sqrt(3) / 2, 4.5  # equilateral sub-triangle of side 9 mm, apex on the edge


def bowtie_pattern(exempt_ok: bool = True) -> Outline:
    """One pattern's side of an interface (notes: "A consistent interface geometry").

    The polygon edge is the line x = 0 with M = (0, 0); the solid sub-triangle has its apex at M and
    base vertices (−a, ±b). The bow-tie arc P0 = (−a/2, ±b/2), P1 = M, P2 = mirror, w = 0.2 is split
    at t = ½ and the pattern keeps its half; a rectangular body closes the outline.
    """
    a, b, body = A_TRI, B_TRI, 20.0
    bottom = RationalQuad((-a / 2, -b / 2), (0, 0), (a / 2, -b / 2), BOWTIE_W).split(0.5)[0]
    top = RationalQuad((-a / 2, b / 2), (0, 0), (a / 2, b / 2), BOWTIE_W).split(0.5)[0].reversed()
    segs = (
        Line((-body, -b), (-a, -b)),
        Line((-a, -b), (-a / 2, -b / 2)),
        bottom,
        Line(bottom.P2, top.P0),
        top,
        Line((-a / 2, b / 2), (-a, b)),
        Line((-a, b), (-body, b)),
        Line((-body, b), (-body, -b)),
    )
    return Outline(Loop(segs))


def notched_bar(W: float = 6.0, R: float = 2.0, L: float = 10.0) -> Outline:
    """Bar [−L, L] × [−W/2, W/2] with semicircular notches of radius R centred at (0, ±W/2).

    The neck between the notches is W − 2R wide. Each semicircle is two quarter arcs (w = cos 45°).
    """
    h, w = W / 2, math.cos(math.pi / 4)
    segs = (
        Line((-L, -h), (-R, -h)),
        RationalQuad((-R, -h), (-R, -h + R), (0, -h + R), w),
        RationalQuad((0, -h + R), (R, -h + R), (R, -h), w),
        Line((R, -h), (L, -h)),
        Line((L, -h), (L, h)),
        Line((L, h), (R, h)),
        RationalQuad((R, h), (R, h - R), (0, h - R), w),
        RationalQuad((0, h - R), (-R, h - R), (-R, h), w),
        Line((-R, h), (-L, h)),
        Line((-L, h), (-L, -h)),
    )
    return Outline(Loop(segs))


# ----------------------------------------------------------------------------------- segments


def test_line_methods() -> None:
    seg = Line((1.0, 2.0), (4.0, 6.0))
    assert np.allclose(seg.point(0.5), (2.5, 4.0))
    assert seg.point(np.array([0.0, 1.0])).shape == (2, 2)
    assert np.allclose(seg.tangent(0.3), (0.6, 0.8))
    assert seg.length == pytest.approx(5.0)
    assert np.array_equal(seg.flatten(1e-3), [[1.0, 2.0], [4.0, 6.0]])


def test_rational_quad_methods_on_circular_arc() -> None:
    R, theta = 3.0, math.radians(100)
    arc = RationalQuad((R, 0), (R, R * math.tan(theta / 2)), (R * math.cos(theta), R * math.sin(theta)),
                       math.cos(theta / 2))
    X = arc.point(np.linspace(0, 1, 101))
    assert np.abs(np.linalg.norm(X, axis=1) - R).max() < 1e-12
    assert arc.length == pytest.approx(R * theta, rel=1e-12)
    T = arc.tangent(np.linspace(0, 1, 11))
    assert np.allclose(np.linalg.norm(T, axis=1), 1.0)
    assert np.abs(np.einsum("ij,ij->i", T, arc.point(np.linspace(0, 1, 11)))).max() < 1e-12
    V = arc.flatten(1e-3)
    assert np.allclose(V[0], arc.P0) and np.allclose(V[-1], arc.P2)
    # sagitta of each chord of a circle is R(1 − cos(φ/2)) with φ the chord's angle
    phi = np.diff(np.unwrap(np.arctan2(V[:, 1], V[:, 0])))
    assert (R * (1 - np.cos(phi / 2))).max() <= 1e-3
    left, right = arc.split(0.5)
    assert left.w == pytest.approx(math.sqrt((1 + arc.w) / 2))
    assert left.length + right.length == pytest.approx(R * theta, rel=1e-12)
    assert np.allclose(left.P2, R * np.array([math.cos(theta / 2), math.sin(theta / 2)]))


# -------------------------------------------------------------------------------------- loops


def test_loop_basics() -> None:
    loop = rounded_polygon([[0, 0], [1, 0], [1, 1], [0, 1]], [0, 0, 0.3, 0])
    assert loop.is_closed()
    assert loop.signed_area == pytest.approx(1 - (1 - math.pi / 4) * 0.09, rel=1e-14)
    rev = loop.reversed()
    assert rev.is_closed()
    assert rev.signed_area == pytest.approx(-loop.signed_area, rel=1e-14)
    assert rev.polar_moment == pytest.approx(-loop.polar_moment, rel=1e-14)
    assert rev.length == pytest.approx(loop.length, rel=1e-14)
    V = loop.flatten(1e-3)
    assert not np.allclose(V[0], V[-1])  # last point not repeated
    assert np.allclose(loop.bbox, [[0, 0], [1, 1]])
    broken = Loop(loop.segments[:-1])
    assert not broken.is_closed()


@pytest.mark.parametrize("tol", [1e-2, 1e-4])
def test_loop_flatten_within_tolerance(tol: float) -> None:
    loop = rounded_polygon([[0, 0], [10, 0], [10, 6], [0, 6]], [1.0, 2.0, 0.5, 3.0])
    V = loop.flatten(tol)
    closed = np.vstack([V, V[:1]])
    dense = dense_boundary(loop, 4_000)
    # exact distance from every dense boundary point to every polyline edge (blocks keep memory small)
    A, D = closed[:-1], np.diff(closed, axis=0)
    dev = 0.0
    for X in np.array_split(dense, 16):
        s = np.clip(np.einsum("mkj,kj->mk", X[:, None] - A[None], D) / np.einsum("kj,kj->k", D, D), 0, 1)
        dev = max(dev, float(np.linalg.norm(X[:, None] - (A[None] + s[..., None] * D[None]), axis=2).min(1).max()))
    assert dev <= tol
    assert dev > 0.25 * tol


# ------------------------------------------------------------------------------------ metrics


def test_unit_square_with_one_rounded_corner() -> None:
    r = 0.25
    outline = Outline(rounded_polygon([[0, 0], [1, 0], [1, 1], [0, 1]], [0, 0, r, 0]))
    area = 1 - (1 - math.pi / 4) * r * r
    perimeter = 4 - 2 * r + math.pi * r / 2
    # about the origin: unit square J = 2/3, minus the corner piece at (1, 1)
    J_sq = r**4 / 6 + r * r * 2 * (1 - r / 2) ** 2
    c = 1 - r
    J_qd = math.pi * r**4 / 8 + 2 * (2 * c * r**3 / 3) + math.pi * r * r / 4 * 2 * c * c
    m = outline.metrics
    assert isinstance(m, RegionMetrics)
    assert m.area == pytest.approx(area, rel=1e-14)
    assert m.perimeter == pytest.approx(perimeter, rel=1e-12)
    assert m.polar_moment == pytest.approx(2 / 3 - (J_sq - J_qd), rel=1e-13)
    assert m.ratio == pytest.approx(4 * math.pi * area / perimeter**2, rel=1e-12)


@pytest.mark.parametrize("r", [0.5, 1.0, 2.5])
def test_rounded_square_closed_forms(r: float) -> None:
    s = 6.0
    h = s / 2
    outline = Outline(rounded_polygon([[-h, -h], [h, -h], [h, h], [-h, h]], [r] * 4))
    area, perimeter, J = rounded_square_closed_forms(s, r)
    assert outline.area == pytest.approx(area, rel=1e-14)
    assert outline.perimeter == pytest.approx(perimeter, rel=1e-12)
    assert outline.polar_moment == pytest.approx(J, rel=1e-13)
    assert np.allclose(outline.bbox, [[-h, -h], [h, h]])
    report = outline.validate()
    assert report.ok and report.simple and report.g1_ok and report.orientation_ok
    assert report.worst_g1_angle < 1e-12
    assert report.min_width == pytest.approx(s, abs=2e-3)


def test_translated_disc_metrics() -> None:
    R, c = 2.0, np.array([5.0, -3.0])
    outline = Outline(disc(R, c))
    assert outline.area == pytest.approx(math.pi * R * R, rel=1e-14)
    assert outline.perimeter == pytest.approx(2 * math.pi * R, rel=1e-12)
    assert outline.polar_moment == pytest.approx(math.pi * R**4 / 2 + math.pi * R * R * (c @ c), rel=1e-13)
    assert outline.metrics.ratio == pytest.approx(1.0, rel=1e-12)
    assert np.allclose(outline.bbox, [c - R, c + R])
    report = outline.validate(tol=1e-3)
    assert report.ok
    assert report.min_width == pytest.approx(2 * R, abs=2e-3)


def test_square_with_square_hole() -> None:
    outline = Outline(square(4.0), (square(2.0, ccw=False),))
    assert outline.area == pytest.approx(12.0)
    assert outline.perimeter == pytest.approx(24.0)
    assert outline.polar_moment == pytest.approx((4**4 - 2**4) / 6)
    flat = outline.flatten(1e-3)
    assert len(flat) == 2 and flat[0].shape == (4, 2)
    report = outline.validate()
    assert report.ok and report.holes_inside
    assert report.min_width == pytest.approx(1.0, abs=1e-9)
    # a hole given counter-clockwise: metrics still subtract it, validation reports the orientation
    wrong = Outline(square(4.0), (square(2.0),))
    assert wrong.area == pytest.approx(12.0)
    assert wrong.polar_moment == pytest.approx((4**4 - 2**4) / 6)
    rep = wrong.validate(raise_on_error=False)
    assert not rep.orientation_ok and not rep.ok
    with pytest.raises(GeometryError, match="orientation"):
        wrong.validate()


# -------------------------------------------------------------------------------- validation


def test_bowtie_interface_geometry() -> None:
    outline = bowtie_pattern()
    b, w = B_TRI, BOWTIE_W
    d = (b / 2) / (1 + w)  # notes: crossing at (edge/16)/(1 + w) from M; 1.875 mm for a 36 mm edge
    assert d == pytest.approx(1.875)
    bottom = outline.outer.segments[2]
    assert isinstance(bottom, RationalQuad)
    assert np.allclose(bottom.P2, (0.0, -d), atol=1e-14)
    assert bottom.w == pytest.approx(math.sqrt((1 + w) / 2))
    assert np.allclose(bottom.tangent(1.0), (1.0, 0.0), atol=1e-14)  # crosses the edge at right angles
    # area against a dense polygon built from the explicit curve formula
    assert outline.area == pytest.approx(shoelace(dense_boundary(outline.outer)), rel=1e-9)
    # the arcs meet the edge x = 0 at right angles: a G1 failure unless that edge is exempt
    rep = outline.validate(raise_on_error=False)
    assert not rep.g1_ok
    assert rep.worst_g1_angle == pytest.approx(math.pi / 2, abs=1e-12)
    assert rep.worst_g1_at is not None and abs(rep.worst_g1_at[0]) < 1e-12
    rep = outline.validate(g1_exempt_lines=[((0.0, -1.0), (0.0, 1.0))])
    assert rep.ok and rep.g1_exempt_joints == 2
    assert rep.worst_g1_angle < 1e-12  # the arcs join the triangle sides tangentially
    # notes: "the interface neck is 3.75 mm wide", at the edge
    assert rep.min_width == pytest.approx(2 * d, abs=2e-3)
    assert rep.min_width_at is not None and abs(rep.min_width_at[0][0]) < 0.05


def test_figure_eight_is_not_simple() -> None:
    crossing = Outline(polygon([[0, 0], [2, 0], [0, 2], [2, 2]]))
    rep = crossing.validate(raise_on_error=False)
    assert not rep.simple and rep.intersections >= 1
    with pytest.raises(GeometryError, match="not simple"):
        crossing.validate()
    # two lobes of arcs that cross at the origin
    w = math.cos(math.pi / 4)
    lobes = Loop((
        RationalQuad((0, 0), (1, 1), (2, 0), w),
        RationalQuad((2, 0), (1, -1), (0, 0), w),
        RationalQuad((0, 0), (-1, 1), (-2, 0), w),
        RationalQuad((-2, 0), (-1, -1), (0, 0), w),
    ))
    rep = Outline(lobes).validate(raise_on_error=False)
    assert not rep.simple
    # a hole that crosses the outer loop
    rep = Outline(square(4.0), (square(2.0, c=(1.5, 0.0), ccw=False),)).validate(raise_on_error=False)
    assert not rep.simple


def test_hole_outside_and_open_loop_fail() -> None:
    rep = Outline(square(4.0), (square(1.0, c=(10.0, 0.0), ccw=False),)).validate(raise_on_error=False)
    assert rep.simple and not rep.holes_inside
    loop = square(4.0)
    gap = Loop((*loop.segments[:-1], Line((-2.0, 2.0), (-2.0, -1.9))))
    rep = Outline(gap).validate(raise_on_error=False)
    assert not rep.closed and rep.max_gap == pytest.approx(0.1)
    with pytest.raises(GeometryError, match="not closed"):
        Outline(gap).validate()


def test_kink_at_arc_joint_fails_g1() -> None:
    r, delta = 0.3, 0.05
    loop = rounded_polygon([[0, 0], [1, 0], [1, 1], [0, 1]], [0, 0, r, 0])
    segs = list(loop.segments)
    k = next(i for i, s in enumerate(segs) if isinstance(s, RationalQuad))
    arc = segs[k]
    segs[k] = RationalQuad(arc.P0, arc.P1 + (delta, 0.0), arc.P2, arc.w)  # P1 off the corner
    rep = Outline(Loop(tuple(segs))).validate(raise_on_error=False)
    assert not rep.g1_ok
    # incoming edge is vertical, the arc starts along P1 − P0 = (δ, r)
    assert rep.worst_g1_angle == pytest.approx(math.atan(delta / r), rel=1e-12)
    assert np.allclose(rep.worst_g1_at, arc.P0)
    with pytest.raises(GeometryError, match="G1"):
        Outline(Loop(tuple(segs))).validate()


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_dumbbell_min_width(tol: float) -> None:
    W, R = 6.0, 2.0
    outline = notched_bar(W, R)
    exempt = [((0.0, W / 2), (1.0, W / 2)), ((0.0, -W / 2), (1.0, -W / 2))]
    rep = outline.validate(tol, g1_exempt_lines=exempt)
    assert rep.ok
    assert rep.min_width == pytest.approx(W - 2 * R, abs=2 * tol)
    (px, py), (qx, qy) = rep.min_width_at  # type: ignore[misc]
    assert abs(px) < 0.05 and abs(qx) < 0.05 and abs(abs(py - qy) - (W - 2 * R)) < 2 * tol
    # as a fabrication requirement
    with pytest.raises(GeometryError, match="too narrow"):
        outline.validate(tol, g1_exempt_lines=exempt, min_width_required=2.5)


@pytest.mark.parametrize("bar", [1.5, 0.05])
def test_straight_bar_dumbbell_min_width(bar: float) -> None:
    # two 10 × 10 squares joined by a 6 mm long bar
    h = bar / 2
    V = [[-13, -5], [-3, -5], [-3, -h], [3, -h], [3, -5], [13, -5],
         [13, 5], [3, 5], [3, h], [-3, h], [-3, 5], [-13, 5]]
    rep = Outline(polygon(V)).validate()
    assert rep.ok
    assert rep.min_width == pytest.approx(bar, abs=1e-9)
    assert isinstance(rep, OutlineReport)


# -------------------------------------------------------------------------------------- SVG


def _svg_commands(d: str) -> list[tuple[str, list[float]]]:
    return [(c, [float(x) for x in args.split()]) for c, args in re.findall(r"([MLQAZ])([^MLQAZ]*)", d)]


def test_svg_path_rounded_square_and_hole() -> None:
    s, r = 6.0, 1.0
    h = s / 2
    outer = rounded_polygon([[-h, -h], [h, -h], [h, h], [-h, h]], [r] * 4)
    hole = disc(1.0).reversed()
    d = Outline(outer, (hole,)).to_svg_path()
    cmds = _svg_commands(d)
    assert [c for c, _ in cmds].count("M") == 2 and [c for c, _ in cmds].count("Z") == 2
    arcs = [args for c, args in cmds if c == "A"]
    assert len(arcs) == 8
    for rx, ry, _rot, large, sweep, _x, _y in arcs[:4]:  # outer corners: radius r, counter-clockwise
        assert (rx, ry, large, sweep) == pytest.approx((r, r, 0, 1), abs=1e-6)
    for rx, ry, _rot, large, sweep, _x, _y in arcs[4:]:  # hole: clockwise
        assert (rx, ry, large, sweep) == pytest.approx((1.0, 1.0, 0, 0), abs=1e-6)
    # the first arc ends at the next line's start, the corner's P2
    first_arc = next(sg for sg in outer.segments if isinstance(sg, RationalQuad))
    assert arcs[0][5:] == pytest.approx(list(first_arc.P2), abs=1e-6)


def test_svg_path_ellipse_parabola_hyperbola() -> None:
    a, b = 5.0, 2.0
    quarter = RationalQuad((a, 0), (a, b), (0, b), math.cos(math.pi / 4))
    loop = Loop((quarter, Line((0, b), (0, 0)), Line((0, 0), (a, 0))))
    (_, m), (c, args), *_ = _svg_commands(Outline(loop).to_svg_path())
    assert m == [a, 0] and c == "A"
    rx, ry, rot, large, sweep, x, y = args
    assert (rx, ry, large, sweep, x, y) == pytest.approx((a, b, 0, 1, 0, b), abs=1e-6)
    assert math.sin(math.radians(rot)) == pytest.approx(0.0, abs=1e-9)
    parabola = Loop((RationalQuad((-1, 1), (0.5, -2), (2, 4), 1.0), Line((2, 4), (-1, 1))))
    cmds = _svg_commands(Outline(parabola).to_svg_path())
    assert cmds[1] == ("Q", pytest.approx([0.5, -2, 2, 4]))
    hyper = Loop((RationalQuad((1, 1), (4 / 3, 2 / 3), (2, 0.5), 3 * math.sqrt(2) / 4), Line((2, 0.5), (1, 1))))
    cmds = _svg_commands(Outline(hyper).to_svg_path())
    pts = np.array([args for c, args in cmds if c == "L"])
    assert len(pts) > 5
    assert np.abs(pts[:-1, 0] * pts[:-1, 1] - 1).max() < 1e-5  # flattened vertices on xy = 1


# ------------------------------------------------------------------------------ symmetry


def rotated(loop: Loop, angle: float) -> Loop:
    c, s_ = math.cos(angle), math.sin(angle)
    R = np.array([[c, -s_], [s_, c]])
    return Loop(tuple(
        Line(R @ g.p0, R @ g.p1) if isinstance(g, Line) else RationalQuad(R @ g.P0, R @ g.P1, R @ g.P2, g.w)
        for g in loop.segments
    ))


def test_declared_symmetry_gives_the_same_min_width_on_a_symmetric_outline() -> None:
    # a hexagon-symmetric region: a disc of six 60° arcs with six round holes near its rim (rotated
    # copies, since the check is on segments); the neck between hole and rim is the min width
    R, w = 10.0, math.cos(math.pi / 6)
    arcs = []
    for k in range(6):
        a0, a1, am = k * math.pi / 3, (k + 1) * math.pi / 3, (k + 0.5) * math.pi / 3
        arcs.append(RationalQuad(R * np.array([math.cos(a0), math.sin(a0)]),
                                 R / w * np.array([math.cos(am), math.sin(am)]),
                                 R * np.array([math.cos(a1), math.sin(a1)]), w))
    hole = disc(1.5, (7.0 * math.cos(0.3), 7.0 * math.sin(0.3))).reversed()
    outline = Outline(Loop(tuple(arcs)), tuple(rotated(hole, k * math.pi / 3) for k in range(6)))
    full = outline.validate(1e-3)
    sector = outline.validate(1e-3, symmetry=6)
    assert full.ok and sector.ok
    assert sector.min_width == pytest.approx(10.0 - 7.0 - 1.5, abs=2e-3)
    assert sector.min_width == pytest.approx(full.min_width, abs=1e-12)


def test_declared_symmetry_is_checked() -> None:
    # a square is 4-fold symmetric but not 6-fold: the claim is a problem, and the width still found
    rep = Outline(square(4.0)).validate(1e-3, symmetry=6, raise_on_error=False)
    assert not rep.ok
    assert any("not 6-fold symmetric" in p for p in rep.problems)
    assert rep.min_width == pytest.approx(4.0, abs=1e-9)
    assert Outline(square(4.0)).validate(1e-3, symmetry=4).min_width == pytest.approx(4.0, abs=1e-9)


def test_symmetry_check_sees_a_different_arc_weight() -> None:
    # four lens-shaped holes, rotated copies except that one bulges more: same end and control points,
    # another weight - not 4-fold symmetric, and the narrowest neck is only found from all sides
    def lens(w: float) -> Loop:
        a, b, c = np.array([3.0, -1.0]), np.array([3.0, 1.0]), np.array([2.0, 0.0])
        return Loop((RationalQuad(a, c + [2.0, 0.0], b, w), RationalQuad(b, c, a, w))).reversed()

    holes = [rotated(lens(0.3), k * math.pi / 2) for k in range(4)]
    symmetric = Outline(square(9.0), tuple(holes))
    lenient = {"g1_tol": 4.0}  # the lenses have corners
    assert symmetric.validate(1e-3, symmetry=4, **lenient).ok
    holes[2] = rotated(lens(0.95), math.pi)
    odd = Outline(square(9.0), tuple(holes))
    rep = odd.validate(1e-3, symmetry=4, raise_on_error=False, **lenient)
    assert rep.problems == ("not 4-fold symmetric about the origin (to 1e-6 mm)",)
    assert rep.min_width == pytest.approx(odd.validate(1e-3, **lenient).min_width, abs=1e-12)
    assert rep.min_width < symmetric.validate(1e-3, **lenient).min_width - 0.1  # the fat lens is the neck
    with pytest.raises(ValueError, match="symmetry"):
        odd.validate(1e-3, symmetry=0)


def test_segment_estimate_is_close_to_the_flattening() -> None:
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    outline = fillet_pattern(get_pattern("0x0488")).outline
    for tol in (1e-3, 1e-4):
        actual = sum(len(loop) for loop in outline.flatten(tol))
        assert 0.67 < outline.estimate_segments(tol) / actual < 1.5


def test_flatten_refuses_a_tolerance_floating_point_cannot_resolve() -> None:
    import fabpat

    outline = fabpat.pattern("0x0488").fillet(weight=0.2).outline
    for tol in (1e-300, 1e-12):  # 1e-300 ran out of memory (MemoryError after GBs)
        with pytest.raises(GeometryError, match=r"below what floating point resolves on a part 62.35 mm across: use "
                                                r"≥ 6.2e-08 mm"):
            outline.flatten(tol)
    assert len(outline.flatten(1e-3)[0]) > 100  # an ordinary tolerance still flattens
