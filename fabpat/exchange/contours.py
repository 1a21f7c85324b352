"""2-D cutting contours for laser cutting: an outline as closed loops of lines and circular arcs (mm).

The DXF and SVG writers and the assembly sheets cut along these, not along the B-rep solid of
:mod:`fabpat.exchange.cad`: a :class:`BulgeLoop` is a DXF ``LWPOLYLINE`` (lines and circular arcs, each arc by
its bulge), :func:`bulge_loops` fits every rational arc of an outline by circular arcs within a
tolerance, and :func:`offset_bulge_loops` offsets the loops by the laser's kerf with OCCT. The OCCT
wires are built with :mod:`fabpat.exchange.cad`'s edge builder, so both rooms make edges the same way.

All OCP imports are inside the functions, so importing this module costs nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.exchange.cad import _pnt, _wire_from

if TYPE_CHECKING:  # pragma: no cover - OCP has no stubs: mypy sees its classes as unchecked
    from OCP.TopoDS import TopoDS_Edge, TopoDS_Face, TopoDS_Wire
from fabpat.geometry.outline import Line, Outline, RationalQuad
from fabpat.validate import SAME_POINT


@dataclass(frozen=True, eq=False)
class BulgeLoop:
    """A closed chain of straight and circular pieces, as in a DXF LWPOLYLINE.

    ``V`` (k, 2) float mm: piece i runs from V[i] to V[(i + 1) % k]; ``bulges`` (k,) float:
    tan(sweep / 4) of piece i, 0 for a straight piece, > 0 counter-clockwise.
    """

    V: NDArray[np.float64]
    bulges: NDArray[np.float64]

    def area(self) -> float:
        """Exact signed area (mm², CCW > 0): chord polygon plus the circular segments."""
        V, b = self.V, self.bulges
        E = np.roll(V, -1, axis=0)
        total = 0.5 * float(np.sum(V[:, 0] * E[:, 1] - V[:, 1] * E[:, 0]))
        theta = 4.0 * np.arctan(np.abs(b))
        chord = np.hypot(*(E - V).T)
        arc = theta > 0
        R = chord[arc] / (2.0 * np.sin(0.5 * theta[arc]))
        total += float(np.sum(np.sign(b[arc]) * 0.5 * R**2 * (theta[arc] - np.sin(theta[arc]))))
        return total

    def flatten(self, tol: float) -> NDArray[np.float64]:
        """(m, 2) points of a closed polyline within ``tol`` mm of the loop (last point not repeated)."""
        from fabpat.geometry.conics import arc_points

        out: list[NDArray[np.float64]] = []
        E = np.roll(self.V, -1, axis=0)
        for s, e, b in zip(self.V, E, self.bulges, strict=True):
            if b == 0.0:
                out.append(s[None])
                continue
            theta = 4.0 * math.atan(abs(float(b)))
            R = float(np.hypot(*(e - s))) / (2.0 * math.sin(0.5 * theta))
            # A chord of a circle of radius R deviates by R (1 − cos(φ/2)) over a sweep φ.
            step = 2.0 * math.acos(max(-1.0, 1.0 - tol / R)) if tol < R else math.pi
            n = max(1, math.ceil(theta / step))
            out.append(arc_points(s, e, float(b), n + 1)[:-1])
        return np.vstack(out)


_ARC_CACHE: dict[tuple[float, ...], NDArray[np.float64]] = {}
_ARC_CACHE_SIZE = 8192


def fitted_arcs(seg: RationalQuad, tol: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Starts (k, 2) and bulges (k,) of circular arcs within ``tol`` mm of a rational arc.

    :func:`fabpat.geometry.conics.fit_arcs` on the arc moved to a canonical position (P0 at the origin, chord
    along +x), cached: an arc fit is invariant under rigid motions, and a pattern — let alone a
    library — repeats the same few arcs many times, so this makes DXF export several times faster.
    """
    P = seg.control_points
    chord = P[2] - P[0]
    length = float(np.hypot(*chord))
    if length <= SAME_POINT:
        raise GeometryError("a rational arc that returns to its start cannot be fitted")
    c, s = chord / length
    R = np.array([[c, s], [-s, c]])  # rotates the chord onto +x
    q = R @ (P[1] - P[0])
    # The key, rounded to 1e-10 mm, merges rotated copies of one arc (they differ by rounding noise
    # only); the first copy is fitted as it is, so fit_arcs still recognises exact circular arcs.
    key = (round(float(q[0]), 10), round(float(q[1]), 10), round(length, 10), seg.w, tol)
    arcs = _ARC_CACHE.get(key)
    if arcs is None:
        from fabpat.geometry.conics import fit_arcs

        Q = np.array([[0.0, 0.0], q, [length, 0.0]])
        arcs = np.array([(s_[0], s_[1], b) for s_, _e, b in fit_arcs(Q, seg.w, tol)])
        if len(_ARC_CACHE) >= _ARC_CACHE_SIZE:
            _ARC_CACHE.clear()
        _ARC_CACHE[key] = arcs
    starts = arcs[:, :2] @ R + P[0]
    starts[0] = P[0]
    return starts, arcs[:, 2]


def bulge_loops(outline: Outline, tol: float) -> list[BulgeLoop]:
    """Every loop (outer first) with each rational arc fitted by circular arcs within ``tol`` mm.

    G1 biarcs from :func:`fabpat.geometry.conics.fit_arcs` (one exact arc for a circular Bézier arc).
    """
    loops = []
    for loop in outline.loops:
        V: list[NDArray[np.float64]] = []
        B: list[NDArray[np.float64]] = []
        for seg in loop.segments:
            if isinstance(seg, Line):
                if np.linalg.norm(seg.p1 - seg.p0) > SAME_POINT:
                    V.append(seg.p0[None])
                    B.append(np.zeros(1))
                continue
            starts, bulges = fitted_arcs(seg, tol)
            V.append(starts)
            B.append(bulges)
        loops.append(BulgeLoop(np.vstack(V), np.concatenate(B)))
    return loops


def _bulge_wire(loop: BulgeLoop) -> TopoDS_Wire:
    from OCP.GC import GC_MakeArcOfCircle

    from fabpat.geometry.conics import arc_points

    E = np.roll(loop.V, -1, axis=0)
    curves = [
        None if b == 0.0 else GC_MakeArcOfCircle(*(_pnt(p) for p in arc_points(s, e, float(b), 3))).Value()
        for s, e, b in zip(loop.V, E, loop.bulges, strict=True)
    ]
    return _wire_from(list(loop.V), curves)


def offset_wires(face: TopoDS_Face, distance: float) -> list[TopoDS_Wire]:
    """Wires of the face's boundary offset by ``distance`` mm away from the material (arc joins)."""
    from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeOffset
    from OCP.GeomAbs import GeomAbs_JoinType
    from OCP.TopAbs import TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    # Arc joins: a laser beam of radius kerf/2 rounds every convex corner by exactly that radius.
    maker = BRepOffsetAPI_MakeOffset(face, GeomAbs_JoinType.GeomAbs_Arc, False)
    maker.Perform(float(distance))
    if not maker.IsDone():
        raise GeometryError(f"OCCT could not offset the outline by {distance:g} mm")
    wires = []
    explorer = TopExp_Explorer(maker.Shape(), TopAbs_WIRE)
    while explorer.More():
        wires.append(TopoDS.Wire(explorer.Current()))
        explorer.Next()
    if not wires:
        raise GeometryError(f"offsetting the outline by {distance:g} mm left nothing")
    return wires


def ordered_edges(wire: TopoDS_Wire) -> list[tuple[TopoDS_Edge, NDArray[np.float64], NDArray[np.float64]]]:
    """(edge, start (2,), end (2,)) along the wire, with edge orientation taken into account."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.TopExp import TopExp

    out = []
    explorer = BRepTools_WireExplorer(wire)
    while explorer.More():
        e = explorer.Current()
        a = BRep_Tool.Pnt_s(TopExp.FirstVertex_s(e, True))
        b = BRep_Tool.Pnt_s(TopExp.LastVertex_s(e, True))
        out.append((e, np.array([a.X(), a.Y()]), np.array([b.X(), b.Y()])))
        explorer.Next()
    return out


_L = TypeVar("_L")


def cut_order(loops: Sequence[_L]) -> list[_L]:
    """One part's loops, given outer loop first (as every loop list in fabpat is), in the order a
    laser cuts them: the holes, then the outer loop. Laser software cuts in file order, and a part
    whose outline is cut first is free in the sheet and can shift before its holes are cut."""
    return [*loops[1:], *loops[:1]]


def outer_first(loops: Sequence[_L], area: Sequence[float]) -> list[_L]:
    """The loops sorted by decreasing |area|: the outer loop of a face comes first."""
    order = np.argsort(-np.abs(np.array(area)))
    return [loops[i] for i in order]


def offset_bulge_loops(loops: list[BulgeLoop], distance: float) -> list[BulgeLoop]:
    """Lines-and-arcs loops (outer first, holes after) offset by ``distance`` mm into the void.

    The outer loop grows and holes shrink (the part's material grows), convex corners get arcs of
    radius ``distance``, and the topology is OCCT's (a hole narrower than 2·distance disappears). The
    offset of a line or circle is a line or circle, so the result is exact: its error is that of
    the arc fit. Returned outer loop counter-clockwise, holes clockwise, outer first.
    """
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.GeomAbs import GeomAbs_CurveType
    from OCP.gp import gp_Pln

    maker = BRepBuilderAPI_MakeFace(gp_Pln(), _bulge_wire(_bulge_oriented(loops[0], True)), True)
    for hole in loops[1:]:
        maker.Add(_bulge_wire(_bulge_oriented(hole, False)))
    out: list[BulgeLoop] = []
    for wire in offset_wires(maker.Face(), distance):
        V, B = [], []
        for e, a, b in ordered_edges(wire):
            chord = b - a
            L2 = float(chord @ chord)
            if L2 <= SAME_POINT**2:
                continue
            c = BRepAdaptor_Curve(e)
            kind = c.GetType()
            if kind == GeomAbs_CurveType.GeomAbs_Line:
                bulge = 0.0
            elif kind == GeomAbs_CurveType.GeomAbs_Circle:
                m = c.Value(0.5 * (c.FirstParameter() + c.LastParameter()))
                rel = np.array([m.X(), m.Y()]) - a
                # bulge = sagitta / half chord, positive when the arc's middle is right of the chord.
                bulge = -2.0 * float(chord[0] * rel[1] - chord[1] * rel[0]) / L2
            else:
                raise GeometryError(f"offset produced an unexpected {kind.name} edge")
            V.append(a)
            B.append(bulge)
        if len(V) >= 2:
            out.append(BulgeLoop(np.array(V), np.array(B)))
    out = outer_first(out, [lp.area() for lp in out])
    return [_bulge_oriented(lp, i == 0) for i, lp in enumerate(out)]


def _bulge_oriented(loop: BulgeLoop, ccw: bool) -> BulgeLoop:
    if (loop.area() > 0) == ccw:
        return loop
    return BulgeLoop(loop.V[::-1].copy(), -np.roll(loop.bulges[::-1], -1))
