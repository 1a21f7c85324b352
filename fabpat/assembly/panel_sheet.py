"""Where a one-piece panel goes on its sheet: the hull of its polygons, grown by half the kerf, checked
against the sheet when the spec is read (:func:`fabpat.assembly.spec.check_sheet_fits`) and nested on it
by the panel's kit (:mod:`fabpat.assembly.panel_kit`). Only the tiling's geometry: no pattern, no part;
:func:`print_bed_report` takes the part's size from the kit."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from fabpat.errors import SpecError


def hull(panel_or_spec: Any) -> NDArray[np.float64]:
    """(k, 2) convex hull (counter-clockwise, mm, panel plane) of the panel's polygons: the part lies inside it
    (a plate never leaves its polygon), so nesting it keeps the part ``sheet.spacing`` from anything else."""
    from scipy.spatial import ConvexHull

    from fabpat.assembly.panel_mesh import panel_tiling

    V = panel_tiling(getattr(panel_or_spec, "spec", panel_or_spec).tiling).V[:, :2]
    return V[ConvexHull(V).vertices]


def size_words(t: Any) -> str:
    """The panel's size in words: "3 × 4 panel", or "panel of flat.obj (12 tiles)" for a mesh's."""
    from pathlib import Path

    return f"{t.rows} × {t.columns} panel" if t.file is None else f"panel of {Path(t.file).name} ({len(t.faces)} tiles)"


def quarter_turn(P: NDArray[np.float64], quarter: bool) -> NDArray[np.float64]:
    """``P`` (k, 2) turned by +90° about the origin if ``quarter``, else as it is."""
    return np.stack([-P[:, 1], P[:, 0]], axis=1) if quarter else P


def _grown(spec: Any) -> NDArray[np.float64]:
    """The hull grown by kerf/2 about its centre (the cut path lies that far outside the part)."""
    H = hull(spec)
    c = H.mean(axis=0)
    d = H - c
    r = np.linalg.norm(d, axis=1)
    return c + d * (1.0 + 0.5 * spec.sheet.kerf / r.min())[..., None] if spec.sheet.kerf > 0 else H


def check_panel_fits(spec: Any) -> None:
    """SpecError unless the panel's hull (plus kerf, margins and one nesting step) lies on the sheet, as it is or
    turned by 90°."""
    from fabpat.assembly.nesting import DEFAULT_RESOLUTION

    s, t = spec.sheet, spec.tiling
    room = np.array([s.width, s.height]) - 2 * s.margin - DEFAULT_RESOLUTION
    P = _grown(spec)
    sizes = [np.ptp(quarter_turn(P, q), axis=0) for q in (False, True)]
    if not any((size <= room + 1e-9).all() for size in sizes):
        w, h = sizes[0]
        raise SpecError(f"{spec.source}: sheet.width × sheet.height = {s.width:g} × {s.height:g} mm is smaller than "
                        f"the {size_words(spec.tiling)} ({w:.1f} × {h:.1f} mm, either way "
                        f"round, plus sheet.margin = {s.margin:g} mm on each side and the nesting grid's "
                        f"{DEFAULT_RESOLUTION:g} mm step): use a larger sheet or "
                        + ("fewer rows or columns" if t.file is None else "a smaller mesh"))


#: (width, height) mm: a print bed most desktop printers hold (theirs run from 180 to 256 mm a side), and
#: PrusaSlicer's own default bed: its command line without a printer profile stops on a larger part
#: ("Objects could not fit on the bed", PrusaSlicer 2.5.0), so a printed panel larger than this is told
COMMON_PRINT_BED = (200.0, 200.0)


def print_bed_report(spec: Any, size: tuple[float, float]) -> tuple[list[str], list[str]]:
    """For a printed panel (``plates.process = "print"``; else nothing) of footprint ``size`` (width, height) mm:
    the kit's check line (the part on the ``[sheet]`` bed, which the spec's check already holds it to) and a
    warning when the part fits :data:`COMMON_PRINT_BED` neither way round."""
    if spec.plates.process != "print":
        return [], []
    s = spec.sheet
    w, h = size
    line = (f"printed part {w:.1f} × {h:.1f} mm: on the print bed of [sheet], {s.width:g} × {s.height:g} mm "
            f"(sheet.margin = {s.margin:g} mm)")
    bw, bh = COMMON_PRINT_BED
    if (w <= bw and h <= bh) or (h <= bw and w <= bh):
        return [line], []
    return [line], [f"the printed panel is {w:.1f} × {h:.1f} mm, larger than a common {bw:g} × {bh:g} mm print bed "
                     f"either way round (PrusaSlicer's command line stops on a part outside its bed); it was checked "
                     f"against [sheet], {s.width:g} × {s.height:g} mm: give sheet.width and sheet.height of your "
                     "printer's bed, or " + ("fewer rows or columns" if spec.tiling.file is None else "a smaller mesh")]


def nest_panel(spec: Any) -> tuple[Any, bool]:
    """The panel's hull nested on the spec's sheet (:func:`fabpat.assembly.nesting.nest`, one item, no turn) and
    whether it was turned by 90° first (when only that way fits)."""
    from fabpat.assembly.nesting import DEFAULT_RESOLUTION, nest

    s = spec.sheet
    room = np.array([s.width, s.height]) - 2 * s.margin - DEFAULT_RESOLUTION
    P = _grown(spec)
    quarter = not (np.ptp(P, axis=0) <= room + 1e-9).all()
    return nest([quarter_turn(P, quarter)], s.width, s.height, s.margin, s.spacing, turns=1), quarter
