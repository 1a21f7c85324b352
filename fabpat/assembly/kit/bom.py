"""Bill of materials: parts, counts, material, time estimates (CSV and Markdown), and the joint table.

Estimates, stated with their assumptions so a reader can redo them with their own machine:

* laser cutting time = cut length / ``estimates.cut_speed`` (default 15 mm/s, a usual speed for 2 mm
  acrylic or plywood on a 40–60 W CO2 laser); travel and engraving are not counted;
* printing time = volume / ``estimates.print_rate`` (default 3 mm³/s: a 0.4 mm nozzle at 0.2 mm
  layers extrudes 4–8 mm³/s while printing, and small parts spend about half their time travelling
  and changing layers). Slicers give better numbers; these are for planning.

Masses use ``plates.density`` (default PLA, 1.24 g/cm³) for every part.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass

from fabpat.assembly.choose.provenance import PatternRecord
from fabpat.assembly.place.nesting import Nesting
from fabpat.assembly.place.parts import PartLibrary
from fabpat.assembly.place.placement import Assembly

COLUMNS = ("part", "kind", "process", "count", "file", "unit_area_mm2", "unit_volume_mm3", "unit_mass_g",
           "total_mass_g", "unit_cut_length_mm", "total_time_min", "pattern", "chosen_by", "energy_cantilever_Nmm",
           "energy_cylinder_Nmm", "energy_dome_Nmm", "utilisation_pct")
#: decimals of each number column in bom.md, the same in every row (bom.csv, data, gives every number to
#: CSV_DECIMALS)
DECIMALS = {"unit_area_mm2": 1, "unit_volume_mm3": 1, "unit_mass_g": 2, "total_mass_g": 2, "unit_cut_length_mm": 1,
            "total_time_min": 1, "energy_cantilever_Nmm": 2, "energy_cylinder_Nmm": 2, "energy_dome_Nmm": 2,
            "utilisation_pct": 1}


@dataclass(frozen=True)
class BomRow:
    """One line of the BOM; ``None`` where a value does not apply (e.g. cut length of a printed part).

    Plates carry their ``pattern``, how it was chosen (``chosen_by``) and its catalog energies (N·mm,
    :mod:`fabpat.assembly.choose.provenance`); the sheet line its ``utilisation_pct``: the plates' polygons
    (as nested, grown by kerf/2) over the area of all sheets used, in %."""

    part: str
    kind: str
    process: str
    count: int
    file: str
    unit_area_mm2: float | None
    unit_volume_mm3: float | None
    unit_mass_g: float | None
    total_mass_g: float | None
    unit_cut_length_mm: float | None
    total_time_min: float | None
    pattern: str | None = None
    chosen_by: str | None = None
    energy_cantilever_Nmm: float | None = None
    energy_cylinder_Nmm: float | None = None
    energy_dome_Nmm: float | None = None
    utilisation_pct: float | None = None


def bom_rows(lib: PartLibrary, files: dict[str, str], nesting: Nesting | None,
             sheet_files: Sequence[str] = (), patterns: Sequence[PatternRecord] = ()) -> list[BomRow]:
    """Rows for every distinct part (plates, then sleeves) and, if nested, the sheets.

    ``file`` is what the part's process uses: the part's STL (``files``, by key) for printed parts, the
    DXF sheets it is nested on (``sheet_files``, by sheet number, space-separated) for laser-cut plates.
    ``patterns``: the plates' :class:`~fabpat.assembly.choose.provenance.PatternRecord` (by part key).
    """
    records = {r.part: r for r in patterns}
    asm = lib.assembly
    spec = asm.spec
    counts = asm.counts()
    rho = spec.plates.density / 1000.0  # g/cm³ → g/mm³
    rows = []
    for key in lib.keys:
        n = counts[key]
        pt = lib.plate_type(key)
        if pt is not None:
            outline = lib.filleted[pt].outline
            area, vol = outline.area, outline.area * asm.type_thickness(pt)
            process = spec.plates.process
            cut = outline.perimeter if process == "laser" else None
            unit_s = cut / spec.estimates.cut_speed if cut is not None else vol / spec.estimates.print_rate
            kind = "plate"
        else:
            area, vol = None, asm.sleeve_types[key].volume()
            process, cut, unit_s, kind = "print", None, vol / spec.estimates.print_rate, "sleeve"
        if process == "laser":
            on = sorted({pl.sheet for pl in nesting.placements if asm.plates[pl.item].type.label == key}
                        if nesting is not None and sheet_files else ())
            file = " ".join(sheet_files[s] for s in on)
        else:
            file = files.get(key, "")
        rec = records.get(key)
        e = rec.energies if rec is not None else {}
        rows.append(BomRow(key, kind, process, n, file, area, vol, vol * rho, n * vol * rho, cut,
                           n * unit_s / 60.0, rec.pattern if rec else None, rec.chosen_by if rec else None,
                           e.get("cantilever"), e.get("cylinder"), e.get("dome")))
    if nesting is not None:
        s = spec.sheet
        what = "laser sheet" if spec.plates.process == "laser" else "print bed"
        used = math.fsum(nesting.utilisation(k) for k in range(nesting.n_sheets)) / max(nesting.n_sheets, 1)
        rows.append(BomRow(f"{what} {s.width:g} × {s.height:g} mm", "sheet", spec.plates.process,
                           nesting.n_sheets, "sheets/", s.width * s.height, None, None, None, None, None,
                           utilisation_pct=100.0 * used))
    return rows


def _fmt(v: float | int | str | None, digits: int = 2) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


#: decimals of every number in bom.csv
CSV_DECIMALS = 3


def _cell(r: BomRow, column: str, digits: int | None = None) -> str:
    return _fmt(getattr(r, column), DECIMALS.get(column, 2) if digits is None else digits)


def bom_csv(rows: list[BomRow]) -> str:
    """CSV text with :data:`COLUMNS` (lengths mm, areas mm², volumes mm³, masses g, times min, energies
    N·mm, utilisation %), every number with :data:`CSV_DECIMALS` decimals."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow([_cell(r, c, CSV_DECIMALS) for c in COLUMNS])
    return buf.getvalue()


def bom_markdown(lib: PartLibrary, rows: list[BomRow], nesting: Nesting | None, checks: list[str],
                 moments: dict[str, float] | None = None, candidates: list[dict] | None = None,
                 patterns: Sequence[PatternRecord] = ()) -> str:
    """The BOM as Markdown: parts table, totals, assumptions, sheets, joints (what joins what: the joint's
    skeleton dihedral angle, the angle its sleeve is printed at and, given the predicted closure's
    ``moments`` {joint label: N·mm}, the moment the sleeve holds), the pattern pairs ``rule = "roundest"``
    tried (``candidates``, the records of :func:`fabpat.assembly.solve.predict.choose_roundest`), checks."""
    asm = lib.assembly
    spec = asm.spec
    out = [f"# Bill of materials — {spec.name}", "",
           f"Tiling: {spec.tiling.kind}, plate edge {asm.plate_edge:g} mm, skeleton edge "
           f"{asm.skeleton.edge_length():.3f} mm, thickness {_thicknesses(asm)} mm; plates by "
           f"{spec.plates.process}, sleeves printed.", "",
           "| part | kind | process | count | file | area (mm²) | volume (mm³) | mass each (g) | mass total (g) "
           "| cut length (mm) | time total (min) |",
           "|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    numbers = ("unit_area_mm2", "unit_volume_mm3", "unit_mass_g", "total_mass_g", "unit_cut_length_mm",
               "total_time_min")
    for r in rows:
        out.append(f"| {r.part} | {r.kind} | {r.process} | {r.count} | {r.file} | "
                   + " | ".join(_cell(r, c) for c in numbers) + " |")
    mass = math.fsum(r.total_mass_g or 0.0 for r in rows)
    time = math.fsum(r.total_time_min or 0.0 for r in rows)
    out += ["", f"Total: {sum(r.count for r in rows if r.kind != 'sheet')} parts, {mass:.1f} g, "
            f"about {time / 60:.1f} h of machine time.", "",
            f"Estimates: cutting = cut length / {spec.estimates.cut_speed:g} mm/s; printing = volume / "
            f"{spec.estimates.print_rate:g} mm³/s (effective rate, travel included); masses at "
            f"{spec.plates.density:g} g/cm³. Change them under [estimates] and [plates] in the spec.", ""]
    out += _sleeve_section(lib, rows)
    out += _patterns_section(rows, patterns)
    if nesting is not None:
        out += ["## Sheets", "",
                "Utilisation: the area of the plates' polygons as nested (grown by kerf/2) over the sheet's area; "
                "material: the plates' own (filleted) area over the sheet's area.", "",
                "| sheet | plates | utilisation (%) | material (%) | used height (mm) |", "|---|---|---:|---:|---:|"]
        for s in range(nesting.n_sheets):
            items = nesting.on_sheet(s)
            labels = ", ".join(asm.plates[i].label for i in items)
            material = math.fsum(lib.filleted[asm.plates[i].type].outline.area for i in items)
            top = max((float(nesting.placed(i)[:, 1].max()) for i in items), default=0.0)
            out.append(f"| {s + 1} | {labels} | {100 * nesting.utilisation(s):.1f} | "
                       f"{100 * material / (nesting.width * nesting.height):.1f} | {top:.1f} |")
        out.append("")
    out += ["## Joints", "",
            "A joint's label is engraved on both plates it joins, next to the interface its sleeve grips.", "",
            "| joint | sleeve | dihedral (°) | sleeve angle (°) | plate A (edge) | plate B (edge) |"
            + (" sleeve moment (N·mm) |" if moments else ""),
            "|---|---|---:|---:|---|---|" + ("---:|" if moments else "")]
    for s in asm.sleeves:
        (pa, ia), (pb, ib) = s.plates
        a, b = asm.plates[pa].label, asm.plates[pb].label
        out.append(f"| {s.label} | {s.kind} | {math.degrees(s.dihedral):.2f} | {math.degrees(s.angle):.2f} | "
                   f"{a} ({ia}) | {b} ({ib}) |" + (f" {moments[s.label]:.2f} |" if moments else ""))
    if moments:
        out += ["", "Sleeve moment: the moment (N·mm) each sleeve transmits between its plates in the predicted "
                "shape of the object in use (prediction.json)."]
    if asm.pins:
        pins = ", ".join(f"{asm.plates[f].label} ({i})" for f, i in asm.pins)
        out += ["", f"Pinned interfaces (both ends of the strip): {pins}."]
    if candidates:
        out += ["", "## Pattern pairs tried (rule = roundest)", "",
                "Each pair closed in the shell solver; kept: the roundest (smallest sphericity rms) whose plates "
                "all stay under material.strain_limit.", "",
                "| hexagon | pentagon | radius (mm) | sphericity rms (%) | peak strain | plates over the limit | "
                "kept |", "|---|---|---:|---:|---:|---:|---|"]
        for c in candidates:
            if "error" in c:
                out.append(f"| {c['hexagon']} | {c['pentagon']} | not built: {c['error']} | | | | |")
            else:
                round_ = ((f"{c['radius']:.2f}", f"{100 * c['sphericity_rms']:.3f}") if c["radius"] is not None
                          else ("no sphere", ""))
                out.append(f"| {c['hexagon']} | {c['pentagon']} | {round_[0]} | "
                           f"{round_[1]} | {c['peak_strain']:.4f} | {c['plates_over_limit']} | "
                           f"{'yes' if c['chosen'] else ''} |")
    out += ["", "## Checks", ""] + [f"- {line}" for line in checks] + [""]
    return "\n".join(out)


def energy_source(patterns: Sequence[PatternRecord]) -> str:
    """Where a BOM's pattern energies come from (the catalog and the plate set-up it was solved at) and, for
    every blank energy, why (the records' notes): one phrase for the sentence above the energies' table."""
    def setup(p: PatternRecord) -> str:
        s = p.catalog_setup
        return (f"{p.catalog} catalog at edge {s['edge']:g} mm, thickness {s['thickness']:g} mm, weight "
                f"{s['weight']:g}" if s else f"{p.catalog} catalog")

    where = "; ".join(sorted({setup(p) for p in patterns if p.catalog_setup})) or \
        "; ".join(sorted({f"{p.catalog} catalog" for p in patterns}))
    notes = sorted({f"{p.part}: {p.note}" for p in patterns if p.note})
    return (where or "no catalog") + (f"; {'; '.join(notes)}" if notes else "")


def _thicknesses(asm: Assembly) -> str:
    """The plates' thickness (mm) for the BOM's head line: the one thickness, or the range of their own."""
    ts = sorted({p.thickness for p in asm.plates})
    return f"{ts[0]:g}" if len(ts) == 1 else f"{ts[0]:g}–{ts[-1]:g} (each plate's own)"


def _sleeve_section(lib: PartLibrary, rows: list[BomRow]) -> list[str]:
    """The Markdown table of the sleeve parts: each part's printed angle (°), slot width (mm) and count; the
    joints printed at each are in the joint table."""
    sleeves = [r for r in rows if r.kind == "sleeve"]
    if not sleeves:
        return []
    out = ["## Sleeve parts", "", "Each sleeve part is printed at one angle between its slots (180°: straight) and "
           "takes plates up to its slot width minus sleeve.clearance thick.", "",
           "| part | printed angle (°) | slot width (mm) | count |", "|---|---:|---:|---:|"]
    for r in sleeves:
        sl = lib.assembly.sleeve_types[r.part]
        out.append(f"| {r.part} | {math.degrees(sl.dihedral):.2f} | {sl.slot_width:g} | {r.count} |")
    return [*out, ""]


def _patterns_section(rows: list[BomRow], patterns: Sequence[PatternRecord]) -> list[str]:
    """The Markdown table of the plates' patterns: how each was chosen and its catalog energies (N·mm)."""
    plates = [r for r in rows if r.kind == "plate"]
    if not plates:
        return []
    out = ["## Patterns", "",
           "How each plate's pattern was chosen, and its strain energy in the paper's three scenarios (N·mm, lower = "
           f"stiffer; {energy_source(patterns)}).", "",
           "| part | pattern | chosen by | Cantilever (N·mm) | Cylinder (N·mm) | Dome (N·mm) |",
           "|---|---|---|---:|---:|---:|"]
    for r in plates:
        cells = [_cell(r, c) or "–" for c in ("energy_cantilever_Nmm", "energy_cylinder_Nmm", "energy_dome_Nmm")]
        out.append(f"| {r.part} | {r.pattern or ''} | {r.chosen_by or ''} | " + " | ".join(cells) + " |")
    return [*out, ""]
