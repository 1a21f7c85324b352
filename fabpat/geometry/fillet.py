"""Filleting: the exact, fabricable outline of a solid pattern (paper §3.3).

The solid pattern is a union of lattice triangles; its boundary has *problematic vertices*:

* **non-manifold** — the link is disconnected (two or more solid runs around the vertex);
* **sharp** — one solid run whose angle is not a straight angle (decided by the actual angle, so
  at fan boundaries of non-hexagons a three-triangle run can be a real corner, and a vertex whose run
  is exactly 180° is straight);
* **interface** — the polygon-edge midpoint where the pattern meets its neighbour.

The paper refines the mesh once (1-to-4) so that the open stars of problematic vertices are disjoint,
then replaces pairs of boundary half-edges at each problematic vertex by a quadratic rational Bézier
arc with control polygon (midpoint of one edge, the vertex, midpoint of the other). We do exactly that,
working on the boundary directly: every boundary edge is split at its midpoint, the half next to a
vertex belongs to that vertex's star, and the arc at a vertex spans the two halves it joins.

The lookup rule (one rule that covers every star — see :data:`HEXAGON_STAR_TABLE` for the table it
gives on the hexagon lattice). Walking the boundary with the solid on the left, each incoming boundary
edge at a vertex is joined to the outgoing edge **across its void run** (never around a solid run):

* one solid run (sharp vertex): that is the only choice; the arc lies in the wedge narrower than 180°,
  so a convex corner is **rounded** (material removed) and a concave one **filled** (material added);
* two or more solid runs (non-manifold vertex): every void run is **bridged** — narrower than 180°:
  an arc fills its corner; exactly 180°: the boundary passes straight; wider than 180° (only at fan
  boundaries of non-hexagons, where the other runs together make a convex corner): the arc rounds that
  convex corner, which is narrower than the bridges next to it, so the solid stays connected.
  Only material is added at void runs ≤ 180°, so the pattern stays connected and no vertex stays pinched.
* each half-edge carries at most one arc (it belongs to exactly one vertex star), and two arcs ending
  at the same edge midpoint are both tangent to that edge: G1 by construction.
* interior arcs have weights (1, 1, 1) (parabolic arcs, as in the paper), except that a
  :class:`~fabpat.patterns.variation.Variation` may give the bridging arcs at non-manifold vertices another
  middle weight (``bridge_weight``: the pattern's continuous family; interfaces never change).

Interface vertices (notes, "A consistent interface geometry"): the bow-tie that forms when a
neighbour is attached is bridged with the arc (P0, M, P0') of weights (1, w, 1), where P0 is the
midpoint of the solid sub-triangle's side leaving M and P0' its mirror image across the polygon edge.
The arc crosses the edge at its parameter midpoint, at right angles, at distance
``d = (edge/16) / (1 + w)`` from M (1.875 mm for edge 36, w = 0.2, every n). Each pattern keeps its own
half (an exact de Casteljau split at t = ½, stored in standard form with middle weight √((1 + w)/2)),
and the outline runs straight along the polygon edge from M − d to M + d: the **interface segment**,
identical for every pattern and every n with the same edge length, so any two patterns connect.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeGuard, Unpack

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError, GeometryError
from fabpat.geometry.outline import Line, Loop, Outline, OutlineReport, PolygonFrame, RationalQuad, Segment
from fabpat.geometry.stars import (
    _ANGLE_EPS,
    HEXAGON_STAR_TABLE,
    StarRun,
    VertexStar,
    _boundary_half_edges,
    _interface_vertices,
    classify,
    star_actions,
    star_runs,
    star_table,
    vertex_stars,
)
from fabpat.patterns.lattice import polygon_vertices
from fabpat.patterns.metrics import RegionMetrics
from fabpat.patterns.pattern import Pattern
from fabpat.patterns.variation import PAPER_VARIATION, Variation
from fabpat.validate import check, check_path

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from fabpat.exchange.registry import ExportOptions

__all__ = ["DEFAULT_WEIGHT", "HEXAGON_STAR_TABLE", "FilletedPattern", "StarRun", "VertexStar", "classify",
           "fillet_pattern", "fillet_solid", "interface_half_length", "star_actions", "star_runs", "star_table",
           "vertex_stars"]

DEFAULT_WEIGHT = 0.2  # interface weight of the paper (§3.3)
_LEN_EPS = 1e-9  # mm


@dataclass(frozen=True, eq=False)
class FilletedPattern:
    """A pattern's exact outline and the data that explains it; made by :meth:`Pattern.fillet
    <fabpat.patterns.pattern.Pattern.fillet>` or :func:`fillet_pattern`.

    It knows its polygon (``sides``, ``edge`` mm, ``depth``) and interface ``weight``, and its
    ``outline`` carries them (:class:`~fabpat.geometry.outline.PolygonFrame`), so meshing and the scenarios
    never ask again. ``interface_segments`` (n, 2, 2): the straight piece of the outline on each
    polygon edge, from M − d to M + d (counter-clockwise). ``interface_arcs``: for each polygon edge
    the two full bow-tie arcs (P0, M, P0', w) whose halves the outline keeps — their middle weight is
    the configured w; :attr:`support_arcs` is the same arcs as one flat tuple. ``variation``: the
    family member (:class:`~fabpat.patterns.variation.Variation`; the paper's fillets by default) that the outline
    *is*: a pattern without non-manifold vertices has no bridging arc, so every member of its family is
    the paper's outline and is recorded as the paper's (:func:`fillet_pattern`).
    """

    pattern: Pattern
    weight: float
    outline: Outline
    interface_segments: NDArray[np.float64]
    interface_arcs: tuple[tuple[RationalQuad, RationalQuad], ...]
    variation: Variation = PAPER_VARIATION

    @property
    def id(self) -> str:
        """The pattern's hex ID (e.g. ``"0x0488"``)."""
        return self.pattern.id

    @property
    def label(self) -> str:
        """The ID and, for a family member, its tag: ``"0x0488"``, ``"0x0488 b0.5"``
        (:meth:`~fabpat.patterns.variation.Variation.tag`) — what parts, sheets and pictures call it."""
        tag = self.variation.tag()
        return f"{self.id} {tag}" if tag else self.id

    @property
    def sides(self) -> int:
        """Number of sides n of the regular polygon."""
        return self.pattern.sides

    @property
    def edge(self) -> float:
        """Polygon edge length, mm."""
        return self.pattern.edge

    @property
    def depth(self) -> int:
        """Subdivision depth of the pattern's slice."""
        return self.pattern.depth

    @property
    def support_arcs(self) -> tuple[RationalQuad, ...]:
        """The interface bow-tie arcs as one flat tuple (2n arcs): the ``support`` of an exported part,
        so STEP and .3dm carry the interface weight w exactly."""
        return tuple(arc for pair in self.interface_arcs for arc in pair)

    def polygon_edges(self) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """The polygon's n edges as (start corner, end corner) pairs of (2,) points in mm, counter-clockwise."""
        corners = polygon_vertices(self.pattern.sides, self.pattern.edge)
        return [(corners[i], corners[(i + 1) % len(corners)]) for i in range(len(corners))]

    def validate(self, tol: float = 1e-2, *, raise_on_error: bool = True, width: bool = True) -> OutlineReport:
        """:meth:`Outline.validate` with the polygon edges exempt from the G1 check.

        The interface arcs meet the interface segment at right angles by design: across the joint
        the neighbour's arc continues with the same tangent, so the assembled boundary is G1. The
        pattern's n-fold symmetry is checked and lets min_width cast rays from one fan sector.
        """
        return self.outline.validate(
            tol,
            raise_on_error=raise_on_error,
            g1_exempt_lines=self.polygon_edges(),
            width=width,
            symmetry=self.pattern.sides,
        )

    @property
    def metrics(self) -> RegionMetrics:
        """Exact area (mm²), perimeter (mm), ratio 4πA/P² and polar moment (mm⁴) of the outline: the
        same :class:`~fabpat.patterns.metrics.RegionMetrics` as
        :attr:`Pattern.metrics <fabpat.patterns.pattern.Pattern.metrics>`
        for the lattice triangles."""
        return self.outline.metrics

    def min_width(self, tol: float = 1e-2) -> float:
        """Narrowest feature (mm) on a ``tol`` mm flattening; validates the outline first (an invalid
        one raises :class:`GeometryError`)."""
        return self.validate(tol).min_width

    def catalog_columns(self, tol: float = 1e-2) -> dict[str, float]:
        """The filleted columns of ``fabpat library`` and the catalog: ``filleted_area`` (mm²),
        ``filleted_perimeter`` (mm), ``filleted_ratio``, ``filleted_polar_moment`` (mm⁴) and
        ``min_width`` (mm, on a ``tol`` mm flattening). Raises :class:`GeometryError` if invalid."""
        width = self.min_width(tol)
        m = self.metrics
        return {
            "filleted_area": m.area,
            "filleted_perimeter": m.perimeter,
            "filleted_ratio": m.ratio,
            "filleted_polar_moment": m.polar_moment,
            "min_width": width,
        }

    @property
    def interface_half_length(self) -> float:
        """d = (edge/16)/(1 + w) for depth 2; in general half the sub-edge over 2(1 + w)."""
        seg = self.interface_segments
        return float(np.linalg.norm(seg[0, 1] - seg[0, 0]) / 2)

    def export(self, path: str | os.PathLike[str], **options: Unpack[ExportOptions]) -> Path:
        """Write a fabrication file, the format chosen by the suffix (.step .stl .3mf .dxf .svg .3dm, and
        any format registered in :mod:`fabpat.exchange.registry`), by the same code as ``fabpat export``.

        ``options``: ``thickness`` (mm, default 2) and the :class:`~fabpat.exchange.registry.ExportSettings`
        fields (``mesh_tolerance``, ``curve_tolerance``, ``kerf`` mm, ``curves``, ``dxf_version``, …).
        Atomic: on error no file is left. Raises :class:`~fabpat.errors.ExportError` for a path that is
        not a file name (not a str or path-like, or holding a NUL), an unknown suffix or option. Returns
        the path written.
        """
        # The writers are the exchange stage's: imported when called, so filleting does not load them.
        from fabpat.exchange.registry import export_filleted

        return export_filleted(self, check_path(path, "the export path", error=ExportError), **options)

    def plot(self, ax: Axes | None = None, *, tol: float = 0.01, color: str = "black", **kwargs: object) -> Axes:
        """:meth:`Outline.plot` of the outline (matplotlib; returns the axes)."""
        return self.outline.plot(ax, tol=tol, color=color, **kwargs)

    def __repr__(self) -> str:
        family = f", {self.variation.label()}" if not self.variation.is_paper else ""
        return (f"FilletedPattern('{self.id}', sides={self.sides}, edge={self.edge:g} mm, weight={self.weight:g}"
                f"{family}, area={self.metrics.area:.1f} mm²)")

    def _repr_svg_(self) -> str:
        """Notebook picture: the exact filleted outline (true curves) in its polygon, true size (mm)."""
        from fabpat.views.pictures import outline_svg

        p = self.pattern
        return outline_svg(self.outline, title=f"{self.label} ({p.sides}-gon, edge {p.edge:g} mm)")


def interface_half_length(edge: float, depth: int = 2, weight: float = DEFAULT_WEIGHT) -> float:
    """Distance from the edge midpoint to each end of the interface segment (mm).

    The solid sub-triangle's side leaving M has its midpoint P0 whose projection on the edge lies
    half of half a sub-triangle base, edge / 2**(depth+2), from M; the arc crosses at that over (1 + w).
    """
    return edge / 2 ** (depth + 2) / (1.0 + weight)


def _bowtie(P0: NDArray[np.float64], M: NDArray[np.float64], t: NDArray[np.float64], w: float) -> RationalQuad:
    """The full interface arc (P0, M, mirror of P0 across the edge line through M along t)."""
    rel = P0 - M
    mirror = M + 2 * (rel @ t) * t - rel
    return RationalQuad(P0, M, mirror, w)


def _midpoint(arc: RationalQuad) -> NDArray[np.float64]:
    """B(½) of a (1, w, 1) arc: (P0 + 2w P1 + P2) / (2 + 2w)."""
    return (arc.P0 + 2 * arc.w * arc.P1 + arc.P2) / (2 + 2 * arc.w)


def _halves(arc: RationalQuad) -> tuple[RationalQuad, RationalQuad]:
    """Exact de Casteljau split of a (1, w, 1) arc at t = ½, both halves in standard form.

    In homogeneous coordinates the left half has control points P0, (P0 + w P1)/2 and the midpoint,
    weights 1, (1 + w)/2, (1 + w)/2; bringing it to standard form gives the middle weight
    √((1 + w)/2) (see :func:`fabpat.geometry.curves.standardize_quad`, which the tests use to check this).
    """
    w, mid = arc.w, _midpoint(arc)
    ws = math.sqrt((1 + w) / 2)
    left = RationalQuad(arc.P0, (arc.P0 + w * arc.P1) / (1 + w), mid, ws)
    right = RationalQuad(mid, (w * arc.P1 + arc.P2) / (1 + w), arc.P2, ws)
    return left, right


def _merge_collinear(segs: list[Segment]) -> list[Segment]:
    """Join consecutive collinear lines (the boundary passing straight through a vertex)."""

    def joinable(a: Segment, b: Segment) -> TypeGuard[Line]:
        """Whether ``a`` and ``b`` are both lines that continue each other (``a`` narrowed to a Line)."""
        if not (isinstance(a, Line) and isinstance(b, Line)):
            return False
        u, v = a.p1 - a.p0, b.p1 - b.p0
        return bool(abs(u[0] * v[1] - u[1] * v[0]) < 1e-12 * max(1.0, float(u @ u)) * max(1.0, float(v @ v)) ** 0.5
                    and u @ v > 0)

    out: list[Segment] = []
    for s in segs:
        last = out[-1] if out else None
        if last is not None and joinable(last, s):
            out[-1] = Line(last.p0, s.end)
        else:
            out.append(s)
    while len(out) > 1 and joinable(last := out[-1], out[0]):
        out[0] = Line(last.p0, out[0].end)
        out.pop()
    return out


def fillet_solid(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    interfaces: dict[int, NDArray[np.float64]] | None = None,
    weight: float = DEFAULT_WEIGHT,
    variation: Variation = PAPER_VARIATION,
) -> tuple[Outline, dict[int, tuple[RationalQuad, RationalQuad]]]:
    """Exact outline of the union of solid triangles ``F`` (k, 3, counter-clockwise) over ``V`` (n, 2).

    ``interfaces`` maps a vertex (a polygon-edge midpoint) to the unit tangent of its polygon edge
    (counter-clockwise); those vertices get the interface treatment with weight ``weight``; the arcs at
    non-manifold vertices get ``variation.bridge_weight`` (1 in the paper). Returns
    the outline and, per interface vertex, the two full bow-tie arcs whose halves the outline keeps.
    Raises :class:`GeometryError` if the boundary cannot be traced into one outer loop plus holes.

    Long because it walks every vertex of the pattern once and decides its fillet in place (the paper's §3.3
    cases in order).
    """
    interfaces = interfaces or {}
    H = _boundary_half_edges(F, len(V))
    if len(H) == 0:
        raise GeometryError("the solid region has no boundary")
    # Each incoming boundary half-edge continues with the first outgoing one counter-clockwise
    # from it at its head, i.e. across the void run; all heads at once, grouped by sort.
    order = np.argsort(H[:, 0], kind="stable")
    lo = np.searchsorted(H[order, 0], H[:, 1], side="left")
    count = np.searchsorted(H[order, 0], H[:, 1], side="right") - lo
    if not count.all():
        raise GeometryError(f"boundary is open at vertex {int(H[np.argmin(count), 1])}")
    hh = np.repeat(np.arange(len(H)), count)
    gg = order[lo[hh] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)]
    d_in, d_out = V[H[:, 0]] - V[H[:, 1]], V[H[:, 1]] - V[H[:, 0]]
    a_in, a_out = np.arctan2(d_in[:, 1], d_in[:, 0]), np.arctan2(d_out[:, 1], d_out[:, 0])
    turn = np.mod(a_out[gg] - a_in[hh], 2 * math.pi)
    turn[turn <= 1e-12] = 2 * math.pi
    pick = np.lexsort((turn, hh))
    pick = pick[np.searchsorted(hh[pick], np.arange(len(H)))]
    nxt = gg[pick]
    is_interface = np.isin(H[:, 1], np.fromiter(interfaces, dtype=np.int64, count=len(interfaces)))
    # the connection at the head of h is an arc (or interface) unless the boundary runs straight on
    arc_at_end = is_interface | (np.abs(turn[pick] - math.pi) > _ANGLE_EPS)

    prev_arc = np.zeros(len(H), dtype=bool)
    prev_arc[nxt] = arc_at_end
    mid = (V[H[:, 0]] + V[H[:, 1]]) / 2

    bowties: dict[int, tuple[RationalQuad, RationalQuad]] = {}
    segments_of: list[list[Segment]] = []
    for h, (a, b) in enumerate(H):
        p = mid[h] if prev_arc[h] else V[a]
        q = mid[h] if arc_at_end[h] else V[b]
        segs: list[Segment] = []
        if np.linalg.norm(q - p) > _LEN_EPS:
            segs.append(Line(p, q))
        g = int(nxt[h])
        if int(b) in interfaces:
            t, M = interfaces[int(b)], V[b]
            into, out_of = _bowtie(mid[h], M, t, weight), _bowtie(mid[g], M, t, weight).reversed()
            first, second = _halves(into)[0], _halves(out_of)[1]
            bowties[int(b)] = (into, out_of)
            segs += [first, Line(first.P2, second.P0), second]
        elif arc_at_end[h]:
            # more than one boundary edge leaves b: b is non-manifold and the arc bridges a void run
            segs.append(RationalQuad(mid[h], V[b], mid[g], variation.bridge_weight if count[h] > 1 else 1.0))
        segments_of.append(segs)

    loops: list[Loop] = []
    seen = np.zeros(len(H), dtype=bool)
    for start in range(len(H)):
        if seen[start]:
            continue
        segs = []
        h = start
        while not seen[h]:
            seen[h] = True
            segs += segments_of[h]
            h = int(nxt[h])
        if h != start:
            raise GeometryError("boundary walk did not close")
        loops.append(Loop(tuple(_merge_collinear(segs))))

    outer = [k for k, lp in enumerate(loops) if lp.signed_area > 0]
    if len(outer) != 1:
        raise GeometryError(f"filleted outline has {len(outer)} outer loops, expected 1 (the solid is not one piece)")
    holes = tuple(lp for k, lp in enumerate(loops) if k != outer[0])
    return Outline(loops[outer[0]], holes), bowties



def checked_inputs(caller: str, pattern: object, weight: object,
                   variation: object) -> tuple[float, Variation]:
    """The interface ``weight`` in its range and the family member (None: the paper's) of a filleting call named
    ``caller``; GeometryError, one line, for a ``pattern`` that is no :class:`Pattern`, a weight out of range or a
    ``variation`` that is no :class:`~fabpat.patterns.variation.Variation`."""
    if not isinstance(pattern, Pattern):
        raise GeometryError(f"{caller} needs a Pattern (fabpat.pattern('0x0488')), got {type(pattern).__name__}")
    w = check("weight", weight, "interface weight", error=GeometryError)
    if variation is None:
        return w, PAPER_VARIATION
    if not isinstance(variation, Variation):
        raise GeometryError(f"variation must be a fabpat.Variation, got {type(variation).__name__}")
    return w, variation

def fillet_pattern(pattern: Pattern, weight: float = DEFAULT_WEIGHT,
                   variation: Variation | None = None) -> FilletedPattern:
    """The exact outline of a library pattern: lines and quadratic rational Bézier arcs.

    ``weight``: the middle weight w of the interface arcs (the paper's 0.2), in its range
    (fabpat.validate: GeometryError otherwise). ``variation``: the family member
    (:class:`~fabpat.patterns.variation.Variation`: interior fillet weights; None = the paper's). A pattern
    without non-manifold vertices (0x0f88) has no arc the variation acts on: its outline, and the
    ``variation`` it records, are the paper's.
    Raises :class:`GeometryError` if the pattern cannot be filleted (not expected for library patterns).
    """
    weight, variation = checked_inputs("fillet_pattern", pattern, weight, variation)
    corners = polygon_vertices(pattern.sides, pattern.edge)
    tangents = np.roll(corners, -1, axis=0) - corners
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    iface = _interface_vertices(pattern)
    try:
        outline, bowties = fillet_solid(
            pattern.V, pattern.solid_faces, {v: tangents[i] for v, i in iface.items()}, weight, variation
        )
    except GeometryError as e:
        raise GeometryError(f"pattern {pattern.id} ({pattern.sides}-gon): {e}") from e
    if len(bowties) != pattern.sides:
        raise GeometryError(f"pattern {pattern.id} does not reach every polygon edge")
    arcs = tuple(bowties[v] for v, _ in sorted(iface.items(), key=lambda kv: kv[1]))
    seg = np.array([[_midpoint(a), _midpoint(b)] for a, b in arcs])
    outline = replace(outline, polygon=PolygonFrame(pattern.sides, pattern.edge, seg))
    if not variation.is_paper and not any(star.kind == "non-manifold" for star in vertex_stars(pattern)):
        variation = PAPER_VARIATION  # no bridging arc: the member's outline is the paper's, and says so
    return FilletedPattern(pattern, float(weight), outline, seg, arcs, variation)


