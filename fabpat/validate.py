"""One check for every number a user gives fabpat: finite, and inside its physical range.

The command line (through :class:`fabpat.cli.options.NumberType`), the assembly specs
(:mod:`fabpat.assembly.spec.load`) and the public functions (``get_pattern``, ``fillet_pattern``,
``mesh_outline``, ``run_scenario``, the exporters) all call :func:`check` with a name from
:data:`RANGES`, so a value is accepted or refused the same way everywhere and the message says the
range. The table, with the reasons for each bound, is in docs/reliability.md.

The ranges are physical, not computational: what a plate, a material or a fabrication process can
be. Whether the *work* a valid combination asks for fits in memory and time is a separate question,
answered by the size estimates next to the heavy code (``fabpat.simulation.mesh.estimate_elements``,
``fabpat.geometry.outline.Outline.estimate_segments``) with limits an option can raise.

This module imports nothing from fabpat but the errors, so the first stage (``lattice``) can use it.
"""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import SupportsFloat, SupportsIndex

from fabpat.errors import FabpatError, RangeError


@dataclass(frozen=True)
class Range:
    """The valid values of one parameter: ``low`` … ``high`` in ``unit``, each end open or closed.

    ``integer`` ranges accept whole numbers only (Python or numpy integers; no bool).
    """

    name: str
    low: float
    high: float
    unit: str = ""
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    why: str = ""

    def describe(self) -> str:
        """``"[1, 1000] mm"``, ``"(-1, 0.5)"``, ``"an integer in [3, 64]"``."""
        def num(x: float) -> str:
            return f"{int(x)}" if self.integer else f"{x:g}"

        lo = f"{'(' if self.low_open else '['}{num(self.low)}"
        hi = f"{num(self.high)}{')' if self.high_open else ']'}"
        text = f"{lo}, {hi}" + (f" {self.unit}" if self.unit else "")
        return f"an integer in {text}" if self.integer else text

    def contains(self, value: float) -> bool:
        """Is ``value`` (already known to be a finite number) between the ends, open or closed?"""
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return bool(above and below)


def _r(name: str, low: float, high: float, unit: str = "", why: str = "", **kw: bool) -> Range:
    return Range(name, low, high, unit, why=why, **kw)


#: Every named range. ``why`` is the reason for the bounds (copied into docs/reliability.md).
RANGES: dict[str, Range] = {r.name: r for r in (
    _r("edge", 1.0, 1000.0, "mm", "polygon edge: a 1 mm plate has 0.06 mm interfaces; 1 m is beyond any print bed "
       "or laser sheet"),
    _r("thickness", 0.01, 100.0, "mm", "plate thickness: from foil (10 µm) to a 10 cm slab; below 0.01 mm "
       "OCCT cannot extrude (Standard_ConstructionError at 1e-9)"),
    _r("weight", 0.01, 10.0, "", "middle weight w of the interface arcs (paper: 0.2); at w = 10 the narrowest "
       "feature of 0x2d88 is 0.42 mm, at w = 1e9 the interface is 4.5e-9 mm long"),
    _r("bridge_weight", 0.25, 2.5, "", "middle weight of the fillet arcs at non-manifold vertices (paper: 1): "
       "necks scale with 2/(1 + w), from 1.6× the paper's at 0.25 to 0.57× at 2.5, where the narrowest "
       "feature of any library pattern is 1.12 mm (hexagons) and 0.87 mm (pentagons) at edge 36 mm, above "
       "the 0.8 mm of two 0.4 mm extrusion lines"),
    _r("h", 0.001, 1000.0, "mm", "target mesh edge; the element-count estimate and the narrowest feature bound "
       "it further"),
    _r("refine", 0, 4, "", "nested refinements of a mesh: each makes 4× the triangles (4 → 256×)", integer=True),
    _r("youngs_modulus", 1e-3, 1e7, "N/mm²", "from soft gels (1 kPa) past diamond (1.2e6 N/mm²)"),
    _r("poisson", -1.0, 0.5, "", "isotropic elasticity needs -1 < ν < 1/2 (positive-definite stiffness)",
       low_open=True, high_open=True),
    _r("strain_limit", 0.0, 0.5, "", "largest principal strain a plate may reach (default 0.02, PLA's yield "
       "strain); the shell model is not meant for strains near 50 %", low_open=True),
    _r("seed", 0, 2**63 - 1, "", "numpy's random generator takes non-negative seeds", integer=True),
    _r("sides", 3, 64, "", "a regular polygon; above 64 sides the fan triangles are slivers", integer=True),
    _r("depth", 1, 6, "", "slice subdivision: depth 6 already has 4096 sub-triangles of edge/64 per fan "
       "triangle", integer=True),
    _r("sample", 1, 1_000_000, "", "patterns drawn by --sample", integer=True),
    _r("workers", 1, 1024, "", "local worker processes", integer=True),
    _r("mesh_tolerance", 1e-6, 10.0, "mm", "STL/3MF chord height: 1 µm is far below any printer; OCCT fails "
       "(Standard_NumericError) at 1e-9"),
    _r("curve_tolerance", 1e-6, 10.0, "mm", "DXF/SVG deviation from the exact outline: 1 µm is far below any "
       "laser"),
    _r("width_tolerance", 1e-5, 1.0, "mm", "flattening tolerance tol of validate/min_width (accurate to about "
       "2 tol): 10 nm is far below any fabrication, and the ray cast grows as tol falls (0x0488: 0.2 GB at "
       "1e-5 mm, 1 GB at 1e-6, 24 GB at 1e-300); above 1 mm the arcs collapse to chords (0x0488 at "
       "tol = 3: 3.80 mm instead of 1.95)"),
    _r("kerf", 0.0, 10.0, "mm", "laser kerf"),
    _r("max_elements", 1, 1_000_000_000, "", "size limit of one mesh (see the size limits)", integer=True),
    _r("end_shortening", 0.0, 0.5, "", "end-pin travel / strip length: at 0.5 the pins would meet in the "
       "middle", low_open=True, high_open=True),
    _r("steps", 1, 1000, "", "reported increments of the end-shortening path", integer=True),
    _r("imperfection_force", 0.0, 100.0, "N", "total upward force that selects the buckle (default 0.01 N; "
       "a force comparable to the buckling load, ~0.5 N for the graded strip, changes the answer)"),
    _r("density", 0.0, 25.0, "g/cm³", "the densest element (osmium) is 22.6 g/cm³", low_open=True),
    _r("sheet_size", 0.0, 10_000.0, "mm", "laser sheet or print bed side: 10 m is beyond any machine",
       low_open=True),
    _r("gap", 0.0, 1000.0, "mm", "sheet margin and spacing, sleeve margin"),
    _r("clearance", 0.0, 10.0, "mm", "sleeve slot width minus plate thickness"),
    _r("sleeve_length", 0.0, 1000.0, "mm", "sleeve wall and depth", low_open=True),
    _r("strip_cells", 1, 1000, "", "spec integers (tiling.rows, tiling.columns, patterns.count, "
       "patterns.group_columns): 1000 columns of 36 mm hexagons are over 50 m long", integer=True),
    _r("rate", 0.0, 1e4, "", "cut speed (mm/s) and print rate (mm³/s)", low_open=True),
)}

#: Relative resolution below which a tolerance means nothing at a part's size. float64 resolves
#: 2.2e-16 relative, but the geometric kernels lose digits in intersections and offsets (OCCT's
#: Precision::Confusion is 1e-7 mm on parts of 10–100 mm), so 1e-9 × size is the finest meaningful value.
FLOAT_RESOLUTION = 1e-9

#: mm: two points closer than this are one point, the round-off of millimetre geometry (skeleton
#: vertices welded, segment ends meeting, a node on an interface segment, faces that touch)
SAME_POINT = 1e-6


def _label(name: str, label: str | None) -> str:
    return label or name


def check(name: str, value: object, label: str | None = None, error: type[FabpatError] = RangeError) -> float:
    """``value`` as a float (an int for integer ranges) if it is a finite number in ``RANGES[name]``.

    ``label`` is how the caller spells the parameter (``--edge``, ``tiling.edge``); the default is the
    range's name. Raises ``error`` (a :class:`FabpatError`, by default :class:`RangeError`) whose one
    line names the parameter, the range and the value.
    """
    r = RANGES[name]
    what = _label(name, label)
    kind = "an integer" if r.integer else "a number"
    # Decimal is not a numbers.Real (PEP 3141 keeps it apart from float) but is what a spreadsheet or a
    # JSON parser with parse_float=Decimal hands over: a number all the same.
    if isinstance(value, bool) or not isinstance(value, numbers.Real | Decimal):
        raise error(f"{what} must be {kind} {_range_text(r).removeprefix('an integer ')}, got {value!r}")
    if r.integer:
        if not isinstance(value, numbers.Integral):
            raise error(f"{what} must be {r.describe()}, got {value!r}")
        whole = int(value)
        if not r.contains(whole):
            raise error(f"{what} = {value} is out of range: must be {_range_text(r)}")
        return whole
    try:
        number = float(value)
    except OverflowError:  # an integer beyond float64 (a TOML literal with 400 digits)
        number = -math.inf if value < 0 else math.inf
    if not math.isfinite(number):
        raise error(f"{what} must be a finite number in {r.describe()}, got {number!r}")
    if not r.contains(number):
        raise error(f"{what} = {number:g} is out of range: must be {_range_text(r)}")
    return number


def as_float(value: object) -> float:
    """``float(value)``, typed for a value of unknown type (a stored or parsed one): the same number, or
    the TypeError (None, a list, …) or ValueError (text that is no number) that ``float`` raises."""
    if isinstance(value, str | bytes | bytearray | SupportsFloat | SupportsIndex):
        return float(value)
    raise TypeError(f"float() argument must be a string or a real number, not '{type(value).__name__}'")


def _range_text(r: Range) -> str:
    return r.describe() if r.integer else f"in {r.describe()}"


def round_up(x: float, digits: int = 2) -> float:
    """``x`` rounded *up* to ``digits`` significant digits: a suggested lower bound ("use h ≥ …") that
    passes the check it comes from (rounding to nearest can land just below it)."""
    if not (math.isfinite(x) and x > 0):
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return float(f"{math.ceil(x / scale * (1 - 1e-12)) * scale:.{digits}g}")  # 2.4, not 2.4000000000000004


def round_down(x: float, digits: int = 3) -> float:
    """``x`` rounded *down* to ``digits`` significant digits: a suggested upper bound ("use h ≤ …")."""
    if not (math.isfinite(x) and x > 0):
        return x
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    # through the decimal digits, so that 1.13 is 1.13 and not 1.1300000000000001 (113 × 0.01)
    return float(f"{math.floor(x / scale * (1 + 1e-12)) * scale:.{digits}g}")


def check_tolerance(tolerance: float, size: float, label: str, error: type[FabpatError] = RangeError) -> float:
    """Refuse a tolerance (mm) finer than floating point resolves on a part ``size`` mm across.

    The floor is :data:`FLOAT_RESOLUTION` × size; returns the tolerance.
    """
    floor = FLOAT_RESOLUTION * size
    if tolerance < floor:
        raise error(f"{label} = {tolerance:g} mm is below what floating point resolves on a part {size:.4g} mm "
                    f"across: use ≥ {floor:.2g} mm")
    return tolerance


def check_size(estimate: float, limit: int, what: str, option: str, hint: str = "",
               error: type[FabpatError] = RangeError) -> None:
    """Refuse work whose estimated size (elements, segments, cells) is above ``limit``.

    ``what`` names the quantity (``"mesh elements at h = 0.05 mm"``); the one-line message gives the
    estimate, the limit and the option that raises it, plus ``hint``.
    """
    if not estimate <= limit:
        shown = f"{estimate:.3g}" if not estimate < 1e6 else f"{int(estimate)}"
        raise error(f"{what}: about {shown}, above the limit of {limit} ({option})"
                    + (f"; {hint}" if hint else ""))


def check_path(path: object, label: str, error: type[FabpatError] = RangeError) -> str | os.PathLike[str]:
    """``path`` if it is a file name (str or path-like) the operating system can take; ``error`` naming
    ``label`` for anything else (None, a number) and for a name with a NUL character, which no file
    system accepts (``os`` raises a bare ValueError "embedded null byte")."""
    if not isinstance(path, str | os.PathLike):
        raise error(f"{label} must be a file name (str or pathlib.Path), got {type(path).__name__}")
    text = os.fspath(path)
    if (b"\0" if isinstance(text, bytes) else "\0") in text:
        raise error(f"{label} {text!r} contains a NUL character, which no file name may hold")
    return path


def check_suffix(path: str | Path, suffixes: tuple[str, ...], label: str,
                 error: type[FabpatError] = RangeError) -> None:
    """Refuse an output path whose suffix (case-insensitive) is not one of ``suffixes`` (``".png"``, …)."""
    suffix = Path(path).suffix.lower()
    if suffix not in suffixes:
        got = f"{suffix!r}" if suffix else "no suffix"
        raise error(f"{label} {str(path)!r} has {got}: the file name must end in {' or '.join(suffixes)}")
