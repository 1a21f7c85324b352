"""Where a single part lies in its DXF or SVG file: ``origin`` = "corner" or "centre".

* ``"corner"`` (default): the part's lower-left corner (of its cut path, kerf included) at
  ``ORIGIN_MARGIN`` mm from (0, 0) in x and y, so laser software and Inkscape, which put (0, 0) at
  a corner of the bed or page, show the whole part on it.
* ``"centre"``: the pattern's own frame, polygon centre at (0, 0), as in the STEP, STL and 3MF files.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import ExportError
from fabpat.geometry.outline import Line, Loop, Outline, RationalQuad

ORIGINS = ("corner", "centre")
DEFAULT_ORIGIN = "corner"
ORIGIN_MARGIN = 1.0  # mm between the cut path's bounding box and the axes


def check_origin(origin: str) -> None:
    """Raise :class:`ExportError` for an unknown origin."""
    if origin not in ORIGINS:
        raise ExportError(f"unknown origin {origin!r}: choose one of {', '.join(ORIGINS)}")


def origin_shift(outline: Outline, kerf: float, origin: str) -> NDArray[np.float64]:
    """(2,) mm to add to the outline's coordinates for ``origin``.

    The cut path lies kerf / 2 outside the material, and the bounding box of a region offset by d
    is the region's box grown by d on every side, so the shift needs no offset computed.
    """
    check_origin(origin)
    if origin == "centre":
        return np.zeros(2)
    lo = outline.bbox[0] - 0.5 * kerf
    return ORIGIN_MARGIN - lo


def transformed(outline: Outline, shift: NDArray[np.float64], flip_y: float | None = None) -> Outline:
    """The outline moved by ``shift`` (2,) mm, then, if ``flip_y`` is given, mirrored to y' = flip_y − y.

    Exact: an affine map moves a rational Bézier's control points and keeps its weights. The mirror
    (for SVG, whose y axis points down) reverses every loop's orientation.
    """
    if not np.any(shift) and flip_y is None:
        return outline
    sign = np.array([1.0, 1.0 if flip_y is None else -1.0])
    offset = np.array([shift[0], shift[1] if flip_y is None else flip_y - shift[1]])

    def f(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return sign * p + offset

    def seg(s: Line | RationalQuad) -> Line | RationalQuad:
        if isinstance(s, Line):
            return Line(f(s.p0), f(s.p1))
        return RationalQuad(f(s.P0), f(s.P1), f(s.P2), s.w)

    loops = [Loop(tuple(seg(s) for s in lp.segments)) for lp in outline.loops]
    return Outline(loops[0], tuple(loops[1:]))


def translated(outline: Outline, shift: NDArray[np.float64]) -> Outline:
    """The outline moved by ``shift`` (2,) mm."""
    return transformed(outline, shift)
