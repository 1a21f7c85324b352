"""Issue 15 §7, specs: a key that does not apply is an error, ranges are named up front, and the kit
applies export's fabrication checks."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fabpat.assembly.placement import check_geometry
from fabpat.assembly.spec import load_spec, parse_spec
from fabpat.errors import SpecError
from tests.test_reliability_files import invoke, one_line_error

ROOT = Path(__file__).resolve().parents[1]
SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
SMALL = ROOT / "assemblies" / "test-small.toml"


def edited(src: Path, dst: Path, **changes: str | None) -> Path:
    """``src`` with ``key = value`` lines replaced (the first line of that key in the file; None: removed)."""
    lines = src.read_text(encoding="utf-8").splitlines()
    for key, value in changes.items():
        k = next(i for i, ln in enumerate(lines) if ln.split("=")[0].strip() == key)
        if value is None:
            del lines[k]
        else:
            lines[k] = f"{key} = {value}"
    dst.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return dst


def strip(**patterns: object) -> dict:
    return {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
            "patterns": patterns, "sheet": {"width": 600.0, "height": 400.0}}


def sphere(**patterns: object) -> dict:
    return {"tiling": {"kind": "truncated-icosahedron", "edge": 36.0}, "patterns": patterns,
            "sheet": {"width": 600.0, "height": 400.0}}


@pytest.mark.parametrize("data, key", [
    (sphere(hexagon="0x0488", pentagon="0x0508", count=2), "patterns.count"),
    (sphere(hexagon="0x0488", pentagon="0x0508", scenario="dome"), "patterns.scenario"),
    (sphere(hexagon="0x0488", pentagon="0x0508", catalog="c.sqlite"), "patterns.catalog"),
    (strip(pattern="0x0488", count=3), "patterns.count"),
    (strip(pattern="0x0488", group_columns=1), "patterns.group_columns"),
    (strip(groups=["0x0488", "0x0508", "0x0588"], group_columns=1, scenario="dome"), "patterns.scenario"),
    (strip(tiles=[["0x0488", "0x0508", "0x0588"]], catalog="c.sqlite"), "patterns.catalog"),
])
def test_a_key_that_does_not_apply_is_an_error(data: dict, key: str) -> None:
    with pytest.raises(SpecError, match=rf"{key} does not apply") as err:
        parse_spec(data, "s.toml")
    assert "\n" not in str(err.value)


def test_count_beside_hexagon_is_refused_like_groups(tmp_path: Path) -> None:
    text = SPHERE.read_text(encoding="utf-8")
    for extra, key in (("count = 2", "patterns.count"), ('groups = ["0x0488"]', "groups")):
        spec = tmp_path / "s.toml"
        spec.write_text(text.replace('pentagon = "0x0508"', f'pentagon = "0x0508"\n{extra}'), encoding="utf-8")
        one_line_error(invoke("assemble", str(spec), "--out", str(tmp_path / "kit")), key)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


@pytest.mark.parametrize("changes, words", [
    ({"depth": "0.001"}, ("sleeve.depth = 0.001", "must be ≥ 1.44 mm", "sleeve.wall")),
    # values inside the keys' physical ranges (fabpat.validate: edge ≥ 1 mm, weight ≤ 10) that break
    # the geometric bounds; 0.001 and 1e6 are refused by those ranges first (tests/test_reliability.py)
    ({"edge": "2"}, ("tiling.edge = 2", "must be ≥ 3.8 mm", "sleeve.margin")),
    ({"weight": "5", "mesh_tolerance": "0.1"}, ("plates.weight = 5", "must be in (0, 3.5]", "output.mesh_tolerance")),
])
def test_downstream_errors_are_named_up_front(tmp_path: Path, changes: dict[str, str], words: tuple[str, ...]) -> None:
    spec = edited(SPHERE, tmp_path / "s.toml", **changes)
    with pytest.raises(SpecError) as err:
        check_geometry(load_spec(spec))
    for w in words:
        assert w in str(err.value)
    res = invoke("assemble", str(spec), "--out", str(tmp_path / "kit"), "--no-progress")
    one_line_error(res, *words)
    assert "intersect" not in res.stderr and "manifold" not in res.stderr and "midpoint" not in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_ranges_follow_the_geometry() -> None:
    """The bounds move with the keys they come from, and the shipped values lie inside them."""
    for path in (SPHERE, SMALL, ROOT / "assemblies" / "graded-strip.toml"):
        check_geometry(load_spec(path))
    # a flat strip: both plates of a joint have one setback, so the least depth is the wall
    data = strip(pattern="0x0488")
    data["sleeve"] = {"depth": 1.19, "wall": 1.2}
    with pytest.raises(SpecError, match=r"sleeve.depth = 1.19 mm must be ≥ 1.2 mm"):
        check_geometry(parse_spec(data, "s.toml"))
    data["sleeve"] = {"depth": 1.2, "wall": 1.2}
    check_geometry(parse_spec(data, "s.toml"))
    data["sleeve"] = {"margin": 10.0}  # a longer sleeve needs a longer edge: (10 + 2.4) / (1 − 1/9.6)
    data["tiling"]["edge"] = 13.8
    with pytest.raises(SpecError, match=r"tiling.edge = 13.8 mm must be ≥ 13.8[0-9]? mm"):
        check_geometry(parse_spec(data, "s.toml"))
    data["sleeve"] = {}
    data["tiling"]["edge"] = 36.0
    data["output"] = {"mesh_tolerance": 0.05}  # coarser STL: a shorter interface is no longer resolved
    data["plates"] = {"weight": 9.0}
    with pytest.raises(SpecError, match=r"plates.weight = 9 must be in \(0, 8]"):
        check_geometry(parse_spec(data, "s.toml"))


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
