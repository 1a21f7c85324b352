"""One-piece panels (``tiling.kind = "panel"``): 3 × 4 hexagons of two patterns fused into ONE part.

Every number is checked against something the fusion did not produce: the plates' own areas and solids
(built apart), the tiling's vertex count, OCCT's BRepCheck, and the files as third-party readers see them
(trimesh, admesh, ezdxf, OpenSCAD, LibreCAD, rhino3dm; each skipped when missing).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.helpers import solid_count

ROOT = Path(__file__).resolve().parents[1]
A, B = "0x0488", "0x0588"
CHECKER = [[A, B, A, B], [B, A, B, A], [A, B, A, B]]  # rows × columns
SPEC = {"name": "panel test", "tiling": {"kind": "panel", "edge": 36.0, "rows": 3, "columns": 4},
        "patterns": {"tiles": CHECKER}, "plates": {"thickness": 2.0},
        "sheet": {"width": 300.0, "height": 260.0, "border": False, "dxf_entities": "segments"},
        "output": {"mesh_tolerance": 0.05}}



def chosen_panel(spec):  # noqa: ANN001, ANN201 - a test's shorthand
    """The panel of ``spec`` with the patterns its ``[patterns]`` choose."""
    from fabpat.assembly.choose.choice import face_patterns
    from fabpat.assembly.place.panel import build_panel

    return build_panel(spec, face_patterns(spec))

def parse(data: dict = SPEC):  # noqa: ANN201 - AssemblySpec
    from fabpat.assembly.spec.load import parse_spec

    return parse_spec(data, "panel.toml")


@pytest.fixture(scope="module")
def panel():  # noqa: ANN201 - Panel

    return chosen_panel(parse())


@pytest.fixture(scope="module")
def kit(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from fabpat.assembly.kit.build import assemble

    out = tmp_path_factory.mktemp("panel") / "kit"
    assemble(parse(), out, timestamp="2025-01-01T00:00:00Z")
    return out


def single_plate(pid: str):  # noqa: ANN201 - FilletedPattern
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    return fillet_pattern(get_pattern(pid, 6, 2, 36.0), 0.2)


def tile_ids() -> list[str]:
    """Face order of a strip (column by column, row minor), from the rows × columns table."""
    return [CHECKER[r][c] for c in range(4) for r in range(3)]


def test_the_fused_outline_is_the_plates_with_one_hole_per_inner_vertex(panel) -> None:  # noqa: ANN001
    from fabpat.assembly.surface.tiling import honeycomb_strip

    ids = tile_ids()
    assert [pt.pattern_id for pt in panel.types] == ids
    plates = {pid: single_plate(pid).outline for pid in (A, B)}
    assert panel.outline.area == pytest.approx(sum(plates[p].area for p in ids), rel=1e-12)
    # a gap between plates is closed where three plates meet: at every vertex of three faces
    faces = honeycomb_strip(3, 4, 36.0).faces
    degree = np.bincount(np.concatenate(faces))
    inner = int((degree == 3).sum())
    assert len(panel.outline.holes) == sum(len(plates[p].holes) for p in ids) + inner
    assert panel.outline.outer.signed_area > 0 and all(h.signed_area < 0 for h in panel.outline.holes)
    assert panel.fused.fused == 23 and panel.fused.joined_arcs == 46  # 3 × 4 hexagons share 23 edges


def test_the_plates_meet_tangentially_where_the_boundary_is_relinked(panel) -> None:  # noqa: ANN001
    from fabpat.assembly.place.panel import joints, relink_angles

    angles = relink_angles(panel.plates, joints(panel.tiling))
    assert len(angles) == 46 and angles.max() < 1e-9  # G1: no cusp for OCCT or Triangle
    # and the fused loops are closed and free of any joint sharper than the free interfaces' right angles
    report = panel.outline.validate(0.01, raise_on_error=False, width=False)
    assert report.closed and report.simple and report.orientation_ok and report.holes_inside


def test_one_valid_solid_whose_volume_is_the_plates_volumes(panel) -> None:  # noqa: ANN001
    from fabpat.exchange.cad import check_valid, make_solid, volume

    check_valid(panel.solid, "panel")  # BRepCheck_Analyzer
    assert solid_count(panel.solid) == 1
    one = {pid: volume(make_solid(single_plate(pid).outline, 2.0, single_plate(pid).support_arcs)) for pid in (A, B)}
    expected = sum(one[p] for p in tile_ids())
    assert volume(panel.solid) == pytest.approx(expected, rel=1e-6)


def test_the_kit_holds_one_part_in_every_format(kit: Path) -> None:
    manifest = json.loads((kit / "manifest.json").read_text())
    assert {"panel.step", "panel.stl", "panel.3mf", "panel.3dm", "panel.dxf", "panel.svg", "sheets/sheet-01.dxf",
            "panel.glb", "panel.png", "bom.csv", "bom.md"} <= set(manifest["files"])
    assert list(manifest["counts"].values()) == [1] and manifest["sheets"] == 1
    assert manifest["tiles"]["T01"] == f"hex {A}" and manifest["tiles"]["T02"] == f"hex {B}"  # per tile, face order
    assert any("BRepCheck valid" in line for line in manifest["checks"])
    # printed (the default process), 217.9 × 218.2 mm: the kit says so against [sheet] and a common bed
    (line,) = [c for c in manifest["checks"] if c.startswith("printed part")]
    w, h = (float(v) for v in re.match(r"printed part ([\d.]+) × ([\d.]+) mm: on the print bed of \[sheet\], "
                                        r"300 × 260 mm", line).groups())
    assert 200 < w < 300 and 200 < h < 260
    assert any("larger than a common 200 × 200 mm print bed" in m for m in manifest["warnings"])
    import csv

    bom = list(csv.DictReader((kit / "bom.csv").read_text().splitlines()))
    assert [r["kind"] for r in bom] == ["panel", "sheet"] and bom[0]["count"] == "1"


def test_step_reads_back_as_one_solid_of_the_plates_volume(kit: Path, panel) -> None:  # noqa: ANN001
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPControl import STEPControl_Reader

    from fabpat.exchange.cad import check_valid, volume

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(kit / "panel.step")) == IFSelect_ReturnStatus.IFSelect_RetDone
    reader.TransferRoots()
    shape = reader.OneShape()
    check_valid(shape, "re-read panel")
    assert volume(shape) == pytest.approx(panel.outline.area * 2.0, rel=1e-6)
    assert "RATIONAL_B_SPLINE_CURVE" in (kit / "panel.step").read_text(errors="replace")  # arcs kept exact


def test_stl_and_3mf_are_one_watertight_body(kit: Path, panel) -> None:  # noqa: ANN001
    import trimesh

    exact = panel.outline.area * 2.0
    for name in ("panel.stl", "panel.3mf"):
        m = trimesh.load(kit / name, force="mesh")
        assert m.is_watertight and m.is_winding_consistent, name
        assert len(m.split(only_watertight=False)) == 1, name
        # chords within 0.05 mm of the curves: the volume within perimeter × tolerance × thickness
        assert abs(m.volume - exact) <= panel.outline.perimeter * 0.05 * 2.0, name


@pytest.mark.skipif(shutil.which("admesh") is None, reason="admesh not installed (Debian package admesh)")
def test_admesh_finds_one_closed_part(kit: Path) -> None:
    text = subprocess.run(["admesh", str(kit / "panel.stl")], capture_output=True, text=True, timeout=120).stdout
    assert re.search(r"Number of parts\s*:\s*1\b", text), text
    for what in ("Edges fixed", "Facets removed", "Facets added", "Facets reversed", "Backwards edges"):
        assert re.search(rf"{what}\s*:\s*0\b", text), (what, text)


def dxf_loops(path: Path, layer: str = "CUT") -> list[np.ndarray]:
    """Closed loops of a DXF's layer as ezdxf reads them (LWPOLYLINEs, or LINE/ARC pieces chained)."""
    import ezdxf
    from ezdxf import path as dxfpath

    doc = ezdxf.readfile(path)
    pieces = [dxfpath.make_path(e) for e in doc.modelspace() if e.dxf.layer == layer and e.dxftype() in
              ("LWPOLYLINE", "LINE", "ARC")]
    from scipy.spatial import cKDTree

    polys = [np.array([(v.x, v.y) for v in p.flattening(0.01)]) for p in pieces]
    tol = 1e-6  # mm: a writer's piece ends agree to ~1e-12 mm
    closed = [P for P in polys if np.allclose(P[0], P[-1], atol=tol)]
    rest = [P for P in polys if not np.allclose(P[0], P[-1], atol=tol)]
    if rest:
        ends = np.array([P[k] for P in rest for k in (0, -1)])
        tree = cKDTree(ends)
        used = np.zeros(len(rest), dtype=bool)
        for i in range(len(rest)):  # chain the open pieces end to start, either way round
            if used[i]:
                continue
            used[i], loop = True, [rest[i]]
            while not np.allclose(loop[-1][-1], loop[0][0], atol=tol):
                j = next(k // 2 for k in tree.query_ball_point(loop[-1][-1], tol) if not used[k // 2])
                used[j] = True
                loop.append(rest[j] if np.allclose(rest[j][0], loop[-1][-1], atol=tol) else rest[j][::-1])
            closed.append(np.vstack(loop))
    return closed


def outer_loops(loops: list[np.ndarray]) -> int:
    """How many loops lie inside no other loop."""
    from matplotlib.path import Path as MplPath

    return sum(not any(MplPath(Q).contains_point(P[0]) for j, Q in enumerate(loops) if j != i)
               for i, P in enumerate(loops))


def test_the_dxf_files_have_one_outer_loop(kit: Path, panel) -> None:  # noqa: ANN001
    for name in ("panel.dxf", "sheets/sheet-01.dxf"):
        loops = dxf_loops(kit / name)
        assert len(loops) == 1 + len(panel.outline.holes), name
        assert outer_loops(loops) == 1, name
        areas = sorted((abs(0.5 * float(np.sum(P[:-1, 0] * P[1:, 1] - P[1:, 0] * P[:-1, 1]))) for P in loops),
                       reverse=True)
        assert areas[0] - sum(areas[1:]) == pytest.approx(panel.outline.area, abs=panel.outline.perimeter * 0.02)


def test_openscad_extrudes_the_sheet_to_the_panel_volume(kit: Path, panel, tmp_path: Path) -> None:  # noqa: ANN001
    from tests.test_fabrication_readers import needs, stl_volume

    exe = needs("openscad", "openscad")
    scad, stl = tmp_path / "import.scad", tmp_path / "import.stl"
    # arcs cut into 2° chords (within 1.6e-4 × radius): coarser than the plate test's, as fast on 4000 arcs
    scad.write_text(f'linear_extrude(height=2) import(file="{kit / "sheets" / "sheet-01.dxf"}", layer="CUT", '
                    '$fn=0, $fa=2, $fs=0.05);\n')
    r = subprocess.run([exe, "-o", str(stl), str(scad)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-500:]
    volume = stl_volume(stl)
    assert abs(volume - 2.0 * panel.outline.area) <= 2.0 * panel.outline.perimeter * 0.02


def test_librecad_prints_the_panel_dxf(kit: Path, tmp_path: Path) -> None:
    import os

    from tests.test_fabrication_readers import needs

    exe = needs("librecad", "librecad")
    dxf, pdf = tmp_path / "p.dxf", tmp_path / "p.pdf"  # dxf2pdf writes the PDF beside the DXF
    shutil.copy(kit / "panel.dxf", dxf)
    r = subprocess.run([exe, "dxf2pdf", "-a", "-o", str(pdf), str(dxf)], capture_output=True, text=True,
                       timeout=60, env={**os.environ, "QT_QPA_PLATFORM": "offscreen"}, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-500:]
    assert pdf.read_bytes()[:5] == b"%PDF-"


def test_the_3dm_holds_the_exact_outline(kit: Path, panel) -> None:  # noqa: ANN001
    r3 = pytest.importorskip("rhino3dm", reason="rhino3dm (PyPI) is needed to read .3dm files back")
    model = r3.File3dm.Read(str(kit / "panel.3dm"))
    def on(layer: str) -> list:
        return [o.Geometry for o in model.Objects if model.Layers[o.Attributes.LayerIndex].Name == layer]

    cut = on("CUT")
    assert len(cut) == 1 + len(panel.outline.holes) and all(c.IsClosed for c in cut)
    assert len(on("INTERFACE")) == len(panel.fused.support) == 2 * 26  # the rim's 26 free interfaces
    (plate,) = on("PLATE")
    assert isinstance(plate, r3.Extrusion)


def test_simulate_assembly_pushes_a_panel_into_an_arch() -> None:
    import math

    from fabpat.assembly.solve.simulation import simulate_assembly

    data = {"tiling": {"kind": "panel", "edge": 36.0, "rows": 1, "columns": 3}, "patterns": {"pattern": A},
            "plates": {"thickness": 0.8}}
    sim = simulate_assembly(parse(data), h=6.0, steps=2, end_shortening=0.05)
    f = sim.fields()
    assert f["plates"] == 1 and f["sleeves"] == 0 and f["converged"] and f["reaction"] > 0
    L = sim.run.setup.length
    # an inextensible half-sine arch of length L shortened by δ rises (2/π) √(δ L)
    rise = 2.0 / math.pi * math.sqrt(0.05 * L * L)
    assert f["max_deflection"] == pytest.approx(rise, rel=0.3)
    assert f["peak"] == pytest.approx(0.5, abs=0.05)  # one pattern: a symmetric arch


@pytest.mark.parametrize(("change", "words"), [
    (lambda d: d.update(sleeve={"margin": 1.0}), "[sleeve] applies to assemblies joined by sleeves"),
    (lambda d: d["tiling"].update(rows=13), "tiling.rows"),
    (lambda d: d.update(sheet={"width": 150.0, "height": 150.0}), "smaller than the 3 × 4 panel"),
    (lambda d: d["tiling"].update(file="x.obj"), "tiling.file and tiling.rows both give"),
])
def test_bad_panel_specs_are_one_line(tmp_path: Path, change, words: str) -> None:  # noqa: ANN001
    import copy

    data = copy.deepcopy(SPEC)
    change(data)
    spec = tmp_path / "bad.toml"
    spec.write_text(toml_text(data))
    out = tmp_path / "kit"
    r = run_cli("assemble", str(spec), "--out", str(out), "--no-progress")
    assert r.returncode == 2 and words in r.stderr and not out.exists(), r.stderr
    assert len([line for line in r.stderr.splitlines() if line.startswith("fabpat: error")]) == 1


@pytest.mark.parametrize("kind", ["panel", "honeycomb-strip"])
def test_a_single_column_is_not_pushed(kind: str) -> None:
    """Its first and last columns are one: an 'end shortening' of nothing once reported converged."""
    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.assembly.spec.load import parse_spec
    from fabpat.errors import SpecError

    data = {"tiling": {"kind": kind, "edge": 36.0, "rows": 3, "columns": 1}, "patterns": {"pattern": "0x0488"}}
    with pytest.raises(SpecError, match="tiling.columns = 1 has only one"):
        simulate_assembly(parse_spec(data, "one.toml"))


def test_print_bed_report_tells_the_size_and_a_part_past_a_common_bed() -> None:
    from fabpat.assembly.kit.panel import print_bed_report

    spec = parse()
    line, warn = print_bed_report(spec, (150.0, 210.0))  # 210 mm > 200 mm whichever way it lies
    assert line == ["printed part 150.0 × 210.0 mm: on the print bed of [sheet], 300 × 260 mm (sheet.margin = 5 mm)"]
    assert len(warn) == 1 and "150.0 × 210.0 mm" in warn[0] and "fewer rows or columns" in warn[0]
    assert print_bed_report(spec, (199.0, 120.0))[1] == []  # within the common bed: the line, no warning
    laser = parse({**SPEC, "plates": {"thickness": 2.0, "process": "laser"}, "sheet": {**SPEC["sheet"], "kerf": 0.1}})
    assert print_bed_report(laser, (250.0, 250.0)) == ([], [])


def test_3mf_is_a_panel_format_only() -> None:
    from fabpat.errors import SpecError

    strip = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
             "patterns": {"pattern": A}, "output": {"formats": ["stl", "3mf"]}}
    with pytest.raises(SpecError, match="'3mf', which is for tiling.kind = \"panel\""):
        parse(strip)
    assert "3mf" in parse({**SPEC, "output": {"formats": ["3mf"]}}).formats


def test_the_shipped_panel_spec_parses() -> None:
    from fabpat.assembly.spec.load import load_spec

    spec = load_spec(ROOT / "assemblies" / "panel.toml", need_sheet=True)
    assert spec.tiling.panel and spec.tiling.strip and (spec.tiling.rows, spec.tiling.columns) == (3, 4)
    assert {p for row in spec.patterns.tiles for p in row} == {A, B}


def toml_text(data: dict) -> str:
    """A small TOML writer for the specs above (tables of numbers, strings, booleans and lists)."""
    def value(v: object) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = [f"{k} = {value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, table in data.items():
        if isinstance(table, dict):
            lines += [f"[{k}]", *(f"{kk} = {value(vv)}" for kk, vv in table.items())]
    return "\n".join(lines) + "\n"


def test_rules_and_tile_tables_choose_each_tiles_pattern() -> None:
    from fabpat.assembly.choose.choice import face_patterns

    graded = parse({"tiling": {"kind": "panel", "edge": 36.0, "rows": 2, "columns": 4},
                    "patterns": {"rule": "graded", "count": 2}})
    ids = face_patterns(graded)
    assert len(set(ids)) == 2 and ids[:4] == [ids[0]] * 4 and ids[4:] == [ids[4]] * 4  # two groups of 2 columns
    table = parse({"tiling": {"kind": "panel", "edge": 36.0, "rows": 1, "columns": 3},
                   "patterns": {"tiles": {"T1": A, "T2": B, "T3": A}, "bridge_weight": {"T2": 0.5}}})
    panel = chosen_panel(table)
    assert [pt.label for pt in panel.types] == [f"hex {A}", f"hex {B} b0.5", f"hex {A}"]
    assert panel.fused.fused == 2 and len(panel.outline.holes) == sum(
        len(panel.filleted[pt].outline.holes) for pt in panel.types)  # a single row: no gap is closed
