"""What every export format reads: the :class:`Part` (exact outline, thickness, name, label) and the
:class:`ExportSettings`, with the checks of their values that every format shares (a printable name, an
ISO 8601 time stamp, the tolerances and element limits). The lowest module of :mod:`fabpat.exchange`: the
formats and the registry import it, it imports none of them. Lengths in mm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from fabpat.errors import ExportError
from fabpat.exchange.cad import DEFAULT_ANGULAR, DEFAULT_CHORD, DEFAULT_THICKNESS, make_solid
from fabpat.geometry.outline import Line, Outline, RationalQuad
from fabpat.validate import check, check_size, check_tolerance

if TYPE_CHECKING:  # pragma: no cover - OCP has no stubs: mypy sees its classes as unchecked
    from OCP.TopoDS import TopoDS_Solid

#: Default limit (``--max-elements``) on the estimated STL/3MF triangles or DXF/SVG segments of one
#: part. Measured here: 0x0488 at a 1e-4 mm chord gives 1 085 068 triangles in 80 s and 589 MB
#: (``/usr/bin/time -v fabpat export 0x0488 --stl m.stl --mesh-tolerance 1e-4``), so 2 000 000 triangles
#: stay near 1 GB and three minutes.
DEFAULT_MAX_EXPORT_ELEMENTS = 2_000_000

#: BRepMesh triangles of an extruded plate ≈ WALL_TRIANGLES × (curved boundary length, mm) ×
#: thickness (mm) / chord (mm): surface deflection control subdivides the curved side walls in both
#: directions. Measured 0.10–0.17 for 0x7f88, 0x2d88 and 0x0488 at t = 2 and 4 mm, chords 1e-3 and 2e-3;
#: 0.2 errs on the large side. The flat caps add about 4 triangles per boundary chord.
WALL_TRIANGLES = 0.2
CAP_TRIANGLES_PER_CHORD = 4


def estimate_triangles(outline: Outline, thickness: float, tolerance: float) -> float:
    """Expected STL/3MF triangle count of the extruded outline at a chord ``tolerance`` (mm)."""
    curved = math.fsum(s.length for loop in outline.loops for s in loop.segments if not isinstance(s, Line))
    return WALL_TRIANGLES * curved * thickness / tolerance + CAP_TRIANGLES_PER_CHORD * outline.estimate_segments(
        tolerance)


@dataclass(frozen=True)
class ExportSettings:
    """Format options, all lengths in mm.

    ``mesh_tolerance``: STL/3MF chord height; ``angular_tolerance``: BRepMesh angle (rad);
    ``curves``: DXF curve mode (arcs, spline, lines); ``curve_tolerance``: DXF/SVG fit tolerance;
    ``kerf``: laser kerf width (DXF/SVG loops move out by kerf / 2); ``dxf_version``: R2010, R12, …;
    ``dxf_entities``: polyline or segments (None: the default for the curve mode and version, see
    :mod:`fabpat.exchange.dxf`); ``svg_curves``: exact or cubic (:mod:`fabpat.exchange.svg`);
    ``origin``: corner or centre, where a single part's DXF/SVG lies (:mod:`fabpat.exchange.origin`);
    ``timestamp``: fixed time (ISO 8601) for byte-reproducible STEP, 3MF, DXF and 3DM files.
    """

    mesh_tolerance: float = DEFAULT_CHORD
    angular_tolerance: float = DEFAULT_ANGULAR
    curves: str = "arcs"
    curve_tolerance: float = 0.01
    kerf: float = 0.0
    dxf_version: str = "R2010"
    dxf_entities: str | None = None
    svg_curves: str = "cubic"
    origin: str = "corner"
    timestamp: str | None = None
    max_elements: int = DEFAULT_MAX_EXPORT_ELEMENTS

    def check(self) -> None:
        """Raise :class:`ExportError` for a value no writer could honour: the tolerances, kerf and element
        limit (ranges: fabpat.validate), the time stamp and the angular tolerance. Each format's own options
        (the DXF curve mode, version and entities, the SVG curves, the origin) are checked by that format,
        through :func:`fabpat.exchange.registry.check_settings`, which every export runs first."""
        for name, v in (("mesh_tolerance", self.mesh_tolerance), ("curve_tolerance", self.curve_tolerance),
                        ("kerf", self.kerf), ("max_elements", self.max_elements)):
            check(name, v, name.replace("_", " "), error=ExportError)
        check_timestamp(self.timestamp, "timestamp")
        if not (self.angular_tolerance > 0 and math.isfinite(self.angular_tolerance)):
            raise ExportError(f"angular tolerance must be > 0, got {self.angular_tolerance:g}")

    def check_part(self, part: Part, formats: Sequence[str], printed: Sequence[str] = ("stl", "3mf")) -> None:
        """Refuse (ExportError) tolerances finer than floating point resolves on the part, and files
        whose estimated triangles or segments are above ``max_elements``, before anything is built.
        ``printed``: the formats of ``formats`` that are meshes of the solid (the registry's print formats
        but STEP)."""
        outline = part.outline
        box = np.asarray(outline.bbox)
        size = float(np.linalg.norm(box[1] - box[0]))
        if any(f in printed for f in formats):
            check_tolerance(self.mesh_tolerance, size, "mesh tolerance", error=ExportError)
            n = estimate_triangles(outline, part.thickness, self.mesh_tolerance)
            check_size(n, self.max_elements, f"mesh triangles of {part.label or part.name}",
                       "raise it with --max-elements", "or use a larger --mesh-tolerance", error=ExportError)
        if ("dxf" in formats and self.curves != "spline") or ("svg" in formats and self.kerf > 0):
            check_tolerance(self.curve_tolerance, size, "curve tolerance", error=ExportError)
            n = outline.estimate_segments(self.curve_tolerance)
            check_size(n, self.max_elements, f"curve segments of {part.label or part.name}",
                       "raise it with --max-elements", "or use a larger --curve-tolerance", error=ExportError)


@dataclass(eq=False)
class Part:
    """What gets exported: the exact outline, plate thickness (mm), product name and engraved label.

    ``support``: whole interface arcs whose halves the outline keeps (see :func:`fabpat.exchange.cad.make_face`),
    flat or as the (n, 2) pairs of ``FilletedPattern.interface_arcs`` (flattened here).
    ``solid`` (a ``TopoDS_Solid``) is built on first use and shared by every 3D format.
    Raises :class:`ExportError` for a thickness ≤ 0, a support that is not arcs, or a name or label
    that is not text or holds a control character (:func:`check_printable`).
    Any other character is fine: STEP encodes it (:func:`fabpat.exchange.step.step_string`).
    """

    outline: Outline
    thickness: float = DEFAULT_THICKNESS
    name: str = "fabpat part"
    label: str | None = None
    support: tuple[RationalQuad, ...] = ()

    def __post_init__(self) -> None:
        check("thickness", self.thickness, error=ExportError)
        check_printable(self.name, "the part name")
        if self.label is not None:
            check_printable(self.label, "the part label")
        self.support = flatten_arcs(self.support)

    @cached_property
    def solid(self) -> TopoDS_Solid:
        """The exact extruded ``TopoDS_Solid`` (z from 0 to thickness), built once by
        :func:`fabpat.exchange.cad.make_solid`."""
        return make_solid(self.outline, self.thickness, self.support)


def flatten_arcs(arcs: object) -> tuple[RationalQuad, ...]:
    """One flat tuple of arcs from arcs nested in tuples or lists (e.g. the interface arc pairs);
    :class:`ExportError` for anything else."""
    if isinstance(arcs, RationalQuad):
        return (arcs,)
    if not isinstance(arcs, tuple | list):
        raise ExportError(f"support must be RationalQuad arcs (or pairs of them), got {type(arcs).__name__}")
    return tuple(a for item in arcs for a in flatten_arcs(item))


def check_timestamp(timestamp: str | None, what: str = "--timestamp") -> str | None:
    """The STEP header time stamp, normalised to ``YYYY-MM-DDThh:mm:ss`` (plus ``Z`` or ``±hh:mm`` when
    a zone is given), if ``timestamp`` is a valid ISO 8601 date or date-time (``2025-01-31``,
    ``2025-01-31T12:00:00``, ``2025-01-31 12:00``, ``20250131``, ``…Z``, ``…+01:00``); fractions of a
    second are dropped. :class:`ExportError` naming ``what`` otherwise.

    Checked before any work, so free text never reaches a file header; the normalised form is what the
    header gets (ISO 10303-21 §8.2.3 wants an ISO 8601 time_stamp, and every accepted spelling of one
    instant gives the same bytes). Parsed by :meth:`datetime.datetime.fromisoformat`.
    """
    from datetime import datetime, timedelta

    if timestamp is None:
        return None
    try:
        if not isinstance(timestamp, str) or not timestamp.isascii() or not timestamp.strip():
            raise ValueError
        t = datetime.fromisoformat(timestamp)
    except ValueError:
        raise ExportError(f"{what} {timestamp!r} is not an ISO 8601 date or time: give e.g. 2025-01-31 or "
                          "2025-01-31T12:00:00Z") from None
    text = t.strftime("%Y-%m-%dT%H:%M:%S")
    offset = t.utcoffset()
    if offset is not None:
        if offset == timedelta(0):
            return text + "Z"
        minutes = int(abs(offset.total_seconds())) // 60
        text += f"{'-' if offset < timedelta(0) else '+'}{minutes // 60:02d}:{minutes % 60:02d}"
    return text


def check_printable(text: object, what: str) -> str:
    """``text`` if it is a str without control characters (U+0000–U+001F, U+007F–U+009F: C0, DEL, C1);
    :class:`ExportError` naming ``what`` and the first one otherwise. No file fabpat writes may hold
    them in a name or label: STEP strings (ISO 10303-21 §6.4.3) and XML 1.0 (3MF, SVG) forbid them,
    and a NUL cuts the name short in OCCT."""
    if not isinstance(text, str):
        raise ExportError(f"{what} must be text, got {type(text).__name__}")
    bad = next((c for c in text if ord(c) < 0x20 or 0x7F <= ord(c) <= 0x9F), None)
    if bad is not None:
        raise ExportError(f"{what} {text!r} holds the control character U+{ord(bad):04X}: names and labels in "
                          "STEP, 3MF, SVG and DXF files hold printable characters only; remove it")
    return text
