"""Quality triangle meshes of flat patterns for the shell solver.

:func:`mesh_polygons` meshes polygon loops (outer loop first, then holes) with Shewchuk's Triangle
(``triangle`` package): every boundary edge is first cut into pieces of length ≤ h (so both sides of a
shared boundary see the same nodes and curves are followed consistently), then a constrained,
quality (minimum angle) Delaunay mesh whose mean edge length is ≈ h is built.
:func:`mesh_outline` flattens an exact :class:`fabpat.geometry.outline.Outline` with a chord tolerance
tied to h (:func:`flatten_outline`: chords moved towards their arcs, so that the polygon keeps the
curves' area) and tags the interface node sets of the regular n-gon the pattern lives in.
:func:`refine_nested` splits every triangle of a mesh into four, its new boundary nodes on the exact
outline: the finer mesh of a mesh-converged energy (:mod:`fabpat.simulation.convergence`).

Lengths are millimetres. Node arrays are float64, triangles int64, counter-clockwise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.simulation.mesh_size import (
    ASSEMBLY_MAX_ELEMENTS,
    DEFAULT_MAX_ELEMENTS,
    MAX_H_PER_MIN_WIDTH,
    check_element_count,
    check_polygon_elements,
    check_resolves,
    estimate_elements,
)
from fabpat.validate import SAME_POINT, check

__all__ = ["AREA_FACTOR", "ASSEMBLY_MAX_ELEMENTS", "CHORD_SHIFT", "DEFAULT_MAX_ELEMENTS", "FLATTEN_TOL_PER_H",
           "INTERFACE_WEIGHT", "MAX_H_PER_MIN_WIDTH", "PROJECTION_TOL", "ShellMesh",
           "check_element_count", "check_polygon_elements", "check_resolves", "estimate_elements", "flatten_outline",
           "interface_segments", "mesh_outline", "mesh_polygons", "refine_nested", "solid_polygon_mesh",
           "tag_segments"]

#: Chord tolerance used to flatten curves, as a fraction of the target edge length h. With h = 1.5 mm
#: the outline is followed to 0.03 mm; the sagitta of a chord c on radius r is c²/8r, so arcs of
#: 2 mm radius get chords of ≈0.7 mm (finer than h, which is what the narrow necks need).
FLATTEN_TOL_PER_H = 0.02

#: A curve's chords are moved towards it by this fraction of their sagitta (:func:`flatten_outline`): the
#: area between a chord and its arc is ≈ 2/3 · chord · sagitta (parabolic segment), so the polygon then
#: encloses the curve's area to second order instead of cutting every convex bulge and filling every
#: concave one. Measured on the lacy 0x4888 (Dome, h = 0.5): chords on the curve at 0.01 mm give 306.6
#: N·mm, moved chords at 0.01 mm 308.4, chords on the curve at 0.003 mm 308.3 (at 0.001 mm 309.1): the
#: narrow necks are that sensitive to the few hundredths of a millimetre a chord polygon takes off them.
CHORD_SHIFT = 2.0 / 3.0

#: Tolerance (mm) of the projection of a refined mesh's new boundary nodes onto the exact outline
#: (:func:`refine_nested`): they are placed on a flattening this fine.
PROJECTION_TOL = 1e-4

#: Triangle's area bound is a maximum, so its triangles come out smaller than the bound; 1.5 × the
#: area of an equilateral triangle of edge h makes the *mean* edge length ≈ h (measured: 1.01–1.53–2.03
#: mm for h = 1, 1.5, 2 on the solid hexagon).
AREA_FACTOR = 1.5


#: Default fillet weight w of the interface vertex (notes: crossing at (edge/16)/(1 + w) from M).
INTERFACE_WEIGHT = 0.2


@dataclass(frozen=True, eq=False)
class ShellMesh:
    """A flat triangle mesh with tagged interfaces.

    V: (n, 2) float64 node coordinates (mm). F: (m, 3) int64 triangles, counter-clockwise.
    interfaces: one int64 array per polygon edge i, the nodes on interface segment i ordered along the
    edge's counter-clockwise tangent (empty if the pattern does not reach that edge).
    """

    V: NDArray[np.float64]
    F: NDArray[np.int64]
    interfaces: tuple[NDArray[np.int64], ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        V = np.ascontiguousarray(self.V, dtype=np.float64)
        F = np.ascontiguousarray(self.F, dtype=np.int64)
        if V.ndim != 2 or V.shape[1] != 2 or F.ndim != 2 or F.shape[1] != 3:
            raise ValueError(f"expected V (n, 2) and F (m, 3), got {V.shape} and {F.shape}")
        ifs = tuple(np.ascontiguousarray(i, dtype=np.int64) for i in self.interfaces)
        for a in (V, F, *ifs):
            a.setflags(write=False)
        object.__setattr__(self, "V", V)
        object.__setattr__(self, "F", F)
        object.__setattr__(self, "interfaces", ifs)

    @property
    def n_nodes(self) -> int:
        """Number of mesh nodes."""
        return int(self.V.shape[0])

    @property
    def n_elements(self) -> int:
        """Number of triangles."""
        return int(self.F.shape[0])

    @property
    def areas(self) -> NDArray[np.float64]:
        """(m,) signed triangle areas (mm²), positive for counter-clockwise triangles."""
        a = self.V[self.F[:, 1]] - self.V[self.F[:, 0]]
        b = self.V[self.F[:, 2]] - self.V[self.F[:, 0]]
        return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])

    def min_angle(self) -> float:
        """Smallest interior angle of all triangles, degrees."""
        P = self.V[self.F]  # (m, 3, 2)
        ang = []
        for k in range(3):
            u = P[:, (k + 1) % 3] - P[:, k]
            v = P[:, (k + 2) % 3] - P[:, k]
            c = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
            ang.append(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
        return float(np.min(ang))

    def edge_lengths(self) -> NDArray[np.float64]:
        """(3m,) lengths of the triangle sides (interior sides counted twice), mm."""
        P = self.V[self.F]
        return np.linalg.norm(P[:, [1, 2, 0]] - P, axis=2).ravel()


def _signed_area(loop: NDArray[np.float64]) -> float:
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _clean_loop(loop: NDArray[np.float64]) -> NDArray[np.float64]:
    """Drop a repeated closing point and consecutive duplicates."""
    P = np.asarray(loop, dtype=np.float64).reshape(-1, 2)
    keep = np.linalg.norm(P - np.roll(P, 1, axis=0), axis=1) > 1e-9
    P = P[keep]
    if P.shape[0] < 3:
        raise GeometryError(f"a loop needs at least 3 distinct points, got {P.shape[0]}")
    return P


def _subdivide(loop: NDArray[np.float64], h: float) -> NDArray[np.float64]:
    """Cut every side of a closed loop into equal pieces of length ≤ h (corners kept)."""
    nxt = np.roll(loop, -1, axis=0)
    out = []
    for p, q in zip(loop, nxt, strict=True):
        k = max(1, math.ceil(float(np.linalg.norm(q - p)) / h - 1e-9))
        t = np.arange(k)[:, None] / k
        out.append(p + t * (q - p))
    return np.concatenate(out)


def _point_inside(loop: NDArray[np.float64]) -> NDArray[np.float64]:
    """A point strictly inside a simple polygon: centroid of the largest triangle of its CDT."""
    import triangle

    n = loop.shape[0]
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    t = triangle.triangulate({"vertices": loop, "segments": seg}, "p")
    P = t["vertices"][t["triangles"]]
    u, v = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    a = np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    return P[int(np.argmax(a))].mean(axis=0)


def tag_segments(
    V: NDArray[np.float64], segments: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]] | None],
    tol: float = SAME_POINT,
) -> tuple[NDArray[np.int64], ...]:
    """Nodes on each segment (p0, p1): within ``tol`` of its line and between its ends, ordered p0→p1.

    V: (n, 2); each segment a pair of (2,) points or None (→ empty set).
    """
    out = []
    for s in segments:
        if s is None:
            out.append(np.zeros(0, dtype=np.int64))
            continue
        p0, p1 = (np.asarray(p, dtype=np.float64) for p in s)
        d = p1 - p0
        L = float(np.linalg.norm(d))
        t = d / L
        rel = V - p0
        along = rel @ t
        off = np.abs(rel[:, 0] * t[1] - rel[:, 1] * t[0])
        idx = np.flatnonzero((off <= tol) & (along >= -tol) & (along <= L + tol))
        out.append(idx[np.argsort(along[idx])].astype(np.int64))
    return tuple(out)


def mesh_polygons(
    loops: Sequence[NDArray[np.float64]],
    h: float,
    min_angle: float = 25.0,
    *,
    interfaces: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]] | None] = (),
    max_steiner: int | None = None,
    max_elements: int = DEFAULT_MAX_ELEMENTS,
) -> ShellMesh:
    """Quality triangle mesh of a polygonal region.

    loops: outer boundary first (any orientation, made counter-clockwise), then holes, each a (k, 2)
        array of corners (closing point optional). Loops must be simple and must not cross.
    h: target (mean) edge length (mm); boundary sides are cut to ≤ h, triangle areas bounded by
        AREA_FACTOR·√3/4·h².
    min_angle: Triangle's quality bound in degrees (≤ ~33 is safe).
    interfaces: optional segments (p0, p1) whose nodes are tagged (see :func:`tag_segments`).
    max_elements: refuse (GeometryError) before meshing if :func:`estimate_elements` is above it.

    Raises GeometryError if the loops are degenerate, the mesh would be too large or Triangle fails;
    RangeError if h is not in its range (fabpat.validate).
    """
    import triangle

    h = check("h", h)
    if len(loops) == 0:
        raise GeometryError("no loops to mesh")
    cleaned = [_clean_loop(raw) for raw in loops]
    net_area = abs(_signed_area(cleaned[0])) - sum(abs(_signed_area(P)) for P in cleaned[1:])
    perimeter = sum(float(np.linalg.norm(P - np.roll(P, 1, axis=0), axis=1).sum()) for P in cleaned)
    check_element_count(max(net_area, 0.0), perimeter, h, max_elements)
    verts, segs, holes = [], [], []
    offset = 0
    for k, P in enumerate(cleaned):
        area = _signed_area(P)
        if k == 0 and area < 0 or k > 0 and area > 0:
            P = P[::-1]  # outer CCW, holes CW (only for a consistent tangent order; Triangle ignores it)
        if k > 0:
            holes.append(_point_inside(P))
        P = _subdivide(P, h)
        n = P.shape[0]
        verts.append(P)
        segs.append(offset + np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1))
        offset += n
    data: dict[str, NDArray] = {"vertices": np.concatenate(verts), "segments": np.concatenate(segs)}
    if holes:
        data["holes"] = np.array(holes)
    amax = AREA_FACTOR * math.sqrt(3.0) / 4.0 * h * h
    opts = f"pq{min_angle:g}a{amax:.10g}"
    if max_steiner is not None:
        opts += f"S{max_steiner}"
    try:
        t = triangle.triangulate(data, opts)
    except Exception as exc:  # Triangle raises RuntimeError/ValueError on bad input
        raise GeometryError(f"Triangle failed to mesh the region: {exc}") from exc
    if "triangles" not in t or len(t["triangles"]) == 0:
        raise GeometryError("Triangle produced no triangles (open or inverted loops?)")
    V = np.asarray(t["vertices"], dtype=np.float64)
    F = np.asarray(t["triangles"], dtype=np.int64)
    # drop vertices no triangle uses (e.g. a stray point inside a hole)
    used = np.zeros(V.shape[0], dtype=bool)
    used[F.ravel()] = True
    if not used.all():
        new = np.cumsum(used) - 1
        V, F = V[used], new[F]
    if F.shape[0] > max_elements:  # the estimate counts boundary pieces of h; finer ones make more
        raise GeometryError(f"the mesh at h = {h:g} mm has {F.shape[0]} triangles, above the limit of "
                            f"{max_elements} (max_elements): raise the limit, or use a larger h or a coarser boundary")
    a = V[F[:, 1]] - V[F[:, 0]]
    b = V[F[:, 2]] - V[F[:, 0]]
    cw = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    F[cw] = F[cw][:, [0, 2, 1]]
    return ShellMesh(V, F, tag_segments(V, interfaces))


def _shifted_chords(seg: object, tol: float) -> NDArray[np.float64]:
    """(k, 2) points of one outline segment: a line's ends, or a curve's chord polygon (vertices on the
    curve within ``tol`` mm) with each chord moved towards its arc by CHORD_SHIFT × its sagitta."""
    from fabpat.geometry import curves

    if not hasattr(seg, "w"):
        return np.asarray(seg.flatten(tol))  # type: ignore[attr-defined]
    P, t = curves.flatten_quad(seg.control_points, seg.w, tol, return_params=True)  # type: ignore[attr-defined]
    P = np.array(P, dtype=np.float64)
    if len(P) < 3:
        return P
    mid = np.asarray(seg.point(0.5 * (t[:-1] + t[1:])))  # type: ignore[attr-defined]
    chord = P[1:] - P[:-1]
    u = chord / np.linalg.norm(chord, axis=1)[:, None]
    n = np.stack([-u[:, 1], u[:, 0]], axis=1)  # left normal of each chord
    d = CHORD_SHIFT * np.einsum("ij,ij->i", mid - P[:-1], n)  # signed shift: towards the arc
    # an inner vertex goes to where its two moved chords meet; (d₁n₁ + d₂n₂)/(1 + n₁·n₂) is that point
    # for d₁ = d₂ and stays finite for the nearly collinear chords of a flat arc (the ends stay put:
    # they join the neighbouring segments tangentially or at a corner of the outline)
    n1, n2, d1, d2 = n[:-1], n[1:], d[:-1], d[1:]
    P[1:-1] += (d1[:, None] * n1 + d2[:, None] * n2) / (1.0 + np.einsum("ij,ij->i", n1, n2))[:, None]
    return P


def flatten_outline(outline: object, tol: float) -> list[NDArray[np.float64]]:
    """Polygon loops of an exact outline for meshing (outer first, last point not repeated), mm.

    Lines are kept; each curve becomes its chord polygon at ``tol`` mm with every chord moved towards the
    arc by :data:`CHORD_SHIFT` of its sagitta, so the polygon keeps the curve's area (to second order)
    and stays within ``tol`` of it (the moved vertices are about 2/3 of a sagitta off the curve, the
    chords' middles 1/3; measured ≤ 0.75 · tol on library patterns). Raises GeometryError if ``tol`` is
    not a positive number.
    """
    from fabpat.geometry.outline import flattening_tolerance

    tol = flattening_tolerance(tol)
    return [np.vstack([_shifted_chords(s, tol)[:-1] for s in loop.segments])
            for loop in outline.loops]  # type: ignore[attr-defined]


def refine_nested(mesh: ShellMesh, outline: object) -> ShellMesh:
    """Split every triangle into four at its side midpoints; new boundary nodes go onto the exact outline.

    The refined mesh is *nested* in ``mesh`` (same nodes first, then one node per side, each triangle
    the union of four new ones), so two meshes of an extrapolation differ by refinement only, not by a
    new Delaunay triangulation (whose node placement alone scatters the energy by tenths of a percent).
    Midpoints of boundary sides are moved to the nearest point of ``outline`` (an
    :class:`~fabpat.geometry.outline.Outline`, within :data:`PROJECTION_TOL` mm), so the boundary converges with
    the mesh. Each interface node set gains the midpoints between its consecutive nodes, in order.
    Raises GeometryError if a moved node inverts a triangle.
    """
    from scipy.spatial import cKDTree

    from fabpat.geometry.polyline import _subdivide as cut_edges

    outline = getattr(outline, "outline", outline)  # a FilletedPattern refines along its outline
    if not hasattr(outline, "flatten") or not isinstance(mesh, ShellMesh):
        raise GeometryError(f"refine_nested needs a ShellMesh and an Outline (or FilletedPattern), got "
                            f"{type(mesh).__name__} and {type(outline).__name__}")
    V, F = mesh.V, mesh.F
    m, n = len(F), len(V)
    sides = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    keys, inv, count = np.unique(sides[:, 0] * n + sides[:, 1], return_inverse=True, return_counts=True)
    uniq = np.stack([keys // n, keys % n], axis=1)
    mid = 0.5 * (V[uniq[:, 0]] + V[uniq[:, 1]])
    boundary = np.flatnonzero(count == 1)
    # nearest point of a fine flattening cut into pieces ≤ 0.05 mm (so that a long straight side's own
    # piece is among the k nearest piece midpoints)
    loops = [_clean_loop(L) for L in outline.flatten(PROJECTION_TOL)]  # type: ignore[attr-defined]
    A, B = cut_edges(np.vstack(loops), np.vstack([np.roll(L, -1, axis=0) for L in loops]), 0.05)
    D = B - A
    _, near = cKDTree(A + 0.5 * D).query(mid[boundary], k=8)
    a, d = A[near], D[near]
    X = mid[boundary][:, None, :]
    s = np.clip(np.einsum("ijk,ijk->ij", X - a, d) / np.maximum(np.einsum("ijk,ijk->ij", d, d), 1e-300), 0.0, 1.0)
    Q = a + s[..., None] * d
    best = np.argmin(np.linalg.norm(Q - X, axis=2), axis=1)
    mid[boundary] = Q[np.arange(len(boundary)), best]
    e01, e12, e20 = n + inv[:m], n + inv[m:2 * m], n + inv[2 * m:]
    # the four children of a triangle stay together (neighbours in space stay neighbours in memory; the
    # tangent time on 0x2d08 measured the same as with the children of all corners one block after another)
    F2 = np.stack([np.stack([F[:, 0], e01, e20], axis=1), np.stack([e01, F[:, 1], e12], axis=1),
                   np.stack([e20, e12, F[:, 2]], axis=1), np.stack([e01, e12, e20], axis=1)], axis=1).reshape(-1, 3)
    V2 = np.vstack([V, mid])
    P = V2[F2]
    u, v = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    if not (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0] > 0).all():
        raise GeometryError("refining the mesh inverted a triangle at the boundary (a curve bulging across "
                            "a whole element?): mesh with a smaller h")
    interfaces = []
    for nodes in mesh.interfaces:
        if nodes.size == 0:
            interfaces.append(nodes)
            continue
        want = np.minimum(nodes[:-1], nodes[1:]) * n + np.maximum(nodes[:-1], nodes[1:])
        at = np.minimum(np.searchsorted(keys, want), len(keys) - 1)
        if not np.array_equal(keys[at], want):
            raise GeometryError("an interface's consecutive nodes are not joined by a mesh side")
        mids = n + at
        merged = np.empty(2 * nodes.size - 1, dtype=np.int64)
        merged[0::2], merged[1::2] = nodes, mids
        interfaces.append(merged)
    return ShellMesh(V2, F2, tuple(interfaces))


def interface_segments(
    sides: int, edge: float = 36.0, *, half_length: float | None = None, weight: float = INTERFACE_WEIGHT,
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The n interface segments [M − d·t, M + d·t] of a regular n-gon, t the CCW edge tangent.

    d defaults to (edge/16)/(1 + weight) (1.875 mm for a 36 mm edge); ``half_length = edge/2`` gives
    whole edges (a solid polygon).
    """
    from fabpat.patterns.lattice import polygon_vertices

    P = polygon_vertices(sides, edge)
    d = (edge / 16.0) / (1.0 + weight) if half_length is None else half_length
    out = []
    for i in range(sides):
        a, b = P[i], P[(i + 1) % sides]
        m, t = 0.5 * (a + b), (b - a) / np.linalg.norm(b - a)
        out.append((m - d * t, m + d * t))
    return out


def mesh_outline(
    outline: object, h: float = 1.5, sides: int | None = None, edge: float | None = None, *,
    min_angle: float = 25.0, weight: float = INTERFACE_WEIGHT, max_elements: int = DEFAULT_MAX_ELEMENTS,
    flatten_tol: float | None = None, refine: int = 0,
) -> ShellMesh:
    """Mesh an exact :class:`fabpat.geometry.outline.Outline` (or a ``FilletedPattern``) and tag its n
    interface node sets.

    Curves are flattened with chord tolerance ``flatten_tol`` (mm; default ``FLATTEN_TOL_PER_H · h``,
    0.03 mm at h = 1.5) by :func:`flatten_outline` (chords moved towards their arcs), then every
    flattened side is cut to ≤ h. ``refine`` > 0 splits the mesh that many times with
    :func:`refine_nested` (each time 4× the triangles, half the edge length; new boundary nodes on the
    exact outline), e.g. the finer mesh of an extrapolation. A filleted pattern's outline carries its polygon
    (:class:`~fabpat.geometry.outline.PolygonFrame`): interface i is then its exact interface segment on polygon
    edge i, and ``sides``/``edge``, if given, must agree. A free-standing outline needs ``sides`` and
    ``edge``; interface i is then the segment of :func:`interface_segments` (whose length depends on the
    interface ``weight`` the outline was filleted with: pass the same one).
    Raises GeometryError if an interface gets fewer than 2 nodes, the polygon is unknown or contradicted,
    h, edge or weight is outside its range (:mod:`fabpat.validate`), or the mesh would have more than
    ``max_elements`` triangles (estimated from the exact area and perimeter before flattening).
    """
    outline = getattr(outline, "outline", outline)  # a FilletedPattern meshes as its outline
    if not hasattr(outline, "flatten"):
        raise GeometryError(f"mesh_outline needs an Outline or a FilletedPattern, got {type(outline).__name__}")
    h = check("h", h, "mesh size h", error=GeometryError)
    if edge is not None:
        edge = check("edge", edge, error=GeometryError)
    weight = check("weight", weight, "interface weight", error=GeometryError)
    frame = getattr(outline, "polygon", None)
    if frame is not None:
        if (sides is not None and sides != frame.sides) or (edge is not None and abs(edge - frame.edge) > 1e-9):
            raise GeometryError(f"the outline belongs to a {frame.sides}-gon of edge {frame.edge:g} mm, "
                                f"not sides={sides}, edge={edge}")
        sides, edge = frame.sides, frame.edge
        segments = [(a, b) for a, b in frame.interfaces]
    elif sides is None or edge is None:
        raise GeometryError("this outline does not say which polygon it belongs to: pass sides and edge "
                            "(or mesh a FilletedPattern, whose outline carries them)")
    else:
        segments = interface_segments(sides, edge, weight=weight)
    refine = int(check("refine", refine, "nested refinements", error=GeometryError))
    if flatten_tol is not None and not 0.0 < flatten_tol <= h:  # also refuses NaN
        raise GeometryError(f"flatten_tol = {flatten_tol!r} mm must be in (0, h] = (0, {h:g}] mm")
    check_element_count(outline.area, outline.perimeter, h, max_elements, fine_ratio=0.5**refine)
    loops = flatten_outline(outline, FLATTEN_TOL_PER_H * h if flatten_tol is None else flatten_tol)
    mesh = mesh_polygons(loops, h, min_angle, interfaces=segments, max_elements=max_elements)
    if 4**refine * mesh.n_elements > max_elements:
        raise GeometryError(f"refining the mesh at h = {h:g} mm {refine} time(s) makes {4**refine * mesh.n_elements} "
                            f"triangles, above the limit of {max_elements} (max_elements): use a larger h")
    for _ in range(refine):
        mesh = refine_nested(mesh, outline)
    for i, nodes in enumerate(mesh.interfaces):
        if nodes.size == 0:
            raise GeometryError(f"the outline does not reach interface {i} of the {sides}-gon of edge {edge:g} mm: "
                                "wrong sides or edge?")
        if nodes.size < 2:
            raise GeometryError(f"interface {i} has {nodes.size} mesh nodes (need ≥ 2): h = {h} too coarse?")
    return mesh


def solid_polygon_mesh(sides: int = 6, edge: float = 36.0, h: float = 1.5) -> ShellMesh:
    """A solid regular n-gon whose interfaces are the whole edges (the notes' CalculiX reference)."""
    from fabpat.patterns.lattice import polygon_vertices

    segs = interface_segments(sides, edge, half_length=edge / 2)
    return mesh_polygons([polygon_vertices(sides, edge)], h, interfaces=segs)
