"""SVG of the exact outline at true size (mm), for laser software that takes SVG and for documents.

Without kerf the path is :meth:`fabpat.outline.Outline.to_svg_path`: lines, exact elliptical ``A``
arcs for w < 1, quadratic ``Q`` for w = 1 (hyperbolic arcs, w > 1, which SVG cannot express, are
flattened within 0.001 mm). With ``kerf`` > 0 the loops are the kerf offset of the circular-arc fit
(:func:`fabpat.cad.offset_bulge_loops`, within ``tolerance`` mm), written as lines and circular
``A`` arcs. The default style is the laser convention (red hairline cut path, no fill, ID in blue);
``filled=True`` draws the part black with holes empty (even-odd rule).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import escape, quoteattr

from fabpat.cad import BulgeLoop, bulge_loops, offset_bulge_loops
from fabpat.errors import ExportError
from fabpat.io import atomic_outputs
from fabpat.outline import Outline

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.exchange.registry import ExportSettings, Part

MARGIN = 1.0  # mm of white space around the part
CUT_STROKE = 0.1  # mm: thin enough for laser software to read as a cut line, thick enough to see


def _num(v: float) -> str:
    s = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def bulge_path(loops: list[BulgeLoop]) -> str:
    """SVG path data (y up, mm) of lines-and-circular-arcs loops; sweep flag 1 = counter-clockwise."""
    out: list[str] = []
    for lp in loops:
        out.append(f"M {_num(lp.V[0, 0])} {_num(lp.V[0, 1])}")
        k = len(lp.V)
        for i, b in enumerate(lp.bulges):
            s, e = lp.V[i], lp.V[(i + 1) % k]
            if b == 0.0:
                out.append(f"L {_num(e[0])} {_num(e[1])}")
                continue
            theta = 4.0 * math.atan(abs(float(b)))
            r = math.hypot(*(e - s)) / (2.0 * math.sin(0.5 * theta))
            large = 1 if theta > math.pi else 0
            sweep = 1 if b > 0 else 0
            out.append(f"A {_num(r)} {_num(r)} 0 {large} {sweep} {_num(e[0])} {_num(e[1])}")
        out.append("Z")
    return " ".join(out)


def svg_document(
    outline: Outline,
    label: str | None = None,
    *,
    kerf: float = 0.0,
    tolerance: float = 0.01,
    filled: bool = False,
    title: str | None = None,
) -> str:
    """A standalone SVG document of the outline (width/height in mm, viewBox in mm)."""
    if not (kerf >= 0 and math.isfinite(kerf)):
        raise ExportError(f"kerf must be ≥ 0 mm, got {kerf:g}")
    if kerf > 0:
        loops = offset_bulge_loops(bulge_loops(outline, tolerance), 0.5 * kerf)
        d = bulge_path(loops)
        pts = [lp.flatten(tolerance) for lp in loops]
    else:
        d = outline.to_svg_path()
        pts = outline.flatten(tolerance)
    lo = [min(float(P[:, i].min()) for P in pts) for i in (0, 1)]
    hi = [max(float(P[:, i].max()) for P in pts) for i in (0, 1)]
    parts: list[str] = []
    if label:
        from fabpat.exchange.dxf import label_placement

        (x, y), h = label_placement(outline, label)
        lo = [min(lo[0], x), min(lo[1], y - h)]
        parts.append(
            f'<text x="{_num(x)}" y="{_num(-y)}" font-size="{_num(h)}" font-family="sans-serif" '
            f'text-anchor="middle" dominant-baseline="central" fill="#0000ff">{escape(label)}</text>'
        )
    x0, y0 = lo[0] - MARGIN, -hi[1] - MARGIN  # SVG y points down: model y flipped by the transform
    w, h = hi[0] - lo[0] + 2 * MARGIN, hi[1] - lo[1] + 2 * MARGIN
    style = 'fill="black" stroke="none"' if filled else f'fill="none" stroke="#ff0000" stroke-width="{CUT_STROKE}"'
    head = (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{_num(w)}mm" height="{_num(h)}mm" '
        f'viewBox="{_num(x0)} {_num(y0)} {_num(w)} {_num(h)}">'
    )
    name = f"<title>{escape(title)}</title>" if title else ""
    path = f'<path id={quoteattr("cut")} transform="scale(1,-1)" fill-rule="evenodd" {style} d="{d}"/>'
    return head + name + path + "".join(parts) + "</svg>\n"


def write(part: Part, path: Path, settings: ExportSettings) -> None:
    """Registry entry point: laser-style SVG with the settings' kerf and tolerance."""
    text = svg_document(part.outline, part.label, kerf=settings.kerf, tolerance=settings.curve_tolerance,
                        title=part.name)
    Path(path).write_text(text, encoding="utf-8")


def write_svg(outline: Outline, path: str | os.PathLike[str], label: str | None = None, **options: object) -> Path:
    """Write :func:`svg_document` atomically; returns the path written."""
    text = svg_document(outline, label, **options)  # type: ignore[arg-type]
    with atomic_outputs(path) as (tmp,):
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
