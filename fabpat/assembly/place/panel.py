"""One-piece panels: a flat patch of a planar tiling cut or printed as ONE part (issue 26, item 4).

A panel is the honeycomb strip's ``rows`` × ``columns`` hexagons (:func:`fabpat.assembly.surface.tiling.
honeycomb_strip`) or the faces of a flat polygon mesh file (``tiling.file``: :mod:`fabpat.assembly.surface.panel_mesh`
reads and checks it and lays it on the exact tiling of regular polygons its faces make), with no sleeves:
the plates sit edge to edge at the plate edge ``e`` itself (no skeleton setback) and are fused at their
interfaces into one exact outline (lines and quadratic rational arcs, nothing approximated), which every
writer of :mod:`fabpat.exchange.registry` takes as a part.

**How the outlines fuse** (:func:`fuse`). Two neighbouring plates share a polygon edge, and the edge
rule of the library (:func:`fabpat.patterns.library.is_tileable`) leaves only the middle sub-triangle of each
edge row solid, its apex at the edge midpoint M: a plate touches its polygon only along its interface
segment [M − d, M + d] (:mod:`fabpat.geometry.fillet`), identical for every pattern, family member and polygon
of one edge. Each plate's outer loop runs ``… a₁, L, a₂ …`` there: a₁ the first half of the bow-tie
arc that crosses the edge at M − d at right angles, L the segment, a₂ the second half of the other
bow-tie arc. The neighbour runs the same segment the other way. So the union of the two plates is
their loops with both copies of L cancelled and re-linked at the segment's ends: at M − d plate A's a₁
continues with plate B's b₂, which is the other half of the very same bow-tie arc (B's sub-triangle
is A's mirror image across the edge), so the fused boundary passes M − d *smoothly* (G1, and the
same conic on both sides): there is no cusp for OCCT or the mesher to handle. The two halves are
joined back into the whole arc (P₀, M, P₀′) of weights (1, w, 1) (checked to 1e-9 mm before it is
trusted, else :class:`~fabpat.errors.GeometryError`), so the fused outline has no joint at all where two
plates meet, and the B-rep carries the interface weight w exactly. What is left of the loops is one
counter-clockwise outer loop (the panel's rim) and clockwise holes: every plate's own holes and the
gaps between plates (one around each interior tiling vertex). A free interface (on the panel's rim)
keeps its segment and its arc halves, exported on their whole arcs as a single plate is
(:attr:`Fused.support`).

**Two different polygons** (a square beside a triangle, the 4.8.8 tiling's octagons and squares). The
interface half-length d = e / 16 / (1 + w) does not depend on the polygon, but the bow-tie arc's control
polygon does: P₀ − M has the component e/16 along the edge for every n and (e/16) cot(π/n) across it
(the sub-triangle at M is similar to the polygon's fan triangle). The (1, w, 1) arc's parameter midpoint
is M − d whatever that second component is, and there the arc is at right angles to the edge by
symmetry; so the two halves of different polygons meet at the same point with the same tangent (G1),
and only their curvature differs (radius (e/16) cot²(π/n) / w there: 11.25 mm for a square, 3.75 mm for
a triangle, 33.75 mm for a hexagon at e = 36, w = 0.2). Measured on a row of 3 squares under 5
triangles and on 2 × 2 octagons round a square (``tests/test_assembly_panel_mesh.py``): position gaps
≤ 2.8e-14 mm, tangent gaps ≤ 3.3e-15 rad. **Decision**: such an interface is fused with its two halves
kept as two arcs (no cusp, a G1 joint OCCT and Triangle take as any other), each built on its own whole
arc in the B-rep (both in :attr:`Fused.support`); the gaps are measured at every such interface
(:attr:`Fused.mixed_gap`, reported by the kit), and a gap over :data:`MATCH_TOL` mm or :data:`G1_TOL`
rad is refused with one line naming the two polygons and the gap (GeometryError) rather than rounded
away. Only the same polygon's halves are one arc and are joined back into it.

Units: mm. Sources: paper §3.3 (fillets, interfaces) and §5 (the strip's end-shortening experiment, run
on a panel by :func:`fabpat.assembly.solve.panel.panel_setup`; a mesh panel's ends:
:func:`fabpat.assembly.surface.panel_mesh.end_interfaces`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.geometry.outline import Line, Loop, Outline, RationalQuad, Segment

if TYPE_CHECKING:
    from OCP.TopoDS import TopoDS_Solid

    from fabpat.assembly.place.placement import PlateType
    from fabpat.assembly.spec.types import AssemblySpec
    from fabpat.assembly.surface.tiling import Tiling
    from fabpat.exchange.registry import Part
    from fabpat.geometry.fillet import FilletedPattern

Arr = NDArray[np.float64]
#: mm: two world points of neighbouring plates closer than this are the same point (the plates' shared
#: interface ends agree to ~1e-14 mm; a mismatch above this is a placement error, never rounded away)
MATCH_TOL = 1e-9
#: rad: two bow-tie halves of different polygons meet G1 when their tangents are closer than this (measured
#: 0 to round-off, ~1e-16 rad: module docstring); above it the panel is refused (a cusp)
G1_TOL = 1e-9


def _moved(seg: Segment, R: Arr, t: Arr) -> Segment:
    """``seg`` under the rigid 2D motion x → R x + t (a rational arc keeps its weight)."""
    if isinstance(seg, Line):
        return Line(R @ seg.p0 + t, R @ seg.p1 + t)
    return _moved_arc(seg, R, t)


def _moved_arc(arc: RationalQuad, R: Arr, t: Arr) -> RationalQuad:
    """``arc`` under the rigid 2D motion x → R x + t, its weight kept."""
    return RationalQuad(R @ arc.P0 + t, R @ arc.P1 + t, R @ arc.P2 + t, arc.w)


def _same_arc(a: RationalQuad, b: RationalQuad) -> bool:
    return abs(a.w - b.w) <= 1e-12 and float(np.abs(a.control_points - b.control_points).max()) <= MATCH_TOL


@dataclass(frozen=True, eq=False)
class PlacedOutline:
    """One plate of a panel: its ``filleted`` pattern (:class:`~fabpat.geometry.fillet.FilletedPattern`) and the rigid
    2D motion ``R`` (2, 2), ``t`` (2,) mm from its polygon frame to the panel's plane."""

    filleted: FilletedPattern
    R: Arr
    t: Arr

    @cached_property
    def loops(self) -> list[list[Segment]]:
        """The outline's loops in the panel's plane, outer first."""
        return [[_moved(s, self.R, self.t) for s in lp.segments] for lp in self.filleted.outline.loops]

    def interface(self, i: int) -> tuple[Arr, Arr]:
        """Interface segment i in the panel's plane: (start, end) (2,) mm, counter-clockwise about the plate."""
        a, b = self.filleted.interface_segments[i]
        return self.R @ a + self.t, self.R @ b + self.t

    def arcs(self, i: int) -> tuple[RationalQuad, RationalQuad]:
        """Interface i's two whole bow-tie arcs (into, out of the segment) in the panel's plane."""
        into, out = self.filleted.interface_arcs[i]
        return _moved_arc(into, self.R, self.t), _moved_arc(out, self.R, self.t)

    def line_index(self, i: int) -> int:
        """Index in the outer loop of interface i's straight segment; GeometryError if it is not there."""
        a, b = self.interface(i)
        for k, s in enumerate(self.loops[0]):
            if isinstance(s, Line) and np.abs(s.p0 - a).max() <= MATCH_TOL and np.abs(s.p1 - b).max() <= MATCH_TOL:
                return k
        raise GeometryError(f"pattern {self.filleted.label}: interface {i} is not a straight piece of its outer loop")


@dataclass(frozen=True)
class Fused:
    """The fused outline (:class:`~fabpat.geometry.outline.Outline`, no polygon frame), the whole bow-tie arcs whose
    halves its free interfaces and its interfaces between two polygons keep (``support``, for
    :func:`fabpat.exchange.cad.make_face`), how many interfaces were fused and how many bow-tie arcs were made whole
    again there (two per fused interface of one polygon)."""

    outline: Outline
    support: tuple[RationalQuad, ...]
    fused: int
    joined_arcs: int
    #: interfaces between two different polygons, whose bow-tie halves stay two arcs meeting G1
    mixed: int = 0
    #: their largest (position mm, tangent rad) gap where the halves meet (module docstring)
    mixed_gap: tuple[float, float] = (0.0, 0.0)


def fuse(plates: Sequence[PlacedOutline], joints: Sequence[tuple[tuple[int, int], tuple[int, int]]]) -> Fused:
    """The union of ``plates`` that meet at ``joints`` ((plate, interface) of one side, of the other), as one
    exact outline: see the module docstring. Each joint's two segments must coincide, run in opposite
    directions, and be flanked by the two halves of one bow-tie arc at each end (within
    :data:`MATCH_TOL` mm); GeometryError otherwise, or if the union is not one piece (one outer loop).
    """
    # plate → {interface: index of its straight segment in the outer loop}
    lines: list[dict[int, int]] = [{} for _ in plates]
    nxt: dict[tuple[int, int], tuple[int, int]] = {}
    for p, pl in enumerate(plates):
        n = len(pl.loops[0])
        nxt.update({(p, k): (p, (k + 1) % n) for k in range(n)})
    whole: dict[tuple[int, int], RationalQuad] = {}  # first half (plate, index) → the whole arc it starts
    cancelled: set[tuple[int, int]] = set()
    mixed: list[tuple[float, float]] = []  # (position mm, tangent rad) gap of each interface of two polygons
    mixed_support: list[RationalQuad] = []
    for (pa, ia), (pb, ib) in joints:
        A, B = plates[pa], plates[pb]
        ka, kb = (lines[pa].setdefault(ia, A.line_index(ia)), lines[pb].setdefault(ib, B.line_index(ib)))
        (a0, a1), (b0, b1) = A.interface(ia), B.interface(ib)
        if np.abs(a0 - b1).max() > MATCH_TOL or np.abs(a1 - b0).max() > MATCH_TOL:
            raise GeometryError(f"plates {pa} and {pb} do not meet at their interfaces {ia} and {ib}")
        (a_in, a_out), (b_in, b_out) = A.arcs(ia), B.arcs(ib)
        na, nb = len(A.loops[0]), len(B.loops[0])
        before_a, after_a = (pa, (ka - 1) % na), (pa, (ka + 1) % na)
        before_b, after_b = (pb, (kb - 1) % nb), (pb, (kb + 1) % nb)
        nxt[before_a], nxt[before_b] = after_b, after_a
        cancelled |= {(pa, ka), (pb, kb)}
        # at the segment's start (A's view) A's arc into it goes on as B's arc out of it, and vice versa
        if _same_arc(a_in, b_out) and _same_arc(b_in, a_out):
            whole[before_a], whole[before_b] = a_in, b_in
            continue
        ends = (_relink_gap(A.loops[0][before_a[1]], B.loops[0][after_b[1]]),
                _relink_gap(B.loops[0][before_b[1]], A.loops[0][after_a[1]]))
        gap = (max(ends[0][0], ends[1][0]), max(ends[0][1], ends[1][1]))
        if gap[0] > MATCH_TOL or gap[1] > G1_TOL:
            raise GeometryError(f"a {_polygon(A)} and a {_polygon(B)} (plates {pa} and {pb}) do not meet smoothly at "
                                f"their interface: the bow-tie halves are {gap[0]:.3g} mm and {gap[1]:.3g} rad apart "
                                "(patterns of different edge or interface weight?)")
        mixed.append(gap)  # two conics meeting G1: both halves kept, each on its whole arc in the B-rep
        mixed_support += [a_in, a_out, b_in, b_out]
    seconds = {nxt[k] for k in whole}
    seen: set[tuple[int, int]] = set()
    loops: list[Loop] = []
    for start in nxt:
        if start in seen or start in cancelled or start in seconds:
            continue
        segs: list[Segment] = []
        k = start
        while k not in seen:
            seen.add(k)
            if k in whole:
                segs.append(whole[k])
                seen.add(nxt[k])
                k = nxt[nxt[k]]
            else:
                segs.append(plates[k[0]].loops[0][k[1]])
                k = nxt[k]
        if k != start:
            raise GeometryError("the fused boundary walk did not close")
        loops.append(Loop(tuple(segs)))
    outer = [lp for lp in loops if lp.signed_area > 0]
    if len(outer) != 1:
        raise GeometryError(f"the fused panel has {len(outer)} outer loops, expected 1 (its plates are not one piece)")
    holes = [lp for lp in loops if lp.signed_area <= 0]
    holes += [Loop(tuple(h)) for pl in plates for h in pl.loops[1:]]
    free = [arc for p, pl in enumerate(plates) for i in range(len(pl.filleted.interface_arcs))
            if i not in lines[p] for arc in pl.arcs(i)]
    gaps = np.array(mixed).reshape(-1, 2)
    return Fused(Outline(outer[0], tuple(holes)), (*free, *mixed_support), len(joints), len(whole), len(mixed),
                 (float(gaps[:, 0].max(initial=0.0)), float(gaps[:, 1].max(initial=0.0))))


def _polygon(plate: PlacedOutline) -> str:
    from fabpat.assembly.spec.types import POLYGON_KEYS

    n = plate.filleted.pattern.sides
    return POLYGON_KEYS.get(n, f"{n}-gon")


def _relink_gap(arrive: Segment, leave: Segment) -> tuple[float, float]:
    """(distance mm, angle rad) between the end of ``arrive`` and the start of ``leave``, and between their
    tangents there: (0, 0) where the boundary goes on smoothly (G1)."""
    u, v = arrive.tangent(1.0), leave.tangent(0.0)
    angle = math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))
    return float(np.abs(arrive.point(1.0) - leave.point(0.0)).max()), angle


def relink_angles(plates: Sequence[PlacedOutline], joints: Sequence[tuple[tuple[int, int], tuple[int, int]]]
                  ) -> Arr:
    """(2 × joints,) angle (rad) between the tangents where the fused boundary is re-linked: at each end of
    each fused interface segment, the end tangent of the arc half arriving on one plate and the start
    tangent of the half leaving on the other (0: tangent, no cusp). A separate check of :func:`fuse`'s
    premise, read from the plates' own half arcs."""
    out = []
    for (pa, ia), (pb, ib) in joints:
        A, B = plates[pa], plates[pb]
        ka, kb = A.line_index(ia), B.line_index(ib)
        for P, k, Q, m in ((A, ka, B, kb), (B, kb, A, ka)):
            arrive = P.loops[0][(k - 1) % len(P.loops[0])]
            leave = Q.loops[0][(m + 1) % len(Q.loops[0])]
            u, v = arrive.tangent(1.0), leave.tangent(0.0)
            out.append(math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v)))
    return np.array(out)


@dataclass(frozen=True, eq=False)
class Panel:
    """A panel spec made: the ``tiling`` at the plate edge (mm), the distinct plates' ``filleted`` patterns
    (by :class:`~fabpat.assembly.place.placement.PlateType`), each face's ``types`` and ``plates`` (placed
    outlines) and the ``fused`` outline. Lengths in mm."""

    spec: AssemblySpec
    tiling: Tiling
    types: tuple[PlateType, ...]
    filleted: dict[PlateType, FilletedPattern]
    plates: tuple[PlacedOutline, ...]
    fused: Fused

    @property
    def outline(self) -> Outline:
        """The fused outline (panel plane, mm): one outer loop and its holes."""
        return self.fused.outline

    @property
    def labels(self) -> tuple[str, ...]:
        """The tiles' labels in face order (as a strip's plates: "T01" …)."""
        return tuple(self.tiling.labels)

    @property
    def name(self) -> str:
        """Product name: the panel's size (rows × columns, or a mesh file's stem and tile count), polygon edge,
        thickness, interface weight and patterns."""
        s = self.spec
        ids = ", ".join(dict.fromkeys(t.label.split(" ", 1)[1] for t in self.types))
        size = (f"{s.tiling.rows}x{s.tiling.columns} hex" if s.tiling.file is None
                else f"{Path(s.tiling.file).stem} {len(self.types)} tiles")
        return f"panel {size} e{s.tiling.edge:g} t{s.plates.thickness:g} w{s.plates.weight:g} ({ids})"

    @cached_property
    def part(self) -> Part:
        """The panel as a :class:`~fabpat.exchange.registry.Part` (z from 0 to the plate thickness) named
        :attr:`name`, its free interfaces' whole bow-tie arcs as ``support``; built once, so every writer
        shares its solid. No engraved label: finding a box for one on the whole panel's material
        (:func:`fabpat.exchange.labels.place_label`) took 7 s per DXF or SVG of a 3 × 4 panel; the kit's
        sheet engraves every tile's label instead (:func:`fabpat.assembly.kit.panel.sheet_document`)."""
        from fabpat.exchange.registry import Part

        return Part(self.outline, self.spec.plates.thickness, self.name, support=self.fused.support)

    @property
    def solid(self) -> TopoDS_Solid:
        """The exact ``TopoDS_Solid`` (BRepCheck valid; :func:`fabpat.exchange.cad.make_solid`), built on first use."""
        return self.part.solid

    def ends(self) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
        """(face, polygon edge) of the free interfaces at the panel's fixed and at its moving end: the first and
        last column (:func:`fabpat.assembly.place.placement.end_interfaces`), or a mesh's ends along the longer side
        of its bounding box (:func:`fabpat.assembly.surface.panel_mesh.end_interfaces`; SpecError if it has none)."""
        if self.tiling.grid is None:
            from fabpat.assembly.surface.panel_mesh import end_interfaces as mesh_ends

            return mesh_ends(self.tiling)
        from fabpat.assembly.place.placement import end_interfaces

        col = self.tiling.grid[:, 1]
        pins = end_interfaces(self.tiling)
        return [p for p in pins if col[p[0]] == 0], [p for p in pins if col[p[0]] != 0]

    def pins(self) -> list[tuple[int, int, Arr, Arr]]:
        """(face, polygon edge, start, end) of the free interfaces at both ends of the panel (:meth:`ends`, the
        fixed end's first), in the panel's plane (mm)."""
        return [(f, i, *self.plates[f].interface(i)) for end in self.ends() for f, i in end]


def joints(tiling: Tiling) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """((face, polygon edge), (face, polygon edge)) of every edge two faces of ``tiling`` share."""
    return [((int(a[0]), int(a[1])), (int(b[0]), int(b[1]))) for a, b in tiling.edge_faces[tiling.interior_edges]]


def build_panel(spec: AssemblySpec, face_patterns: Sequence[str]) -> Panel:
    """Fillet, place and fuse the plates of a ``kind = "panel"`` spec (an AssemblySpec); ``face_patterns`` the
    face pattern IDs (face order; default :func:`fabpat.assembly.kit.build.face_patterns`). Raises SpecError
    (patterns, geometry limits: :func:`check_panel`) or GeometryError (plates that do not fuse)."""
    from fabpat.assembly.place.placement import PlateType
    from fabpat.assembly.surface.panel_mesh import panel_tiling
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    check_panel(spec)
    ids = list(face_patterns)
    e = spec.tiling.edge
    tiling = panel_tiling(spec.tiling)
    if len(ids) != len(tiling.faces):
        raise ValueError(f"need {len(tiling.faces)} pattern IDs, got {len(ids)}")
    types = tuple(PlateType(len(loop), pid, spec.patterns.bridge_weight_of(f) if spec.patterns else 1.0)
                  for f, (loop, pid) in enumerate(zip(tiling.faces, ids, strict=True)))
    filleted = {pt: fillet_pattern(get_pattern(pt.pattern_id, pt.sides, pt.depth, e), spec.plates.weight,
                                   pt.variation) for pt in dict.fromkeys(types)}
    frames = tiling.frames()
    plates = tuple(PlacedOutline(filleted[pt], frames[f][:2, :2].copy(), frames[f][:2, 3].copy())
                   for f, pt in enumerate(types))
    return Panel(spec, tiling, types, filleted, plates, fuse(plates, joints(tiling)))


def check_panel(spec: AssemblySpec) -> None:
    """Refuse (SpecError naming the key and its range) a panel whose interface segment is shorter than
    :data:`fabpat.assembly.place.placement.MIN_INTERFACE_CHORDS` STL chords, as for a kit's plates
    (:func:`fabpat.assembly.place.placement.check_interface_chords`)."""
    from fabpat.assembly.place.placement import check_interface_chords

    check_interface_chords(spec)
