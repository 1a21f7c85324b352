"""The segments of an outline: straight :class:`Line` pieces, quadratic rational Bézier arcs
(:class:`RationalQuad`, paper §3.3) and the closed :class:`Loop` chains of them that an
:class:`fabpat.geometry.outline.Outline` is made of. Coordinates in mm; the curve mathematics lives in
:mod:`fabpat.geometry.curves`, and these classes are thin exact wrappers over it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fabpat.errors import GeometryError
from fabpat.geometry import conics, curves

Point = NDArray[np.float64]  # shape (2,)


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
        if np.ndim(t) == 0 and (t0 := float(np.asarray(t, dtype=np.float64))) in (0.0, 1.0):
            d = self.P1 - self.P0 if t0 == 0.0 else self.P2 - self.P1
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
        return RationalQuad(PL[0], PL[1], PL[2], w=wL), RationalQuad(PR[0], PR[1], PR[2], w=wR)

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
