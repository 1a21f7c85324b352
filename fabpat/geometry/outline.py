"""The exact outline of a filleted pattern: straight segments and quadratic rational Bézier arcs.

An :class:`Outline` is one outer loop (counter-clockwise) plus hole loops (clockwise). Each loop is a
closed sequence of segments, each segment either a :class:`Line` or a :class:`RationalQuad`; the end
point of one segment is the start point of the next, and the last ends where the first starts.
Coordinates are millimetres in the polygon's plane, the polygon centre at the origin.

This is the exact geometry of the paper's §3.3: every approximation (flattening for DXF lines, STL,
the FE mesh) is derived from it with an explicit tolerance in mm. The curve mathematics lives in
:mod:`fabpat.geometry.curves`; the methods here are thin wrappers over it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fabpat.errors import GeometryError
from fabpat.geometry import polyline
from fabpat.geometry.segments import Line, Loop, Point, RationalQuad, Segment, _end_direction, _start_direction, _unit
from fabpat.patterns.metrics import RegionMetrics
from fabpat.validate import as_float, check, check_tolerance

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["SVG_FLATTEN_TOL", "Line", "Loop", "Outline", "OutlineReport", "Point", "PolygonFrame", "RationalQuad",
           "Segment", "flattening_tolerance"]

SVG_FLATTEN_TOL = 1e-3
"""mm: chord tolerance for the arcs SVG cannot draw exactly (hyperbolic, w > 1)."""


@dataclass(frozen=True)
class OutlineReport:
    """What :meth:`Outline.validate` found. Lengths in mm, angles in radians.

    ``simple``: no loop touches or crosses itself or another loop (on a flattening at the validation
    tolerance). ``orientation_ok``: outer counter-clockwise, holes clockwise. ``holes_inside``: every
    hole inside the outer loop and outside the other holes. ``worst_g1_angle``: the largest angle
    between the tangents at a joint where an arc meets another segment (exempt joints excluded).
    ``min_width``: see :func:`fabpat.geometry.polyline.ray_min_width`; ``min_width_at`` are the two ends of the
    narrowest chord. ``problems`` lists every failure; empty means valid.
    """

    closed: bool
    max_gap: float
    simple: bool
    intersections: int
    orientation_ok: bool
    holes_inside: bool
    g1_ok: bool
    worst_g1_angle: float
    worst_g1_at: tuple[float, float] | None
    g1_exempt_joints: int
    min_width: float
    min_width_at: tuple[tuple[float, float], tuple[float, float]] | None
    problems: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """True when no problem was found."""
        return not self.problems


def _dedupe(V: NDArray[np.float64], atol: float) -> NDArray[np.float64]:
    """Drop points of a closed polyline (k, 2) that repeat their predecessor (incl. last vs first)."""
    keep = np.linalg.norm(V - np.roll(V, 1, axis=0), axis=1) > atol
    return V[keep] if keep.any() else V[:1]


def flattening_tolerance(tol: object) -> float:
    """``tol`` as a float in mm, or :class:`GeometryError` if it is not a positive number: the
    flattening routines of :mod:`fabpat.geometry.curves` need tol > 0 (they raise a bare ValueError)."""
    try:
        value = as_float(tol)
    except (TypeError, ValueError):
        raise GeometryError(f"tol must be a positive number of mm, got {tol!r}") from None
    if not 0 < value < math.inf:  # inf would flatten every curve to its chord
        raise GeometryError(f"tol must be a positive, finite number of mm, got {tol!r}")
    return value


def _fmt(v: float) -> str:
    s = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


@dataclass(frozen=True, eq=False)
class PolygonFrame:
    """The regular polygon a pattern's outline lives in, so meshing and scenarios need not be told.

    ``sides`` n, ``edge`` (mm), ``interfaces`` (n, 2, 2) float: the straight piece of the outline on
    polygon edge i, from M − d to M + d counter-clockwise (see :mod:`fabpat.geometry.fillet`).
    """

    sides: int
    edge: float
    interfaces: NDArray[np.float64]

    def __post_init__(self) -> None:
        segs = np.array(self.interfaces, dtype=np.float64)
        if segs.shape != (self.sides, 2, 2):
            raise GeometryError(f"a {self.sides}-gon frame needs ({self.sides}, 2, 2) interfaces, got {segs.shape}")
        segs.setflags(write=False)
        object.__setattr__(self, "interfaces", segs)


@dataclass(frozen=True, eq=False)
class Outline:
    """One outer loop and any number of hole loops; ``polygon`` says which regular polygon (sides, edge,
    interface segments) a pattern's outline belongs to, ``None`` for a free-standing shape."""

    outer: Loop
    holes: tuple[Loop, ...] = field(default_factory=tuple)
    polygon: PolygonFrame | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.outer, Loop):
            raise GeometryError(f"an Outline's outer loop must be a Loop, got {type(self.outer).__name__}")
        if not isinstance(self.holes, Sequence) or not all(isinstance(h, Loop) for h in self.holes):
            raise GeometryError(f"an Outline's holes must be a sequence of Loops, got {self.holes!r:.80}")
        if self.polygon is not None and not isinstance(self.polygon, PolygonFrame):
            raise GeometryError("an Outline's polygon must be a PolygonFrame or None, got "
                                f"{type(self.polygon).__name__}")
        object.__setattr__(self, "holes", tuple(self.holes))

    def __repr__(self) -> str:
        n = sum(len(loop.segments) for loop in self.loops)
        where = "" if self.polygon is None else f", {self.polygon.sides}-gon edge {self.polygon.edge:g} mm"
        holes = f"{len(self.holes)} hole{'' if len(self.holes) == 1 else 's'}"
        return f"Outline({holes}, {n} segments, area={self.area:.1f} mm²{where})"

    def _repr_svg_(self) -> str:
        """Notebook picture: the exact outline (lines, exact arcs ``A``/``Q``) filled black, true size (mm),
        framed by its polygon when it knows one (as a ``FilletedPattern``'s picture is), else by its
        bounding box."""
        from fabpat.views.pictures import outline_svg

        return outline_svg(self)

    def plot(self, ax: Axes | None = None, *, tol: float = 0.01, color: str = "black", **kwargs: object) -> Axes:
        """Draw the outline filled (holes empty) on a matplotlib ``ax`` (a new figure if None), equal
        axes in mm; curves flattened within ``tol`` mm. ``kwargs`` go to the ``PathPatch``. Returns ax."""
        import matplotlib.pyplot as plt
        from matplotlib.patches import PathPatch
        from matplotlib.path import Path as MplPath

        if ax is None:
            _, ax = plt.subplots()
        elif not hasattr(ax, "add_patch"):
            raise GeometryError(f"ax must be a matplotlib Axes, got {type(ax).__name__}")
        verts, codes = [], []
        for P in self.flatten(tol):
            verts += [*P, P[0]]
            codes += [MplPath.MOVETO] + [MplPath.LINETO] * (len(P) - 1) + [MplPath.CLOSEPOLY]
        ax.add_patch(PathPatch(MplPath(np.array(verts), codes), facecolor=color, edgecolor="none", **kwargs))
        lo, hi = self.bbox
        pad = 0.02 * float(np.max(hi - lo))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        return ax

    @property
    def loops(self) -> tuple[Loop, ...]:
        """Outer loop first, then the holes."""
        return (self.outer, *self.holes)

    # ---------------------------------------------------------------------------------- metrics

    @cached_property
    def area(self) -> float:
        """Solid area, mm²: outer minus holes (from exact signed areas, whatever their orientation)."""
        return abs(self.outer.signed_area) - math.fsum(abs(h.signed_area) for h in self.holes)

    @cached_property
    def perimeter(self) -> float:
        """Total boundary length of all loops, mm."""
        return math.fsum(loop.length for loop in self.loops)

    @cached_property
    def polar_moment(self) -> float:
        """∫∫ (x² + y²) dA of the solid about the origin, mm⁴."""
        def region(loop: Loop) -> float:
            return math.copysign(1.0, loop.signed_area) * loop.polar_moment

        return region(self.outer) - math.fsum(region(h) for h in self.holes)

    @cached_property
    def bbox(self) -> NDArray[np.float64]:
        """(2, 2): exact [[xmin, ymin], [xmax, ymax]] of all loops."""
        B = np.array([loop.bbox for loop in self.loops])
        return np.stack([B[:, 0].min(axis=0), B[:, 1].max(axis=0)])

    @cached_property
    def metrics(self) -> RegionMetrics:
        """Area (mm²), perimeter (mm), isoperimetric ratio and polar moment (mm⁴) of the exact outline."""
        return RegionMetrics.from_values(self.area, self.perimeter, self.polar_moment)

    def flatten(self, tol: float) -> list[NDArray[np.float64]]:
        """Closed polylines (k_i, 2) within tol mm of each loop, outer first, last point not repeated.

        Raises :class:`GeometryError` if ``tol`` is not a positive number, or finer than floating point
        resolves on the outline (:func:`fabpat.validate.check_tolerance`: 1e-9 × its size; 1e-300 ran
        out of memory)."""
        tol = flattening_tolerance(tol)
        size = float(np.max(self.bbox[1] - self.bbox[0]))
        check_tolerance(tol, size, "tol", error=GeometryError)
        return [loop.flatten(tol) for loop in self.loops]

    def estimate_segments(self, tol: float, reference: float = 0.01) -> float:
        """How many chords :meth:`flatten` would make at ``tol`` mm, without making them.

        Each curve is flattened at ``max(tol, reference)`` mm (cheap) and, for a finer tol, its chord
        count scaled by √(reference / tol): a chord c of a curve of radius r has sagitta c²/8r, so the
        count of a smooth curve grows as tol^(-1/2). Lines count 1.
        """
        tol = flattening_tolerance(tol)
        coarse = max(tol, reference)
        scale = math.sqrt(coarse / tol) if tol > 0 else math.inf
        total = 0.0
        for loop in self.loops:
            for s in loop.segments:
                total += 1.0 if isinstance(s, Line) else (len(s.flatten(coarse)) - 1) * scale
        return total

    # ------------------------------------------------------------------------------- validation

    def validate(
        self,
        tol: float = 1e-3,
        *,
        raise_on_error: bool = True,
        closed_atol: float = 1e-9,
        g1_tol: float = 1e-6,
        g1_exempt_lines: Sequence[tuple[ArrayLike, ArrayLike]] = (),
        min_width_required: float | None = None,
        width: bool = True,
        symmetry: int = 1,
    ) -> OutlineReport:
        """Check that the outline is a valid, fabricable region; return an :class:`OutlineReport`.

        tol (mm) is the flattening tolerance for the polyline checks (simplicity, containment,
        min_width): loops closer than about 2 tol may be reported as touching, and min_width is
        accurate to about 2 tol. G1 is checked on the exact tangents at every joint where an arc
        meets another segment, except joints lying (within 1e-6 mm) on one of ``g1_exempt_lines``
        (each given by two points), where a corner is intended - e.g. the polygon edges, which the
        interface arcs meet at right angles. ``min_width_required`` turns a too-narrow neck into a
        problem; ``width=False`` skips the (most expensive) width computation. ``symmetry`` = n > 1
        declares n-fold rotational symmetry about the origin: it is checked on the segments' end and
        control points (1e-6 mm; a violation is a problem) and lets min_width cast rays from one
        sector of the boundary only, n times fewer.

        Raises GeometryError listing every problem if ``raise_on_error`` and the outline is invalid,
        and if ``tol`` is outside ``width_tolerance`` of :mod:`fabpat.validate` ([1e-5, 1] mm: finer
        makes the ray cast of min_width grow without bound, 24 GB at 1e-300 mm; coarser replaces the arcs
        by their chords).

        One function, not one per check: the checks run in order on one flattening (closure and orientation,
        simplicity, containment, G1, symmetry, width) and each adds its line to the one report; split, each
        would re-flatten or pass the report along.
        """
        tol = check("width_tolerance", tol, "tol", error=GeometryError)
        if any(not loop.segments for loop in self.loops):
            raise GeometryError("invalid outline: a loop has no segments")
        problems: list[str] = []
        gaps = [float(loop.gaps().max()) for loop in self.loops]
        max_gap = max(gaps)
        closed = max_gap <= closed_atol
        if not closed:
            bad = [i for i, g in enumerate(gaps) if g > closed_atol]
            problems.append(f"not closed: loop(s) {bad} have gaps up to {max_gap:.3g} mm")

        areas = [loop.signed_area for loop in self.loops]
        orientation_ok = areas[0] > 0 and all(a < 0 for a in areas[1:])
        if not orientation_ok:
            problems.append(
                "wrong orientation: the outer loop must be counter-clockwise and holes clockwise "
                f"(signed areas {[round(a, 6) for a in areas]} mm²)"
            )

        polys = [_dedupe(loop.flatten(tol), 1e-12) for loop in self.loops]
        hits = polyline.polyline_intersections(polys, eps=1e-9)
        simple = len(hits) == 0
        if not simple:
            li, ei = int(hits[0, 0]), int(hits[0, 1])
            where = polys[li][ei]
            problems.append(
                f"not simple: {len(hits)} touching/crossing edge pair(s), first near "
                f"({where[0]:.4f}, {where[1]:.4f}) between loops {li} and {int(hits[0, 2])}"
            )

        # With no crossings, one vertex per hole decides containment for the whole hole.
        probes = np.array([P[0] for P in polys[1:]]).reshape(-1, 2)
        outside = np.flatnonzero(~polyline.points_in_polygon(probes, polys[0]))
        nested = [
            (int(i), j)
            for j in range(len(probes))
            for i in np.flatnonzero(polyline.points_in_polygon(probes, polys[j + 1]))
            if i != j
        ]
        holes_inside = outside.size == 0 and not nested
        if outside.size:
            problems.append(f"hole(s) {outside.tolist()} not inside the outer loop")
        if nested:
            problems.append(f"hole(s) inside other holes (hole, container): {nested}")

        worst, worst_at, exempt = self._worst_g1(g1_exempt_lines)
        g1_ok = worst < g1_tol
        if not g1_ok:
            near = "" if worst_at is None else f" near ({worst_at[0]:.4f}, {worst_at[1]:.4f})"  # None: no joints
            problems.append(f"not G1: tangents differ by {math.degrees(worst):.4g}° at an arc joint{near}")

        if symmetry < 1:
            raise ValueError(f"symmetry must be a positive integer, got {symmetry}")
        if symmetry > 1 and not self._has_symmetry(symmetry):
            problems.append(f"not {symmetry}-fold symmetric about the origin (to 1e-6 mm)")
            symmetry = 1

        min_width, min_width_at = math.inf, None
        if width:
            # The solid must lie on the left of every edge, whatever the loops' given orientation.
            oriented = [
                P if (a > 0) == (i == 0) else P[::-1] for i, (P, a) in enumerate(zip(polys, areas, strict=True))
            ]
            spacing = max(self.perimeter / 1500.0, 2.0 * tol)
            min_width, p, q = polyline.ray_min_width(oriented, spacing, symmetry=symmetry)
            if math.isfinite(min_width):
                min_width_at = ((float(p[0]), float(p[1])), (float(q[0]), float(q[1])))
            if min_width_required is not None and not min_width >= min_width_required:
                problems.append(f"too narrow: min width {min_width:.4g} mm < {min_width_required:.4g} mm")

        report = OutlineReport(
            closed=closed,
            max_gap=max_gap,
            simple=simple,
            intersections=len(hits),
            orientation_ok=orientation_ok,
            holes_inside=holes_inside,
            g1_ok=g1_ok,
            worst_g1_angle=worst,
            worst_g1_at=None if worst_at is None else (float(worst_at[0]), float(worst_at[1])),
            g1_exempt_joints=exempt,
            min_width=min_width,
            min_width_at=min_width_at,
            problems=tuple(problems),
        )
        if raise_on_error and problems:
            raise GeometryError("invalid outline: " + "; ".join(problems))
        return report

    def _has_symmetry(self, n: int, atol: float = 1e-6) -> bool:
        """Whether rotating every segment's start point, middle point (t = ½, which carries an arc's
        weight) and arc control point by 2π/n lands on one of those points."""
        from scipy.spatial import cKDTree

        segs = [s for loop in self.loops for s in loop.segments]
        arcs = [s for s in segs if isinstance(s, RationalQuad)]
        P = np.array(
            [s.start for s in segs]
            + [s.P1 for s in arcs]
            + [(s.P0 + 2.0 * s.w * s.P1 + s.P2) / (2.0 + 2.0 * s.w) for s in arcs]  # C(½), exact
            + [0.5 * (s.p0 + s.p1) for s in segs if isinstance(s, Line)]
        )
        c, s_ = math.cos(2 * math.pi / n), math.sin(2 * math.pi / n)
        R = P @ np.array([[c, s_], [-s_, c]])
        return bool(cKDTree(P).query(R)[0].max() <= atol)

    def _worst_g1(
        self, exempt_lines: Sequence[tuple[ArrayLike, ArrayLike]]
    ) -> tuple[float, NDArray[np.float64] | None, int]:
        """Largest tangent angle (rad) at arc joints, where, and how many joints were exempt."""
        at, u, v = [], [], []
        for loop in self.loops:
            segs = loop.segments
            for s, nxt in zip(segs, segs[1:] + segs[:1], strict=True):
                if isinstance(s, RationalQuad) or isinstance(nxt, RationalQuad):
                    at.append(s.end)
                    u.append(_end_direction(s))
                    v.append(_start_direction(nxt))
        if not at:
            return 0.0, None, 0
        P, U, W = np.array(at), _unit(np.array(u)), _unit(np.array(v))
        exempt_mask = np.zeros(len(P), dtype=bool)
        for a, b in exempt_lines:
            a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
            d = b - a
            exempt_mask |= np.abs(d[0] * (P[:, 1] - a[1]) - d[1] * (P[:, 0] - a[0])) <= 1e-6 * float(np.hypot(*d))
        angle = np.arctan2(np.abs(U[:, 0] * W[:, 1] - U[:, 1] * W[:, 0]), np.einsum("ij,ij->i", U, W))
        angle[exempt_mask] = -1.0
        k = int(np.argmax(angle))
        if angle[k] < 0:
            return 0.0, None, int(exempt_mask.sum())
        return float(angle[k]), P[k], int(exempt_mask.sum())

    # ---------------------------------------------------------------------------------- export

    def to_svg_path(self) -> str:
        """SVG path data (the ``d`` attribute) with the arcs as true curves, one subpath per loop.

        Numbers are the outline's own coordinates in mm with y up (wrap the path in
        ``transform="scale(1, -1)"`` to view it the usual way), written to 1e-6 mm. Lines become
        ``L``; elliptic arcs (w < 1) become exact elliptical-arc ``A`` commands from the conic
        conversion (the sweep flag is 1 for a counter-clockwise arc in these coordinates); parabolic
        arcs (w = 1) are exactly SVG's quadratic Bézier ``Q``; hyperbolic arcs (w > 1), which SVG
        cannot express, are flattened to ``L`` commands within ``SVG_FLATTEN_TOL`` = 0.001 mm.
        """
        return " ".join(loop_svg_path(loop) for loop in self.loops)


def loop_svg_path(loop: Loop) -> str:
    """One loop as an SVG subpath (``M … Z``), written as :meth:`Outline.to_svg_path` writes each loop."""
    p = loop.segments[0].start
    return " ".join([f"M {_fmt(p[0])} {_fmt(p[1])}", *(_svg_segment(s) for s in loop.segments), "Z"])


def _svg_segment(s: Segment) -> str:
    """One segment as SVG path commands (the current point is already its start)."""
    if isinstance(s, Line) or s.is_straight:
        return f"L {_fmt(s.end[0])} {_fmt(s.end[1])}"
    if abs(s.w - 1.0) <= 1e-12:
        return f"Q {_fmt(s.P1[0])} {_fmt(s.P1[1])} {_fmt(s.P2[0])} {_fmt(s.P2[1])}"
    if s.w > 1.0:
        return " ".join(f"L {_fmt(x)} {_fmt(y)}" for x, y in s.flatten(SVG_FLATTEN_TOL)[1:])
    e = s.to_conic().ellipse
    assert e is not None  # w < 1 is always an ellipse
    rx, ry = e.semi_axes
    large = 1 if e.end_param - e.start_param > math.pi else 0
    sweep = 0 if e.reversed else 1
    rot = math.degrees(e.rotation)
    return f"A {_fmt(rx)} {_fmt(ry)} {_fmt(rot)} {large} {sweep} {_fmt(s.P2[0])} {_fmt(s.P2[1])}"
