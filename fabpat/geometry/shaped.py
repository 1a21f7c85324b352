"""Shaped plates: a pattern filleted inside its mesh face's own (almost regular, planar) polygon.

A regular plate is the pattern's slice copied into the n fan triangles (centre, v_i, v_{i+1}) of the
regular n-gon (paper §3.1). A shaped plate copies it into the fan triangles (c', p_i, p_{i+1}) of a
given convex polygon p instead: slice f is carried by the **affine** map taking (0, v_f, v_{f+1}) to
(c', p_f, p_{f+1}), which sends lattice point (i, j) of fan f to c' + (i (p_f − c') + j (p_{f+1} − c'))/N,
N = 2^depth. The unfilleted triangulation (the lattice vertices V and solid triangles F that
:func:`~fabpat.geometry.fillet.fillet_pattern` fillets) is mapped this way and filleted by the same
:func:`~fabpat.geometry.fillet.fillet_solid`, the interfaces at the mapped edge midpoints with the
edges' own tangents.

Why it is exact: the fillet is built on straight-edged triangles, whatever their shape; an affine map
(a projective map too) keeps the triangles straight-edged, so every curve of the shaped outline is
again a line or a quadratic rational Bézier arc with the fillet's weights (1 inside, the bridge
weight of the variation at non-manifold vertices, w at the interfaces), constructed on the mapped
triangles exactly as on a regular plate: no approximation enters. Adjacent slices' maps agree on
their shared spoke (both send it to the segment c' → p_{f+1} with the same lattice spacing), so the
mapped triangulation is conforming and the vertex indices of the regular pattern serve unchanged.

What changes:

* slices are affinely distorted, so a boundary that ran straight across a spoke in the regular plate
  (two cells of adjacent slices in line) may kink there; the kink is filleted like any sharp corner,
  with a (1, 1, 1) arc, so cell corners along spokes may gain small arcs the regular plate has not;
* the interface. Each edge's midpoint M is a lattice point (affine maps keep midpoints), so two
  plates sharing a mesh edge place M identically; their interface segments must coincide too. The
  bow-tie (P0, M, P0', w), P0 the midpoint of a slice side leaving M, crosses the edge at
  M + ((P0 − M)·t / (1 + w)) t; on a regular plate the two sides leaving M project on the edge
  symmetrically and the segment runs from M − d t to M + d t, d = ``interface_half_length(edge, depth, w)``.
  Under the affine map they project in the ratio σ : 1 − σ, σ the place along the edge of c''s foot,
  a property of the face, not of the edge: the segment would be off-centre, by a different amount on
  each of the two plates. So the two lattice points joined to M inside the fan (the far corners of the
  triangle that touches the edge at M only) are slid parallel to the edge, along their lattice row,
  by (½ − σ) L_e / N, which puts them symmetric about M's normal (the least change that does; at
  depth 1, where they lie on spokes shared by two edges, each is moved the least that satisfies both
  edges). The triangle at M is then isosceles like the regular one, the bow-ties keep the weight w,
  and the interface segment is the edge's own: centred on its midpoint, half-length
  ``interface_half_length(L_e, depth, w)``, scaled by L_e / edge from the regular plate's
  (:attr:`ShapedPattern.interface_half_lengths`, one sleeve per edge). At depth ≥ 2 the moved points
  stay on their row's line and move less than half a lattice step, so the triangles stay valid for
  any convex polygon (at depth 1 the fillet checks them like any triangulation). The triangulation is
  still straight-edged, so the outline is still exact. Where c''s foot falls outside an edge (σ < 0
  or > 1: a stretched octagon, 20.7 % / 15.6°) the slide exceeds half a lattice step and the outline
  crossed itself for every pattern tried: such a polygon is refused.

The centre c' is the polygon's vertex centroid. It commutes with affine maps: for a polygon that is an
affine image of the regular one (a stretched or sheared face), every slice's map is that one affine
map, so the plate is exactly the regular plate's affine image (up to the interface slides) and no
spoke kinks. It also keeps the fans fat: the point closest to every edge's perpendicular bisector
(the circumcentre, when there is one) would need no slides, but it leaves a triangle's fans flat, or
outside it for an obtuse one; on 10 random triangles within 25 % / 20° it gave the narrowest neck
0.05× the regular plate's where the centroid gives 0.45×, and the same as the centroid for n = 4, 6.

Measured (:data:`MAX_IRREGULARITY`; stretched, sheared, jittered and cyclic polygons, every 5th or
10th depth-2 library pattern, n = 3…8, :meth:`ShapedPattern.validate` at 0.01 mm): the fillet never
failed and every outline validated, on hexagons up to 50 % edge / 25° angle deviation; what gives is
the narrowest neck, which shrinks with the shortest edge and the flattest fan. Within 20 % / 15° it
stayed ≥ 0.61× the regular plate's for n = 3…6 and ≥ 0.49× for n = 8 (≥ 0.70× within 15 % / 10°,
down to 0.45× within 25 % / 20°); the library's narrowest regular neck being 1.95 mm at the paper's
36 mm edge, 20 % / 15° keeps every plate ≥ 0.95 mm wide there, and admits the faces of the geodesic
Goldberg spheres (≤ 8.1 % / 6.0° up to GP(5, 0)) and the planar ones up to GP(4, 0) (18.4 % / 5.1°).
The limit is 20 % / 20°: a target's mapped faces need the corners (an egg of 1.1 : 1 bends GP(3, 0)'s faces
16.5° out of regular), the narrowest neck stays ≥ 0.45× the regular plate's for n = 3…6 (≥ 0.88 mm at 36 mm,
above the 0.8 mm a print or a cut holds), the one polygon that broke every pattern inside it (an octagon,
20.7 % / 15.6°) is refused by the centroid-foot check, and a kit's own width check still refuses a plate too
narrow for its process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fabpat.errors import GeometryError
from fabpat.geometry.fillet import (
    DEFAULT_WEIGHT,
    FilletedPattern,
    _midpoint,
    checked_inputs,
    fillet_solid,
    interface_half_length,
)
from fabpat.geometry.outline import OutlineReport, PolygonFrame
from fabpat.geometry.stars import _interface_vertices, vertex_stars
from fabpat.patterns.pattern import Pattern, pattern_topology
from fabpat.patterns.variation import PAPER_VARIATION, Variation

__all__ = ["MAX_IRREGULARITY", "ShapedPattern", "irregularity", "shape_pattern"]

MAX_IRREGULARITY: tuple[float, float] = (0.20, math.radians(20.0))
"""(relative edge deviation, angle deviation in rad) beyond which :func:`shape_pattern` refuses a polygon."""


@dataclass(frozen=True, eq=False, kw_only=True)
class ShapedPattern(FilletedPattern):
    """A pattern's exact outline in its own polygon; made by :func:`shape_pattern`.

    Everything a :class:`~fabpat.geometry.fillet.FilletedPattern` has, so exporting (STEP, DXF, SVG,
    STL, …) and meshing take it unchanged: ``pattern`` is the library pattern in the regular n-gon of
    the polygon's mean edge (``edge``, mm); ``interface_segments`` (n, 2, 2) mm and the outline's
    :class:`~fabpat.geometry.outline.PolygonFrame` are the true interface segments, on the polygon's
    own edges; ``interface_arcs`` the bow-ties (weights w). Besides: ``corners`` (n, 2) mm, the
    polygon, counter-clockwise; ``centre`` (2,) mm, the fans' common apex c'; ``interface_half_lengths``
    (n,) mm, each edge's ``interface_half_length(L_e, depth, w)`` (a sleeve per edge; the inherited
    scalar ``interface_half_length`` is edge 0's); ``irregularity`` (relative edge deviation, angle
    deviation rad) of the polygon (:func:`irregularity`).
    """

    corners: NDArray[np.float64]
    centre: NDArray[np.float64]
    interface_half_lengths: NDArray[np.float64]
    irregularity: tuple[float, float]

    def polygon_edges(self) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """The polygon's n edges as (start corner, end corner) pairs of (2,) points in mm, counter-clockwise."""
        P = self.corners
        return [(P[i], P[(i + 1) % len(P)]) for i in range(len(P))]

    def validate(self, tol: float = 1e-2, *, raise_on_error: bool = True, width: bool = True) -> OutlineReport:
        """:meth:`Outline.validate <fabpat.geometry.outline.Outline.validate>` with the polygon's own
        edges exempt from the G1 check (the interface arcs meet them at right angles by design) and no
        symmetry assumed. Raises :class:`GeometryError` if invalid and ``raise_on_error``."""
        return self.outline.validate(tol, raise_on_error=raise_on_error, g1_exempt_lines=self.polygon_edges(),
                                     width=width)

    def __repr__(self) -> str:
        edge, angle = self.irregularity
        return (f"ShapedPattern('{self.id}', sides={self.sides}, mean edge={self.edge:g} mm, "
                f"irregularity {100 * edge:.1f} % / {math.degrees(angle):.1f}°, area={self.metrics.area:.1f} mm²)")


def _polygon(polygon: ArrayLike) -> NDArray[np.float64]:
    """``polygon`` as an (n, 2) float array of finite mm, n ≥ 3, or :class:`GeometryError`."""
    try:
        P = np.array(polygon, dtype=np.float64)
    except (TypeError, ValueError):
        raise GeometryError(f"the polygon must be an (n, 2) array of mm, got {polygon!r:.80}") from None
    if P.ndim != 2 or P.shape[1] != 2 or len(P) < 3:
        raise GeometryError(f"the polygon must be an (n, 2) array of mm with n ≥ 3, got shape {P.shape}")
    if not np.isfinite(P).all():
        raise GeometryError("the polygon's corners must be finite numbers of mm")
    return P


def _turns(P: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n,) signed turning angle (rad) at each corner, counter-clockwise positive."""
    E = np.roll(P, -1, axis=0) - P
    prev = np.roll(E, 1, axis=0)
    return np.arctan2(prev[:, 0] * E[:, 1] - prev[:, 1] * E[:, 0], np.einsum("ij,ij->i", prev, E))


def irregularity(polygon: ArrayLike) -> tuple[float, float]:
    """How far a polygon (n, 2) mm is from the regular n-gon of its mean edge: (the largest
    |L_e − L̄| / L̄ over its edges, the largest |interior angle − (n − 2)π/n| in rad over its corners).

    Both are 0 for a regular polygon. A clockwise or reflex corner counts by its actual interior angle.
    Raises :class:`GeometryError` for an array that is not (n ≥ 3, 2) finite numbers or has an edge of
    length 0.
    """
    P = _polygon(polygon)
    L = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    if not (L > 0).all():
        raise GeometryError(f"the polygon has an edge of length 0 (corner {int(np.argmin(L))})")
    mean = float(L.mean())
    return float(np.abs(L - mean).max() / mean), float(np.abs(_turns(P) - 2 * math.pi / len(P)).max())


def _check_tolerance(tolerance: tuple[float, float]) -> tuple[float, float]:
    """``tolerance`` as two non-negative floats, or :class:`GeometryError`."""
    try:
        edge, angle = (float(x) for x in tolerance)
    except (TypeError, ValueError):
        raise GeometryError(f"tolerance must be (relative edge deviation, angle deviation rad), got {tolerance!r}"
                            ) from None
    if not (edge >= 0 and angle >= 0):
        raise GeometryError(f"tolerance must be two numbers ≥ 0, got {tolerance!r}")
    return edge, angle


def _check_shape(P: NDArray[np.float64], sides: int, tolerance: tuple[float, float]) -> tuple[float, float]:
    """The polygon's irregularity after checking it fits the pattern: n corners, counter-clockwise,
    convex, within ``tolerance``. Raises :class:`GeometryError` naming what is wrong."""
    if len(P) != sides:
        raise GeometryError(f"the pattern is a {sides}-gon's but the polygon has {len(P)} corners")
    edge_limit, angle_limit = _check_tolerance(tolerance)
    area = 0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]))
    if not area > 0:
        raise GeometryError("the polygon must be counter-clockwise (its signed area is "
                            f"{area:.6g} mm²)")
    dev = irregularity(P)
    if not (_turns(P) > 0).all():
        raise GeometryError("the polygon must be convex: corner "
                            f"{int(np.argmin(_turns(P)))} is reflex or straight")
    if dev[0] > edge_limit:
        raise GeometryError(f"the polygon is too irregular for a shaped plate: an edge deviates "
                            f"{100 * dev[0]:.1f} % from the mean edge (limit {100 * edge_limit:.1f} %)")
    if dev[1] > angle_limit:
        raise GeometryError(f"the polygon is too irregular for a shaped plate: a corner deviates "
                            f"{math.degrees(dev[1]):.1f}° from the regular angle "
                            f"(limit {math.degrees(angle_limit):.1f}°)")
    return dev


def _mapped_vertices(pattern: Pattern, P: NDArray[np.float64], c: NDArray[np.float64]) -> NDArray[np.float64]:
    """(nv, 2) mm: the pattern's lattice points sent by each fan's affine map into (c, p_f, p_{f+1})."""
    topo = pattern_topology(pattern.sides, pattern.depth)
    N = 2**pattern.depth
    B = P[topo.point_fan] - c
    C = P[(topo.point_fan + 1) % pattern.sides] - c
    return c + (topo.point_ij[:, :1] * B + topo.point_ij[:, 1:] * C) / N


def _centre_interfaces(V: NDArray[np.float64], pattern: Pattern, iface: dict[int, int], T: NDArray[np.float64],
                       L: NDArray[np.float64]) -> NDArray[np.float64]:
    """V with the two lattice points joined to each edge midpoint M inside its fan moved the least that
    makes their projections on the edge M ∓ L_e / (2N): the bow-tie at M then crosses the edge
    symmetrically, at M ∓ interface_half_length(L_e) (module docstring).

    Each such point q gets one linear condition (q − M)·t_e = ∓L_e / (2N) per edge it serves (two at
    depth 1, where it lies on a spoke); the least change meeting them all is q + Aᵀ(AAᵀ)⁻¹(b − Aq).
    """
    N = 2**pattern.depth
    edges = {i: v for v, i in iface.items()}
    rows: dict[int, list[tuple[NDArray[np.float64], float]]] = {}
    for e, m in edges.items():
        near = np.flatnonzero((pattern.F == m).any(axis=1))
        for q in {int(x) for x in pattern.F[near].ravel()} - {m}:
            r = V[q] - V[m]
            if abs(float(T[e, 0] * r[1] - T[e, 1] * r[0])) > 1e-9 * L[e]:  # off the edge: joined to M inside
                target = float(T[e] @ V[m]) + math.copysign(L[e] / (2 * N), float(r @ T[e]))
                rows.setdefault(q, []).append((T[e], target))
    out = V.copy()
    for q, conds in rows.items():
        A = np.array([a for a, _ in conds])
        b = np.array([b for _, b in conds])
        out[q] = V[q] + A.T @ np.linalg.solve(A @ A.T, b - A @ V[q])
    return out


def shape_pattern(pattern: Pattern, polygon: ArrayLike, weight: float = DEFAULT_WEIGHT,
                  variation: Variation | None = None,
                  tolerance: tuple[float, float] = MAX_IRREGULARITY) -> ShapedPattern:
    """The exact outline of a library pattern in the convex polygon ``polygon`` (n, 2) mm, counter-clockwise,
    n = ``pattern.sides`` (see the module docstring for the construction and why it is exact).

    ``weight``: the interface weight w of the regular plate (the paper's 0.2, in its range of
    :mod:`fabpat.validate`), kept by every bow-tie.
    ``variation``: the family member (:class:`~fabpat.patterns.variation.Variation`; None = the paper's).
    ``tolerance``: the largest (relative edge deviation, angle deviation rad) accepted
    (:func:`irregularity`; :data:`MAX_IRREGULARITY` by default). Only the pattern's slice and n are
    used: the result's ``pattern`` is it in the regular n-gon of the polygon's mean edge. The polygon's
    own regular n-gon (:func:`~fabpat.patterns.lattice.polygon_vertices`) gives the regular plate's outline
    to rounding (1e-12 mm).

    Raises :class:`GeometryError` for a malformed, clockwise or non-convex polygon, one with another
    number of corners, one more irregular than ``tolerance`` (the message names the deviation and the
    limit), a weight out of range, or a pattern that cannot be filleted in it.
    """
    weight, variation = checked_inputs("shape_pattern", pattern, weight, variation)
    P = _polygon(polygon)
    dev = _check_shape(P, pattern.sides, tolerance)
    n = len(P)
    c = P.mean(axis=0)  # the vertex centroid (module docstring)
    E = np.roll(P, -1, axis=0) - P
    L = np.linalg.norm(E, axis=1)
    T = E / L[:, None]
    sigma = np.einsum("ij,ij->i", c - P, T) / L
    if not ((sigma > 0) & (sigma < 1)).all():  # measured: the slides then break the fillet (module docstring)
        e = int(np.argmax(np.abs(sigma - 0.5)))
        raise GeometryError(f"the polygon is too irregular for a shaped plate: its centroid's foot on edge {e} lies "
                            f"outside the edge (at {sigma[e]:.3f} of it; limit 0 to 1)")
    mean_edge = float(L.mean())
    regular = Pattern(pattern.slice, n, mean_edge)
    iface = _interface_vertices(regular)
    V = _centre_interfaces(_mapped_vertices(regular, P, c), regular, iface, T, L)
    try:
        outline, bowties = fillet_solid(V, regular.solid_faces, {v: T[i] for v, i in iface.items()}, weight, variation)
    except GeometryError as e:
        raise GeometryError(f"pattern {pattern.id} in the shaped {n}-gon: {e}") from e
    if len(bowties) != n:
        raise GeometryError(f"pattern {pattern.id} does not reach every polygon edge")
    arcs = tuple(bowties[v] for v, _ in sorted(iface.items(), key=lambda kv: kv[1]))
    seg = np.array([[_midpoint(a), _midpoint(b)] for a, b in arcs])
    outline = replace(outline, polygon=PolygonFrame(n, mean_edge, seg))
    if not variation.is_paper and not any(star.kind == "non-manifold" for star in vertex_stars(regular)):
        variation = PAPER_VARIATION  # no bridging arc: the member's outline is the paper's, and says so
    d = np.array([interface_half_length(float(length), regular.depth, weight) for length in L])
    for a in (P, c, d):
        a.setflags(write=False)
    return ShapedPattern(regular, float(weight), outline, seg, arcs, variation, corners=P, centre=c,
                         interface_half_lengths=d, irregularity=dev)
