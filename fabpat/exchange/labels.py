"""Where an engraved label goes on a part: a text box that lies wholly on the material.

A label is written as left-aligned text (DXF TEXT with its default alignment, SVG ``text-anchor``
start): its first point is the baseline start, so every reader puts it in the same place, whether
or not it honours alignment codes. The box assumed for the text is ``CHAR_WIDTH`` × height per
character wide and one height tall, a conservative width for the usual CAD and sans-serif fonts.

Search (:func:`place_label`): the clearance (distance to the boundary) of the material is sampled on
a grid; the box of height h and width w fits centred at a grid point c in direction θ when every
sample of its mid-line, spaced one grid step g apart, has clearance ≥ h/2 + g/2 + ``LABEL_MARGIN``
(every point of the box is within h/2 of the mid-line and g/2 of a sample, and the clearance is
1-Lipschitz). Horizontal text is tried first; lacy parts whose bars are too narrow for horizontal
text of ``MIN_TEXT_HEIGHT`` get the text along a bar, at θ in 15° steps. A part with no room for a
label of ``MIN_TEXT_HEIGHT`` gets none (a label on the sheet beside the part would be cut off
with the scrap).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.geometry.outline import Outline

if TYPE_CHECKING:  # pragma: no cover
    from scipy.spatial import cKDTree

MAX_TEXT_HEIGHT = 3.0  # mm
MIN_TEXT_HEIGHT = 1.0  # mm: smaller engraved text is unreadable
CHAR_WIDTH = 0.9  # text width per character / text height (conservative for the standard font)
LABEL_MARGIN = 0.1  # mm: material kept between the text box and the boundary
_FLAT = 0.05  # mm: boundary flattening for the clearance field (subtracted from it)
_HEIGHTS = np.round(np.arange(MAX_TEXT_HEIGHT, MIN_TEXT_HEIGHT - 1e-9, -0.125), 3)
_ANGLES = (0.0, 90.0, 30.0, -30.0, 60.0, -60.0, 15.0, -15.0, 45.0, -45.0, 75.0, -75.0)  # degrees, readable


@dataclass(frozen=True)
class Label:
    """A placed label: ``start`` (2,) mm is the baseline start (the text's first point), ``angle``
    the baseline direction in degrees (counter-clockwise from +x), ``height`` the cap height (mm),
    ``width`` the assumed text width (mm, ``CHAR_WIDTH`` × height × characters)."""

    text: str
    start: tuple[float, float]
    angle: float
    height: float
    width: float


def box_width(text: str, height: float) -> float:
    """Assumed width (mm) of ``text`` written ``height`` mm tall."""
    return CHAR_WIDTH * max(len(text), 1) * height


def label_at(text: str, centre: NDArray[np.float64], angle: float, height: float) -> Label:
    """The label whose assumed box is centred at ``centre`` (2,) mm, baseline at ``angle`` degrees."""
    a = math.radians(angle)
    u, v = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    w = box_width(text, height)
    s = np.asarray(centre, dtype=np.float64) - 0.5 * w * u - 0.5 * height * v
    return Label(text, (float(s[0]), float(s[1])), float(angle), float(height), w)


def _material(outline: Outline) -> tuple[list[NDArray[np.float64]], cKDTree]:
    """Flattened loops and a KD-tree of boundary points ≤ _FLAT apart."""
    from scipy.spatial import cKDTree

    polys = [P for P in outline.flatten(_FLAT)]
    pts = []
    for P in polys:
        Q = np.roll(P, -1, axis=0)
        n = np.maximum(1, np.ceil(np.hypot(*(Q - P).T) / _FLAT)).astype(int)
        t = np.concatenate([np.arange(k) / k for k in n])
        i = np.repeat(np.arange(len(P)), n)
        pts.append(P[i] + t[:, None] * (Q[i] - P[i]))
    return polys, cKDTree(np.vstack(pts))


def _clearance(X: NDArray[np.float64], polys: list[NDArray[np.float64]], tree: cKDTree) -> NDArray[np.float64]:
    """A lower bound of the distance to the boundary of points on the material, −1 elsewhere."""
    from matplotlib.path import Path as MPath

    inside = MPath(polys[0]).contains_points(X)
    for hole in polys[1:]:
        inside &= ~MPath(hole).contains_points(X)
    out = np.full(len(X), -1.0)
    # Clearance beyond what the largest label needs is not looked for (it would only cost time).
    d, _ = tree.query(X[inside], distance_upper_bound=MAX_TEXT_HEIGHT)
    # Boundary points are ≤ _FLAT apart on a polyline within _FLAT of the curve.
    out[inside] = np.minimum(d, MAX_TEXT_HEIGHT) - 1.5 * _FLAT
    return out


_CACHE_SIZE = 16
_placed: dict[tuple[str, int, bytes], Label | None] = {}


def place_label(outline: Outline, text: str, grid: int = 160) -> Label | None:
    """The largest label (``MIN_TEXT_HEIGHT`` … ``MAX_TEXT_HEIGHT`` mm) whose box lies on the material.

    ``grid``: clearance samples along the longer side of the bounding box. Returns ``None`` when no
    box of ``MIN_TEXT_HEIGHT`` fits anywhere (see the module docstring for the search and its bound).
    The search is relative to the bounding box, so its result for a moved copy of an outline is the
    same label moved: the last few results are kept, keyed by the outline relative to its lower-left
    corner (DXF, SVG and the no-label warning of one part then search once).
    """
    polys, tree = _material(outline)
    lo = outline.bbox[0]
    key = (text, grid, np.round(np.vstack(polys) - lo, 6).tobytes())
    if key not in _placed:
        if len(_placed) >= _CACHE_SIZE:
            del _placed[next(iter(_placed))]
        found = _search(outline, polys, tree, text, grid)
        _placed[key] = None if found is None else dataclasses.replace(
            found, start=(found.start[0] - float(lo[0]), found.start[1] - float(lo[1])))
    rel = _placed[key]
    return None if rel is None else dataclasses.replace(
        rel, start=(rel.start[0] + float(lo[0]), rel.start[1] + float(lo[1])))


def _search(outline: Outline, polys: list[NDArray[np.float64]], tree: cKDTree, text: str, grid: int) -> Label | None:
    from scipy.ndimage import minimum_filter1d

    lo, hi = outline.bbox
    g = float((hi - lo).max()) / grid
    centre, size = 0.5 * (lo + hi), hi - lo
    best: Label | None = None
    for angle in _ANGLES:
        a = math.radians(angle)
        u, v = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        # The grid, in the text's frame, covers the bounding box.
        hu, hv = (0.5 * float(abs(size[0] * w[0]) + abs(size[1] * w[1])) for w in (u, v))
        U, V = np.meshgrid(np.arange(-hu, hu + g, g), np.arange(-hv, hv + g, g))  # U along the baseline
        X = centre + U[..., None] * u + V[..., None] * v
        C = _clearance(X.reshape(-1, 2), polys, tree).reshape(U.shape)
        if C.max() < 0.5 * MIN_TEXT_HEIGHT:
            continue
        for h in _HEIGHTS:
            if best is not None and h <= best.height:
                break
            k = math.ceil(0.5 * box_width(text, h) / g)
            worst = minimum_filter1d(C, 2 * k + 1, axis=1, mode="constant", cval=-1.0)
            slack = worst - (0.5 * h + 0.5 * g + LABEL_MARGIN)
            i = int(np.argmax(slack))
            if slack.flat[i] >= 0:
                best = label_at(text, X.reshape(-1, 2)[i], angle, float(h))
                break
        if best is not None and angle == 0.0:
            return best  # horizontal text reads best: take it whenever it fits
    return best
