"""A strip kit is checked against its own use, as the sphere's is: the end pins push it together (as
`simulate-assembly` does), the kit holds that prediction, and a plate over the strain limit is refused.
Every kit's BOM and manifest say where each pattern came from and what the catalog knows of it."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest

from tests.helpers import invoke

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "assemblies" / "test-small.toml"
FIELDS = {"converged", "plates", "sleeves", "nodes", "energy", "peak", "half_ratio", "radius", "peak_strain",
          "peak_strain_plate", "strain_limit", "over_limit", "h"}


@pytest.fixture(scope="module")
def kit(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("strip") / "kit"
    r = invoke("assemble", str(SMALL), "--out", str(out), "--no-progress")
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.slow
def test_the_strip_kit_holds_its_prediction(kit: Path) -> None:
    files = json.loads((kit / "manifest.json").read_text())["files"]
    assert {"prediction.json", "predicted.stl", "predicted.glb", "predicted.png", "assembly.step", "assembly.glb",
            "assembly.png"} <= set(files)
    rec = json.loads((kit / "prediction.json").read_text())
    assert FIELDS <= set(rec) and rec["radius"] is None and rec["plates"] == 3 and rec["sleeves"] == 2
    assert 0 < rec["peak"] < 1 and rec["max_deflection"] > 10.0  # an arch, tens of mm high
    assert rec["over_limit"] == [] and rec["peak_strain"] < rec["strain_limit"] == 0.02


def test_the_prediction_is_what_simulate_assembly_reports(kit: Path) -> None:
    rec = json.loads((kit / "prediction.json").read_text())
    r = invoke("simulate-assembly", str(SMALL), "--json", "--no-progress")
    assert r.returncode == 0, r.stderr
    sim = json.loads(r.stdout)
    assert rec["peak_strain_plate"] == sim["peak_strain_plate"] and rec["nodes"] == sim["nodes"]
    for key in ("energy", "peak", "half_ratio", "max_deflection", "peak_strain", "reaction"):
        assert rec[key] == pytest.approx(sim[key], rel=1e-9), key


def test_the_predicted_files_are_the_bent_strip(kit: Path) -> None:
    import trimesh

    stl = trimesh.load(kit / "predicted.stl")
    flat = trimesh.load(kit / "assembly.glb", force="mesh")
    rec = json.loads((kit / "prediction.json").read_text())
    height = float(stl.bounds[1, 2] - stl.bounds[0, 2])
    assert height > rec["max_deflection"]  # the arch, plus the plates' thickness and the sleeves
    assert float(flat.bounds[1, 1] - flat.bounds[0, 1]) * 1000 < 10.0  # the flat strip (GLB in metres, y up)
    scene = trimesh.load(kit / "predicted.glb")
    assert {"T1", "T2", "T3", "E1", "E2"} <= set(scene.graph.nodes)


@pytest.mark.slow
def test_a_strip_over_the_strain_limit_is_refused(tmp_path: Path) -> None:
    """2 mm plates pushed together by 10 % reach 3.5 % on the 1 × 3 strip (limit 2 %)."""
    spec = tmp_path / "thick.toml"
    spec.write_text(SMALL.read_text().replace("thickness = 0.8", "thickness = 2.0").replace(
        "[sheet]", '[output]\nformats = ["bom"]\n\n[sheet]'))
    out = tmp_path / "kit"
    r = invoke("assemble", str(spec), "--out", str(out), "--no-progress")
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert re.search(r"plate T\d would reach a peak strain of 0\.03\d+ when its end pins push the strip together by "
                     r"10 % of its length, over material.strain_limit = 0.02", r.stderr), r.stderr
    assert "--force" in r.stderr and not out.exists()
    res = invoke("assemble", str(spec), "--out", str(out), "--no-progress", "--force")
    assert res.returncode == 0, res.stderr
    warnings = [ln for ln in res.stderr.splitlines() if ln.startswith("fabpat: warning: plate T")]
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(warnings) == len(manifest["warnings"]) == 3
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "skipped"), "--no-progress", "--no-predict")
    assert res.returncode == 0 and "not checked" in res.stderr and "push the strip together" in res.stderr, res.stderr


def test_bom_and_manifest_record_the_patterns(kit: Path) -> None:
    from fabpat import catalog

    manifest = json.loads((kit / "manifest.json").read_text())
    records = {r["part"]: r for r in manifest["patterns"]}
    assert list(records) == ["hex 0x0488", "hex 0x0508", "hex 0x0588"]
    rows = {r["part"]: r for r in csv.DictReader((kit / "bom.csv").open())}
    for part, rec in records.items():
        assert rec["chosen_by"] == "explicit (patterns.groups)" and rec["catalog"] == "built-in"
        assert rec["catalog_setup"] == {"edge": 36.0, "thickness": 2.0, "weight": 0.2}  # 0.8 mm is not in it
        for sc in ("cantilever", "cylinder", "dome"):
            want = catalog.energies(None, sc)[rec["pattern"]]
            assert rec["energies_Nmm"][sc] == pytest.approx(want, rel=1e-12)
            assert float(rows[part][f"energy_{sc}_Nmm"]) == pytest.approx(want, abs=5e-4)
        assert rows[part]["chosen_by"] == rec["chosen_by"] and rows[part]["pattern"] == rec["pattern"]
    md = (kit / "bom.md").read_text()
    assert "## Patterns" in md and "| hex 0x0488 | 0x0488 | explicit (patterns.groups) |" in md


def test_a_rule_is_named_as_the_chooser(tmp_path: Path) -> None:
    from fabpat.assembly.kit.build import assemble
    from fabpat.assembly.spec.load import parse_spec

    spec = parse_spec({"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 4},
                       "patterns": {"rule": "graded", "count": 2}, "plates": {"thickness": 0.8},
                       "sheet": {"width": 300.0, "height": 200.0}, "output": {"formats": ["bom"]}}, "g.toml")
    assemble(spec, tmp_path / "kit", predict=False)
    records = json.loads((tmp_path / "kit" / "manifest.json").read_text())["patterns"]
    assert len(records) == 2 and all(r["chosen_by"] == "rule = 'graded' (cylinder energies)" for r in records)
    cyl = [r["energies_Nmm"]["cylinder"] for r in records]
    assert cyl[0] < cyl[1]  # stiff (low energy) first


def test_bom_md_columns_have_fixed_decimals(kit: Path) -> None:
    md = (kit / "bom.md").read_text().splitlines()
    for head in ("| part | kind |", "| joint | sleeve |", "| part | pattern |", "| sheet | plates |"):
        start = next(i for i, ln in enumerate(md) if ln.startswith(head))
        rows = [ln.strip("|").split("|") for ln in md[start + 2:] if ln.startswith("| ")]
        rows = rows[:next((k for k, r in enumerate(rows) if len(r) != len(rows[0])), len(rows))]
        for col in range(len(rows[0])):
            decimals = {len(c.strip().split(".")[1]) for r in rows
                        if re.fullmatch(r"-?\d+\.\d+", (c := r[col]).strip())}
            assert len(decimals) <= 1, (head, col, decimals)


def test_sheet_utilisation_is_in_the_bom(kit: Path) -> None:
    rows = list(csv.DictReader((kit / "bom.csv").open()))
    sheet = next(r for r in rows if r["kind"] == "sheet")
    plates = [r for r in rows if r["kind"] == "plate"]
    assert float(sheet["utilisation_pct"]) > 0
    md = (kit / "bom.md").read_text()
    assert "| sheet | plates | utilisation (%) | material (%) | used height (mm) |" in md
    # each sheet's material share: its plates' own area over its area, 170 × 90 mm
    material = sum(float(r["unit_area_mm2"]) * int(r["count"]) for r in plates) / (170 * 90)
    shares = [float(m) for m in re.findall(r"\| \d+ \| T[^|]+\| [\d.]+ \| ([\d.]+) \|", md)]
    assert sum(shares) / 100 == pytest.approx(material, abs=2e-3)
