"""Exact B-rep geometry of a pattern plate: outline → planar face → extruded solid (mm).

Every :class:`~fabpat.geometry.outline.Line` becomes a line edge and every
:class:`~fabpat.geometry.outline.RationalQuad` a rational Bézier edge with weights (1, w, 1) — the same
construction as build123d's ``Edge.make_bezier(p0, p1, p2, weights=[1, w, 1])``, never a polyline.
The solid is checked with ``BRepCheck_Analyzer``; an invalid one raises :class:`GeometryError`.

Layers:

* ``make_face`` / ``make_solid`` / ``mesh`` work on raw OCP shapes. The exporters use them because
  ``import build123d`` alone costs ≈ 3.5 s (it pulls in scikit-learn), while OCP loads in ≈ 1 s.
* :func:`outline_face` / :func:`pattern_solid` wrap the same shapes as build123d ``Face`` / ``Solid``
  for interactive and scripted use (build123d is imported only when they are called).
* The 2D cutting contours for DXF/SVG (loops of lines and circular arcs, their kerf offset) live in
  :mod:`fabpat.exchange.contours`, which builds its OCCT wires with this module's edge builder.

All OCP imports are inside the functions, so importing this module costs nothing.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, TypeAlias

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.geometry.outline import Line, Loop, Outline, RationalQuad
from fabpat.validate import SAME_POINT

if TYPE_CHECKING:  # pragma: no cover - typing only (OCP has no stubs: mypy sees its classes as unchecked)
    from build123d import Face, Shape, Solid
    from OCP.Geom import Geom_BezierCurve, Geom_Curve
    from OCP.gp import gp_Pnt
    from OCP.TopoDS import TopoDS_Face, TopoDS_Shape, TopoDS_Solid, TopoDS_Wire

#: an OCCT shape or a build123d one around it (its ``wrapped`` OCCT shape is what the writers use)
ShapeLike: TypeAlias = "TopoDS_Shape | Shape"

DEFAULT_THICKNESS = 2.0  # mm: the paper's plate thickness (§4.1)
DEFAULT_ANGULAR = 0.5  # rad: BRepMesh angular deflection; the chord tolerance in mm is what matters
# mm: STL/3MF chord height. 0.005, not 0.01: at 0.01 the chords of concave arcs, which lie outside the
# material, put one lacy pattern (0x2508) 0.107 % over its volume; at 0.005 every pattern is within 0.1 %.
DEFAULT_CHORD = 0.005


def part_name(pattern_id: str, sides: int, edge: float, thickness: float, weight: float, variation: str = "") -> str:
    """The product name written to STEP/3MF: ID and every parameter that changes the geometry,
    ending with the family member's ``variation`` label (:meth:`fabpat.patterns.variation.Variation.label`) if any.

    >>> part_name("0x0488", 6, 36.0, 2.0, 0.2)
    'fabpat 0x0488 n6 e36mm t2mm w0.2'
    >>> part_name("0x0488", 6, 36.0, 2.0, 0.2, "bridge_weight=0.5")
    'fabpat 0x0488 n6 e36mm t2mm w0.2 bridge_weight=0.5'
    """
    name = f"fabpat {pattern_id} n{sides} e{edge:g}mm t{thickness:g}mm w{weight:g}"
    return f"{name} {variation}" if variation else name


# -- raw OCP construction ---------------------------------------------------------------------------


def _pnt(p: NDArray[np.float64]) -> gp_Pnt:
    from OCP.gp import gp_Pnt

    return gp_Pnt(float(p[0]), float(p[1]), 0.0)


def _wire_from(starts: list[NDArray[np.float64]], curves: list[Piece]) -> TopoDS_Wire:
    """A closed ``TopoDS_Wire``: piece i runs from starts[i] to starts[i+1] (cyclic) along curves[i].

    ``curves[i]`` is None for a straight piece, a ``Geom_Curve`` whose ends are those points, or
    ``(curve, first, last, reversed)`` for a piece of a longer curve (``reversed``: the piece runs
    from the point at ``last`` to the point at ``first``). Consecutive edges share one
    ``TopoDS_Vertex``, so the wire is closed by construction.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeVertex, BRepBuilderAPI_MakeWire
    from OCP.TopoDS import TopoDS

    verts = [BRepBuilderAPI_MakeVertex(_pnt(p)).Vertex() for p in starts]
    maker = BRepBuilderAPI_MakeWire()
    for i, curve in enumerate(curves):
        v0, v1 = verts[i], verts[(i + 1) % len(verts)]
        flip = False
        if curve is None:
            edge = BRepBuilderAPI_MakeEdge(v0, v1)
        elif isinstance(curve, tuple):
            geom, first, last, flip = curve
            edge = BRepBuilderAPI_MakeEdge(geom, v1, v0, first, last) if flip else BRepBuilderAPI_MakeEdge(
                geom, v0, v1, first, last
            )
        else:
            edge = BRepBuilderAPI_MakeEdge(curve, v0, v1)
        if not edge.IsDone():
            raise GeometryError(f"cannot build edge {i} of a loop (degenerate segment?)")
        maker.Add(TopoDS.Edge(edge.Edge().Reversed()) if flip else edge.Edge())
    if not maker.IsDone():
        raise GeometryError("cannot build a wire from the loop")
    return maker.Wire()


def _bezier(seg: RationalQuad) -> Geom_BezierCurve:
    """Same construction as build123d's ``Edge.make_bezier(P0, P1, P2, weights=[1, w, 1])``."""
    from OCP.collections import Array1_double, Array1_gp_Pnt
    from OCP.Geom import Geom_BezierCurve

    poles, weights = Array1_gp_Pnt(1, 3), Array1_double(1, 3)
    for k, (p, w) in enumerate(zip(seg.control_points, (1.0, seg.w, 1.0), strict=True)):
        poles.SetValue(k + 1, _pnt(p))
        weights.SetValue(k + 1, w)
    return Geom_BezierCurve(poles, weights)


Support = tuple[tuple[NDArray[np.float64], float, "Geom_BezierCurve", float, float], ...]
#: one piece of a wire (:func:`_wire_from`): None (straight), a whole curve, or (curve, first, last, reversed)
Piece: TypeAlias = "Geom_Curve | tuple[Geom_Curve, float, float, bool] | None"


def _support(arcs: Sequence[RationalQuad]) -> Support:
    """(control points, weight, whole curve, first, last) of both halves of every support arc."""
    from fabpat.geometry.curves import split_quad

    out = []
    for arc in arcs:
        geom = _bezier(arc)
        halves = split_quad(arc.control_points, arc.w)
        out += [(P, w, geom, lo, hi) for (lo, hi), (P, w) in zip(((0.0, 0.5), (0.5, 1.0)), halves, strict=True)]
    return tuple(out)


def _on_support(seg: RationalQuad, support: Support) -> tuple[Geom_BezierCurve, float, float, bool] | None:
    """``(curve, first, last, reversed)`` if ``seg`` is a half of a support arc, else None."""
    for P, w, geom, lo, hi in support:
        if abs(w - seg.w) > 1e-9:
            continue
        for flip, Q in ((False, P), (True, P[::-1])):
            if np.abs(Q - seg.control_points).max() <= 1e-9:
                return geom, lo, hi, flip
    return None


def _wire(loop: Loop, support: Support = ()) -> TopoDS_Wire:
    """The loop as a wire of line edges and rational Bézier edges with weights (1, w, 1).

    A segment that is one half of a ``support`` arc is built on that whole arc, trimmed to
    [0, ½] or [½, 1]: the same point set, but its curve keeps the arc's own weights.
    """
    segs = [s for s in loop.segments if isinstance(s, RationalQuad) or np.linalg.norm(s.end - s.start) > SAME_POINT]
    if len(segs) < 2:
        raise GeometryError(f"a loop needs at least 2 segments, got {len(segs)}")
    curves: list[Piece] = []
    for i, s in enumerate(segs):
        gap = float(np.linalg.norm(s.end - segs[(i + 1) % len(segs)].start))
        if gap > SAME_POINT:
            raise GeometryError(f"loop is not closed: gap of {gap:.3g} mm after segment {i}")
        if isinstance(s, Line):
            curves.append(None)
        else:
            curves.append(_on_support(s, support) or _bezier(s))
    return _wire_from([s.start for s in segs], curves)


def _oriented(loop: Loop, ccw: bool) -> Loop:
    """The loop, reversed if needed so that it runs counter-clockwise (``ccw``) or clockwise."""
    return loop if (loop.signed_area > 0) == ccw else loop.reversed()


@contextlib.contextmanager
def occt_errors(what: str) -> Iterator[None]:
    """Turn an OCCT exception (``Standard_Failure`` and its kin, raised through OCP) into GeometryError.

    OCCT signals bad parameters by exceptions such as ``Standard_NumericError`` (a mesh tolerance of
    1e-9 mm) or ``Standard_ConstructionError`` (an extrusion of 1e-9 mm); this is the boundary where
    fabpat calls it, so the user sees one line naming what failed.
    """
    try:
        yield
    except Exception as e:
        if not type(e).__module__.startswith("OCP"):
            raise
        raise GeometryError(f"{what} failed in OpenCASCADE ({type(e).__name__}: {str(e).strip() or 'no detail'})"
                            ) from e


def make_face(outline: Outline, support: Sequence[RationalQuad] = (), check: bool = True) -> TopoDS_Face:
    """The outline as a planar ``TopoDS_Face`` on z = 0 with normal +z (outer CCW, holes CW).

    ``support``: whole arcs of which the outline keeps halves — the interface bow-ties
    (``FilletedPattern.interface_arcs``). Those halves are built as trimmed edges on the whole arc,
    so the B-rep (and STEP) carries the configured weights (1, w, 1) instead of the half's
    standard-form weight √((1 + w)/2). Loops are re-oriented by their signed area if needed.
    Raises :class:`GeometryError` for open loops or (if ``check``) an invalid face.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.gp import gp_Pln

    with occt_errors("building the outline face"):
        sup = _support(support)
        maker = BRepBuilderAPI_MakeFace(gp_Pln(), _wire(_oriented(outline.outer, ccw=True), sup), True)
        for hole in outline.holes:
            maker.Add(_wire(_oriented(hole, ccw=False), sup))
    if not maker.IsDone():
        raise GeometryError("cannot build a face from the outline")
    face = maker.Face()
    if check:
        check_valid(face, "outline face")
    return face


def make_solid(outline: Outline, thickness: float = DEFAULT_THICKNESS,
               support: Sequence[RationalQuad] = ()) -> TopoDS_Solid:
    """The face extruded along +z by ``thickness`` mm: a valid ``TopoDS_Solid`` (z from 0 to t).

    ``support`` as for :func:`make_face`.
    """
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Vec
    from OCP.TopAbs import TopAbs_SOLID

    if not thickness > 0 or not math.isfinite(thickness):
        raise GeometryError(f"thickness must be > 0 mm, got {thickness:g}")
    face = make_face(outline, support, check=False)
    with occt_errors(f"extruding the outline by {thickness:g} mm"):
        solid = BRepPrimAPI_MakePrism(face, gp_Vec(0.0, 0.0, float(thickness))).Shape()
    if solid.ShapeType() != TopAbs_SOLID:
        raise GeometryError(f"extrusion gave a {solid.ShapeType().name}, not a solid")
    check_valid(solid, "extruded solid")
    return solid


def check_valid(shape: TopoDS_Shape, what: str = "shape") -> None:
    """Raise :class:`GeometryError` unless ``BRepCheck_Analyzer`` finds the shape valid."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    if not BRepCheck_Analyzer(shape).IsValid():
        raise GeometryError(f"{what} is not a valid B-rep (self-intersecting or mis-oriented outline?)")


def volume(shape: ShapeLike) -> float:
    """Volume of a solid in mm³ (adaptive Gauss–Kronrod on the exact surfaces, rel. 1e-10)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    # Adaptive Gauss–Kronrod: ~1e-15 on the w = 0.2 bow-tie, where the fixed-order default is off
    # by ~1e-7 and the adaptive Gauss variant by up to 1e-4 (measured).
    BRepGProp.VolumePropertiesGK_s(getattr(shape, "wrapped", shape), props, 1e-10)
    return float(props.Mass())


def mesh(shape: TopoDS_Shape, tolerance: float, angular: float = DEFAULT_ANGULAR) -> None:
    """Triangulate ``shape`` in place with a chord tolerance in **mm** (not relative to its size).

    ``BRepMesh_IncrementalMesh(shape, tolerance, isRelative=False, angular, parallel=False)``:
    build123d's ``export_stl`` tolerance is relative, hence this direct call. One thread is faster
    than the parallel mesher for one small part on a shared 2-core machine (measured). Surface
    deflection control must stay on (the default): without it the side faces of an extruded arc,
    triangulated in their anisotropic (u, z) parameter space, get slanted triangles that cut
    inside the arc by far more than the tolerance (the tests catch this).
    """
    from OCP.BRepMesh import BRepMesh_IncrementalMesh

    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise GeometryError(f"mesh tolerance must be > 0 mm, got {tolerance:g}")
    with occt_errors(f"meshing the solid with a {tolerance:g} mm chord"):
        done = BRepMesh_IncrementalMesh(shape, float(tolerance), False, float(angular), False)
    if not done.IsDone():
        raise GeometryError("BRepMesh failed to triangulate the solid")


# -- build123d wrappers -----------------------------------------------------------------------------


def outline_face(outline: Outline, support: Sequence[RationalQuad] = ()) -> Face:
    """The outline as a build123d ``Face`` with exact line and rational Bézier edges (mm, z = 0)."""
    from build123d import Face

    return Face(make_face(outline, support))


def pattern_solid(
    outline: Outline,
    thickness: float = DEFAULT_THICKNESS,
    name: str | None = None,
    support: Sequence[RationalQuad] = (),
) -> Solid:
    """The plate as a BRepCheck-valid build123d ``Solid`` (z from 0 to ``thickness`` mm).

    ``name`` becomes the solid's ``label`` (build123d's exporters write it as the product name);
    see :func:`part_name`; ``support`` as for :func:`make_face`. Raises :class:`GeometryError` if
    the outline does not give a valid solid.
    """
    from build123d import Solid

    solid = Solid(make_solid(outline, thickness, support))
    if name is not None:
        solid.label = name
    return solid
