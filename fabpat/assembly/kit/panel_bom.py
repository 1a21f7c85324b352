"""A panel's bill of materials: one part, its sheet, and the pattern of every tile (``bom.csv``, ``bom.md``).

The estimates are a kit's (:mod:`fabpat.assembly.kit.bom`): cutting time = the fused outline's length /
``estimates.cut_speed``, printing time = volume / ``estimates.print_rate``, masses at ``plates.density``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from fabpat.assembly.kit.bom import BomRow, bom_csv, energy_source
from fabpat.assembly.place.panel import Panel
from fabpat.assembly.spec.sheet import sheet_of

if TYPE_CHECKING:
    from fabpat.assembly.kit.result import KitReport
    from fabpat.assembly.place.nesting import Nesting


def bom_rows(panel: Panel, nesting: Nesting | None, files: list[str]) -> list[BomRow]:
    """The panel's row (the part, with the file its process uses) and the sheet's (its utilisation: the part's
    hull grown by kerf/2 over the sheet's area, %)."""
    from fabpat.assembly.choose.provenance import chosen_by

    spec = panel.spec
    outline = panel.outline
    area, vol = outline.area, outline.area * spec.plates.thickness
    mass = vol * spec.plates.density / 1000.0
    laser = spec.plates.process == "laser"
    cut = outline.perimeter if laser else None
    seconds = cut / spec.estimates.cut_speed if cut is not None else vol / spec.estimates.print_rate
    want = "sheets/sheet-01.dxf" if laser else "panel.stl"
    ids = ", ".join(dict.fromkeys(pt.label.split(" ", 1)[1] for pt in panel.types))
    rows = [BomRow(panel.name, "panel", spec.plates.process, 1, want if want in files else "", area, vol, mass, mass,
                   cut, seconds / 60.0, ids, chosen_by(spec))]
    if nesting is not None:
        s = sheet_of(spec)
        what = "laser sheet" if laser else "print bed"
        # the sheet's file only when the kit wrote it (``dxf`` in output.formats); the plan is the same without
        rows.append(BomRow(f"{what} {s.width:g} × {s.height:g} mm", "sheet", spec.plates.process, nesting.n_sheets,
                           "sheets/" if "sheets/sheet-01.dxf" in files else "", s.width * s.height,
                           None, None, None, None, None, utilisation_pct=100.0 * nesting.utilisation(0)))
    return rows


def bom_markdown(panel: Panel, rows: list[BomRow], checks: list[str]) -> str:
    """The BOM as Markdown: the part and sheet, the estimates' assumptions, every tile's pattern (with the
    catalog energies of :mod:`fabpat.assembly.choose.provenance`, N·mm), the checks."""
    from fabpat.assembly.choose.provenance import pattern_records
    from fabpat.assembly.spec.types import POLYGON_KEYS

    spec = panel.spec
    t = spec.tiling
    records = {r.part: r for r in pattern_records(spec, list(dict.fromkeys(panel.types)))}
    counts = {n: sum(len(f) == n for f in panel.tiling.faces) for n in sorted({len(f) for f in panel.tiling.faces})}
    tiles = (f"{t.rows} × {t.columns} hexagons" if t.file is None else
             " and ".join(f"{k} {POLYGON_KEYS[n]}s" for n, k in counts.items()) + f" of {Path(t.file).name}")
    out = [f"# Bill of materials — {spec.name}", "",
           f"One part: {tiles} of edge {t.edge:g} mm fused at their interfaces, "
           f"thickness {spec.plates.thickness:g} mm, by {spec.plates.process}.", "",
           "| part | kind | process | count | file | area (mm²) | volume (mm³) | mass (g) | cut length (mm) "
           "| time (min) | utilisation (%) |", "|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|"]

    def num(v: float | None, d: int = 1) -> str:
        return "" if v is None else f"{v:.{d}f}"

    for r in rows:
        out.append(f"| {r.part} | {r.kind} | {r.process} | {r.count} | {r.file} | {num(r.unit_area_mm2)} | "
                   f"{num(r.unit_volume_mm3)} | {num(r.total_mass_g, 2)} | {num(r.unit_cut_length_mm)} | "
                   f"{num(r.total_time_min)} | {num(r.utilisation_pct)} |")
    out += ["", f"Estimates: cutting = cut length / {spec.estimates.cut_speed:g} mm/s; printing = volume / "
            f"{spec.estimates.print_rate:g} mm³/s; masses at {spec.plates.density:g} g/cm³.", "",
            "## Tiles", "", "Each tile's label is engraved on the sheet at its polygon edge 0; its pattern's strain "
            f"energy in the paper's three scenarios (N·mm, lower = stiffer; {energy_source(list(records.values()))}).",
            "",
            f"| tile | {'row | column' if t.file is None else 'face'} | pattern | chosen by | Cantilever (N·mm) | "
            "Cylinder (N·mm) | Dome (N·mm) |",
            f"|---|{'---:|---:' if t.file is None else '---:'}|---|---|---:|---:|---:|"]
    # a strip's tile sits at its row and column; a mesh's at its face (from 1, in the file's order)
    where = ([f"{int(r)} | {int(c)}" for r, c in panel.tiling.grid] if panel.tiling.grid is not None
             else [str(f + 1) for f in range(len(panel.types))])
    for label, pt, at in zip(panel.labels, panel.types, where, strict=True):
        rec = records[pt.label]
        e = [num(rec.energies.get(s), 2) or "–" for s in ("cantilever", "cylinder", "dome")]
        out.append(f"| {label} | {at} | {pt.label} | {rec.chosen_by} | " + " | ".join(e) + " |")
    out += ["", "## Checks", "", *(f"- {line}" for line in checks), ""]
    return "\n".join(out)


def bom_files(panel: Panel, nesting: Nesting | None, report: KitReport, folder: Path, files: list[str]) -> list[str]:
    """Write ``bom.csv`` and ``bom.md`` into ``folder`` (``files``: the kit's files so far); returns their names."""
    rows = bom_rows(panel, nesting, files)
    (folder / "bom.csv").write_text(bom_csv(rows), encoding="utf-8")
    (folder / "bom.md").write_text(bom_markdown(panel, rows, report.lines()), encoding="utf-8")
    return ["bom.csv", "bom.md"]
