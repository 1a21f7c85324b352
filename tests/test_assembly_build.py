"""`fabpat assemble`: every output of the small spec exists and re-reads; bad specs leave nothing, and the
kit applies export's fabrication checks to its plates (too thin to print, below the laser's kerf limit)."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.helpers import FLAT_SPHERE as SPHERE
from tests.helpers import edited, one_line_error
from tests.helpers import invoke_result as invoke

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "assemblies" / "test-small.toml"


@pytest.fixture(scope="module")
def kit(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str]]:
    out = tmp_path_factory.mktemp("assemble") / "kit"
    r = run_cli("assemble", str(SMALL), "--out", str(out), "--no-progress", "--timestamp", "2026-01-01T00:00:00")
    assert r.returncode == 0, r.stderr
    return out, r.stdout.splitlines()


def test_lists_the_files_written(kit: tuple[Path, list[str]]) -> None:
    out, lines = kit
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["generator"] == "fabpat assemble"
    assert [Path(line) for line in lines] == [out / f for f in manifest["files"]] + [out / "manifest.json"]
    on_disk = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
    assert on_disk == sorted([*manifest["files"], "manifest.json"])
    assert {"assembly.step", "assembly.glb", "assembly.png", "net.svg", "bom.csv", "bom.md"} <= set(manifest["files"])
    assert manifest["counts"] == {"hex 0x0488": 1, "hex 0x0508": 1, "hex 0x0588": 1, "S-flat": 2}
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]  # no temporary folders left


def test_step_assembly_reimports(kit: tuple[Path, list[str]]) -> None:
    from fabpat.assembly.show.export import read_step_solids

    count, names = read_step_solids(kit[0] / "assembly.step")
    assert count == 5  # 3 plates + 2 sleeves
    assert sorted(names) == ["E1", "E2", "T1", "T2", "T3"]
    text = (kit[0] / "assembly.step").read_text(errors="replace")
    assert "fabpat 0x0488 n6 e36mm t0.8mm w0.2" in text and "fabpat sleeve 180.00deg" in text
    assert "RATIONAL_B_SPLINE_CURVE" in text  # exact fillets, not facets


def test_part_stls(kit: tuple[Path, list[str]]) -> None:
    import trimesh

    stls = sorted((kit[0] / "parts").glob("*.stl"))
    assert [p.name for p in stls] == ["plate-hex-0x0488.stl", "plate-hex-0x0508.stl", "plate-hex-0x0588.stl",
                                      "sleeve-S-flat.stl"]
    for p in stls:
        m = trimesh.load(p)
        assert m.is_watertight and m.volume > 0
        assert m.bounds[0, 2] == pytest.approx(0.0, abs=1e-6)  # lies on the bed
    plate = trimesh.load(stls[0])
    assert plate.bounds[1, 2] - plate.bounds[0, 2] == pytest.approx(0.8, abs=1e-6)  # plates.thickness


def test_output_tolerances_reach_the_kit(kit: tuple[Path, list[str]], tmp_path: Path) -> None:
    """``[output] mesh_tolerance`` / ``curve_tolerance`` (mm) set the STL chord and the sheets' arcs."""
    import ezdxf
    import trimesh

    coarse = tmp_path / "coarse.toml"
    coarse.write_text(SMALL.read_text() + "\n[output]\nformats = [\"stl\", \"dxf\"]\n"
                      "mesh_tolerance = 0.1\ncurve_tolerance = 0.2\n")
    out = tmp_path / "kit"
    r = run_cli("assemble", str(coarse), "--out", str(out), "--no-progress")
    assert r.returncode == 0, r.stderr
    name = "plate-hex-0x0488.stl"
    assert len(trimesh.load(out / "parts" / name).faces) < 0.5 * len(trimesh.load(kit[0] / "parts" / name).faces)

    def vertices(folder: Path) -> int:
        doc = ezdxf.readfile(folder / "sheets" / "sheet-01.dxf")
        return sum(len(e) for e in doc.modelspace().query("LWPOLYLINE[layer=='CUT']"))

    assert vertices(out) < vertices(kit[0])


def test_glb_preview(kit: tuple[Path, list[str]]) -> None:
    import trimesh

    scene = trimesh.load(kit[0] / "assembly.glb")
    assert len(scene.graph.nodes_geometry) == 5
    lo, hi = scene.bounds  # metres, glTF's unit
    # three columns 1.5 E apart, each plate wider than one edge and narrower than two
    assert 0.001 * (2 * 1.5 * 36.8 + 36.0) < hi[0] - lo[0] < 0.001 * (2 * 1.5 * 36.8 + 2 * 36.0)
    assert len(scene.geometry) == 4  # three plates and one sleeve kind: the two sleeves share a mesh


def test_sheets_reread_without_overlaps(kit: tuple[Path, list[str]]) -> None:
    import manifold3d

    from fabpat.assembly.kit.sheets import read_sheet

    sheets = sorted((kit[0] / "sheets").glob("*.dxf"))
    assert len(sheets) == 2
    plates = []
    texts_all: list[str] = []
    for path in sheets:
        loops, texts = read_sheet(path)
        texts_all += texts
        boxes = [(P.min(axis=0), P.max(axis=0)) for P in loops]
        # outer loops: not inside another loop's box (holes are); oriented counter-clockwise
        outer = [P if manifold3d.CrossSection([P]).area() > 0 else P[::-1] for i, P in enumerate(loops)
                 if not any(j != i and np.all(boxes[j][0] <= boxes[i][0]) and np.all(boxes[i][1] <= boxes[j][1])
                            for j in range(len(loops)))]
        for P in outer:
            assert P.min() >= 5.0 - 0.2 and P[:, 0].max() <= 165.0 + 0.2 and P[:, 1].max() <= 85.0 + 0.2
        for i, P in enumerate(outer):
            for Q in outer[i + 1:]:
                both = manifold3d.CrossSection([P]) ^ manifold3d.CrossSection([Q])
                assert both.area() == pytest.approx(0.0, abs=1e-9)
        plates += outer
    assert len(plates) == 3
    for label in ("T1", "T2", "T3", "E1", "E2", "PIN"):
        assert label in texts_all


def test_net_svg(kit: tuple[Path, list[str]]) -> None:
    root = ElementTree.parse(kit[0] / "net.svg").getroot()
    ns = "{http://www.w3.org/2000/svg}"
    texts = [e.text for e in root.iter(f"{ns}text")]
    assert {"T1", "T2", "T3"} <= set(texts) and texts.count("E1") == 2 and texts.count("PIN") == 4
    assert root.get("width", "").endswith("mm")


def test_bom(kit: tuple[Path, list[str]]) -> None:
    rows = list(csv.DictReader((kit[0] / "bom.csv").open()))
    by = {r["part"]: r for r in rows}
    assert int(by["S-flat"]["count"]) == 2 and by["S-flat"]["process"] == "print"
    assert by["hex 0x0488"]["process"] == "laser" and float(by["hex 0x0488"]["unit_cut_length_mm"]) > 100
    assert float(by["hex 0x0488"]["unit_volume_mm3"]) == pytest.approx(0.8 * float(by["hex 0x0488"]["unit_area_mm2"]),
                                                                 rel=1e-3)
    assert int(by["laser sheet 170 × 90 mm"]["count"]) == 2
    # what each process uses: the laser-cut plates list their DXF sheets (not an STL), sleeves their STL
    manifest = json.loads((kit[0] / "manifest.json").read_text())
    sheets = sorted(f for f in manifest["files"] if f.startswith("sheets/"))
    listed = [r["file"].split() for r in rows if r["kind"] == "plate"]
    assert all(names and set(names) <= set(sheets) for names in listed), listed
    assert sorted({n for names in listed for n in names}) == sheets  # every sheet carries some plate
    assert by["S-flat"]["file"].endswith(".stl") and (kit[0] / by["S-flat"]["file"]).is_file()
    assert not any(r["file"].endswith(".stl") for r in rows if r["process"] == "laser")
    md = (kit[0] / "bom.md").read_text()
    assert "| E1 | S-flat | 180.00 | 180.00 | T1 (2) | T2 (5) |" in md and "Pinned interfaces" in md


def test_png(kit: tuple[Path, list[str]]) -> None:
    import matplotlib.image as mpimg

    img = mpimg.imread(kit[0] / "assembly.png")
    assert img.shape[0] > 400 and img.shape[1] > 400
    assert np.ptp(img[..., :3]) > 0.5  # not blank


def test_refuses_a_foreign_folder(tmp_path: Path) -> None:
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    r = run_cli("assemble", str(SMALL), "--out", str(foreign), "--no-progress")
    assert r.returncode == 2 and "not an earlier `fabpat assemble` output" in r.stderr
    assert (foreign / "notes.txt").read_text() == "keep me"


BAD = {
    "unknown-pattern": ('[patterns]\npattern = "0x9999"\n', "patterns.pattern = '0x9999': unknown pattern"),
    "missing-key": ("", "missing key tiling.edge"),
    "small-sheet": ('[patterns]\npattern = "0x0488"\n', "smaller than a hexagon plate"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_specs_fail_cleanly(case: str, tmp_path: Path) -> None:
    patterns, message = BAD[case]
    edge = "" if case == "missing-key" else "edge = 36.0\n"
    sheet = "width = 60.0\nheight = 60.0\n" if case == "small-sheet" else "width = 170.0\nheight = 90.0\n"
    text = (f'[tiling]\nkind = "honeycomb-strip"\n{edge}rows = 1\ncolumns = 2\n'
            f'{patterns or chr(10).join(["[patterns]", "pattern = " + chr(34) + "0x0488" + chr(34), ""])}'
            f"[sheet]\n{sheet}")
    spec = tmp_path / f"{case}.toml"
    spec.write_text(text)
    out = tmp_path / "out"
    r = run_cli("assemble", str(spec), "--out", str(out))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fabpat: error: ") and message in lines[0], r.stderr
    assert not out.exists()
    assert sorted(os.listdir(tmp_path)) == [spec.name]  # no half-filled or temporary folder


def test_failure_after_start_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.assembly.kit import build
    from fabpat.assembly.spec.load import load_spec
    from fabpat.errors import ExportError

    def broken(*args: object, **kwargs: object) -> None:
        raise ExportError("disk full (simulated)")

    monkeypatch.setattr("fabpat.assembly.show.export.write_glb", broken)
    with pytest.raises(ExportError, match="simulated"):
        build.assemble(load_spec(SMALL), tmp_path / "kit")
    assert os.listdir(tmp_path) == []


def test_count_beside_hexagon_is_refused_like_groups(tmp_path: Path) -> None:
    text = SPHERE.read_text(encoding="utf-8")
    for extra, key in (("count = 2", "patterns.count"), ('groups = ["0x0488"]', "groups")):
        spec = tmp_path / "s.toml"
        spec.write_text(text.replace('pentagon = "0x0508"', f'pentagon = "0x0508"\n{extra}'), encoding="utf-8")
        one_line_error(invoke("assemble", str(spec), "--out", str(tmp_path / "kit")), key)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_plates_too_thin_to_print(tmp_path: Path) -> None:
    """edge = 12 printed: export warns for these plates, the kit refuses them, or warns with --force."""
    spec = edited(SPHERE, tmp_path / "s.toml", edge="12.0", process='"print"', depth="1.5", formats='["bom"]',
                  kerf=None, cut_speed=None)  # laser-only keys are refused with process = "print"
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress")
    one_line_error(res, "plate hex 0x0488: min feature width 0.658 mm is below 0.8 mm for printing",
                   "(and 1 more)", "--force")
    assert not (tmp_path / "kit").exists()
    for pid, sides, width in (("0x0488", "6", "0.658"), ("0x0508", "5", "0.516")):  # export's own verdict
        exp = invoke("export", pid, "--sides", sides, "--edge", "12", "--stl", str(tmp_path / "p.stl"))
        assert exp.exit_code == 0 and f"min feature width {width} mm is below 0.8 mm for printing" in exp.stderr
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress", "--force", "--no-predict")
    assert res.exit_code == 0, res.stderr
    warnings = [ln for ln in res.stderr.splitlines() if ln.startswith("fabpat: warning:")]
    # the two plates too thin to print, then the strain limit that --no-predict left unchecked
    assert len(warnings) == 3 and "plate pent 0x0508" in warnings[1] and "0.8 mm for printing" in warnings[0]
    assert "strain_limit" in warnings[2] and "not checked" in warnings[2]
    manifest = json.loads((tmp_path / "kit" / "manifest.json").read_text(encoding="utf-8"))
    assert len(manifest["warnings"]) == 3


def test_laser_plates_use_the_kerf_limit(tmp_path: Path) -> None:
    """Laser: the limit is 2 × sheet.kerf, as for export's DXF/SVG (the shipped sphere passes at 0.15)."""
    spec = edited(SPHERE, tmp_path / "s.toml", kerf="1.0", formats='["bom"]')
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress")
    one_line_error(res, "plate hex 0x0488: min feature width 1.95 mm is below 2 mm for laser cutting with a 1 mm kerf",
                   "--force")
    exp = invoke("export", "0x0488", "--dxf", str(tmp_path / "p.dxf"), "--kerf", "1")
    assert "min feature width 1.95 mm is below 2 mm for laser cutting with a 1 mm kerf" in exp.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.dxf", "s.toml"]


@pytest.mark.slow
def test_assemble_places_the_sphere_and_fillets_its_plates_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch
                                                                 ) -> None:
    """A default ``assemble`` of the shipped sphere (its prediction included) places the assembly once and
    fillets each of its two plate types once: the prediction solves the kit's own placement and outlines."""
    import fabpat.assembly.place.placement as placement
    import fabpat.assembly.place.shaped as shaped
    import fabpat.geometry.fillet as fillet

    calls = {"place": 0, "fillet": 0}
    place, fillet_pattern = placement.place, fillet.fillet_pattern

    def counted_place(*args: object, **kwargs: object) -> object:
        calls["place"] += 1
        return place(*args, **kwargs)  # type: ignore[arg-type]

    def counted_fillet(*args: object, **kwargs: object) -> object:
        calls["fillet"] += 1
        return fillet_pattern(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(placement, "place", counted_place)
    monkeypatch.setattr(shaped, "place", counted_place)  # bound at import by the placement of every kind
    monkeypatch.setattr(fillet, "fillet_pattern", counted_fillet)
    spec = edited(ROOT / "assemblies" / "truncated-icosahedron.toml", tmp_path / "sphere.toml", formats='["bom"]')
    r = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--predict-h", "7.5", "--no-progress")
    assert r.exit_code == 0, r.stderr
    prediction = json.loads((tmp_path / "kit" / "prediction.json").read_text(encoding="utf-8"))
    assert prediction["sphericity_rms"] < 0.01  # the prediction ran
    assert calls == {"place": 1, "fillet": 2}
