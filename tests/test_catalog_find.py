"""Finding patterns in a catalog: per-polygon rows (--sides), filters, sort, top N, the stiffness-per-mass
column, and short reprs of the rows. Catalogs are written by hand (tests.test_catalog.fake_catalog)."""

from __future__ import annotations

import csv
import io
import json
import sqlite3
from pathlib import Path

import pytest

import fabpat
from fabpat.catalog import CatalogError, open_catalog
from fabpat.catalog.rows import find_rows, parse_condition
from fabpat.errors import PatternError
from fabpat.views.browse import page_data
from fabpat.views.plots import plot_catalog
from tests.helpers import invoke_result as invoke
from tests.test_catalog import fake_catalog

# filleted areas (fake_catalog): 850, 950, 1050, 1150 mm² in this order
HEX = {"0x0488": {"dome": 400.0, "cylinder": 30.0}, "0x0508": {"dome": 200.0, "cylinder": 20.0},
       "0x0588": {"dome": 100.0, "cylinder": 40.0}, "0x0688": {"dome": 300.0, "cylinder": 10.0}}
PENT = {"0x0508": {"dome": 150.0, "cylinder": 15.0}, "0x0788": {"dome": 90.0, "cylinder": 25.0}}


@pytest.fixture
def db(tmp_path: Path) -> Path:
    return fake_catalog(tmp_path / "c.sqlite", {6: HEX, 5: PENT})


def json_rows(*args: str) -> list[dict]:
    res = invoke("catalog", *args, "--format", "json")
    assert res.exit_code == 0, res.stderr
    return json.loads(res.stdout)


def one_line_error(args: tuple[str, ...], *words: str) -> str:
    res = invoke(*args)
    assert res.exit_code == 2 and res.stderr.startswith("fabpat: error:") and res.stderr.count("\n") == 1, res.output
    assert "Traceback" not in res.output and all(w in res.stderr for w in words), res.stderr
    return res.stderr


# -- each polygon its own rows --------------------------------------------------------------------------

def test_sides_selects_the_polygons_own_rows(db: Path) -> None:
    hexa = json_rows("--db", str(db))  # --sides 6 is the default
    assert [r["id"] for r in hexa] == list(HEX) and {r["sides"] for r in hexa} == {6}
    pent = json_rows("--db", str(db), "--sides", "5")
    assert {r["id"]: r["energy_dome"] for r in pent} == {"0x0508": 150.0, "0x0788": 90.0}
    long = list(csv.DictReader(io.StringIO(invoke("catalog", "--db", str(db), "--sides", "5", "--long",
                                                  "--format", "csv").stdout)))
    assert {(r["id"], r["scenario"], float(r["energy"])) for r in long} == {
        (pid, s, e) for pid, en in PENT.items() for s, e in en.items()}
    assert fabpat.catalog(db, sides=5)[0]["energy_dome"] == 150.0
    assert fabpat.catalog(db)[1]["energy_dome"] == 200.0  # the API's default polygon is the hexagon too
    assert len(fabpat.catalog(db, sides=None)) == 6


def test_a_polygon_the_catalog_lacks_names_the_sweep(tmp_path: Path) -> None:
    db = fake_catalog(tmp_path / "hex.sqlite", {6: HEX})
    for cmd in (("catalog",), ("catalog", "--long"), ("browse", "--out", str(tmp_path / "b.html")),
                ("plot", "--out", str(tmp_path / "figs"))):
        one_line_error((*cmd, "--db", str(db), "--sides", "5"), "no catalog energies for pentagons (sides = 5)",
                       f"run `fabpat sweep --sides 5 --db {db}`")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hex.sqlite"]
    with pytest.raises(CatalogError, match="fabpat sweep --sides 5"):
        fabpat.catalog(db, sides=5)
    tri = fake_catalog(tmp_path / "tri.sqlite", {3: {"0x0488": {"dome": 1.0}}})
    one_line_error(("catalog", "--db", str(tri)), "no catalog energies for hexagons (sides = 6)",
                   f"sweep --sides 6 --db {tri}", "it holds sides=3 depth=2 edge=36 thickness=2 weight=0.2")


def test_browse_and_plot_use_the_pentagon_rows(db: Path, tmp_path: Path) -> None:
    with open_catalog(db) as cat:
        data = page_data(cat, 5)
        assert data["ids"] == list(PENT) and data["setup"]["sides"] == 5
        assert data["values"]["energy_dome"] == [150.0, 90.0]
        plot_catalog(cat, tmp_path / "figs", ["0x0788"], sides=5)  # a pentagon-only ID: highlighted
        with pytest.raises(PatternError, match="0x0688"):
            plot_catalog(cat, tmp_path / "other", ["0x0688"], sides=5)  # a hexagon-only ID is not there
    res = invoke("browse", "--db", str(db), "--sides", "5", "--out", str(tmp_path / "b.html"))
    assert res.exit_code == 0 and "2 patterns" in res.stdout, res.output


# -- filters, sort, top ---------------------------------------------------------------------------------

def test_where_sort_top(db: Path) -> None:
    args = ("--db", str(db))
    assert [r["id"] for r in json_rows(*args, "--where", "energy_dome<300")] == ["0x0508", "0x0588"]
    assert [r["id"] for r in json_rows(*args, "--where", "energy_dome <= 300", "--where", "energy_cylinder>15")] \
        == ["0x0508", "0x0588"]
    assert [r["id"] for r in json_rows(*args, "--where", "energy_dome=200")] == ["0x0508"]
    assert [r["id"] for r in json_rows(*args, "--where", "energy_dome!=200", "--where", "energy_dome>=300")] \
        == ["0x0488", "0x0688"]
    assert [r["id"] for r in json_rows(*args, "--sort", "energy_dome")] == ["0x0588", "0x0508", "0x0688", "0x0488"]
    assert [r["id"] for r in json_rows(*args, "--sort", "-energy_dome")] == ["0x0488", "0x0688", "0x0508", "0x0588"]
    assert [r["id"] for r in json_rows(*args, "--sort=-energy_cylinder", "--top", "2")] == ["0x0588", "0x0488"]
    assert [r["id"] for r in json_rows(*args, "--top", "1")] == ["0x0488"]
    assert json_rows(*args, "--where", "energy_dome<1") == []
    table = invoke("catalog", *args, "--where", "max_displacement_dome<9", "--sort", "-specific_stiffness_dome")
    assert table.exit_code == 0 and "max_displacement_dome" in table.stdout and "specific_stiffness_dome" in \
        table.stdout  # the columns asked about are shown
    long = invoke("catalog", *args, "--long", "--where", "energy>=300", "--sort=-energy", "--format", "csv")
    assert [(r["id"], r["scenario"]) for r in csv.DictReader(io.StringIO(long.stdout))] == [
        ("0x0488", "dome"), ("0x0688", "dome")]
    rows = fabpat.catalog(db, where=["energy_dome<350"], sort="-energy_dome", top=2)
    assert [r["id"] for r in rows] == ["0x0688", "0x0508"]
    # an empty selection as CSV is still a CSV: the header line, no rows (a script reading it sees the columns)
    none = invoke("catalog", *args, "--where", "energy_dome<1", "--format", "csv")
    assert none.exit_code == 0
    lines = none.stdout.splitlines()
    assert len(lines) == 1 and lines[0].startswith("id,sides,depth,") and "energy_dome" in lines[0]


def test_rows_without_a_value_sort_last_and_fail_every_filter() -> None:
    rows = [{"id": "a", "e": None}, {"id": "b", "e": 2.0}, {"id": "c", "e": 1.0}, {"id": "d", "e": 2.0}]
    assert [r["id"] for r in find_rows(rows, ["e"], sort="e")] == ["c", "b", "d", "a"]
    assert [r["id"] for r in find_rows(rows, ["e"], sort="-e")] == ["b", "d", "c", "a"]  # ties keep their order
    assert [r["id"] for r in find_rows(rows, ["e"], where="e!=5")] == ["b", "c", "d"]


@pytest.mark.parametrize("option, text, words", [
    ("--where", "energy_dom<300", ["unknown field 'energy_dom'", "energy_S", "specific_stiffness_S",
                                   "(S: cylinder, dome)", "filleted_area"]),
    ("--where", "id=0x0488", ["unknown field 'id'", "energy_S"]),
    ("--where", "svg_path<1", ["unknown field 'svg_path'"]),
    ("--where", "energy_dome==300", ["unknown operator '=='", "< <= > >= = !="]),
    ("--where", "energy_dome~300", ["unknown operator '~'", "< <= > >= = !="]),
    ("--where", "energy_dome", ["not FIELD OP NUMBER", "< <= > >= = !="]),
    ("--where", "energy_dome<abc", ["'abc' is not a finite number"]),
    ("--where", "energy_dome<inf", ["'inf' is not a finite number"]),
    ("--where", "energy_dome<1; DROP TABLE results", ["is not a finite number"]),
    ("--where", "energy_dome<1_000", ["'1_000' is not a finite number in plain decimal notation"]),
    ("--where", "energy_dome<\uff13\uff10\uff10", ["is not a finite number in plain decimal notation"]),
    ("--sort", "colour", ["cannot sort by 'colour'", "energy_S", "-FIELD descending"]),
    ("--sort", "energy_dome ", ["cannot sort by 'energy_dome '", "no spaces around the name"]),
    ("--sort", " -energy_dome", ["cannot sort by ' -energy_dome'", "no spaces around the name"]),
    ("--top", "0", ["--top", "[1, 1000000]"]),
    ("--top", "x", ["--top", "not an integer"]),
])
def test_bad_finding_options_are_one_line(db: Path, option: str, text: str, words: list[str]) -> None:
    before = db.read_bytes()
    one_line_error(("catalog", "--db", str(db), option, text), *words)
    assert db.read_bytes() == before  # user text never reaches SQL
    with sqlite3.connect(db) as c:
        assert c.execute("SELECT COUNT(*) FROM results").fetchone()[0] == 12
    c.close()


def test_sort_by_id_both_ways(db: Path) -> None:
    args = ("--db", str(db), "--sort")
    assert [r["id"] for r in json_rows(*args, "id")] == ["0x0488", "0x0508", "0x0588", "0x0688"]
    assert [r["id"] for r in json_rows(*args, "-id", "--top", "2")] == ["0x0688", "0x0588"]
    assert "0x0688" in invoke("catalog", *args, "-id").stdout  # the table shows it too
    assert [r["id"] for r in fabpat.catalog(db, sort="-id")] == ["0x0688", "0x0588", "0x0508", "0x0488"]


def test_a_bad_sort_is_one_short_line_naming_the_columns_compactly(db: Path) -> None:
    # every column spelt out made a message of 482 characters, wrapped over lines in a terminal
    err = one_line_error(("catalog", "--db", str(db), "--sort=RANDOM()"), "cannot sort by 'RANDOM()'", "id, sides",
                         "min_width", "energy_S, max_displacement_S, specific_stiffness_S (S: cylinder, dome)")
    assert len(err) < 350, len(err)
    long = one_line_error(("catalog", "--db", str(db), "--long", "--sort", "x" * 5000), "cannot sort by")
    assert len(long) < 400, len(long)


def test_filters_that_keep_no_row_raise_naming_the_filter(db: Path) -> None:
    # the docs list "a filter that matches nothing" under CatalogError: never an empty list
    with pytest.raises(CatalogError, match=r"no pattern meets the filter 'energy_dome<50': energy_dome spans 100 "
                                           r"… 400 over the 4 patterns"):
        fabpat.catalog(db, where="energy_dome<50")
    with pytest.raises(CatalogError, match=r"all the filters 'energy_dome<150' and 'energy_cylinder<30' together"):
        fabpat.catalog(db, where=["energy_dome<150", "energy_cylinder<30"])
    assert [r["id"] for r in fabpat.catalog(db, where=["energy_dome<150"])] == ["0x0588"]
    assert json_rows("--db", str(db), "--where", "energy_dome<50") == []  # the command: an empty table or CSV


@pytest.mark.parametrize("kwargs, words", [
    ({"sides": float("nan")}, "sides must be a finite number, got nan"),
    ({"sides": float("inf")}, "sides must be a finite number"),
    ({"sides": 6.5}, "sides must be an integer in [3, 64], got 6.5"),
    ({"sides": 2}, "sides = 2 is out of range"),
    ({"edge": float("nan")}, "edge must be a finite number"),
    ({"where": 5}, "where must be a filter 'FIELD OP NUMBER' or a list of them, got 5"),
    ({"where": None}, "where must be a filter"),
])
def test_hostile_catalog_arguments_are_catalog_errors(db: Path, kwargs: dict, words: str) -> None:
    with pytest.raises(CatalogError) as err:
        fabpat.catalog(db, **kwargs)
    assert words in str(err.value) and "\n" not in str(err.value)
    assert len(fabpat.catalog(db, sides=6.0)) == 4  # a whole float is still the polygon


def test_match_energy_refuses_a_string_by_name(db: Path) -> None:
    from fabpat.catalog.family import match_energy

    for bad in ("x", None, float("nan"), -1.0, True):
        with pytest.raises(CatalogError, match="energy must be a positive number of N·mm"):
            match_energy("dome", bad, db=db)  # type: ignore[arg-type]
    with pytest.raises(CatalogError, match="min_width must be a finite number"):
        match_energy("dome", 100.0, db=db, min_width="wide")  # type: ignore[arg-type]


def test_api_finding_errors_are_catalog_errors(db: Path) -> None:
    for kwargs in ({"where": ["bogus<1"]}, {"where": [3]}, {"sort": "bogus"}, {"sort": 5}, {"top": 0},
                   {"top": 2.5}, {"top": True}):
        with pytest.raises(CatalogError) as err:
            fabpat.catalog(db, **kwargs)
        assert "\n" not in str(err.value)
    assert parse_condition(" energy_dome >= -2.5e2 ", ["energy_dome"]).value == -250.0
    with open_catalog(db) as cat:  # the low-level readers raise CatalogError too, not a bare ValueError
        for call in (lambda: cat.results(bogus=1), lambda: cat.pattern_rows(colour="red")):
            with pytest.raises(CatalogError, match="cannot filter by"):
                call()
    with pytest.raises(CatalogError, match="unknown scenario 'twist'"):
        fabpat.catalog.energies(db, "twist")


# -- stiffness per mass ---------------------------------------------------------------------------------

def test_specific_stiffness_is_one_over_energy_times_filleted_area(db: Path) -> None:
    rows = {r["id"]: r for r in json_rows("--db", str(db))}
    areas = {"0x0488": 850.0, "0x0508": 950.0, "0x0588": 1050.0, "0x0688": 1150.0}  # fake_catalog's, by hand
    for pid, en in HEX.items():
        for s, e in en.items():
            assert rows[pid][f"specific_stiffness_{s}"] == pytest.approx(1.0 / (e * areas[pid]), rel=1e-12)
    # the stiffest per gram in the Dome scenario, as the docs' one command finds it: 0x0588 (1/105000)
    best = json_rows("--db", str(db), "--sort=-specific_stiffness_dome", "--top", "1")
    assert [r["id"] for r in best] == ["0x0588"]
    # per gram is not per plate: 0x0688 is stiffer than 0x0488 in the Dome (300 < 400 N·mm) but heavier
    # (1150 against 850 mm²): 300 × 1150 = 345000 > 400 × 850 = 340000, so 0x0488 ranks before it
    by_energy = [r["id"] for r in json_rows("--db", str(db), "--sort", "energy_dome")]
    per_gram = [r["id"] for r in json_rows("--db", str(db), "--sort=-specific_stiffness_dome")]
    assert by_energy == ["0x0588", "0x0508", "0x0688", "0x0488"]
    assert per_gram == ["0x0588", "0x0508", "0x0488", "0x0688"]


def test_builtin_catalog_has_the_column_and_the_documented_command_runs() -> None:
    res = invoke("catalog", "--sort=-specific_stiffness_dome", "--top", "1", "--format", "json")
    assert res.exit_code == 0, res.stderr
    (best,) = json.loads(res.stdout)
    rows = fabpat.catalog()
    assert best["id"] == max(rows, key=lambda r: 1 / (r["energy_dome"] * r["filleted_area"]))["id"]


# -- short reprs ----------------------------------------------------------------------------------------

def test_catalog_rows_repr_is_short_and_says_what_it_holds() -> None:
    rows = fabpat.catalog()
    text = repr(rows)
    assert len(text) < 1500, len(text)  # the list's own repr is about 320 KB
    assert "430 patterns" in text and "catalog.sqlite" in text and "sides=6 depth=2 edge=36 mm" in text
    assert "energy_dome" in text and "specific_stiffness_dome" in text and "0x0488" not in text
    page = rows._repr_html_()
    assert len(page) < 10_000 and page.count("<tr>") == 1 + 10 and "first 10 of 430" in page
    assert "<th>energy_dome</th>" in page and "<td>0x0488</td>" in page
    assert list(rows) == rows and isinstance(rows[0], dict)  # still the plain list of dicts


def test_html_table_escapes_and_handles_few_rows() -> None:
    from fabpat.catalog.rows import CatalogRows

    rows = CatalogRows([{"id": "<b>x</b>", "sides": 6, "energy_dome": None}], source="a&b.sqlite")
    page = rows._repr_html_()
    assert "&lt;b&gt;x&lt;/b&gt;" in page and "<b>" not in page and "a&amp;b.sqlite" in page
    assert page.count("<tr>") == 2 and "first" not in page
    assert "1 patterns from a&b.sqlite" in repr(rows)
    assert repr(CatalogRows()).startswith("<CatalogRows: 0 patterns")


def test_catalog_depth_keeps_one_depth() -> None:
    import json

    from tests.helpers import invoke, one_line_error

    r = invoke("catalog", "--depth", "2", "--format", "json")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert len(rows) == 430 and {row["depth"] for row in rows} == {2}
    # the built-in catalog holds no depth-4 pattern: one line naming the depths it holds, as fabpat.catalog(depth=4)
    one_line_error(invoke("catalog", "--depth", "4", "--format", "json"), "holds depth 2, 3")
    one_line_error(invoke("catalog", "--depth", "0"), "--depth")
