"""The SPLINE pieces of fabpat's DXF ``--curves spline`` mode (:mod:`fabpat.exchange.dxf` writes them).

An outline's rational arcs are rational degree-2 NURBS (:func:`spline_pieces`), exact. LibreCAD 2.2 and
Inkscape 1.2 ignore SPLINE weights and draw the parabola of the control points, so an arc that parabola
leaves more than the tolerance away is written as its own halves, quarters, … (:func:`readable_arcs`): still
the exact arc for a reader that honours weights, within the tolerance for one that does not. The kerf
offset of the exact face (:func:`offset_spline_pieces`) is lines, circular arcs and non-rational cubic
SPLINEs within the tolerance. Lengths in mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import GeometryError
from fabpat.exchange.cad import make_face
from fabpat.exchange.contours import offset_wires, ordered_edges
from fabpat.geometry.outline import Line, Loop, Outline
from fabpat.geometry.polygons import signed_area
from fabpat.validate import SAME_POINT

MAX_SPLINE_DEGREE = 3  # kerf-offset splines: LibreCAD 2.2 and Inkscape 1.2 read degree ≤ 3 only
_APPROX_SEGMENTS = 256  # most Bézier spans OCCT may use for one offset segment
_WEIGHT_SAMPLES = 65  # parameters at which a weightless reading is compared with the rational arc
_MAX_SPLITS = 30  # split depth no arc reaches: a guard against a runaway recursion


@dataclass(frozen=True, eq=False)
class SplinePiece:
    """One segment as a clamped NURBS curve (DXF SPLINE): ``degree``, ``control`` (n, 2) mm,
    ``weights`` (n,), ``knots`` (n + degree + 1,)."""

    degree: int
    control: NDArray[np.float64]
    weights: NDArray[np.float64]
    knots: NDArray[np.float64]

    @property
    def start(self) -> NDArray[np.float64]:
        """(2,) mm: the first control point, where a clamped spline starts."""
        return self.control[0]

    def reversed(self) -> SplinePiece:
        """The same curve traversed the other way (control points and weights reversed, knots mirrored)."""
        k = self.knots
        return SplinePiece(self.degree, self.control[::-1].copy(), self.weights[::-1].copy(), (k[0] + k[-1] - k)[::-1])


# A loop as written in "spline" mode: pieces head to tail; a LINE piece is a (2, 2) array, an ARC
# piece a BulgeLoop-style (start, end, bulge) triple, a SPLINE piece a SplinePiece.
Piece = NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64], float] | SplinePiece


def _oriented(loop: Loop, ccw: bool) -> Loop:
    return loop if (loop.signed_area > 0) == ccw else loop.reversed()


def weightless_error(control: NDArray[np.float64], w: float) -> float:
    """How far (mm) a reader that ignores SPLINE weights draws the rational arc with ``control`` (3, 2) mm and
    middle weight ``w``: the largest distance between the arc and the quadratic Bézier of the same control
    points (LibreCAD 2.2 and Inkscape 1.2 draw that), both at one parameter, sampled at 65 parameters. The
    distance at one parameter bounds the distance between the curves from above."""
    t = np.linspace(0.0, 1.0, _WEIGHT_SAMPLES)[:, None]
    B = np.hstack([(1 - t) ** 2, 2 * t * (1 - t), t * t])  # Bernstein basis (m, 3)
    Bw = B * np.array([1.0, w, 1.0])
    exact = (Bw @ control) / Bw.sum(axis=1, keepdims=True)
    return float(np.max(np.linalg.norm(exact - B @ control, axis=1)))


def readable_arcs(control: NDArray[np.float64], w: float, tol: float) -> list[tuple[NDArray[np.float64], float]]:
    """The rational arc (``control`` (3, 2) mm, middle weight ``w``) as consecutive rational arcs, each
    ``(control (3, 2), w)``, whose :func:`weightless_error` is at most 0.8 × ``tol`` mm: the arc itself when it
    already is, else its halves (de Casteljau at t = 1/2 in homogeneous coordinates, then each half in
    standard form: middle weight √((1 + w)/2), which tends to 1), split again until each is.

    The halves are exactly the arc, so a reader that honours weights still draws it exactly. Each split
    halves the chord and moves the weight towards 1, so the weightless error falls about eightfold.
    Raises :class:`GeometryError` if ``tol`` is not a positive number of mm."""
    if not (tol > 0 and math.isfinite(tol)):
        raise GeometryError(f"tolerance must be > 0 mm, got {tol:g}")
    return _split_arc(np.asarray(control, dtype=np.float64), float(w), tol, 0)


def _split_arc(control: NDArray[np.float64], w: float, tol: float,
               depth: int) -> list[tuple[NDArray[np.float64], float]]:
    P0, P1, P2 = control
    if w == 1.0 or weightless_error(control, w) <= 0.8 * tol:
        return [(control, w)]
    if depth >= _MAX_SPLITS:  # pragma: no cover - the error falls eightfold per split
        raise GeometryError(f"cannot split a rational arc (weight {w:g}) within {tol:g} mm")
    M = (P0 + 2 * w * P1 + P2) / (2 * (1 + w))  # the arc's point at t = 1/2
    half = math.sqrt(0.5 * (1 + w))
    left = np.array([P0, (P0 + w * P1) / (1 + w), M])
    right = np.array([M, (w * P1 + P2) / (1 + w), P2])
    return _split_arc(left, half, tol, depth + 1) + _split_arc(right, half, tol, depth + 1)


def spline_pieces(outline: Outline, tol: float | None = None) -> list[list[Piece]]:
    """Every loop (outer counter-clockwise, then holes clockwise) as exact pieces.

    A rational arc is the rational Bézier (control points P0, P1, P2, weights (1, w, 1)) written
    as a degree-2 NURBS on knots (0, 0, 0, 1, 1, 1) — the same curve (a Bézier curve is the
    B-spline on a clamped knot vector without interior knots); a straight segment is a line. With
    ``tol`` (mm) an arc that a reader ignoring weights would draw more than ``tol`` off is written as
    the consecutive pieces of :func:`readable_arcs` instead: still exact, and within ``tol`` for
    LibreCAD and Inkscape, which ignore weights.
    """
    knots = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    out = []
    for i, lp in enumerate(outline.loops):
        pieces: list[Piece] = []
        for seg in _oriented(lp, i == 0).segments:
            if isinstance(seg, Line) or seg.is_straight:
                if np.linalg.norm(seg.end - seg.start) > SAME_POINT:
                    pieces.append(np.array([seg.start, seg.end]))
                continue
            control = np.array(seg.control_points, dtype=np.float64)
            arcs = [(control, float(seg.w))] if tol is None else readable_arcs(control, float(seg.w), tol)
            pieces += [SplinePiece(2, c, np.array([1.0, w, 1.0]), knots) for c, w in arcs]
        out.append(pieces)
    return out


def _reverse_pieces(pieces: list[Piece]) -> list[Piece]:
    out: list[Piece] = []
    for p in reversed(pieces):
        if isinstance(p, SplinePiece):
            out.append(p.reversed())
        elif isinstance(p, tuple):
            out.append((p[1], p[0], -p[2]))
        else:
            out.append(p[::-1].copy())
    return out


def offset_spline_pieces(outline: Outline, distance: float, tol: float) -> list[list[Piece]]:
    """The exact face's loops offset by ``distance`` mm into the void, one piece per offset edge.

    Lines stay lines and circles (the arc joins) become arcs, exactly; the offset of a rational
    arc (an OCCT offset curve) becomes a C1 cubic B-spline (C2 would need degree 5 in OCCT) within ``tol`` mm. Raises
    :class:`GeometryError` when OCCT cannot approximate within ``tol``.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.Geom import Geom_TrimmedCurve
    from OCP.GeomAbs import GeomAbs_CurveType, GeomAbs_Shape
    from OCP.GeomConvert import GeomConvert, GeomConvert_ApproxCurve
    from OCP.TopAbs import TopAbs_REVERSED

    loops: list[list[Piece]] = []
    areas: list[float] = []
    for wire in offset_wires(make_face(outline), distance):
        pieces: list[Piece] = []
        starts = []
        for e, a, b in ordered_edges(wire):
            chord = b - a
            if float(chord @ chord) <= SAME_POINT**2:
                continue
            starts.append(a)
            kind = BRepAdaptor_Curve(e).GetType()
            if kind == GeomAbs_CurveType.GeomAbs_Line:
                pieces.append(np.array([a, b]))
                continue
            if kind == GeomAbs_CurveType.GeomAbs_Circle:
                c = BRepAdaptor_Curve(e)
                m = c.Value(0.5 * (c.FirstParameter() + c.LastParameter()))
                rel = np.array([m.X(), m.Y()]) - a
                # bulge = sagitta / half chord, positive when the arc's middle is right of the chord.
                pieces.append((a, b, -2.0 * float(chord[0] * rel[1] - chord[1] * rel[0]) / float(chord @ chord)))
                continue
            curve = BRep_Tool.Curve_s(e, 0.0, 0.0)
            lo, hi = BRep_Tool.Range_s(e)
            approx = GeomConvert_ApproxCurve(Geom_TrimmedCurve(curve, lo, hi), 0.5 * tol, GeomAbs_Shape.GeomAbs_C1,
                                             _APPROX_SEGMENTS, MAX_SPLINE_DEGREE)
            if not approx.HasResult() or approx.MaxError() > tol:
                raise GeometryError(f"cannot approximate the kerf offset within {tol:g} mm by cubic splines")
            bs = GeomConvert.CurveToBSplineCurve_s(approx.Curve())
            if e.Orientation() == TopAbs_REVERSED:
                bs.Reverse()
            n = bs.NbPoles()
            pieces.append(SplinePiece(
                bs.Degree(),
                np.array([[bs.Pole(i).X(), bs.Pole(i).Y()] for i in range(1, n + 1)]),
                np.array([bs.Weight(i) for i in range(1, n + 1)]),
                np.array([bs.Knot(i) for i in range(1, bs.NbKnots() + 1) for _ in range(bs.Multiplicity(i))]),
            ))
        if not pieces:
            continue
        P = np.array(starts)
        areas.append(signed_area(P))
        loops.append(pieces)
    out = []
    for k, i in enumerate(np.argsort(-np.abs(np.array(areas)))):  # outer loop first, counter-clockwise
        out.append(loops[i] if (areas[i] > 0) == (k == 0) else _reverse_pieces(loops[i]))
    return out
