"""DXF for laser cutting and CNC: the outline's loops on layer ``CUT``, the pattern ID on ``ENGRAVE``.

One closed entity per outline loop, coordinates in millimetres (``$INSUNITS`` = 4, mm; DXF R12 has
no units variable, so R12 files are mm by convention only). Curve modes:

* ``"arcs"`` (default): every rational arc fitted by circular arcs within ``tolerance`` mm (G1
  biarcs from :func:`fabpat.conics.fit_arcs`) in an LWPOLYLINE with bulges — what every laser and
  CNC program reads. Lines stay exact.
* ``"spline"``: one exact rational SPLINE per loop: degree 2, each segment a Bézier piece between
  double knots, with its control points and weights (1, w, 1) (lines as straight degree-2 pieces).
* ``"lines"``: polylines within ``tolerance`` mm (exact chord test of
  :func:`fabpat.curves.flatten_quad`).

``dxf_version="R12"`` writes old-style POLYLINE entities (bulges kept) for old software; R12 has
no SPLINE entity, so ``curves="spline"`` needs R2000 or newer.

Kerf: ``kerf`` > 0 offsets every loop by kerf / 2 into the void (the outer loop grows, holes shrink),
so a beam that removes kerf / 2 on each side of the path leaves the part at its nominal size. The
offset is OCCT's ``BRepOffsetAPI_MakeOffset`` with arc joins (robust to loops that merge or holes
that vanish), applied to the fitted arcs in ``"arcs"`` / ``"lines"`` mode (an offset of lines and
circles is exact lines and circles) and to the exact face in ``"spline"`` mode (see
:func:`fabpat.cad.offset_spline_loops`; the weights are then no longer (1, w, 1)).
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from fabpat.cad import CLOSE_TOL, bulge_loops, make_face, offset_bulge_loops, offset_wires, ordered_edges, outer_first
from fabpat.errors import ExportError, GeometryError
from fabpat.io import atomic_outputs
from fabpat.outline import Line, Loop, Outline

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.exchange.registry import ExportSettings, Part

CURVE_MODES = ("arcs", "spline", "lines")
DXF_VERSIONS = ("R12", "R2000", "R2004", "R2007", "R2010", "R2013", "R2018")
DEFAULT_VERSION = "R2010"
DEFAULT_TOLERANCE = 0.01  # mm: largest distance between the written curves and the exact outline
CUT_LAYER, ENGRAVE_LAYER = "CUT", "ENGRAVE"
CUT_COLOR, ENGRAVE_COLOR = 1, 5  # ACI red / blue: the usual laser-software convention
MAX_TEXT_HEIGHT = 3.0  # mm
MIN_TEXT_HEIGHT = 1.0  # mm: smaller engraved text is unreadable; such labels go below the part
CHAR_WIDTH = 0.9  # text width per character / text height (conservative for the standard font)


def check_options(curves: str, tolerance: float, kerf: float, dxf_version: str) -> None:
    """Raise :class:`ExportError` for an option the DXF writer cannot honour."""
    if curves not in CURVE_MODES:
        raise ExportError(f"unknown curve mode {curves!r}: choose one of {', '.join(CURVE_MODES)}")
    if dxf_version not in DXF_VERSIONS:
        raise ExportError(f"unknown DXF version {dxf_version!r}: choose one of {', '.join(DXF_VERSIONS)}")
    if curves == "spline" and dxf_version == "R12":
        raise ExportError("DXF R12 has no SPLINE entity: use --curves arcs or lines, or a newer version")
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise ExportError(f"curve tolerance must be > 0 mm, got {tolerance:g}")
    if not (kerf >= 0 and math.isfinite(kerf)):
        raise ExportError(f"kerf must be ≥ 0 mm, got {kerf:g}")


@dataclass(frozen=True, eq=False)
class SplineLoop:
    """A closed loop as one clamped NURBS curve (DXF SPLINE): ``degree``, ``control`` (n, 2) mm,
    ``weights`` (n,), ``knots`` (n + degree + 1,); the first and last control points coincide."""

    degree: int
    control: NDArray[np.float64]
    weights: NDArray[np.float64]
    knots: NDArray[np.float64]


def offset_spline_loops(outline: Outline, distance: float, tol: float) -> list[SplineLoop]:
    """The exact face's loops offset by ``distance`` mm into the void, as one NURBS per loop.

    The offset of a rational arc is not a rational quadratic: OCCT returns an exact offset curve,
    which is approximated here by a C1 B-spline within ``tol`` mm; lines and join arcs convert
    exactly. The pieces of a loop are joined into one B-spline (degrees raised to the largest).
    """
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_TrimmedCurve
    from OCP.GeomAbs import GeomAbs_Shape
    from OCP.GeomConvert import GeomConvert, GeomConvert_ApproxCurve, GeomConvert_CompCurveToBSplineCurve
    from OCP.TopAbs import TopAbs_REVERSED

    out: list[SplineLoop] = []
    areas: list[float] = []
    for wire in offset_wires(make_face(outline), distance):
        joined = None
        pts = []
        for e, a, _b in ordered_edges(wire):
            curve = BRep_Tool.Curve_s(e, 0.0, 0.0)
            lo, hi = BRep_Tool.Range_s(e)
            trimmed = Geom_TrimmedCurve(curve, lo, hi)
            if curve.DynamicType().Name() in ("Geom_OffsetCurve", "Geom_TrimmedCurve"):
                approx = GeomConvert_ApproxCurve(trimmed, 0.5 * tol, GeomAbs_Shape.GeomAbs_C1, 64, 8)
                if not approx.HasResult() or approx.MaxError() > tol:
                    raise GeometryError(f"cannot approximate the kerf offset within {tol:g} mm")
                bs = approx.Curve()
            else:
                bs = GeomConvert.CurveToBSplineCurve_s(trimmed)
            if e.Orientation() == TopAbs_REVERSED:
                bs.Reverse()
            pts.append(a)
            if joined is None:
                joined = GeomConvert_CompCurveToBSplineCurve(bs)
            elif not joined.Add(bs, 10 * CLOSE_TOL, True, False, 0):
                raise GeometryError("cannot join the offset pieces into one spline")
        if joined is None:
            continue
        c = joined.BSplineCurve()
        control = np.array([[p.X(), p.Y()] for p in (c.Pole(i) for i in range(1, c.NbPoles() + 1))])
        weights = np.array([c.Weight(i) for i in range(1, c.NbPoles() + 1)])
        knots = np.array(
            [c.Knot(i) for i in range(1, c.NbKnots() + 1) for _ in range(c.Multiplicity(i))], dtype=np.float64
        )
        out.append(SplineLoop(c.Degree(), control, weights, knots))
        P = np.array(pts)
        areas.append(0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - P[:, 1] * np.roll(P[:, 0], -1))))
    return outer_first(out, areas)


def spline_loop(loop: Loop) -> SplineLoop:
    """The loop as one exact degree-2 NURBS: segment i is the Bézier piece on knots [i, i + 1].

    Interior knots are doubled, so each piece is exactly its segment (C0 joints, which is what the
    outline's corners are): control points P0, P1, P2 and weights (1, w, 1) per rational arc, and a
    straight line as P0, midpoint, P1 with weights 1.
    """
    control: list[NDArray[np.float64]] = []
    weights: list[float] = []
    for seg in loop.segments:
        if isinstance(seg, Line):
            mid, w = 0.5 * (seg.p0 + seg.p1), 1.0
        else:
            mid, w = seg.P1, seg.w
        control += [seg.start, mid]
        weights += [1.0, w]
    control.append(loop.segments[0].start)
    weights.append(1.0)
    k = len(loop.segments)
    knots = np.concatenate([[0.0], np.repeat(np.arange(k + 1, dtype=np.float64), 2), [float(k)]])
    return SplineLoop(2, np.array(control), np.array(weights), knots)


def polyline(loop: Loop, tol: float) -> NDArray[np.float64]:
    """(m, 2) closed polyline within ``tol`` mm of the loop (last point not repeated)."""
    from fabpat.curves import flatten_quad

    pts: list[NDArray[np.float64]] = []
    for seg in loop.segments:
        if isinstance(seg, Line):
            pts.append(seg.p0[None])
        else:
            pts.append(np.asarray(flatten_quad(seg.control_points, seg.w, tol))[:-1])
    return np.vstack(pts)


def label_placement(outline: Outline, text: str) -> tuple[tuple[float, float], float]:
    """Centre (x, y) mm and height mm for an engraved label on the material, or below the part.

    Grid search (32 × 32, refined once) for the point of the material farthest from the boundary
    of a 0.1 mm flattening; the text box must fit in that clearance circle. If the largest height
    that fits is below MIN_TEXT_HEIGHT, the label goes 2 mm under the part instead (on the sheet).
    """
    from fabpat.polyline import points_in_polygon

    flat = 0.1  # mm: coarse is enough, the clearance is reduced by it below
    polys = [polyline(loop, flat) for loop in outline.loops]
    A = np.vstack(polys)
    B = np.vstack([np.roll(P, -1, axis=0) for P in polys])
    lo, hi = polys[0].min(axis=0), polys[0].max(axis=0)

    D = B - A
    L2 = np.maximum(np.einsum("ij,ij->i", D, D), 1e-300)

    def clearance(X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance to the boundary of points on the material, −1 elsewhere."""
        inside = points_in_polygon(X, polys[0])
        for hole in polys[1:]:
            inside &= ~points_in_polygon(X, hole)
        out = np.full(len(X), -1.0)
        Y = X[inside]
        s = np.clip(((Y[:, None, :] - A[None]) * D[None]).sum(-1) / L2, 0.0, 1.0)
        out[inside] = np.hypot(*(Y[:, None, :] - A[None] - s[..., None] * D[None]).transpose(2, 0, 1)).min(axis=1)
        return out

    step = float((hi - lo).max()) / 32
    X = np.stack(np.meshgrid(*(np.arange(lo[i], hi[i], step) + step / 2 for i in (0, 1))), -1).reshape(-1, 2)
    best = X[np.argmax(clearance(X))]
    fine = best + np.stack(np.meshgrid(*(np.linspace(-step, step, 9),) * 2), -1).reshape(-1, 2)
    c = clearance(fine)
    best, r = fine[np.argmax(c)], float(c.max()) - flat
    n = max(len(text), 1)
    height = min(MAX_TEXT_HEIGHT, 0.9 * r / math.hypot(0.5 * CHAR_WIDTH * n, 0.5))
    if height >= MIN_TEXT_HEIGHT:
        return (float(best[0]), float(best[1])), height
    return (float(0.5 * (lo[0] + hi[0])), float(lo[1] - 2.0 - 0.5 * MAX_TEXT_HEIGHT)), MAX_TEXT_HEIGHT


def dxf_document(
    outline: Outline,
    label: str | None = None,
    *,
    curves: str = "arcs",
    tolerance: float = DEFAULT_TOLERANCE,
    kerf: float = 0.0,
    dxf_version: str = DEFAULT_VERSION,
) -> Any:
    """The ezdxf ``Drawing`` of the outline (see the module docstring for the options, all mm)."""
    import ezdxf
    from ezdxf.enums import TextEntityAlignment

    check_options(curves, tolerance, kerf, dxf_version)
    ezdxf_log = logging.getLogger("ezdxf")
    level = ezdxf_log.level
    if dxf_version == "R12":  # R12 has no $INSUNITS; ezdxf would log that on every new document
        ezdxf_log.setLevel(logging.ERROR)
    try:
        doc = ezdxf.new(dxf_version, units=ezdxf.units.MM)  # $INSUNITS = 4 and $MEASUREMENT = 1 (metric)
    finally:
        ezdxf_log.setLevel(level)
    doc.layers.add(CUT_LAYER, color=CUT_COLOR)
    doc.layers.add(ENGRAVE_LAYER, color=ENGRAVE_COLOR)
    msp = doc.modelspace()
    cut = {"layer": CUT_LAYER}

    def add_closed(points: list[tuple[float, float, float]]) -> None:
        if dxf_version == "R12":
            msp.add_polyline2d(points, format="xyb", close=True, dxfattribs=cut)
        else:
            msp.add_lwpolyline(points, format="xyb", close=True, dxfattribs=cut)

    half = 0.5 * kerf
    if curves == "spline":
        exact = half == 0
        splines = [spline_loop(lp) for lp in outline.loops] if exact else offset_spline_loops(outline, half, tolerance)
        for sp in splines:
            msp.add_rational_spline(sp.control.tolist(), sp.weights.tolist(), sp.degree, sp.knots.tolist(),
                                    dxfattribs=cut)
    elif curves == "arcs":
        loops = bulge_loops(outline, tolerance)
        for lp in offset_bulge_loops(loops, half) if half > 0 else loops:
            add_closed([(float(x), float(y), float(b)) for (x, y), b in zip(lp.V, lp.bulges, strict=True)])
    else:
        if half > 0:  # offset the arc fit, then flatten: fit and flattening get half the tolerance each
            grown = offset_bulge_loops(bulge_loops(outline, 0.5 * tolerance), half)
            polys = [lp.flatten(0.5 * tolerance) for lp in grown]
        else:
            polys = [polyline(lp, tolerance) for lp in outline.loops]
        for P in polys:
            add_closed([(float(x), float(y), 0.0) for x, y in P])
    if label:
        (x, y), height = label_placement(outline, label)
        text = msp.add_text(label, height=height, dxfattribs={"layer": ENGRAVE_LAYER})
        text.set_placement((x, y), align=TextEntityAlignment.MIDDLE_CENTER)
    return doc


def dump_dxf(outline: Outline, path: str | os.PathLike[str], label: str | None = None, **options: Any) -> None:
    """Write :func:`dxf_document` to ``path`` (not atomic; see :func:`write_dxf`)."""
    doc = dxf_document(outline, label, **options)
    try:
        doc.saveas(os.fsdecode(path))
    except OSError as e:
        raise ExportError(f"cannot write the DXF file {path}: {e.strerror}") from e


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: the part's outline with the settings' curve mode, tolerance and kerf."""
    dump_dxf(
        part.outline,
        path,
        part.label,
        curves=settings.curves,
        tolerance=settings.curve_tolerance,
        kerf=settings.kerf,
        dxf_version=settings.dxf_version,
    )


def write_dxf(outline: Outline, path: str | os.PathLike[str], label: str | None = None, **options: Any) -> Path:
    """Write the outline as DXF atomically; ``options`` as for :func:`dxf_document`."""
    check_options(
        options.get("curves", "arcs"),
        options.get("tolerance", DEFAULT_TOLERANCE),
        options.get("kerf", 0.0),
        options.get("dxf_version", DEFAULT_VERSION),
    )
    with atomic_outputs(path) as (tmp,):
        dump_dxf(outline, tmp, label, **options)
    return Path(path)
