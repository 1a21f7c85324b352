"""The exact outline of a filleted pattern: straight segments and quadratic rational Bézier arcs.

An :class:`Outline` is one outer loop (counter-clockwise) plus hole loops (clockwise). Each loop is a
closed sequence of segments, each segment either a :class:`Line` or a :class:`RationalQuad`; the end
point of one segment is the start point of the next, and the last ends where the first starts.
Coordinates are millimetres in the polygon's plane, the polygon centre at the origin.

This is the exact geometry of the paper's §3.3: every approximation (flattening for DXF lines, STL,
the FE mesh) is derived from it with an explicit tolerance in mm. The curve mathematics lives in
:mod:`fabpat.curves`; the methods here are thin wrappers over it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fabpat import conics, curves, polyline
from fabpat.errors import GeometryError
from fabpat.metrics import RegionMetrics
from fabpat.validate import check

Point = NDArray[np.float64]  # shape (2,)

SVG_FLATTEN_TOL = 1e-3
"""mm: chord tolerance for the arcs SVG cannot draw exactly (hyperbolic, w > 1)."""


# The library's outlines reuse the same few hundred arcs (same lattice vertex, same edge pair) across
# hundreds of patterns, so memoising the two costly per-arc computations on the exact control points
# makes validating the whole library several times faster without changing any result.
@lru_cache(maxsize=1 << 16)
def _flatten(P: bytes, w: float, tol: float) -> NDArray[np.float64]:
    out = np.array(curves.flatten_quad(np.frombuffer(P).reshape(3, 2), w, tol))
    out.setflags(write=False)
    return out


@lru_cache(maxsize=1 << 16)
def _arc_length(P: bytes, w: float) -> float:
    return curves.quad_arc_length(np.frombuffer(P).reshape(3, 2), w)


def _point(p: object) -> Point:
    # A point made here owns its read-only data, so a segment may share another one's end point
    # instead of copying it (a read-only *view* could still change through its base: copied).
    if type(p) is np.ndarray and p.shape == (2,) and p.base is None and not p.flags.writeable and p.dtype == np.float64:
        return p
    a = np.array(p, dtype=np.float64)
    if a.shape != (2,):
        a = a.reshape(2).copy()
    a.setflags(write=False)
    return a


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


@dataclass(frozen=True, eq=False)
class Line:
    """Straight segment from ``p0`` to ``p1``."""

    p0: Point
    p1: Point

    def __post_init__(self) -> None:
        object.__setattr__(self, "p0", _point(self.p0))
        object.__setattr__(self, "p1", _point(self.p1))

    @property
    def start(self) -> Point:
        """Start point p0 (mm)."""
        return self.p0

    @property
    def end(self) -> Point:
        """End point p1 (mm)."""
        return self.p1

    def reversed(self) -> Line:
        """The same segment traversed from p1 to p0."""
        return Line(self.p1, self.p0)

    def point(self, t: ArrayLike) -> NDArray[np.float64]:
        """Points at t ∈ [0, 1] (float or (m,)): (2,) or (m, 2), mm."""
        return self.p0 + np.multiply.outer(np.asarray(t, dtype=np.float64), self.p1 - self.p0)

    def derivative(self, t: ArrayLike) -> NDArray[np.float64]:
        """dC/dt (mm per unit parameter): (2,) or (m, 2)."""
        return np.broadcast_to(self.p1 - self.p0, np.shape(t) + (2,)).copy()

    def tangent(self, t: ArrayLike) -> NDArray[np.float64]:
        """Unit tangent in the direction of travel: (2,) or (m, 2)."""
        return _unit(self.derivative(t))

    @cached_property
    def length(self) -> float:
        """mm."""
        return float(np.linalg.norm(self.p1 - self.p0))

    def flatten(self, tol: float) -> NDArray[np.float64]:
        """(2, 2): both end points (exact for any tol)."""
        return np.stack([self.p0, self.p1])

    @property
    def area_term(self) -> float:
        """∫ (x dy − y dx) / 2 along the segment, mm²; sums to a loop's signed area."""
        return 0.5 * float(self.p0[0] * self.p1[1] - self.p0[1] * self.p1[0])

    @property
    def polar_term(self) -> float:
        """∫ (x² + y²)(x dy − y dx) / 4 along the segment, mm⁴ (exact: the integrand is quadratic)."""
        a, b = self.p0, self.p1
        return float((a[0] * b[1] - a[1] * b[0]) * (a @ a + a @ b + b @ b) / 12.0)

    @property
    def bbox(self) -> NDArray[np.float64]:
        """(2, 2): [[xmin, ymin], [xmax, ymax]]."""
        return np.stack([np.minimum(self.p0, self.p1), np.maximum(self.p0, self.p1)])


@dataclass(frozen=True, eq=False)
class RationalQuad:
    """Quadratic rational Bézier arc with control points P0, P1, P2 and weights (1, w, 1).

    Every quadratic rational Bézier curve can be brought to this standard form (end weights 1) by a
    reparametrisation, so one weight describes it: w < 1 ellipse, w = 1 parabola, w > 1 hyperbola;
    w = cos(θ/2) with |P0P1| = |P1P2| gives a circular arc of opening angle θ.
    """

    P0: Point
    P1: Point
    P2: Point
    w: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "P0", _point(self.P0))
        object.__setattr__(self, "P1", _point(self.P1))
        object.__setattr__(self, "P2", _point(self.P2))
        object.__setattr__(self, "w", float(self.w))
        if not self.w > 0:
            raise ValueError(f"weight must be positive, got {self.w}")

    @property
    def start(self) -> Point:
        """Start point P0 (mm)."""
        return self.P0

    @property
    def end(self) -> Point:
        """End point P2 (mm)."""
        return self.P2

    @cached_property
    def control_points(self) -> NDArray[np.float64]:
        """(3, 2) float, read-only."""
        P = np.array([self.P0, self.P1, self.P2])
        P.setflags(write=False)
        return P

    @property
    def weights(self) -> NDArray[np.float64]:
        """(3,) float: (1, w, 1)."""
        return np.array([1.0, self.w, 1.0])

    def reversed(self) -> RationalQuad:
        """The same arc traversed from P2 to P0 (weight unchanged)."""
        return RationalQuad(self.P2, self.P1, self.P0, self.w)

    def point(self, t: ArrayLike) -> NDArray[np.float64]:
        """Points at t ∈ [0, 1] (float or (m,)) by homogeneous de Casteljau: (2,) or (m, 2), mm."""
        return curves.evaluate(self.control_points, self.weights, t)

    def derivative(self, t: ArrayLike) -> NDArray[np.float64]:
        """dC/dt (mm per unit parameter), exact: (2,) or (m, 2)."""
        return curves.derivative(self.control_points, self.weights, t)

    def tangent(self, t: ArrayLike) -> NDArray[np.float64]:
        """Unit tangent in the direction of travel: (2,) or (m, 2)."""
        # At the ends a Bézier curve is tangent to its control polygon (w > 0): no evaluation needed,
        # and the G1 check asks only for end tangents.
        if np.ndim(t) == 0 and float(t) in (0.0, 1.0):  # type: ignore[arg-type]
            d = self.P1 - self.P0 if float(t) == 0.0 else self.P2 - self.P1  # type: ignore[arg-type]
            if np.any(d):
                return _unit(d)
        return _unit(self.derivative(t))

    @cached_property
    def length(self) -> float:
        """Arc length, mm (adaptive Gauss–Kronrod, relative accuracy 1e-12)."""
        return _arc_length(self.control_points.tobytes(), self.w)

    def flatten(self, tol: float) -> NDArray[np.float64]:
        """(k, 2) read-only points on the arc, both ends included, polyline within tol mm of the arc."""
        return _flatten(self.control_points.tobytes(), self.w, float(tol))

    @cached_property
    def area_term(self) -> float:
        """∫ (x dy − y dx) / 2 along the arc, mm², closed form."""
        return curves.quad_area(self.control_points, self.w)

    @cached_property
    def polar_term(self) -> float:
        """∫ (x² + y²)(x dy − y dx) / 4 along the arc, mm⁴ (Gauss–Legendre, exact to rounding)."""
        return curves.quad_polar_moment(self.control_points, self.w)

    @cached_property
    def bbox(self) -> NDArray[np.float64]:
        """(2, 2): exact [[xmin, ymin], [xmax, ymax]]."""
        return curves.quad_bbox(self.control_points, self.w)

    @property
    def is_straight(self) -> bool:
        """True if the control points are collinear (the arc is then a straight segment)."""
        d1, d2 = self.P1 - self.P0, self.P2 - self.P0
        scale = max(float(np.abs(self.control_points - self.P0).max()), 1e-300)
        return abs(float(d1[0] * d2[1] - d1[1] * d2[0])) <= 1e-13 * scale * scale

    def split(self, t: float = 0.5) -> tuple[RationalQuad, RationalQuad]:
        """Exact split at t into two standard-form arcs (each re-normalised to weights (1, w', 1))."""
        (PL, wL), (PR, wR) = curves.split_quad(self.control_points, self.w, t)
        return RationalQuad(*PL, w=wL), RationalQuad(*PR, w=wR)

    def to_conic(self) -> conics.Conic:
        """The conic carrying the arc (ellipse with DXF parameters, or implicit coefficients)."""
        return conics.quad_to_conic(self.control_points, self.w)

    def fit_arcs(self, tol: float) -> list[conics.ArcTriple]:
        """Circular arcs within tol mm as (start, end, bulge) triples for a DXF LWPOLYLINE."""
        return conics.fit_arcs(self.control_points, self.w, tol)


Segment = Line | RationalQuad


def _start_direction(s: Segment) -> NDArray[np.float64]:
    """A (not normalised) tangent at the start: a Bézier curve leaves along its first control leg."""
    if isinstance(s, Line):
        return s.p1 - s.p0
    d = s.P1 - s.P0
    return d if d.any() else s.derivative(0.0)


def _end_direction(s: Segment) -> NDArray[np.float64]:
    """A (not normalised) tangent at the end."""
    if isinstance(s, Line):
        return s.p1 - s.p0
    d = s.P2 - s.P1
    return d if d.any() else s.derivative(1.0)


@dataclass(frozen=True, eq=False)
class Loop:
    """A closed chain of segments (outer: counter-clockwise, hole: clockwise)."""

    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        segments = self.segments
        if isinstance(segments, Line | RationalQuad) or not isinstance(segments, Sequence) or not all(
                isinstance(s, Line | RationalQuad) for s in segments):
            raise GeometryError(f"a Loop is a sequence of Line and RationalQuad segments, got {segments!r:.80}")
        object.__setattr__(self, "segments", tuple(segments))

    @cached_property
    def signed_area(self) -> float:
        """Signed enclosed area, mm² (> 0 counter-clockwise), exact (Green's theorem per segment)."""
        return math.fsum(s.area_term for s in self.segments)

    @cached_property
    def length(self) -> float:
        """mm."""
        return math.fsum(s.length for s in self.segments)

    @cached_property
    def polar_moment(self) -> float:
        """Signed ∫∫ (x² + y²) dA of the enclosed region about the origin, mm⁴ (< 0 if clockwise)."""
        return math.fsum(s.polar_term for s in self.segments)

    def flatten(self, tol: float) -> NDArray[np.float64]:
        """(k, 2): closed polyline within tol mm of the loop, last point not repeated."""
        return np.vstack([s.flatten(tol)[:-1] for s in self.segments])

    def gaps(self) -> NDArray[np.float64]:
        """(n,) distances from the end of segment i to the start of segment i + 1 (cyclic), mm."""
        segs = self.segments
        ends = np.array([s.end for s in segs])
        starts = np.array([s.start for s in segs[1:] + segs[:1]])
        return np.linalg.norm(ends - starts, axis=1)

    def is_closed(self, atol: float = 1e-9) -> bool:
        """True if every segment ends within atol mm of where the next one (cyclically) starts."""
        return bool(self.segments) and bool(self.gaps().max() <= atol)

    def reversed(self) -> Loop:
        """The same loop traversed the other way."""
        return Loop(tuple(s.reversed() for s in reversed(self.segments)))

    @cached_property
    def bbox(self) -> NDArray[np.float64]:
        """(2, 2): exact [[xmin, ymin], [xmax, ymax]]."""
        B = np.array([s.bbox for s in self.segments])
        return np.stack([B[:, 0].min(axis=0), B[:, 1].max(axis=0)])


@dataclass(frozen=True)
class OutlineReport:
    """What :meth:`Outline.validate` found. Lengths in mm, angles in radians.

    ``simple``: no loop touches or crosses itself or another loop (on a flattening at the validation
    tolerance). ``orientation_ok``: outer counter-clockwise, holes clockwise. ``holes_inside``: every
    hole inside the outer loop and outside the other holes. ``worst_g1_angle``: the largest angle
    between the tangents at a joint where an arc meets another segment (exempt joints excluded).
    ``min_width``: see :func:`fabpat.polyline.ray_min_width`; ``min_width_at`` are the two ends of the
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
    flattening routines of :mod:`fabpat.curves` need tol > 0 (they raise a bare ValueError)."""
    try:
        value = float(tol)  # type: ignore[arg-type]
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
    polygon edge i, from M − d to M + d counter-clockwise (see :mod:`fabpat.fillet`).
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
        from fabpat.pictures import outline_svg

        return outline_svg(self)

    def plot(self, ax: Any = None, *, tol: float = 0.01, color: str = "black", **kwargs: Any) -> Any:
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

        Raises :class:`GeometryError` if ``tol`` is not a positive number."""
        tol = flattening_tolerance(tol)
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
            problems.append(
                f"not G1: tangents differ by {math.degrees(worst):.4g}° at an arc joint near "
                f"({worst_at[0]:.4f}, {worst_at[1]:.4f})"  # type: ignore[index]
            )

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
        out: list[str] = []
        for loop in self.loops:
            p = loop.segments[0].start
            out.append(f"M {_fmt(p[0])} {_fmt(p[1])}")
            for s in loop.segments:
                out.append(_svg_segment(s))
            out.append("Z")
        return " ".join(out)


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
