"""Pictures of patterns: SVG of one pattern, contact sheets of a library (SVG and PNG).

Solid is black on white, the polygon outline is drawn thin in grey. SVG coordinates are millimetres
(y flipped so the picture is the pattern seen from above), so an SVG opens at true size.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fabpat.geometry.outline import Line, Loop, Outline, RationalQuad
from fabpat.patterns.lattice import polygon_vertices
from fabpat.patterns.pattern import Pattern

_SEAM = 0.04  # mm: a same-colour stroke that hides anti-aliasing seams between solid triangles


def _fmt(x: float) -> str:
    return f"{x:.4f}".rstrip("0").rstrip(".")


def _points(P: NDArray[np.float64]) -> str:
    return " ".join(f"{_fmt(x)},{_fmt(-y)}" for x, y in P)


def pattern_group(pattern: Pattern, outline_path: str | None = None) -> str:
    """SVG elements (no ``<svg>`` wrapper) drawing a pattern centred at the origin, y up.

    ``outline_path``: SVG path data of the filleted outline (y up, mm); if given it is drawn instead
    of the lattice triangles, with the even-odd rule so holes stay empty.
    """
    if outline_path is None:
        tris = pattern.V[pattern.solid_faces]
        body = (
            f'<g fill="black" stroke="black" stroke-width="{_SEAM}" stroke-linejoin="round">'
            + "".join(f'<polygon points="{_points(t)}"/>' for t in tris)
            + "</g>"
        )
    else:
        body = _path_element(outline_path)
    return body + _frame_element(pattern.sides, pattern.edge)


def _path_element(outline_path: str) -> str:
    return f'<path transform="scale(1,-1)" fill="black" fill-rule="evenodd" d="{outline_path}"/>'


def _frame_element(sides: int, edge: float) -> str:
    """The polygon's boundary in grey, drawn over the pattern."""
    return (
        f'<polygon points="{_points(polygon_vertices(sides, edge))}" fill="none" stroke="#888" '
        f'stroke-width="{_fmt(edge / 200)}"/>'
    )


def _extent(pattern: Pattern) -> float:
    return _polygon_extent(pattern.sides, pattern.edge)


def _polygon_extent(sides: int, edge: float) -> float:
    return float(np.abs(polygon_vertices(sides, edge)).max()) * 1.05


def _document(x0: float, y0: float, w: float, h: float, label: str, body: str) -> str:
    """A standalone true-size SVG (1 unit = 1 mm) showing the box (x0, y0, w, h) in SVG coordinates."""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{_fmt(w)}mm" height="{_fmt(h)}mm" '
        f'viewBox="{_fmt(x0)} {_fmt(y0)} {_fmt(w)} {_fmt(h)}">\n'
        f"<title>{label}</title>\n"
        f'<rect x="{_fmt(x0)}" y="{_fmt(y0)}" width="{_fmt(w)}" height="{_fmt(h)}" fill="white"/>\n'
        f"{body}\n</svg>\n"
    )


def pattern_svg(pattern: Pattern, outline_path: str | None = None, title: str | None = None) -> str:
    """A standalone SVG document of one pattern at true size (mm)."""
    r = _extent(pattern)
    label = title or f"{pattern.id} ({pattern.sides}-gon, edge {pattern.edge:g} mm)"
    return _document(-r, -r, 2 * r, 2 * r, label, pattern_group(pattern, outline_path))


def outline_svg(outline: Outline, title: str | None = None) -> str:
    """A standalone true-size SVG (mm) of an exact outline: :meth:`Outline.to_svg_path` (lines, exact
    elliptical arcs ``A``, parabolic ``Q``) filled black with holes empty.

    An outline that knows its polygon (``outline.polygon``) is framed exactly as :func:`pattern_svg`
    frames a filleted pattern: centred, the grey polygon drawn, 5 % margin. A free-standing outline has
    no polygon, so it is framed by its bounding box plus a 5 % margin.
    """
    frame = outline.polygon
    if frame is not None:
        r = _polygon_extent(frame.sides, frame.edge)
        label = title or f"outline ({frame.sides}-gon, edge {frame.edge:g} mm)"
        body = _path_element(outline.to_svg_path()) + _frame_element(frame.sides, frame.edge)
        return _document(-r, -r, 2 * r, 2 * r, label, body)
    lo, hi = outline.bbox
    pad = 0.05 * float(np.max(hi - lo))
    x0, y0 = float(lo[0]) - pad, -float(hi[1]) - pad  # SVG's y points down: the top is -max y
    w, h = float(hi[0] - lo[0]) + 2 * pad, float(hi[1] - lo[1]) + 2 * pad
    return _document(x0, y0, w, h, title or "outline", _path_element(outline.to_svg_path()))


def _grid(count: int) -> tuple[int, int]:
    cols = max(1, math.ceil(math.sqrt(count * 1.2)))
    return cols, math.ceil(count / cols)


def contact_sheet_svg(patterns: Sequence[Pattern]) -> str:
    """All patterns in a grid, each labelled with its ID."""
    if not patterns:
        raise ValueError("a contact sheet needs at least one pattern")
    r = _extent(patterns[0])
    cell_w, cell_h = 2 * r, 2 * r + r * 0.35
    cols, rows = _grid(len(patterns))
    W, H = cols * cell_w, rows * cell_h
    font = r * 0.22
    cells = []
    for k, p in enumerate(patterns):
        cx, cy = (k % cols) * cell_w + r, (k // cols) * cell_h + r
        cells.append(
            f'<g transform="translate({_fmt(cx)},{_fmt(cy)})">{pattern_group(p)}'
            f'<text x="0" y="{_fmt(r + font)}" font-size="{_fmt(font)}" text-anchor="middle" '
            f'font-family="monospace">{p.id}</text></g>'
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{_fmt(W)}mm" height="{_fmt(H)}mm" '
        f'viewBox="0 0 {_fmt(W)} {_fmt(H)}">\n<rect width="{_fmt(W)}" height="{_fmt(H)}" fill="white"/>\n'
        + "\n".join(cells)
        + "\n</svg>\n"
    )


def contact_sheet_png(patterns: Sequence[Pattern], path: str | Path, dpi: int = 100) -> None:
    """All patterns in a grid with IDs, rendered by matplotlib (one collection for all triangles)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    if not patterns:
        raise ValueError("a contact sheet needs at least one pattern")
    r = _extent(patterns[0])
    cell_w, cell_h = 2 * r, 2 * r + r * 0.35
    cols, rows = _grid(len(patterns))
    tris, outlines, offsets = [], [], []
    for k, p in enumerate(patterns):
        off = np.array([(k % cols) * cell_w + r, -((k // cols) * cell_h + r)])
        offsets.append(off)
        tris.append(p.V[p.solid_faces] + off)
        outlines.append(polygon_vertices(p.sides, p.edge) + off)
    inch = 1.1  # inches per cell: IDs stay legible
    fig = plt.figure(figsize=(cols * inch, rows * inch * cell_h / cell_w))
    ax = fig.add_axes((0, 0, 1, 1))
    solid = list(np.concatenate(tris))  # one (3, 2) array per triangle
    ax.add_collection(PolyCollection(solid, facecolors="black", edgecolors="black", linewidths=0.1))
    ax.add_collection(PolyCollection(outlines, facecolors="none", edgecolors="#888888", linewidths=0.4))
    for p, off in zip(patterns, offsets, strict=True):
        ax.text(off[0], off[1] - r * 1.12, p.id, ha="center", va="center", fontsize=6, family="monospace")
    ax.set_xlim(0, cols * cell_w)
    ax.set_ylim(-rows * cell_h, 0)
    ax.set_aspect("equal")
    ax.axis("off")
    fig.savefig(path, dpi=dpi, facecolor="white", format="png")
    plt.close(fig)


def _only_arcs_at(outline: Outline, centre: NDArray[np.float64]) -> Outline:
    """The outline with every arc not centred on ``centre`` put back to its two control-polygon legs."""

    def keep(loop: Loop) -> Loop:
        segs: list[Line | RationalQuad] = []
        for s in loop.segments:
            if isinstance(s, RationalQuad) and not np.allclose(s.P1, centre):
                segs += [Line(s.P0, s.P1), Line(s.P1, s.P2)]
            else:
                segs.append(s)
        return Loop(tuple(segs))

    return Outline(keep(outline.outer), tuple(keep(h) for h in outline.holes))


def star_table_svg(k: int = 6, radius: float = 9.0, columns: int = 3) -> str:
    """The filleting lookup table as a figure: each star configuration before (lattice triangles) and
    after filleting its centre vertex (exact arcs), with kind and actions — the paper's Figs 9–10."""
    from fabpat.geometry.fillet import fillet_solid, star_table

    rows = [r for r in star_table(k) if r[1] not in ("empty", "interior")]
    cell = 2.5 * radius
    cols = columns
    W, H = 2 * cell * cols, cell * math.ceil(len(rows) / cols)
    angles = 2 * math.pi * np.arange(k) / k
    V = np.vstack([[0.0, 0.0], radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)])
    F = np.array([[0, 1 + i, 1 + (i + 1) % k] for i in range(k)])
    font = radius * 0.14
    parts = []
    for n, (labels, kind, actions) in enumerate(rows):
        solid = np.array([c == "S" for c in labels])
        outline = _only_arcs_at(fillet_solid(V, F[solid])[0], V[0])
        x0, cy = (n % cols) * 2 * cell, (n // cols) * cell + cell / 2 - radius * 0.1
        ring = f'<polygon points="{_points(V[1:])}" fill="none" stroke="#bbb" stroke-width="0.08"/>'
        before = "".join(f'<polygon points="{_points(V[f])}"/>' for f in F[solid])
        acts = " ".join(a for a in actions if a != "keep")
        parts.append(
            f'<g transform="translate({_fmt(x0 + cell / 2)},{_fmt(cy)})">{ring}'
            f'<g fill="black" stroke="black" stroke-width="{_SEAM}">{before}</g></g>'
            f'<g transform="translate({_fmt(x0 + 1.5 * cell)},{_fmt(cy)})">{ring}'
            f'<path transform="scale(1,-1)" fill="black" fill-rule="evenodd" d="{outline.to_svg_path()}"/></g>'
            f'<text x="{_fmt(x0 + cell)}" y="{_fmt(cy + radius * 1.15)}" font-size="{_fmt(font)}" '
            f'text-anchor="middle" font-family="monospace">{labels} {kind}: {acts}</text>'
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{_fmt(W * 4)}" height="{_fmt(H * 4)}" '
        f'viewBox="0 0 {_fmt(W)} {_fmt(H)}">\n<rect width="{_fmt(W)}" height="{_fmt(H)}" fill="white"/>\n'
        + "\n".join(parts)
        + "\n</svg>\n"
    )
