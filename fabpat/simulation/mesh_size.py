"""Mesh sizes before meshing: how many triangles a target edge h makes, the limits that refuse a mesh
too large to solve, and the coarsest h that still resolves a pattern's narrowest feature.

Lengths in mm, areas in mm². Every check raises :class:`~fabpat.errors.GeometryError` with the h that
would pass; :mod:`fabpat.simulation.mesh` calls them before Triangle runs.
"""

from __future__ import annotations

import math

from fabpat.errors import GeometryError
from fabpat.validate import check, check_size, round_down, round_up

#: Default limit of :func:`estimate_elements` (``--max-elements``). Measured here with
#: ``/usr/bin/time -v fabpat simulate 0x2d88 --scenario cantilever --h H``: 1 890 elements (h = 1.5)
#: 182 MB and 8 s, 14 458 (h = 0.5) 685 MB and 41 s, 38 662 (h = 0.3) 1.72 GB and 147 s, i.e. about
#: 40 kB and 4 ms per element and nonlinear scenario. 50 000 elements stay near 2 GB and 4 minutes.
DEFAULT_MAX_ELEMENTS = 50_000
#: Default limit of a whole assembly's plate meshes (``simulate-assembly --max-elements``): at the same
#: ~40 kB per element, 200 000 elements stay near 8 GB; the shipped sphere has about 21 000 at h = 3
ASSEMBLY_MAX_ELEMENTS = 200_000

#: A mesh whose target edge is longer than this many times the pattern's narrowest feature
#: (``min_width``) is refused: with h = 2 × min_width the Dome energy of 0x2d88 is 4.8 % below
#: h = 1 mm, with h = 36 mm 28 % below (measured with ``fabpat simulate 0x2d88 --scenario dome --h …``).
MAX_H_PER_MIN_WIDTH = 2.0


def estimate_elements(area: float, perimeter: float, h: float) -> float:
    """Expected triangle count of a quality mesh of target edge h (mm) over ``area`` (mm²).

    One equilateral triangle of edge h per √3/4·h² of area, plus one per boundary piece of length h
    (boundary triangles are smaller); within a factor 1.5 of the meshes :func:`mesh_polygons` makes.
    """
    return area / (math.sqrt(3.0) / 4.0 * h * h) + perimeter / h


def check_element_count(area: float, perimeter: float, h: float, max_elements: int, *, fine_ratio: float = 1.0,
                        option: str = "raise it with --max-elements", h_max: float | None = None) -> None:
    """Raise GeometryError before meshing if :func:`estimate_elements` is above ``max_elements``.

    ``fine_ratio``: the mesh checked is h × fine_ratio (the finer mesh of an extrapolation), but the
    message speaks of, and suggests, the h the user gave. ``option``: how to raise the limit. ``h_max``:
    the coarsest h the outline allows (mm); a suggestion above it becomes "no h … fits".
    """
    max_elements = int(check("max_elements", max_elements, error=GeometryError))
    n = estimate_elements(area, perimeter, h * fine_ratio)
    # the h at which the estimate equals the limit: N·c·h² − P·h − A = 0 with c = √3/4 (both terms of
    # estimate_elements), rounded up so that the suggested h passes this very check
    c = math.sqrt(3.0) / 4.0
    suggest = (perimeter + math.sqrt(perimeter**2 + 4.0 * max_elements * area / c)) / (2.0 * max_elements)
    what = f"mesh elements at h = {h:g} mm" if fine_ratio == 1.0 else \
        f"mesh elements of the finer mesh of h = {h:g} mm (h × {fine_ratio:.4g} = {h * fine_ratio:g} mm)"
    fit = round_up(suggest / fine_ratio)
    hint = f"or use h ≥ {fit:g} mm" if h_max is None or fit <= h_max else \
        f"no h up to {h_max:g} mm (the most this outline allows) fits"
    check_size(n, max_elements, what, option, hint, error=GeometryError)


def check_polygon_elements(sides: int, edge: float, h: float, max_elements: int = DEFAULT_MAX_ELEMENTS, *,
                           fine_ratio: float = 1.0, option: str = "raise it with --max-elements") -> None:
    """:func:`check_element_count` for the solid regular polygon, which bounds every pattern's mesh."""
    area = sides * edge * edge / (4.0 * math.tan(math.pi / sides))
    check_element_count(area, sides * edge, h, max_elements, fine_ratio=fine_ratio, option=option)


def check_resolves(h: float, min_width: float, what: str = "the pattern") -> None:
    """Raise GeometryError if h (mm) is above MAX_H_PER_MIN_WIDTH × the narrowest feature (mm)."""
    if math.isfinite(min_width) and h > MAX_H_PER_MIN_WIDTH * min_width:
        raise GeometryError(f"h = {h:g} mm is too coarse for {what}, whose narrowest feature (min_width) is "
                            f"{min_width:.3g} mm: use h ≤ {round_down(MAX_H_PER_MIN_WIDTH * min_width):g} mm")
