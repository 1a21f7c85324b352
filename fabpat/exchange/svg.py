"""SVG of the outline at true size (mm), for laser and cutter software and for documents.

Coordinates are written already in SVG's frame (y down, 1 user unit = 1 mm): no ``transform`` on
the cut path, so software that ignores transforms places the part right. ``origin`` as in
:mod:`fabpat.exchange.origin`: "corner" (default) puts the part 1 mm from the page's left and bottom
edges on a page (``viewBox`` 0 0 W H) with 1 mm of white space around it; "centre" keeps the
pattern's frame, polygon centre at (0, 0).

Curves (``curves``):

* ``"cubic"`` (default, for cutting): lines and cubic Béziers ``C`` within ``tolerance`` mm of the
  exact outline (:mod:`fabpat.exchange.cubic`) — what every cutter and plotter reads.
* ``"exact"``: lines, exact elliptical ``A`` arcs for w < 1 (rotated ellipses in general), quadratic
  ``Q`` for w = 1 (:meth:`fabpat.geometry.outline.Outline.to_svg_path`; hyperbolic arcs, w > 1, which SVG
  cannot express, flattened within 0.001 mm). Browsers and svgelements read it exactly; some
  libraries and cutters mis-place rotated arcs.

With ``kerf`` > 0 the loops are the kerf offset of the circular-arc fit
(:func:`fabpat.exchange.contours.offset_bulge_loops`): circular ``A`` arcs (never rotated) in "exact" mode, cubic
Béziers in "cubic" mode (arc fit and cubic each within half the tolerance). The default style is
the laser convention (red hairline cut path, no fill, ID in blue); ``filled=True`` draws the part
black with holes empty (even-odd rule). The label (:func:`fabpat.exchange.labels.place_label`)
starts at its first point (``text-anchor`` start, alphabetic baseline); only a label turned along a
bar of a lacy part carries a ``rotate`` transform.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, Unpack
from xml.sax.saxutils import escape, quoteattr

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError
from fabpat.exchange.contours import BulgeLoop, bulge_loops, cut_order, offset_bulge_loops
from fabpat.exchange.origin import DEFAULT_ORIGIN, ORIGIN_MARGIN, origin_shift, transformed
from fabpat.geometry.outline import Line, Outline, loop_svg_path
from fabpat.io import atomic_outputs

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.exchange.part import ExportSettings, Part


class SvgOptions(TypedDict, total=False):
    """The drawing options of :func:`svg_document` (mm), as keywords of :func:`write_svg`."""

    kerf: float
    tolerance: float
    curves: str
    origin: str
    filled: bool
    title: str | None

SVG_CURVES = ("exact", "cubic")
DEFAULT_SVG_CURVES = "cubic"
MARGIN = ORIGIN_MARGIN  # mm of white space around the part
CUT_STROKE = 0.1  # mm: thin enough for laser software to read as a cut line, thick enough to see


def check_svg_curves(curves: str) -> None:
    """Raise :class:`ExportError` for an unknown SVG curve mode."""
    if curves not in SVG_CURVES:
        raise ExportError(f"unknown SVG curve mode {curves!r}: choose one of {', '.join(SVG_CURVES)}")


def _num(v: float) -> str:
    s = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _pt(p: NDArray[np.float64]) -> str:
    return f"{_num(p[0])} {_num(p[1])}"


def _cubics(cubics: list[NDArray[np.float64]]) -> list[str]:
    return [f"C {_pt(C[1])} {_pt(C[2])} {_pt(C[3])}" for C in cubics]


def bulge_path(loops: list[BulgeLoop], cubic_tol: float | None = None) -> str:
    """SVG path data of lines-and-circular-arcs loops, in the coordinates given.

    Arcs as circular ``A`` commands (sweep flag 1 = positive angle direction of these coordinates),
    or, with ``cubic_tol`` (mm), as cubic Béziers within it.
    """
    from fabpat.exchange.cubic import bulge_to_quads, quad_to_cubics

    out: list[str] = []
    for lp in loops:
        out.append(f"M {_pt(lp.V[0])}")
        k = len(lp.V)
        for i, b in enumerate(lp.bulges):
            s, e = lp.V[i], lp.V[(i + 1) % k]
            if b == 0.0:
                out.append(f"L {_pt(e)}")
            elif cubic_tol is not None:
                for P, w in bulge_to_quads(s, e, float(b)):
                    out += _cubics(quad_to_cubics(P, w, cubic_tol))
            else:
                theta = 4.0 * math.atan(abs(float(b)))
                r = math.hypot(*(e - s)) / (2.0 * math.sin(0.5 * theta))
                large = 1 if theta > math.pi else 0
                sweep = 1 if b > 0 else 0
                out.append(f"A {_num(r)} {_num(r)} 0 {large} {sweep} {_pt(e)}")
        out.append("Z")
    return " ".join(out)


def cubic_path(outline: Outline, tol: float) -> str:
    """SVG path data of the outline with lines as ``L`` and arcs as cubic Béziers within ``tol`` mm."""
    from fabpat.exchange.cubic import quad_to_cubics

    out: list[str] = []
    for loop in cut_order(outline.loops):
        out.append(f"M {_pt(loop.segments[0].start)}")
        for s in loop.segments:
            if isinstance(s, Line) or s.is_straight:
                out.append(f"L {_pt(s.end)}")
            else:
                out += _cubics(quad_to_cubics(s.control_points, s.w, tol))
        out.append("Z")
    return " ".join(out)


def _flipped(loops: list[BulgeLoop], top: float) -> list[BulgeLoop]:
    """Loops mirrored to y' = top − y (a mirror turns every arc the other way)."""
    return [BulgeLoop(np.column_stack([lp.V[:, 0], top - lp.V[:, 1]]), -lp.bulges) for lp in loops]


def svg_document(
    outline: Outline,
    label: str | None = None,
    *,
    kerf: float = 0.0,
    tolerance: float = 0.01,
    curves: str = DEFAULT_SVG_CURVES,
    origin: str = DEFAULT_ORIGIN,
    filled: bool = False,
    title: str | None = None,
) -> str:
    """A standalone SVG document of the outline (width/height in mm, viewBox in mm).

    Options as in the module docstring; raises :class:`ExportError` for a bad one.
    """
    from fabpat.exchange.labels import place_label

    if not (kerf >= 0 and math.isfinite(kerf)):
        raise ExportError(f"kerf must be ≥ 0 mm, got {kerf:g}")
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise ExportError(f"curve tolerance must be > 0 mm, got {tolerance:g}")
    check_svg_curves(curves)
    shift = origin_shift(outline, kerf, origin)
    box = outline.bbox + shift  # the cut path's box is this grown by kerf / 2 (exact for an offset)
    lo, hi = box[0] - 0.5 * kerf, box[1] + 0.5 * kerf
    # SVG y = top − model y: the page's top edge is `top` above the model's x axis (corner) or the
    # model's frame is kept with y negated (centre).
    top = hi[1] + MARGIN if origin == "corner" else 0.0
    cubic = curves == "cubic"
    if kerf > 0:
        fit = 0.5 * tolerance if cubic else tolerance
        moved = transformed(outline, shift)
        loops = _flipped(offset_bulge_loops(bulge_loops(moved, fit), 0.5 * kerf), top)
        d = bulge_path(cut_order(loops), 0.5 * tolerance if cubic else None)
    else:
        page = transformed(outline, shift, flip_y=top)
        d = cubic_path(page, tolerance) if cubic else " ".join(loop_svg_path(lp) for lp in cut_order(page.loops))
    parts: list[str] = []
    placed = place_label(transformed(outline, shift), label) if label else None
    if placed is not None:
        x, y = placed.start[0], top - placed.start[1]
        turn = f' transform="rotate({_num(-placed.angle)} {_num(x)} {_num(y)})"' if placed.angle else ""
        parts.append(
            f'<text x="{_num(x)}" y="{_num(y)}" font-size="{_num(placed.height)}" font-family="sans-serif" '
            f'fill="#0000ff"{turn}>{escape(placed.text)}</text>'
        )
    x0, y0 = lo[0] - MARGIN, top - hi[1] - MARGIN
    w, h = hi[0] - lo[0] + 2 * MARGIN, hi[1] - lo[1] + 2 * MARGIN
    style = 'fill="black" stroke="none"' if filled else f'fill="none" stroke="#ff0000" stroke-width="{CUT_STROKE}"'
    head = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{_num(w)}mm" height="{_num(h)}mm" '
        f'viewBox="{_num(x0)} {_num(y0)} {_num(w)} {_num(h)}">'
    )
    name = f"<title>{escape(title)}</title>" if title else ""
    path = f'<path id={quoteattr("cut")} fill-rule="evenodd" {style} d="{d}"/>'
    return head + name + path + "".join(parts) + "</svg>\n"


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: laser-style SVG with the settings' kerf, tolerance, curves and origin."""
    text = svg_document(part.outline, part.label, kerf=settings.kerf, tolerance=settings.curve_tolerance,
                        curves=settings.svg_curves, origin=settings.origin, title=part.name)
    Path(path).write_text(text, encoding="utf-8")


def write_svg(outline: Outline, path: str | os.PathLike[str], label: str | None = None,
              **options: Unpack[SvgOptions]) -> Path:
    """Write :func:`svg_document` atomically; returns the path written."""
    text = svg_document(outline, label, **options)
    with atomic_outputs(path) as (tmp,):
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
