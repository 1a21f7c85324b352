"""Whether a one-piece panel fits its sheet: the hull of its polygons, grown by half the kerf, checked
against the sheet when the spec is read (:func:`fabpat.assembly.spec.load.check_sheet_fits`) and nested on it
by the panel's kit (:func:`fabpat.assembly.kit.panel.nest_panel`). Only the tiling's geometry: no pattern, no
part."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SpecError

if TYPE_CHECKING:
    from fabpat.assembly.spec.types import AssemblySpec, SheetSpec, TilingSpec

#: mm: the nesting grid's step (:func:`fabpat.assembly.place.nesting.nest`), here because the spec's sheet check
#: leaves room for one step: finer packs a little denser, costs ∝ 1/step²
DEFAULT_RESOLUTION = 1.0


def sheet_of(spec: AssemblySpec) -> SheetSpec:
    """``spec``'s ``[sheet]``: what nesting, the sheets and the BOM lay the plates on. Raises SpecError (one line)
    for a spec without one (read without ``need_sheet``, :func:`fabpat.assembly.spec.load.load_spec`)."""
    if spec.sheet is None:
        raise SpecError(f"{spec.source}: missing table [sheet] (fabpat assemble nests the plates on this laser sheet "
                        "or print bed: give its width and height)")
    return spec.sheet


def hull(spec: AssemblySpec) -> NDArray[np.float64]:
    """(k, 2) convex hull (counter-clockwise, mm, panel plane) of the panel's polygons: the part lies inside it
    (a plate never leaves its polygon), so nesting it keeps the part ``sheet.spacing`` from anything else."""
    from scipy.spatial import ConvexHull

    from fabpat.assembly.surface.panel_mesh import panel_tiling

    V = panel_tiling(spec.tiling).V[:, :2]
    return V[ConvexHull(V).vertices]


def size_words(t: TilingSpec) -> str:
    """The panel's size in words: "3 × 4 panel", or "panel of flat.obj (12 tiles)" for a mesh's."""
    from pathlib import Path

    return f"{t.rows} × {t.columns} panel" if t.file is None else f"panel of {Path(t.file).name} ({len(t.faces)} tiles)"


def quarter_turn(P: NDArray[np.float64], quarter: bool) -> NDArray[np.float64]:
    """``P`` (k, 2) turned by +90° about the origin if ``quarter``, else as it is."""
    return np.stack([-P[:, 1], P[:, 0]], axis=1) if quarter else P


def grown_hull(spec: AssemblySpec) -> NDArray[np.float64]:
    """The hull grown by kerf/2 about its centre (the cut path lies that far outside the part)."""
    H = hull(spec)
    c = H.mean(axis=0)
    d = H - c
    r = np.linalg.norm(d, axis=1)
    kerf = spec.sheet.kerf if spec.sheet is not None else 0.0  # no sheet: nothing is cut
    return c + d * (1.0 + 0.5 * kerf / r.min())[..., None] if kerf > 0 else H


def check_panel_fits(spec: AssemblySpec) -> None:
    """SpecError unless the panel's hull (plus kerf, margins and one nesting step) lies on the sheet, as it is or
    turned by 90° (a spec without ``[sheet]`` has nothing to fit on)."""
    s, t = spec.sheet, spec.tiling
    if s is None:
        return
    room = np.array([s.width, s.height]) - 2 * s.margin - DEFAULT_RESOLUTION
    P = grown_hull(spec)
    sizes = [np.ptp(quarter_turn(P, q), axis=0) for q in (False, True)]
    if not any((size <= room + 1e-9).all() for size in sizes):
        w, h = sizes[0]
        raise SpecError(f"{spec.source}: sheet.width × sheet.height = {s.width:g} × {s.height:g} mm is smaller than "
                        f"the {size_words(spec.tiling)} ({w:.1f} × {h:.1f} mm, either way "
                        f"round, plus sheet.margin = {s.margin:g} mm on each side and the nesting grid's "
                        f"{DEFAULT_RESOLUTION:g} mm step): use a larger sheet or "
                        + ("fewer rows or columns" if t.file is None else "a smaller mesh"))
