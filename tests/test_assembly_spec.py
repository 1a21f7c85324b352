"""Spec files: the shipped specs load; every bad value is one clear line naming the key, and a key that does
not apply (to the tiling, to the process) or a format listed twice is an error, and the numbers and sizes
use the same ranges as the commands' options."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import pytest

from fabpat.assembly.spec.load import load_spec, parse_spec
from fabpat.errors import SpecError
from tests.helpers import SPECS, strip


def base(**tables: dict) -> dict:
    data = {
        "tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
        "patterns": {"pattern": "0x0488"},
        "sheet": {"width": 170.0, "height": 90.0},
    }
    data.update(tables)
    return data


@pytest.mark.parametrize("name", ["graded-strip.toml", "truncated-icosahedron.toml", "test-small.toml"])
def test_shipped_specs_load(name: str) -> None:
    spec = load_spec(SPECS / name)
    assert spec.tiling.edge == 36.0
    assert spec.sleeve.clearance == pytest.approx(0.2)


def test_shipped_spec_contents() -> None:
    strip = load_spec(SPECS / "graded-strip.toml")
    assert (strip.tiling.rows, strip.tiling.columns) == (2, 15)
    assert strip.patterns.rule == "graded" and strip.patterns.count == 5 and strip.patterns.group_columns == 3
    assert strip.patterns.scenario == "cylinder"
    sphere = load_spec(SPECS / "truncated-icosahedron.toml")
    assert sphere.patterns.polygons == ((6, "0x0488"), (5, "0x0508"))
    assert sphere.polygon_sides == (6, 5)


def test_defaults() -> None:
    spec = parse_spec(base())
    assert spec.plates.thickness == 2.0 and spec.plates.process == "print"
    assert spec.sleeve.wall == 1.2 and spec.sleeve.depth == 3.0 and spec.sleeve.margin == 1.0
    assert spec.formats == ("step", "stl", "glb", "3dm", "dxf", "svg", "bom", "png")
    assert spec.sheet.kerf == 0.0
    assert parse_spec(base(plates={"process": "laser"})).sheet.kerf == pytest.approx(0.15)
    from fabpat.exchange.cad import DEFAULT_CHORD

    assert spec.mesh_tolerance == DEFAULT_CHORD and spec.curve_tolerance == 0.01
    tuned = parse_spec(base(output={"mesh_tolerance": 0.05, "curve_tolerance": 0.002}))
    assert (tuned.mesh_tolerance, tuned.curve_tolerance) == (0.05, 0.002)


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"tiling": {"kind": "cube", "edge": 36.0}}, ["tiling.kind", "honeycomb-strip", "truncated-icosahedron"]),
        ({"tiling": {"kind": "honeycomb-strip", "rows": 1, "columns": 3}}, ["missing key tiling.edge"]),
        ({"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "columns": 3}}, ["missing key tiling.rows"]),
        ({"tiling": {"kind": "truncated-icosahedron", "edge": 36.0, "rows": 2}}, ["tiling.rows", "honeycomb-strip"]),
        ({"tiling": {"kind": "honeycomb-strip", "edge": -1, "rows": 1, "columns": 3}}, ["tiling.edge", "[1, 1000] mm"]),
        ({"patterns": {"pattern": "0x9999"}}, ["patterns.pattern", "0x9999", "unknown pattern"]),
        ({"patterns": {"pattern": "hello"}}, ["patterns.pattern", "not a pattern ID"]),
        ({"patterns": {}}, ["[patterns] needs one of", "groups"]),
        ({"patterns": {"pattern": "0x0488", "groups": ["0x0488"]}}, ["both"]),
        ({"patterns": {"groups": ["0x0488", "0x0508"], "group_columns": 1}}, ["patterns.groups", "3 groups"]),
        ({"patterns": {"rule": "random"}}, ["patterns.rule", "graded"]),
        ({"patterns": {"rule": "graded", "scenario": "twist"}}, ["patterns.scenario", "cylinder", "dome"]),
        ({"patterns": {"hexagon": "0x0488", "pentagon": "0x0508"}}, ["patterns.hexagon", "does not apply"]),
        ({"plates": {"process": "cnc"}}, ["plates.process", "print", "laser"]),
        ({"sleeve": {"clerance": 0.2}}, ["unknown key sleeve.clerance", "clearance, margin, wall, depth"]),
        ({"sheet": {"width": 170.0}}, ["missing key sheet.height"]),
        ({"sheet": {"width": 50.0, "height": 50.0}}, ["sheet.width × sheet.height", "smaller than a hexagon plate"]),
        ({"output": {"formats": ["step", "obj"]}}, ["output.formats", "'obj'", "step, stl, glb"]),
        ({"output": {"mesh_tolerance": 0}}, ["output.mesh_tolerance", "[1e-06, 10] mm"]),
        ({"output": {"curve_tolerance": "fine"}}, ["output.curve_tolerance", "number"]),
        ({"colour": "red"}, ["unknown key colour"]),
    ],
)
def test_bad_specs_name_the_key(change: dict, words: list[str]) -> None:
    with pytest.raises(SpecError) as e:
        parse_spec(base(**change), "x.toml")
    msg = str(e.value)
    lines = msg.splitlines()  # one line per problem, after a line counting them when there are several
    assert all(ln.startswith("x.toml: ") for ln in lines)
    assert len(lines) == 1 or lines[0] == f"x.toml: {len(lines) - 1} problems in the spec:", lines
    for w in words:
        assert w in msg


def test_missing_table_and_sphere_patterns() -> None:
    data = base()
    del data["sheet"]
    with pytest.raises(SpecError, match=r"missing table \[sheet\]"):
        parse_spec(data, need_sheet=True)  # fabpat assemble's
    assert parse_spec(data).sheet is None  # a simulation needs no sheet
    sphere = {"kind": "truncated-icosahedron", "edge": 36.0}
    with pytest.raises(SpecError, match="missing key patterns.pentagon"):
        parse_spec(base(tiling=sphere, patterns={"hexagon": "0x0488"}, sheet={"width": 600, "height": 400}))
    spec = parse_spec(base(tiling=sphere, patterns={"rule": "similar-energy"}, sheet={"width": 600, "height": 400}))
    assert spec.patterns.scenario == "dome"


def test_relative_catalog_path_is_next_to_the_spec(tmp_path: Path) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('[tiling]\nkind = "honeycomb-strip"\nedge = 36.0\nrows = 1\ncolumns = 4\n'
                    '[patterns]\nrule = "graded"\ncount = 2\ncatalog = "cat.sqlite"\n'
                    "[sheet]\nwidth = 600.0\nheight = 400.0\n")
    p = load_spec(spec).patterns
    assert p.catalog == str(tmp_path / "cat.sqlite") and p.group_columns == 2 and p.scenario == "cylinder"


def test_unreadable_and_invalid_toml(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="cannot read spec"):
        load_spec(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[tiling\nkind = 1\n")
    with pytest.raises(SpecError, match="invalid TOML"):
        load_spec(bad)


def test_spec_saved_with_a_utf8_bom_is_read(tmp_path: Path) -> None:
    """Windows editors (Notepad) save UTF-8 with a byte-order mark; tomllib refuses it at line 1."""
    text = (SPECS / "test-small.toml").read_text(encoding="utf-8")
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert bom.read_bytes()[:3] == b"\xef\xbb\xbf"
    plain = load_spec(SPECS / "test-small.toml")
    read = load_spec(bom)
    assert (read.name, read.tiling, read.patterns, read.sheet) == (plain.name, plain.tiling, plain.patterns,
                                                                    plain.sheet)


def test_sheet_border_key() -> None:
    assert parse_spec(base()).sheet.border is True
    assert parse_spec(base(sheet={"width": 170.0, "height": 90.0, "border": False})).sheet.border is False
    with pytest.raises(SpecError, match="sheet.border .* must be true or false"):
        parse_spec(base(sheet={"width": 170.0, "height": 90.0, "border": "no"}))


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


def _print_strip(**tables: dict) -> dict:
    return {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
            "patterns": {"pattern": "0x0488"}, "plates": {"process": "print"},
            "sheet": {"width": 600.0, "height": 400.0}, **tables}


@pytest.mark.parametrize("data, key", [
    (_print_strip(sheet={"width": 600.0, "height": 400.0, "kerf": 0.2}), "sheet.kerf"),
    (_print_strip(estimates={"cut_speed": 15.0}), "estimates.cut_speed"),
])
def test_laser_keys_do_not_apply_to_print(data: dict, key: str) -> None:
    with pytest.raises(SpecError, match=rf"{key} does not apply to plates.process = 'print'"):
        parse_spec(data, "s.toml")


def test_laser_keys_apply_to_laser_and_print_rate_to_both() -> None:
    data = _print_strip(sheet={"width": 600.0, "height": 400.0, "kerf": 0.2},
                        estimates={"cut_speed": 12.0, "print_rate": 2.0})
    data["plates"] = {"process": "laser"}
    spec = parse_spec(data, "s.toml")
    assert (spec.sheet.kerf, spec.estimates.cut_speed, spec.estimates.print_rate) == (0.2, 12.0, 2.0)
    assert parse_spec(_print_strip(estimates={"print_rate": 2.0}), "s.toml").estimates.print_rate == 2.0


def test_a_format_listed_twice_is_refused() -> None:
    with pytest.raises(SpecError, match="output.formats lists 'step' twice"):
        parse_spec(_print_strip(output={"formats": ["step", "stl", "step"]}), "s.toml")


def _leaf_keys(data: dict, prefix: tuple = ()) -> list[tuple]:
    out = []
    for k, v in data.items():
        if isinstance(v, dict):
            out += _leaf_keys(v, (*prefix, k))
        else:
            out.append((*prefix, k))
    return out


def _with(data: dict, key: tuple, value: object) -> dict:
    d = copy.deepcopy(data)
    t = d
    for k in key[:-1]:
        t = t[k]
    t[key[-1]] = value
    return d


GRADED = tomllib.loads((SPECS / "graded-strip.toml").read_text())


SPHERE = tomllib.loads((SPECS / "truncated-icosahedron.toml").read_text())


def _spec_numeric_keys() -> list[tuple[str, tuple]]:
    out = []
    for name, data in (("graded", GRADED), ("sphere", SPHERE)):
        for key in _leaf_keys(data):
            v = data
            for k in key:
                v = v[k]
            if isinstance(v, float) and key[0] != "patterns":
                out.append((name, key))
    return out


@pytest.mark.parametrize(("spec", "key"), _spec_numeric_keys())
def test_spec_numbers_use_the_same_ranges(spec: str, key: tuple) -> None:
    from fabpat.assembly.spec.load import parse_spec

    data = GRADED if spec == "graded" else SPHERE
    refused = 0
    for value in (math.nan, math.inf, -1.0, 1e308):
        with pytest.raises(SpecError) as e:
            parse_spec(_with(data, key, value), "s.toml")
        msg = str(e.value)
        assert "\n" not in msg and ".".join(key) in msg
        refused += 1
    assert refused == 4


@pytest.mark.parametrize(("key", "value", "words"), [
    (("output", "mesh_tolerance"), 1e-7, ["output.mesh_tolerance", "[1e-06, 10] mm"]),
    (("sheet", "width"), 1e12, ["sheet.width", "(0, 10000] mm"]),
    (("tiling", "columns"), 10**12, ["tiling.columns", "[1, 1000]"]),
])
def test_spec_sizes(key: tuple, value: float, words: list[str]) -> None:
    from fabpat.assembly.spec.load import parse_spec

    with pytest.raises(SpecError) as e:
        parse_spec(_with(GRADED, key, value), "s.toml")
    for w in words:
        assert w in str(e.value)


@pytest.mark.parametrize("cell", [["0x0488"], {"id": "0x0488"}])
def test_spec_cell_that_is_a_list_or_table(cell: object) -> None:
    from fabpat.assembly.spec.load import parse_spec

    data = copy.deepcopy(GRADED)
    data["patterns"] = {"tiles": [[cell] * data["tiling"]["columns"]] * data["tiling"]["rows"]}
    with pytest.raises(SpecError, match=r"patterns.tiles\[0\]\[0\]"):
        parse_spec(data, "s.toml")


@pytest.mark.parametrize("cell", [[1], {"a": 1}])
def test_every_spec_value_as_list_or_table(cell: object) -> None:
    from fabpat.assembly.spec.load import parse_spec

    for key in _leaf_keys(SPHERE):
        with pytest.raises(SpecError):
            parse_spec(_with(SPHERE, key, cell), "s.toml")
