"""The export formats in one place, and one atomic export of a part to several files.

A format is a name, a file suffix and a module under ``fabpat.exchange`` with a function
``write(part, path, settings)``; adding a format is one new module and one :func:`register_format`
line. Modules are imported only when a file of their format is written, so OCP (≈ 1 s) and ezdxf
(≈ 0.4 s) load only when needed.

Process limits for the minimum-feature-width warning (documented defaults):

* printing (STEP, STL, 3MF): ``PRINT_MIN_WIDTH`` = 0.8 mm, two perimeters of a 0.4 mm nozzle;
* laser cutting (DXF, SVG, 3DM): ``LASER_WIDTH_FACTOR`` × kerf = 2 × kerf — a bar narrower than two
  kerfs is burnt through or too weak to survive the cut. No laser check when kerf = 0.
"""

from __future__ import annotations

import contextlib
import importlib
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, Unpack

from fabpat.errors import ExportError
from fabpat.exchange.cad import DEFAULT_THICKNESS, occt_errors
from fabpat.exchange.part import (  # noqa: F401 - Part, ExportSettings and their limits are part of this API
    DEFAULT_MAX_EXPORT_ELEMENTS,
    ExportSettings,
    Part,
    estimate_triangles,
    flatten_arcs,
)
from fabpat.geometry.outline import Outline

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.geometry.fillet import FilletedPattern
from fabpat.io import atomic_outputs, check_distinct, check_file_name
from fabpat.validate import check

PRINT_MIN_WIDTH = 0.8  # mm
LASER_WIDTH_FACTOR = 2.0  # × kerf
WIDTH_TOL = 0.01  # mm: flattening tolerance of the min-width check (accurate to ≈ 2 × this)



@dataclass(frozen=True)
class Format:
    """One file format: ``name`` (CLI spelling), ``suffix`` (the one written by ``--all``), writer module,
    ``process`` (print/laser), and ``aliases``: other suffixes read as this format (``.stp`` for STEP)."""

    name: str
    suffix: str
    module: str
    process: str
    description: str
    aliases: tuple[str, ...] = ()

    @property
    def suffixes(self) -> tuple[str, ...]:
        """Every suffix of this format, lower case, the main one first."""
        return (self.suffix.lower(), *(a.lower() for a in self.aliases))

    @property
    def write(self) -> Callable[[Part, Path, ExportSettings], None]:
        """The format module's ``write(part, path, settings)``, imported on first use."""
        write: Callable[[Part, Path, ExportSettings], None] = importlib.import_module(
            f"fabpat.exchange.{self.module}").write
        return write


FORMATS: dict[str, Format] = {}


def register_format(name: str, suffix: str, module: str, process: str, description: str,
                    aliases: tuple[str, ...] = ()) -> None:
    """Add a format; ``module`` is a module name under ``fabpat.exchange`` that defines ``write``;
    ``aliases`` are further suffixes recognised as it (matched regardless of case, like ``suffix``)."""
    FORMATS[name] = Format(name, suffix, module, process, description, tuple(aliases))


register_format("step", ".step", "step", "print", "STEP AP214 exact solid (mm)", aliases=(".stp",))
register_format("stl", ".stl", "stl", "print", "binary STL mesh (mm)")
register_format("3mf", ".3mf", "threemf", "print", "3MF mesh (mm)")
register_format("dxf", ".dxf", "dxf", "laser", "DXF outline: CUT and ENGRAVE layers (mm)")
register_format("svg", ".svg", "svg", "laser", "SVG outline at true size (mm)")
register_format("3dm", ".3dm", "rhino", "laser", "Rhino 3DM: exact NURBS outline on CUT, plate extrusion (mm)")


def format_of(path: str | os.PathLike[str]) -> str:
    """The registered format name of a file's suffix (``p.step`` → ``"step"``); :class:`ExportError`
    naming the known suffixes otherwise."""
    suffix = Path(path).suffix.lower()
    for name, fmt in FORMATS.items():
        if suffix in fmt.suffixes:
            return name
    known = " ".join(s for f in FORMATS.values() for s in f.suffixes)
    raise ExportError(f"cannot tell the format of {os.fspath(path)!r} from its suffix: use one of {known}")


def check_target(name: str, path: str | os.PathLike[str], what: str | None = None) -> None:
    """:class:`ExportError` unless ``name`` is a registered format and ``path`` names a file whose
    suffix (any case) is one of that format's (:func:`format_of` would read it as this format).
    ``what``: how the message names the output (the CLI's ``--dxf``); default ``"the DXF file"``."""
    if name not in FORMATS:
        raise ExportError(f"unknown format {name!r}: choose from {', '.join(FORMATS)}")
    what = what or f"the {name.upper()} file"
    check_file_name(path, f"cannot write {what}")
    suffixes = FORMATS[name].suffixes
    if Path(path).suffix.lower() not in suffixes:
        raise ExportError(f"{what} must end in {' or '.join(suffixes)}, got {os.fspath(path)!r} (programs tell a "
                          "file's format by its suffix)")


def parse_formats(text: str) -> list[str]:
    """``"step,stl,dxf"`` → ``["step", "stl", "dxf"]``; :class:`ExportError` for unknown or none."""
    names = [s.strip().lower() for s in text.split(",") if s.strip()]
    unknown = [n for n in names if n not in FORMATS]
    if unknown:
        raise ExportError(f"unknown format {unknown[0]!r}: choose from {', '.join(FORMATS)}")
    if not names:
        raise ExportError(f"no format given ({text!r}): give one or more of {', '.join(FORMATS)}, comma-separated")
    return list(dict.fromkeys(names))


def width_warnings(outline: Outline, formats: list[str], kerf: float) -> list[str]:
    """One message per process whose limit the outline's minimum feature width is below."""
    processes = {FORMATS[f].process for f in formats}
    limits = {"print": PRINT_MIN_WIDTH, "laser": LASER_WIDTH_FACTOR * kerf}
    if not any(limits[p] > 0 for p in processes):
        return []
    validate = getattr(outline, "validate", None)
    if validate is None:
        return []
    width = validate(WIDTH_TOL, raise_on_error=False).min_width
    out = []
    for process in sorted(processes):
        if width < limits[process]:
            what = "printing" if process == "print" else f"laser cutting with a {kerf:g} mm kerf"
            out.append(f"min feature width {width:.3g} mm is below {limits[process]:.3g} mm for {what}")
    return out


def label_warning(part: Part, formats: list[str]) -> str | None:
    """The message when the part's label is left out of its DXF/SVG (no room on the material), else None.

    The DXF and SVG writers place the label with :func:`fabpat.exchange.labels.place_label` and write
    none when no box of ``MIN_TEXT_HEIGHT`` mm fits on the material; this says so instead of staying silent.
    """
    from fabpat.exchange.labels import MIN_TEXT_HEIGHT, place_label

    labelled = [f.upper() for f in formats if f in ("dxf", "svg")]
    if not part.label or not labelled or place_label(part.outline, part.label) is not None:
        return None
    return (f"{part.name}: no label on the {'/'.join(labelled)}: no {MIN_TEXT_HEIGHT:g} mm box for "
            f"{part.label!r} fits on the material")


Job = tuple[Part | Callable[[], Part], Mapping[str, str | os.PathLike[str]]]


def check_settings(settings: ExportSettings) -> None:
    """Raise :class:`ExportError` for any option no writer could honour: the shared values
    (:meth:`ExportSettings.check`), then each format's own options, checked by that format (the DXF curve
    mode, version, entities and origin: :func:`fabpat.exchange.dxf.check_options`; the SVG curves:
    :func:`fabpat.exchange.svg.check_svg_curves`), whatever formats are written: a bad option is
    refused before any file, not when a later part reaches that format."""
    from fabpat.exchange.dxf import check_options
    from fabpat.exchange.svg import check_svg_curves

    for name, v in (("mesh_tolerance", settings.mesh_tolerance), ("curve_tolerance", settings.curve_tolerance),
                    ("kerf", settings.kerf), ("max_elements", settings.max_elements)):
        check(name, v, name.replace("_", " "), error=ExportError)
    check_options(settings.curves, settings.curve_tolerance, settings.kerf, settings.dxf_version,
                  settings.dxf_entities, settings.origin)
    check_svg_curves(settings.svg_curves)
    settings.check()


def meshed_formats() -> list[str]:
    """The registered formats that are meshes of the solid (printed, but not the exact STEP)."""
    return [name for name, f in FORMATS.items() if f.process == "print" and name != "step"]


def export_parts(
    jobs: Sequence[Job],
    settings: ExportSettings | None = None,
    on_part: Callable[[Part, list[str]], None] | None = None,
    part_guard: Callable[[], contextlib.AbstractContextManager[object]] = contextlib.nullcontext,
) -> list[Path]:
    """Write every job's part to its ``{format: path}`` targets in one atomic block.

    A job's part may be a callable that builds it, so a whole library is built one part at a time.
    Every target must end in a suffix of its format (:meth:`Format.suffixes`: no DXF in a ``.dwg``) and
    name a file, not a folder (``a.stl/``).
    All options, formats and folders are checked before any file is created, and on any error (in
    any part) no file is left. ``on_part(part, formats)`` runs after each part is written (progress,
    warnings). Each part's building, writing and ``on_part`` run inside ``part_guard()`` (the CLI holds
    Ctrl-C there until the part is done, :func:`fabpat.cli.deferred_interrupts`), still inside the
    atomic block. Returns the paths written.
    """
    settings = settings or ExportSettings()
    check_settings(settings)
    paths: list[Path] = []
    for _, targets in jobs:
        if not targets:
            raise ExportError("no output file requested")
        for name, target in targets.items():
            check_target(name, target)
        paths += [Path(p) for p in targets.values()]
    check_distinct(paths)  # the one check every command shares (atomic_outputs repeats it)
    with atomic_outputs(*paths) as temps:
        tmp = iter(temps)
        for job, targets in jobs:
            with part_guard():
                part = job() if callable(job) else job
                settings.check_part(part, list(targets), meshed_formats())
                for name in targets:
                    with occt_errors(f"writing the {name.upper()} file of {part.label or part.name}"):
                        FORMATS[name].write(part, next(tmp), settings)
                if on_part is not None:
                    on_part(part, list(targets))
    return paths


def export_part(
    part: Part, targets: Mapping[str, str | os.PathLike[str]], settings: ExportSettings | None = None
) -> list[Path]:
    """Write one part to every ``{format: path}`` atomically (see :func:`export_parts`)."""
    return export_parts([(part, targets)], settings)


def filleted_part(filleted: FilletedPattern, thickness: float = DEFAULT_THICKNESS) -> Part:
    """The part of a :class:`~fabpat.geometry.fillet.FilletedPattern`: named by its ID and parameters (and its
    variation, :func:`fabpat.exchange.cad.part_name`), labelled with its ID (``"0x0488 b0.5"`` for a
    ``bridge_weight`` of 0.5, so two members of one family are told apart on the sheet), its interface
    bow-tie arcs as ``support`` (so STEP carries their weights (1, w, 1))."""
    from fabpat.exchange.cad import part_name

    variation = filleted.variation
    name = part_name(filleted.id, filleted.sides, filleted.edge, thickness, filleted.weight, variation.label())
    return Part(filleted.outline, thickness, name, label=filleted.label, support=filleted.support_arcs)


class SettingsOptions(TypedDict, total=False):
    """The :class:`ExportSettings` fields as keywords (mm, rad; see there)."""

    mesh_tolerance: float
    angular_tolerance: float
    curves: str
    curve_tolerance: float
    kerf: float
    dxf_version: str
    dxf_entities: str | None
    svg_curves: str
    origin: str
    timestamp: str | None
    max_elements: int


class ExportOptions(SettingsOptions, total=False):
    """The keywords of :func:`export_filleted`: the plate ``thickness`` (mm) and the :class:`ExportSettings` fields."""

    thickness: float


_SETTINGS_FIELDS = tuple(ExportSettings.__dataclass_fields__)
_NUMERIC_OPTIONS = ("thickness", "mesh_tolerance", "angular_tolerance", "curve_tolerance", "kerf")


def export_filleted(filleted: FilletedPattern, path: str | os.PathLike[str], **options: Unpack[ExportOptions]) -> Path:
    """Write ``filleted`` to ``path`` in the format of its suffix (:func:`format_of`), atomically.

    ``options``: ``thickness`` (mm) and any :class:`ExportSettings` field. The same part and writers
    as ``fabpat export``. Raises :class:`ExportError` for an unknown suffix or option.
    """
    if not isinstance(path, str | os.PathLike):
        raise ExportError(f"path must be a file name, got {path!r}")
    name = format_of(path)
    thickness = options.pop("thickness", DEFAULT_THICKNESS)
    unknown = sorted(set(options) - set(_SETTINGS_FIELDS))
    if unknown:
        raise ExportError(f"unknown export option {unknown[0]!r}: choose from thickness, {', '.join(_SETTINGS_FIELDS)}")
    for key, value in (("thickness", thickness), *options.items()):
        if key in _NUMERIC_OPTIONS and (isinstance(value, bool) or not isinstance(value, int | float)):
            raise ExportError(f"{key} must be a number (mm), got {value!r}")
    fields: SettingsOptions = options  # "thickness" popped: the rest are ExportSettings fields
    settings = ExportSettings(**fields)
    return export_part(filleted_part(filleted, thickness), {name: path}, settings)[0]
