"""Family members in assembly specs: ``[patterns] bridge_weight`` for every plate or per plate label."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from fabpat.assembly.build import plan
from fabpat.assembly.spec import load_spec
from fabpat.errors import SpecError
from fabpat.library import get_pattern
from tests.conftest import run_cli

SMALL = Path(__file__).parent.parent / "assemblies" / "test-small.toml"


def _spec(tmp_path: Path, line: str) -> Path:
    text = SMALL.read_text().replace("group_columns = 1", f"group_columns = 1\n{line}", 1)
    path = tmp_path / "v.toml"
    path.write_text(text)
    return path


def test_one_number_sets_every_plate_and_a_table_names_plates(tmp_path: Path) -> None:
    every = load_spec(_spec(tmp_path, "bridge_weight = 0.5"))
    assert every.patterns.bridge_weights == (0.5, 0.5, 0.5)
    some = load_spec(_spec(tmp_path, "bridge_weight = {T1 = 0.5, T3 = 2.0}"))
    assert some.patterns.bridge_weights == (0.5, 1.0, 2.0)
    assert load_spec(SMALL).patterns.bridge_weight_of(0) == 1.0


@pytest.mark.parametrize(("line", "words"), [
    ("bridge_weight = {T9 = 0.5}", "patterns.bridge_weight.T9 is not a plate of this honeycomb-strip (labels T1 … T3)"),
    ("bridge_weight = 3.0", "patterns.bridge_weight = 3 is out of range: must be in [0.25, 2.5]"),
    ("bridge_weight = {T2 = 0.1}", "patterns.bridge_weight.T2 = 0.1 is out of range"),
    ("bridge_weight = \"wide\"", "patterns.bridge_weight must be a number (every plate) or a table"),
])
def test_bad_bridge_weights_are_one_line(tmp_path: Path, line: str, words: str) -> None:
    with pytest.raises(SpecError, match=None) as e:
        load_spec(_spec(tmp_path, line))
    assert words in str(e.value) and "\n" not in str(e.value)


def test_each_member_is_its_own_plate_type_with_its_own_outline(tmp_path: Path) -> None:
    spec = load_spec(_spec(tmp_path, "bridge_weight = {T1 = 0.5, T3 = 2.0}"))
    assembly, filleted = plan(spec)
    labels = [p.type.label for p in assembly.plates]
    assert labels == ["hex 0x0488 b0.5", "hex 0x0508", "hex 0x0588 b2"]
    for pt, fp in filleted.items():
        direct = get_pattern(pt.pattern_id).fillet(bridge_weight=pt.bridge_weight)
        assert fp.outline.to_svg_path() == direct.outline.to_svg_path()
        assert fp.metrics.area == pytest.approx(direct.metrics.area, rel=1e-12)


def test_the_kit_names_members_and_does_not_borrow_the_papers_energies(tmp_path: Path) -> None:
    spec = _spec(tmp_path, "bridge_weight = {T1 = 0.5}")
    res = run_cli("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-predict")
    assert res.returncode == 0, res.stderr
    with (tmp_path / "kit" / "bom.csv").open() as f:
        rows = {r["part"]: r for r in csv.DictReader(f)}
    assert {"hex 0x0488 b0.5", "hex 0x0508", "hex 0x0588"} <= set(rows)
    member, paper = rows["hex 0x0488 b0.5"], rows["hex 0x0508"]
    assert paper["energy_cylinder_Nmm"] != ""  # the catalog's own energy of the paper's member
    # the built-in catalog holds no family rows for it: blank, not the paper member's number
    manifest = json.loads((tmp_path / "kit" / "manifest.json").read_text())
    rec = next(r for r in manifest["patterns"] if r["part"] == "hex 0x0488 b0.5")
    assert rec["bridge_weight"] == 0.5
    if member["energy_cylinder_Nmm"] == "":
        assert "outside the catalog's family" in rec["note"]
    else:  # a catalog with the family: the interpolated energy, below the paper's (wider necks: stiffer)
        from fabpat.catalog import energies, open_catalog

        with open_catalog() as cat:
            paper_0488 = energies(cat, "cylinder")["0x0488"]
        assert "interpolated" in rec["note"]
        assert float(member["energy_cylinder_Nmm"]) < paper_0488
    assert (tmp_path / "kit" / "parts" / "plate-hex-0x0488-b0.5.stl").is_file()
