"""The kit of a one-piece panel (``tiling.kind = "panel"``): the fused part in every format, nested on the sheet.

:func:`assemble_panel` is what :func:`fabpat.assembly.kit.build.assemble` does for a panel: the patterns are chosen
as a strip's (rows × columns) or, for a panel from a mesh file, as a mesh tiling's (by polygon or face
label), the plates filleted and fused (:mod:`fabpat.assembly.place.panel`), the one part checked (a valid
B-rep whose volume is the plates' volumes summed from their own solids, one outer loop), nested on the
spec's sheet, and then written, by the same writers as ``fabpat export`` (:mod:`fabpat.exchange.registry`),
into a temporary folder that becomes ``--out`` only at the end (:mod:`fabpat.assembly.kit.folder`):

* ``panel.step`` (exact solid, AP214), ``panel.stl``, ``panel.3mf`` (meshes at ``output.mesh_tolerance``),
  ``panel.3dm`` (exact NURBS outline and extrusion), ``panel.dxf`` and ``panel.svg`` (the part at true size,
  as ``fabpat export`` writes a plate, without kerf: the part as designed), ``panel.glb`` (a mesh to look
  at), ``panel.png`` (the tiles coloured by pattern), ``sheets/sheet-01.dxf`` (the part nested on the
  sheet: CUT loops moved out by kerf/2, the tiles' labels on ENGRAVE, the bed on the non-plotting layer
  SHEET), ``bom.csv``/``bom.md`` and ``manifest.json``, each as ``output.formats`` asks (``dxf`` gives both DXF files).

A panel has no sleeves, no net and no prediction: ``fabpat simulate-assembly`` pushes it together as a
strip (:func:`fabpat.assembly.solve.panel.panel_setup`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fabpat.assembly.place.panel import Panel, build_panel
from fabpat.assembly.spec.sheet import DEFAULT_RESOLUTION, grown_hull, quarter_turn, sheet_of
from fabpat.errors import ExportError

if TYPE_CHECKING:
    from ezdxf.document import Drawing

    from fabpat.assembly.kit.result import AssembleResult
    from fabpat.assembly.place.nesting import Nesting
    from fabpat.assembly.spec.types import AssemblySpec

#: relative difference allowed between the fused solid's volume and the plates' volumes summed: both are
#: exact (adaptive Gauss–Kronrod at 1e-10, :func:`fabpat.exchange.cad.volume`); measured 4e-16 on a 3 × 4 panel
VOLUME_RTOL = 1e-6
#: the kit files of each ``output.formats`` entry
PANEL_FILES = {"step": ("panel.step",), "stl": ("panel.stl",), "3mf": ("panel.3mf",), "3dm": ("panel.3dm",),
               "dxf": ("panel.dxf",), "svg": ("panel.svg",)}


@dataclass(frozen=True)
class PanelReport:
    """What the panel kit's checks measured: ``tiles``, ``fused`` interfaces, ``holes`` of the outline, the solid's
    ``volume`` and the plates' summed ``plate_volume`` (mm³), ``sheets`` used and their smallest margin gap."""

    tiles: int
    fused: int
    holes: int
    volume: float
    plate_volume: float
    sheets: int
    #: interfaces between two different polygons and their largest (position mm, tangent rad) relink gap
    mixed: int = 0
    mixed_gap: tuple[float, float] = (0.0, 0.0)
    #: a printed panel's size on its print bed (:func:`fabpat.assembly.spec.sheet.print_bed_report`)
    bed: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        """The report as ``fabpat assemble`` prints it and the manifest stores it."""
        rel = abs(self.volume - self.plate_volume) / self.plate_volume
        mixed = ([f"{self.mixed} interfaces join two different polygons: their bow-tie halves meet G1 (position gap "
                  f"{self.mixed_gap[0]:.1e} mm, tangent gap {self.mixed_gap[1]:.1e} rad), kept as two arcs"]
                 if self.mixed else [])
        return [f"{self.tiles} tiles fused at {self.fused} interfaces into one part: 1 outer loop, {self.holes} holes",
                *mixed,
                f"one solid, BRepCheck valid: volume {self.volume:.3f} mm³ = the plates' {self.plate_volume:.3f} mm³ "
                f"(relative difference {rel:.1e})",
                *([f"{self.sheets} sheet(s): the panel's hull within the sheet's margins"] if self.sheets else []),
                *self.bed]


def sheet_document(panel: Panel, nesting: Nesting, quarter: bool) -> Drawing:
    """The ezdxf drawing of the panel's sheet (mm): the fused outline's loops on CUT (bulge arcs within
    ``output.curve_tolerance``, moved out by kerf/2), each tile's label on ENGRAVE in the solid sub-triangle at
    its polygon edge 0 (:func:`fabpat.assembly.kit.sheets.edge_label_spots`), the bed on SHEET (unless
    ``sheet.border = false``)."""
    import ezdxf

    from fabpat.assembly.kit.sheets import SHEET_COLOR, SHEET_LAYER, edge_label_spots
    from fabpat.exchange.contours import bulge_loops, cut_order, offset_bulge_loops
    from fabpat.exchange.dxf import CUT_COLOR, CUT_LAYER, ENGRAVE_COLOR, ENGRAVE_LAYER, add_bulge_segments, set_extents
    from fabpat.exchange.labels import label_at

    spec = panel.spec
    s = sheet_of(spec)
    doc = ezdxf.new("R2010", units=ezdxf.units.MM)
    doc.layers.add(CUT_LAYER, color=CUT_COLOR)
    doc.layers.add(ENGRAVE_LAYER, color=ENGRAVE_COLOR)
    msp = doc.modelspace()
    if s.border:
        layer = doc.layers.add(SHEET_LAYER, color=SHEET_COLOR)
        layer.dxf.plot = 0
        msp.add_lwpolyline([(0, 0), (s.width, 0), (s.width, s.height), (0, s.height)], close=True,
                           dxfattribs={"layer": SHEET_LAYER})
    place = nesting.placements[0]

    def where(P: NDArray[np.float64]) -> NDArray[np.float64]:
        return place.apply(quarter_turn(np.atleast_2d(P), quarter))

    loops = bulge_loops(panel.outline, spec.curve_tolerance)
    for lp in cut_order(offset_bulge_loops(loops, 0.5 * s.kerf) if s.kerf > 0 else loops):
        V = where(lp.V)
        if s.dxf_entities == "segments":
            add_bulge_segments(msp, V, lp.bulges, {"layer": CUT_LAYER})
        else:
            msp.add_lwpolyline([(float(x), float(y), float(b)) for (x, y), b in zip(V, lp.bulges, strict=True)],
                               format="xyb", close=True, dxfattribs={"layer": CUT_LAYER})
    turn = 90.0 * quarter + math.degrees(place.angle)
    chars = max(len(lab) for lab in panel.labels)
    for label, pt, pl in zip(panel.labels, panel.types, panel.plates, strict=True):
        spots = edge_label_spots(pt, spec.tiling.edge, chars)
        if not spots:
            continue
        centre, _, ang, h = spots[0]
        q = where(pl.R @ centre + pl.t)[0]
        placed = label_at(label, q, turn + math.degrees(math.atan2(pl.R[1, 0], pl.R[0, 0]) + ang), h)
        msp.add_text(label, height=h, rotation=placed.angle,
                     dxfattribs={"layer": ENGRAVE_LAYER, "insert": placed.start})
    set_extents(doc)
    return doc


def plate_volume(panel: Panel) -> float:
    """The plates' volumes summed (mm³), each distinct plate's own exact solid built apart (not the fused one)."""
    from fabpat.exchange.cad import make_solid, volume

    one = {pt: volume(make_solid(fp.outline, panel.spec.plates.thickness, fp.support_arcs))
           for pt, fp in panel.filleted.items()}
    return math.fsum(one[pt] for pt in panel.types)


def check_panel_part(panel: Panel) -> tuple[float, float]:
    """(solid volume, plates' summed volume) in mm³; ExportError unless they agree within :data:`VOLUME_RTOL`.
    The solid is BRepCheck valid or not built (:func:`fabpat.exchange.cad.make_solid` checks it: GeometryError)."""
    from fabpat.exchange.cad import volume

    v, plates = volume(panel.solid), plate_volume(panel)
    if abs(v - plates) > VOLUME_RTOL * plates:
        raise ExportError(f"{panel.spec.source}: the fused panel's volume {v:.6f} mm³ differs from its plates' "
                          f"{plates:.6f} mm³: the plates overlap or leave gaps (a fusion error)")
    return v, plates


def assemble_panel(spec: AssemblySpec, out: Path, tell: Callable[[str], None], timestamp: str | None,
                   energies: Callable[[int], dict[str, float]] | None = None, force: bool = False) -> AssembleResult:
    """:func:`fabpat.assembly.kit.build.assemble` for ``tiling.kind = "panel"`` (arguments checked there): see the
    module
    docstring. Raises SpecError, ExportError (plates too narrow for the process without ``force``; a fused part
    that fails its checks), GeometryError; on any error ``out`` is untouched."""
    from fabpat.assembly.choose.choice import face_patterns, with_members
    from fabpat.assembly.choose.provenance import pattern_records
    from fabpat.assembly.kit.folder import GENERATOR, MANIFEST, check_out, write_kit
    from fabpat.assembly.kit.result import AssembleResult, fabrication_problems
    from fabpat.assembly.place.nesting import check_nesting

    check_out(out)
    spec = with_members(spec, energies)
    tell("patterns")
    ids = face_patterns(spec, energies)
    tell("fusing")
    panel = build_panel(spec, ids)
    problems = fabrication_problems(spec, panel.filleted)
    if problems and not force:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ExportError(f"{spec.source}: {problems[0]}{more}: choose a larger tiling.edge or other patterns, "
                          "or give --force to build the panel anyway")
    tell("nesting")
    nesting, quarter = nest_panel(spec)
    check_nesting(nesting)
    tell("checks")
    v, plates = check_panel_part(panel)
    lo, hi = panel.outline.bbox
    bed, too_large = print_bed_report(spec, (float(hi[0] - lo[0]), float(hi[1] - lo[1])))
    problems = [*problems, *too_large]
    report = PanelReport(len(panel.types), panel.fused.fused, len(panel.outline.holes), v, plates, nesting.n_sheets,
                         panel.fused.mixed, panel.fused.mixed_gap, tuple(bed))
    def write(tmp: Path) -> tuple[list[str], dict[str, object]]:
        files = write_panel_files(panel, nesting, quarter, report, tmp, tell, timestamp)
        return files, {"generator": GENERATOR, "spec": spec.name, "source": spec.source, "files": files,
                       "counts": {panel.name: 1}, "tiles": dict(zip(panel.labels, [t.label for t in panel.types],
                                                                    strict=True)),
                       # how each tile's pattern was chosen and its catalog energies, as a kit's manifest has them
                       "patterns": [r.as_dict() for r in pattern_records(spec, list(dict.fromkeys(panel.types)))],
                       "sheets": nesting.n_sheets, "checks": report.lines(), "warnings": problems,
                       "prediction": "not made for a panel: `fabpat simulate-assembly` pushes it together as a strip",
                       "sha256": None}

    files = write_kit(out, write)
    return AssembleResult(out, (*files, MANIFEST), report, nesting.n_sheets, tuple(problems))


#: progress steps of a panel kit before its files (:func:`fabpat.assembly.kit.build.steps`)
PANEL_STEPS = ("patterns", "fusing", "nesting", "checks")


def panel_steps(spec: AssemblySpec) -> list[str]:
    """The progress steps of :func:`assemble_panel` for ``spec``'s formats, in order."""
    f = spec.formats
    return [*PANEL_STEPS, *(name.upper() for name in PANEL_FILES if name in f and name != "dxf"),
            *(["sheets"] if "dxf" in f else []), *(["GLB"] if "glb" in f else []), *(["PNG"] if "png" in f else []),
            *(["BOM"] if "bom" in f else [])]


def write_panel_files(panel: Panel, nesting: Nesting, quarter: bool, report: PanelReport, tmp: Path,
                      tell: Callable[[str], None], timestamp: str | None) -> list[str]:
    """Write the panel kit's files into ``tmp`` (see the module docstring); returns them relative to it. With
    ``timestamp`` (ISO 8601, checked) every file is byte-reproducible: the same panel gives the same bytes."""
    from fabpat.exchange.registry import ExportSettings, export_parts

    spec = panel.spec
    f = spec.formats
    part = panel.part
    # the part files hold the part as designed (no kerf): the sheet's loops are the cut path, out by kerf/2
    settings = ExportSettings(mesh_tolerance=spec.mesh_tolerance, curve_tolerance=spec.curve_tolerance,
                              timestamp=timestamp, dxf_entities=sheet_of(spec).dxf_entities)
    files: list[str] = []
    for name, (file,) in PANEL_FILES.items():
        if name in f and name != "dxf":
            tell(name.upper())
            export_parts([(part, {name: tmp / file})], settings)
            files.append(file)
    if "dxf" in f:
        tell("sheets")
        export_parts([(part, {"dxf": tmp / "panel.dxf"})], settings)
        (tmp / "sheets").mkdir()
        from fabpat.exchange.dxf import save_document

        save_document(sheet_document(panel, nesting, quarter), tmp / "sheets" / "sheet-01.dxf", timestamp,
                      f"{spec.name}/sheets/sheet-01.dxf")
        files += ["panel.dxf", "sheets/sheet-01.dxf"]
    if "glb" in f:
        tell("GLB")
        write_glb(panel, tmp / "panel.glb")
        files.append("panel.glb")
    if "png" in f:
        tell("PNG")
        render_png(panel, tmp / "panel.png")
        files.append("panel.png")
    if "bom" in f:
        tell("BOM")
        from fabpat.assembly.kit.panel_bom import bom_files

        files += bom_files(panel, nesting, report, tmp, files)
    return files


def write_glb(panel: Panel, path: Path) -> None:
    """The part as binary glTF 2.0 in metres, y-up (:func:`fabpat.assembly.show.export.glb_bytes`), as every kit GLB:
    a root node named after the spec, one node ``panel`` with the part's mesh (at the kit's check tolerance)
    and a PBR material in the first pattern colour of ``panel.png``."""
    import trimesh
    from trimesh.visual.material import PBRMaterial

    from fabpat.assembly.place.parts import CHECK_TOLERANCE
    from fabpat.assembly.show.export import (
        GLB_METALLIC,
        GLB_ROUGHNESS,
        GLB_UNIT,
        PALETTE,
        glb_bytes,
        slug,
        srgb_to_linear,
    )
    from fabpat.exchange.threemf import triangulate

    V, F = triangulate(panel.solid, CHECK_TOLERANCE)
    mesh = trimesh.Trimesh(V * GLB_UNIT, F, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
        name=slug(panel.name), baseColorFactor=[*srgb_to_linear(PALETTE[0]), 1.0],
        metallicFactor=GLB_METALLIC, roughnessFactor=GLB_ROUGHNESS))
    sc = trimesh.Scene()
    root = panel.spec.name or "panel"
    sc.graph.update(frame_from=sc.graph.base_frame, frame_to=root, matrix=np.eye(4))
    sc.add_geometry(mesh, node_name="panel" if root != "panel" else "panel part", geom_name=slug(panel.name),
                    parent_node_name=root)
    path.write_bytes(glb_bytes(sc))


def render_png(panel: Panel, path: Path) -> None:
    """The panel from above: each tile's plate filled in its pattern's colour
    (:data:`fabpat.assembly.show.export.PALETTE`),
    labelled, the fused rim drawn, mm axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fabpat.assembly.show.export import PALETTE
    from fabpat.assembly.show.render import plain_text
    from fabpat.geometry.outline import Loop, Outline

    colour = {pt: PALETTE[i % len(PALETTE)] for i, pt in enumerate(dict.fromkeys(panel.types))}
    fig, ax = plt.subplots(figsize=(8, 7), dpi=120)
    for pl, pt, label in zip(panel.plates, panel.types, panel.labels, strict=True):
        o = Outline(Loop(tuple(pl.loops[0])), tuple(Loop(tuple(h)) for h in pl.loops[1:]))
        o.plot(ax, color=colour[pt])
        ax.text(*pl.t, label, ha="center", va="center", fontsize=7)
    for P in panel.outline.flatten(0.05)[:1]:
        ax.plot(*np.vstack([P, P[:1]]).T, color="black", lw=0.6)
    lo, hi = panel.outline.bbox
    ax.set_xlim(lo[0] - 2, hi[0] + 2)
    ax.set_ylim(lo[1] - 2, hi[1] + 2)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in colour.values()]
    ax.legend(handles, [pt.label for pt in colour], fontsize=8, loc="upper right")
    ax.set_title(plain_text(f"{panel.spec.name}: one part, {len(panel.types)} tiles"))
    fig.tight_layout()
    fig.savefig(path, format="png")
    plt.close(fig)


#: (width, height) mm: a print bed most desktop printers hold (theirs run from 180 to 256 mm a side), and
#: PrusaSlicer's own default bed: its command line without a printer profile stops on a larger part
#: ("Objects could not fit on the bed", PrusaSlicer 2.5.0), so a printed panel larger than this is told
COMMON_PRINT_BED = (200.0, 200.0)


def print_bed_report(spec: AssemblySpec, size: tuple[float, float]) -> tuple[list[str], list[str]]:
    """For a printed panel (``plates.process = "print"``; else nothing) of footprint ``size`` (width, height) mm:
    the kit's check line (the part on the ``[sheet]`` bed, which the spec's check already holds it to) and a
    warning when the part fits :data:`COMMON_PRINT_BED` neither way round."""
    if spec.plates.process != "print":
        return [], []
    s = sheet_of(spec)
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


def nest_panel(spec: AssemblySpec) -> tuple[Nesting, bool]:
    """The panel's hull nested on the spec's sheet (:func:`fabpat.assembly.place.nesting.nest`, one item, no turn) and
    whether it was turned by 90° first (when only that way fits)."""
    from fabpat.assembly.place.nesting import nest

    s = sheet_of(spec)
    room = np.array([s.width, s.height]) - 2 * s.margin - DEFAULT_RESOLUTION
    P = grown_hull(spec)
    quarter = not (np.ptp(P, axis=0) <= room + 1e-9).all()
    return nest([quarter_turn(P, quarter)], s.width, s.height, s.margin, s.spacing, turns=1), quarter
