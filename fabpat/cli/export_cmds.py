"""``fabpat export``: fabrication files (STEP, STL, 3MF, DXF, SVG, 3DM) for one pattern or the library.

The command parses options, builds the filleted outline and calls :mod:`fabpat.exchange.registry`;
all files of one command are written through one :func:`fabpat.io.atomic_outputs` block, so an error
leaves no file. Width warnings and labels left out (no room on the part) go to stderr and do not change the exit code.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from fabpat.cli.options import (
    edge_option,
    id_depth_option,
    max_elements_option,
    number_option,
    sides_option,
    thickness_option,
    variation_option,
    warn_inert_variation,
    weight_option,
)
from fabpat.errors import ExportError
from fabpat.exchange.cad import DEFAULT_CHORD
from fabpat.exchange.registry import (
    DEFAULT_MAX_EXPORT_ELEMENTS,
    FORMATS,
    ExportSettings,
    Job,
    Part,
    check_settings,
    check_target,
    export_parts,
    filleted_part,
    label_warning,
    parse_formats,
    width_warnings,
)
from fabpat.io import check_output_folder, output_folder
from fabpat.patterns.variation import PAPER_VARIATION, Variation

if TYPE_CHECKING:  # pragma: no cover
    from fabpat.patterns.pattern import Pattern

DEFAULT_ALL_FORMATS = "step,stl,dxf"
#: the option that names each format's file
OPTION_OF = {"step": "--step", "stl": "--stl", "3mf": "--3mf", "dxf": "--dxf", "svg": "--svg", "3dm": "--3dm"}


def make_part(pattern: Pattern, thickness: float, weight: float, variation: Variation = PAPER_VARIATION) -> Part:
    """The filleted pattern (the family member ``variation``) as an exportable part
    (:func:`fabpat.exchange.registry.filleted_part`, the same one ``FilletedPattern.export`` writes)."""
    return filleted_part(pattern.fillet(weight, variation), thickness)


def _warn(message: str) -> None:
    click.echo(f"fabpat: warning: {message}", err=True)


def _write_all(jobs: list[Job], settings: ExportSettings, progress: bool) -> list[Path]:
    """Build each part and write its files in one atomic block, with width warnings and a progress bar."""
    from fabpat.cli import deferred_interrupts

    narrow: list[tuple[str | None, list[str]]] = []
    unlabelled: list[str] = []
    from fabpat.progress import Progress

    done = [0]
    # a bar on a terminal, else a line every few seconds (a pipe, a log): --all takes minutes
    with Progress("export", total=len(jobs), enabled=progress) as bar:
        def on_part(part: Part, formats: list[str]) -> None:
            messages = width_warnings(part.outline, formats, settings.kerf)
            if messages:
                narrow.append((part.label, messages))
            missing = label_warning(part, formats)
            if missing:
                unlabelled.append(missing)
            done[0] += 1
            bar.update(f"{done[0]} of {len(jobs)} parts written", done[0])

        # a Ctrl-C or SIGTERM takes effect between parts, not inside an import or a finalizer
        paths = export_parts(jobs, settings, on_part, part_guard=deferred_interrupts)
    if len(jobs) == 1:
        for message in narrow[0][1] if narrow else []:
            _warn(f"{narrow[0][0]}: {message}" if narrow[0][0] else message)
    elif narrow:
        label, messages = narrow[0]
        _warn(f"{len(narrow)} patterns have features too narrow for their process, e.g. {label}: {messages[0]}")
    if len(unlabelled) == 1:
        _warn(unlabelled[0])
    elif unlabelled:
        _warn(f"{len(unlabelled)} patterns have no label on their DXF/SVG, e.g. {unlabelled[0]}")
    return paths


@click.command("export")
@click.argument("pattern_id", metavar="[ID]", required=False)
@sides_option
@id_depth_option
@edge_option
@thickness_option
@weight_option
@variation_option
@click.option("--step", "step", type=click.Path(dir_okay=False), help="STEP AP214 file (exact solid).")
@click.option("--stl", "stl", type=click.Path(dir_okay=False), help="Binary STL file (chord --mesh-tolerance).")
@click.option("--3mf", "threemf", type=click.Path(dir_okay=False), help="3MF file (mesh for slicers).")
@click.option("--dxf", "dxf", type=click.Path(dir_okay=False), help="DXF file (CUT and ENGRAVE layers).")
@click.option("--svg", "svg", type=click.Path(dir_okay=False), help="SVG file (exact outline, true size).")
@click.option("--3dm", "rhino", type=click.Path(dir_okay=False),
              help="Rhino 3DM file: exact rational NURBS outline on layer CUT, plate as a closed extrusion.")
@click.option("--curves", type=click.Choice(["arcs", "spline", "lines"]), default="arcs", show_default=True,
              help="DXF curves: circular arcs or polylines within --curve-tolerance, or exact rational splines "
                   "(one SPLINE per curved segment).")
@number_option("--mesh-tolerance", range_name="mesh_tolerance", default=DEFAULT_CHORD, show_default=True,
               help="STL/3MF: largest distance in mm between the triangles and the exact surface.")
@number_option("--curve-tolerance", range_name="curve_tolerance", default=0.01, show_default=True,
               help="DXF arcs/lines, SVG cubics and kerf offsets: largest deviation in mm from the exact outline.")
@number_option("--kerf", range_name="kerf", default=0.0, show_default=True,
               help="Laser kerf in mm: DXF/SVG loops move out by kerf/2.")
@click.option("--dxf-version", type=click.Choice(["R2010", "R2000", "R12"]), default="R2010", show_default=True,
              help="DXF version; R12 (for old software) writes LINE and ARC entities.")
@click.option("--dxf-entities", type=click.Choice(["polyline", "segments"]), default=None,
              help="DXF arcs/lines as one closed LWPOLYLINE per loop (laser software that fills closed shapes) "
                   "or one LINE/ARC per piece (OpenSCAD and every other reader). "
                   "[default: polyline; segments for R12 and --curves spline]")
@click.option("--svg-curves", type=click.Choice(["cubic", "exact"]), default="cubic", show_default=True,
              help="SVG arcs as cubic Béziers within --curve-tolerance (cutters) or exact elliptical arcs.")
@click.option("--origin", type=click.Choice(["corner", "centre"]), default="corner", show_default=True,
              help="DXF/SVG placement: lower-left corner 1 mm from (0, 0), or the polygon centre at (0, 0).")
@click.option("--all", "all_", is_flag=True, help="Export every pattern of the library (needs --out).")
@click.option("--out", type=click.Path(file_okay=False), help="Folder for --all (created if missing).")
@click.option("--formats", default=None, help=f"Formats for --all, comma-separated [default: {DEFAULT_ALL_FORMATS}].")
@max_elements_option(DEFAULT_MAX_EXPORT_ELEMENTS, "STL/3MF triangles or DXF/SVG curve segments of one part")
def export_cmd(pattern_id: str | None, sides: int, depth: int | None, edge: float, thickness: float, weight: float,
               variation: Variation, step: str | None, stl: str | None, threemf: str | None, dxf: str | None,
               svg: str | None, rhino: str | None,
               curves: str, mesh_tolerance: float, curve_tolerance: float, kerf: float, dxf_version: str,
               dxf_entities: str | None, svg_curves: str, origin: str,
               all_: bool, out: str | None, formats: str | None, max_elements: int) -> None:
    """Write fabrication files for one pattern (ID) or, with --all, for the whole library.

    Warns on stderr when the narrowest feature is below the process limit: 0.8 mm for printing
    (STEP/STL/3MF), 2 × kerf for laser cutting (DXF/SVG/3DM).

    \b
    Examples:
      fabpat export 0x0488 --step p.step --stl p.stl --dxf p.dxf --kerf 0.15
      fabpat export 0x0688 --3dm p.3dm
      fabpat export 0x0488 --variation bridge_weight=0.5 --step wide-necks.step
      fabpat export --all --out parts --formats step,dxf
    """
    settings = ExportSettings(curves=curves, kerf=kerf, dxf_version=dxf_version, mesh_tolerance=mesh_tolerance,
                              curve_tolerance=curve_tolerance, dxf_entities=dxf_entities, svg_curves=svg_curves,
                              origin=origin, max_elements=max_elements)
    check_settings(settings)
    files = {"step": step, "stl": stl, "3mf": threemf, "dxf": dxf, "svg": svg, "3dm": rhino}
    if all_:
        if pattern_id is not None:
            raise click.UsageError("give either an ID or --all, not both")
        if depth not in (None, 2):
            raise click.UsageError("--all exports the depth-2 library; --depth goes with an ID")
        if any(files.values()):
            raise click.UsageError("--all writes into --out; single-file options (--step, …) need an ID")
        if out is None:
            raise click.UsageError("--all needs --out DIR")
        names = parse_formats(DEFAULT_ALL_FORMATS if formats is None else formats)  # '' is an error, not the default
        _export_library(sides, edge, thickness, weight, names, Path(out), settings, variation)
        return
    if pattern_id is None:
        raise click.UsageError("missing pattern ID (or --all)")
    if out is not None or formats is not None:
        raise click.UsageError("--out and --formats go with --all; for one pattern use --step, --stl, …")
    targets = {name: p for name, p in files.items() if p}  # raw text: Path("a.stl/") would drop the slash
    if not targets:
        raise ExportError("no output requested: give at least one of --step, --stl, --3mf, --dxf, --svg, --3dm")
    for name, p in targets.items():  # before the pattern is built: --dxf out.dwg is refused as the API does
        check_target(name, p, OPTION_OF[name])
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    pattern = get_pattern(pattern_id, sides, depth, edge)  # depth None: from the ID's length
    filleted = fillet_pattern(pattern, weight, variation)  # once: the warning's member is the part's
    warn_inert_variation(variation, filleted.variation, pattern.id)
    jobs = [(lambda: filleted_part(filleted, thickness), targets)]
    for path in _write_all(jobs, settings, progress=False):
        click.echo(f"wrote {path}")


def _export_library(sides: int, edge: float, thickness: float, weight: float, names: list[str], out: Path,
                    settings: ExportSettings, variation: Variation) -> None:
    from fabpat.patterns.library import enumerate_library

    check_output_folder(out)
    lib = enumerate_library(sides, 2)
    ids = list(lib.ids)

    def job(pid: str) -> Job:
        return (lambda: make_part(lib.pattern(pid, edge), thickness, weight, variation),
                {n: out / f"{pid}{FORMATS[n].suffix}" for n in names})

    with output_folder(out):  # a folder this command created is removed again on any error
        paths = _write_all([job(pid) for pid in ids], settings, progress=True)
    click.echo(f"wrote {len(paths)} files for {len(ids)} patterns to {out}")


COMMANDS = [export_cmd]
