"""The catalog database and the built-in catalog shipped with the package, and the one opening path of every
command that reads or writes a catalog: a damaged, foreign, locked, read-only or empty file, or a full disk,
is refused in one line naming the real cause, and the refused file is left byte-identical."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import random
import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest

from fabpat.catalog import CatalogError, builtin_path, energies, open_catalog, pipeline_modules, solver_version
from fabpat.catalog import sqlite_file as catalog_file  # the file-level helpers a test replaces
from fabpat.catalog.sweep import simulate_pattern
from fabpat.simulation.scenarios import SCENARIOS
from tests.helpers import SWEEP, digest, in_small_tmpfs, needs_unshare, one_line_error, tmpfs_error
from tests.helpers import invoke_result as invoke

REGENERATE = ("stale built-in catalog: regenerate it with `fabpat sweep --db fabpat/data/catalog.sqlite --family` "
              "for each polygon it holds (--sides 6, --sides 5)")


def test_builtin_catalog_is_the_default_library(hex_library) -> None:
    """The hexagons of the default set-up, and beside them, once swept, the pentagons of the same set-up
    (each polygon its own rows): every pattern of the library, mesh-converged, every solve converged."""
    from fabpat.patterns.library import enumerate_library

    default = {"depth": 2, "edge": 36.0, "thickness": 2.0, "weight": 0.2, "patterns": 430}
    with open_catalog() as cat:
        setups = [s for s in cat.setups() if s["depth"] == 2]  # the depth-3 patterns: tests/test_catalog_depths.py
        assert {"sides": 6, **default} in setups
        assert all(s == {"sides": s["sides"], **default} and s["sides"] in (5, 6) for s in setups), setups
        assert {(s["sides"], s["depth"]) for s in cat.setups()} == {(5, 2), (6, 2), (5, 3), (6, 3)}
        assert cat.scenarios() == list(SCENARIOS)
        polygons = {int(s["sides"]): (cat.pattern_rows(pictures=True, sides=s["sides"], depth=2),
                                      cat.results(sides=s["sides"], depth=2)) for s in setups}
    for sides, (rows, results) in polygons.items():
        library = hex_library if sides == 6 else enumerate_library(sides, 2)
        assert [r["id"] for r in rows] == sorted(library.ids)
        assert all(r["svg_path"] and r["min_width"] > 0 for r in rows)
        assert len(results) == 3 * 430
        assert {(r["E"], r["nu"], r["nonlinear"]) for r in results} == {(1000.0, 0.35, 1)}  # PLA, nonlinear
        assert len({r["solver_version"] for r in results}) == 1
        # mesh-converged: every energy extrapolated from a mesh of h = 2.5 mm and its nested refinement, finer
        # (1.1 × min_width, rounded down) for patterns with necks narrower than 2.27 mm (docs/accuracy.md)
        min_width = {r["id"]: r["min_width"] for r in rows}
        expected = {r["id"]: min(2.5, math.floor(1.1 * min_width[r["id"]] * 100 * (1 + 1e-12)) / 100) for r in results}
        assert all(r["h"] == pytest.approx(expected[r["id"]], abs=1e-12) and r["h_fine"] == r["h"] / 2
                   for r in results)
        failed = [f"{r['id']} {r['scenario']}: {r['error']}" for r in results if not r["converged"]]
        assert not failed, failed[:3]
        for s in SCENARIOS:
            e = energies(None, s, sides)
            assert len(e) == 430 and min(e.values()) > 0
    hexagons, hex_results = polygons[6]
    assert all(r["min_width"] > 1.5 for r in hexagons)  # notes: necks ≈ 1.95 mm at the narrowest
    assert {r["h"] for r in hex_results} == {2.5, 2.47, 2.14}  # necks of 1.95 and 2.25 mm (notes)
    # the notes' solid hexagon (the stiffest possible plate) has cantilever energy 2.6 N·mm: every pattern,
    # having less material, is softer
    assert min(energies(None, "cantilever").values()) > 2.6


def test_builtin_rows_recompute_to_the_same_numbers() -> None:
    """Three random result rows (one per scenario) recomputed now agree with the shipped ones."""
    seed = int(os.environ.get("FABPAT_CATALOG_SEED", "2024"))
    rng = random.Random(seed)
    with open_catalog() as cat:
        rows = [rng.choice(cat.results(scenario=s)) for s in SCENARIOS]
        pats = {(r["id"], r["sides"]): r for r in cat.pattern_rows()}
    for r in rows:
        new = simulate_pattern(r["id"], r["sides"], r["depth"], r["edge"], r["thickness"], r["weight"], r["E"],
                               r["nu"], r["h"], [r["scenario"]], extrapolate=r["h_fine"] is not None)
        p, q = new
        where = f"{r['id']} {r['scenario']} (seed {seed}); {REGENERATE}"
        assert q["converged"] == 1, where
        assert q["energy"] == pytest.approx(r["energy"], rel=1e-6), where
        assert q["max_displacement"] == pytest.approx(r["max_displacement"], rel=1e-6), where
        assert q["nodes"] == r["nodes"], where
        for k in ("area", "perimeter", "polar_moment", "filleted_area", "filleted_polar_moment", "min_width"):
            assert p[k] == pytest.approx(pats[r["id"], r["sides"]][k], rel=1e-9), f"{k}: {where}"


def test_builtin_version_is_reported() -> None:
    with open_catalog() as cat:
        stored = cat.query("SELECT DISTINCT solver_version FROM results")[0]["solver_version"]
    assert stored.startswith("fabpat ") and solver_version().startswith("fabpat ")


def test_builtin_catalog_was_computed_by_this_code() -> None:
    """Every row carries the digest of the pipeline that ships: a sweep into a copy of the built-in
    catalog then recomputes nothing, and a changed solver (or mesher) cannot ship with old numbers."""
    with open_catalog() as cat:
        stored = {r["solver_version"] for r in cat.query("SELECT DISTINCT solver_version FROM results")}
        members = {r["solver_version"] for r in cat.query("SELECT DISTINCT solver_version FROM family")}
    assert stored == {solver_version()}, REGENERATE
    assert members <= {solver_version()}, REGENERATE  # the family members too (fabpat sweep --family)


def test_solver_version_covers_exactly_the_pipeline_code() -> None:
    names = {p.relative_to(builtin_path().parents[1]).as_posix() for p in pipeline_modules()}
    assert {"geometry/fillet.py", "simulation/mesh.py", "simulation/scenarios.py", "shell/solve.py", "shell/element.py",
            "shell/__init__.py", "patterns/lattice.py", "geometry/curves.py", "__init__.py"} <= names
    assert not {n for n in names if n.startswith(("cli/", "catalog/", "views/"))}
    assert solver_version() == solver_version() and solver_version().startswith("fabpat ")


CODE = '''"""Module docstring."""
import math  # why: a comment
X = "é"; """the attribute's documentation, after a non-ASCII string on its line"""


def f(a: int = 1) -> float:
    """A docstring
    over two lines."""
    s = "# not a comment"  # a comment
    return math.sqrt(a)
'''.replace("sqrt(a)\n", "sqrt(a)   \n")  # trailing space: stripped too


def test_code_text_leaves_out_comments_and_docstrings_only() -> None:
    from fabpat.catalog.version import code_text

    assert code_text(CODE) == ('import math\nX = "é";\ndef f(a: int = 1) -> float:\n'
                               '    s = "# not a comment"\n    return math.sqrt(a)')
    reworded = CODE.replace("A docstring", "Another explanation").replace("a comment\n", "why, again\n")
    assert code_text(reworded) == code_text(CODE)
    for change in (("a: int = 1", "a: int = 2"), ("math.sqrt", "math.exp"), ('"# not a comment"', '"#"')):
        assert code_text(CODE.replace(*change)) != code_text(CODE), change


def _pipeline_sources() -> dict[str, str]:
    base = builtin_path().parents[1]
    return {p.relative_to(base).as_posix(): p.read_text(encoding="utf-8") for p in pipeline_modules()}


def _moved(sources: dict[str, str], name: str, new_module: str) -> dict[str, str]:
    """``sources`` with geometry/outline.py's top-level function ``name`` cut into a new module ``new_module`` that
    has outline.py's imports, and imported back into outline.py from there."""
    import ast

    text = sources["geometry/outline.py"]
    node = next(n for n in ast.parse(text).body if isinstance(n, ast.FunctionDef) and n.name == name)
    lines = text.splitlines()
    body = "\n".join(lines[node.lineno - 1:node.end_lineno])
    head = "\n".join(ln for ln in lines if ln.startswith(("import ", "from ")))
    rest = lines[:node.lineno - 1] + lines[node.end_lineno:]
    rest.insert(next(i for i, ln in enumerate(rest) if ln.startswith("from fabpat")),
                f"from fabpat.geometry.{new_module} import {name}")
    out = dict(sources)
    out["geometry/outline.py"] = "\n".join(rest) + "\n"
    out[f"geometry/{new_module}.py"] = f'"""Moved."""\n{head}\n\n\n{body}\n'
    return out


def test_moving_code_between_modules_keeps_the_solver_digest() -> None:
    """A function cut from one pipeline module into another (imports adjusted), or an import from another
    module path, hashes the same; a changed statement, or an import switched to another module's
    definition of a name two modules define, does not."""
    from fabpat.catalog.version import ambiguous_names, program_digest

    src = _pipeline_sources()
    before = program_digest(list(src.values()))
    moved = _moved(src, "flattening_tolerance", "tolerances")
    assert program_digest(list(moved.values())) == before
    split = dict(moved)
    seg = "geometry/segments.py"
    split[seg] = moved[seg].replace("from functools import cached_property, lru_cache\n",
                                    "from functools import lru_cache\n")
    assert split != moved and program_digest(list(split.values())) == before  # cached_property is bound elsewhere
    renamed = {k: v.replace("from fabpat.errors import", "from fabpat.core.errors import") for k, v in src.items()}
    assert renamed != src and program_digest(list(renamed.values())) == before
    changed = dict(moved)
    changed["geometry/tolerances.py"] = changed["geometry/tolerances.py"].replace("0 < value", "0 <= value")
    assert changed != moved and program_digest(list(changed.values())) != before
    assert "_subdivide" in ambiguous_names(list(src.values()))  # defined in mesh.py and polyline.py
    switched = dict(src)
    mesh = "simulation/mesh.py"
    switched[mesh] = src[mesh].replace("from fabpat.geometry.polyline import _subdivide",
                                       "from fabpat.simulation.mesh import _subdivide")
    assert switched != src and program_digest(list(switched.values())) != before


def fake_rows(pattern_id: str, sides: int, energies: dict[str, object], *, area: float = 1000.0,
              thickness: float = 2.0, **result: object) -> list[dict[str, object]]:
    """A pattern's catalog rows written by hand (no solve): one ``patterns`` row with plausible metrics and
    a converged ``results`` row per scenario of ``energies`` (N·mm; ``result`` overrides other columns)."""
    key = {"id": pattern_id, "sides": sides, "depth": 2, "edge": 36.0, "thickness": thickness, "weight": 0.2}
    rows: list[dict[str, object]] = [
        {"table": "patterns", **key, "area": area, "perimeter": 300.0, "ratio": 0.14, "polar_moment": 4.0e5,
         "filleted_area": area + 50.0, "filleted_perimeter": 290.0, "filleted_ratio": 0.15,
         "filleted_polar_moment": 4.2e5, "min_width": 2.0, "input_hash": "x"}]
    for s, e in energies.items():
        rows.append({"table": "results", **key, "scenario": s, "E": 1000.0, "nu": 0.35, "h": 2.5, "nonlinear": 1,
                     "energy": e, "max_displacement": 3.0, "converged": 1, "solver_version": "test",
                     "input_hash": "x", "computed_at": "now", **result})
    return rows


def fake_catalog(path: Path, table: dict[int, dict[str, dict[str, object]]], thickness: float = 2.0) -> Path:
    """A catalog of hand-made rows: ``{sides: {ID: {scenario: energy}}}`` (see :func:`fake_rows`)."""
    with open_catalog(path, write=True) as cat:
        for sides, by_id in table.items():
            for k, (pid, en) in enumerate(by_id.items()):
                cat.write_rows(fake_rows(pid, sides, en, area=800.0 + 100 * k, thickness=thickness))
        cat.finish()
    return path


def _tiny(path: Path) -> Path:
    rows = simulate_pattern("0xf608", 6, 2, 36.0, 2.0, 0.2, 1000.0, 0.35, 1.5, [])  # geometry only: fast
    rows.append({"table": "results", "id": "0xf608", "sides": 6, "depth": 2, "edge": 36.0, "thickness": 2.0,
                 "weight": 0.2, "scenario": "dome", "E": 1000.0, "nu": 0.35, "h": 1.5, "nonlinear": 1,
                 "energy": 140.0, "max_displacement": 4.5, "converged": 1, "solver_version": "test",
                 "input_hash": "x", "computed_at": "now"})
    with open_catalog(path, write=True) as cat:
        cat.write_rows(rows)
        cat.finish()
    return path


def test_read_api_plain_rows(tmp_path: Path) -> None:
    db = _tiny(tmp_path / "c.sqlite")
    with open_catalog(db) as cat:
        (row,) = cat.pattern_rows()
        assert row["id"] == "0xf608" and row["energy_dome"] == 140.0 and row["converged_dome"] is True
        assert "energy_cantilever" not in row  # scenarios that were never run are not columns
        assert cat.query("SELECT COUNT(*) AS n FROM results WHERE scenario = ?", ["dome"]) == [{"n": 1}]
        assert energies(cat, "dome") == {"0xf608": 140.0}
        assert energies(cat, "cylinder") == {}
        with pytest.raises(ValueError, match="cannot filter"):
            cat.pattern_rows(colour="red")
        with pytest.raises(CatalogError, match="read-only"):
            cat.write_rows([])
    assert energies(db, "dome", 6) == {"0xf608": 140.0}
    assert energies(db, "dome", 5) == {}
    with pytest.raises(ValueError, match="unknown scenario"):
        energies(db, "twist")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.sqlite"]  # readers create no -wal/-shm files


def test_open_errors(tmp_path: Path) -> None:
    with pytest.raises(CatalogError, match="does not exist"):
        open_catalog(tmp_path / "missing.sqlite")
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(os.urandom(4096))
    with pytest.raises(CatalogError, match="not a fabpat catalog"):
        open_catalog(junk)
    with pytest.raises(CatalogError, match="not a fabpat catalog"):
        open_catalog(junk, write=True)
    with pytest.raises(CatalogError, match="cannot create catalog"):  # a folder that takes no files
        open_catalog("/proc/fabpat-test.sqlite", write=True)
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as c:
        c.execute("CREATE TABLE t (x)")
    with pytest.raises(CatalogError, match="not a fabpat catalog"):
        open_catalog(other)
    db = _tiny(tmp_path / "c.sqlite")
    with sqlite3.connect(db) as c:
        c.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    with pytest.raises(CatalogError, match="schema 99"):
        open_catalog(db)
    with pytest.raises(CatalogError, match="read-only"):
        open_catalog(None, write=True)
    assert builtin_path().name == "catalog.sqlite"


def test_cli_catalog_formats(tmp_path: Path) -> None:
    res = invoke("catalog", "--format", "json")
    assert res.exit_code == 0, res.stderr
    rows = json.loads(res.stdout)
    assert len(rows) == 430 and {"energy_cantilever", "energy_cylinder", "energy_dome", "min_width"} <= set(rows[0])
    db = _tiny(tmp_path / "c.sqlite")
    res = invoke("catalog", "--db", str(db), "--format", "csv", "--long")
    (row,) = list(csv.DictReader(io.StringIO(res.stdout)))
    assert row["scenario"] == "dome" and float(row["energy"]) == 140.0
    res = invoke("catalog", "--db", str(db))
    assert res.exit_code == 0 and "0xf608" in res.stdout and "energy_dome" in res.stdout
    res = invoke("catalog", "--db", str(tmp_path / "nope.sqlite"))
    assert res.exit_code == 2 and res.stderr.startswith("fabpat: error:") and res.stderr.count("\n") == 1


def _stamped_catalog(path: Path, version: str, every_neck_narrow: bool = False) -> Path:
    """A catalog of one pattern's rows with the input hashes a sweep under ``version`` stores: set-up mesh
    2.5 mm (extrapolated with 1.25 mm); the Dome row used 2.14 mm, as a narrow neck makes it (every row,
    as in a depth-3 sample, with ``every_neck_narrow``)."""
    from fabpat.catalog.sweep import pattern_hash, result_hash

    rows = fake_rows("0x0488", 6, {"dome": 430.0, "cylinder": 40.0})
    for r in rows:
        key = (r["id"], r["sides"], 2, 36.0, 2.0, 0.2)
        if r["table"] == "patterns":
            r["input_hash"] = pattern_hash(*key, version)  # type: ignore[arg-type]
        else:
            r.update(solver_version=version, h_fine=1.25, input_hash=result_hash(
                *key, 1000.0, 0.35, 2.5, r["scenario"], version, 1.25))  # type: ignore[arg-type]
            if r["scenario"] == "dome" or every_neck_narrow:
                r.update(h=2.14, h_fine=1.07)
    with open_catalog(path, write=True) as cat:
        cat.write_rows(rows)
        cat.finish()
    return path


def test_restamp_rewrites_every_hash_for_the_new_version(tmp_path: Path) -> None:
    import sqlite3

    from fabpat.catalog.restamp import restamp
    from fabpat.catalog.sweep import pattern_hash, result_hash

    db = _stamped_catalog(tmp_path / "c.sqlite", "fabpat old")
    report = restamp(db, "fabpat old", "fabpat new")
    assert report.rows == {"patterns": 1, "results": 2, "family": 0}
    con = sqlite3.connect(db)
    key = ("0x0488", 6, 2, 36.0, 2.0, 0.2)
    assert con.execute("SELECT input_hash FROM patterns").fetchall() == [(pattern_hash(*key, "fabpat new"),)]
    got = dict(con.execute("SELECT scenario, input_hash FROM results").fetchall())
    assert got == {s: result_hash(*key, 1000.0, 0.35, 2.5, s, "fabpat new", 1.25) for s in ("dome", "cylinder")}
    assert con.execute("SELECT DISTINCT solver_version FROM results").fetchall() == [("fabpat new",)]
    assert con.execute("SELECT energy FROM results WHERE scenario = 'dome'").fetchall() == [(430.0,)]


def test_restamp_finds_the_set_up_mesh_when_no_row_stores_it(tmp_path: Path) -> None:
    from fabpat.catalog.restamp import restamp

    db = _stamped_catalog(tmp_path / "c.sqlite", "fabpat old", every_neck_narrow=True)  # no row at h = 2.5
    assert restamp(db, "fabpat old", "fabpat new").rows == {"patterns": 1, "results": 2, "family": 0}


def test_restamp_refuses_rows_stored_under_another_version_and_writes_nothing(tmp_path: Path) -> None:
    from fabpat.catalog.restamp import restamp

    db = _stamped_catalog(tmp_path / "c.sqlite", "fabpat other")
    before = db.read_bytes()
    with pytest.raises(CatalogError, match="its input hash is not the one 'fabpat old' gives its inputs"):
        restamp(db, "fabpat old", "fabpat new")
    assert db.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["c.sqlite"]
    with pytest.raises(CatalogError, match="no such catalog file"):
        restamp(tmp_path / "none.sqlite", "a", "b")


def commands(db: Path, tmp: Path) -> dict[str, tuple[str, ...]]:
    """The four commands that open a catalog, each as one CLI call on ``db``."""
    return {"sweep": (*SWEEP, "--db", str(db)), "catalog": ("catalog", "--db", str(db)),
            "browse": ("browse", "--db", str(db), "--out", str(tmp / "b.html")),
            "plot": ("plot", "--db", str(db), "--out", str(tmp / "figures"))}


def copy_of(db: Path, tmp: Path, name: str = "c.sqlite") -> Path:
    out = tmp / name
    shutil.copy(db, out)
    return out


def assert_refused_unchanged(db: Path, tmp: Path, *words: str) -> None:
    """Every catalog command refuses ``db`` with one line, and the file is byte-identical afterwards."""
    before = digest(db)
    for name, args in commands(db, tmp).items():
        res = invoke(*args)
        one_line_error(res, *words)
        assert digest(db) == before, f"{name} changed the refused file"
        assert sorted(p.name for p in tmp.iterdir()) == [db.name], f"{name} left {list(tmp.iterdir())}"


@pytest.mark.parametrize("offset", [0, 4096, 12288])
def test_damaged_catalog_one_line_everywhere(small_catalog: Path, tmp_path: Path, offset: int) -> None:
    db = copy_of(small_catalog, tmp_path)
    with db.open("r+b") as f:  # 8 KiB overwritten: the header (0) or b-tree pages
        f.seek(offset)
        f.write(bytes(range(256)) * 32)
    assert_refused_unchanged(db, tmp_path, ".recover" if offset else "not a fabpat catalog")


@pytest.mark.parametrize("sql, words", [
    ("DROP TABLE results", ("damaged", "table results is missing")),
    ("ALTER TABLE results DROP COLUMN energy", ("damaged", "no column energy")),
    ("ALTER TABLE patterns DROP COLUMN svg_path", ("damaged", "no column svg_path")),
])
def test_missing_table_or_column(small_catalog: Path, tmp_path: Path, sql: str, words: tuple[str, ...]) -> None:
    db = copy_of(small_catalog, tmp_path)
    with sqlite3.connect(db) as c:
        c.execute(sql)
    c.close()
    assert_refused_unchanged(db, tmp_path, *words)


def test_foreign_sqlite_file_gets_no_tables(tmp_path: Path) -> None:
    db = tmp_path / "mine.sqlite"
    with sqlite3.connect(db) as c:
        c.execute("CREATE TABLE recipes (name TEXT)")
        c.execute("INSERT INTO recipes VALUES ('bread')")
    c.close()
    assert_refused_unchanged(db, tmp_path, "not a fabpat catalog", "recipes")
    with sqlite3.connect(db) as c:
        assert [r[0] for r in c.execute("SELECT name FROM sqlite_master")] == ["recipes"]
    c.close()


def test_other_schema_is_refused_before_any_change(small_catalog: Path, tmp_path: Path) -> None:
    db = copy_of(small_catalog, tmp_path)
    with sqlite3.connect(db) as c:
        c.execute("UPDATE meta SET value = '2' WHERE key = 'schema_version'")
    c.close()
    assert db.read_bytes()[18:20] == b"\x01\x01"  # rollback-journal mode (WAL would be 2, 2)
    assert_refused_unchanged(db, tmp_path, "schema 2", "expected 1")
    assert db.read_bytes()[18:20] == b"\x01\x01"


def test_a_file_that_is_not_sqlite(tmp_path: Path) -> None:
    db = tmp_path / "notes.sqlite"
    db.write_text("shopping list\n" * 100)
    assert_refused_unchanged(db, tmp_path, "not a fabpat catalog", "not an SQLite database")


def test_locked_catalog_is_called_locked(small_catalog: Path, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(catalog_file, "LOCK_TIMEOUT", 0.2)
    db = copy_of(small_catalog, tmp_path)
    holder = sqlite3.connect(db, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")  # another program (sqlite3 shell, a stuck writer) holds the file
    try:
        with pytest.raises(CatalogError, match="locked"):
            open_catalog(db)
        with pytest.raises(CatalogError, match="locked"):
            open_catalog(db, write=True)
        for name in ("sweep", "catalog"):
            res = invoke(*commands(db, tmp_path)[name])
            one_line_error(res, "locked")
            assert "not a fabpat catalog" not in res.stderr
    finally:
        holder.execute("ROLLBACK")
        holder.close()


def test_read_only_catalog_is_called_read_only(small_catalog: Path, tmp_path: Path) -> None:
    db = copy_of(small_catalog, tmp_path)
    if os.geteuid() != 0:  # root writes to any file: then the read-only mount below is the test
        db.chmod(0o444)
        before = digest(db)
        one_line_error(invoke(*commands(db, tmp_path)["sweep"]), "read-only")
        assert digest(db) == before
        assert invoke("catalog", "--db", str(db)).exit_code == 0  # reading a read-only catalog is fine
    ro = sqlite3.connect(f"{db.as_uri()}?mode=ro", uri=True)
    with pytest.raises(sqlite3.OperationalError) as err:
        ro.execute("CREATE TABLE x (y)")  # SQLite's read-only error, as a read-only file or mount gives it
    ro.close()
    assert catalog_file._cause(err.value, db, "write to").args[0].startswith(f"catalog {db} is read-only")


@needs_unshare
def test_read_only_mount(small_catalog: Path, tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    db = copy_of(small_catalog, ro)
    before = digest(db)
    env = dict(os.environ, FABPAT_CACHE="off")
    from tests.conftest import FABPAT

    fab = " ".join(FABPAT)
    script = (f"mount --bind {ro} {ro} && mount -o remount,ro,bind {ro} && "
              f"{fab} {' '.join(SWEEP)} --db {db}; echo rc=$?; {fab} catalog --db {db} --format csv > /dev/null; "
              "echo rc=$?")
    res = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, env=env, timeout=120)
    assert res.stdout.split() == ["rc=2", "rc=0"], (res.stdout, res.stderr)
    one_line_error(subprocess.CompletedProcess([], 2, "", res.stderr), "read-only")
    assert "not a fabpat catalog" not in res.stderr
    assert digest(db) == before


def test_disk_full_while_storing_keeps_the_committed_rows(tmp_path: Path) -> None:
    """SQLite's own full-disk error (SQLITE_FULL), reached with max_page_count: runs without a tmpfs."""
    from fabpat.catalog.sweep import simulate_pattern

    db = tmp_path / "c.sqlite"
    rows = [simulate_pattern(pid, 6, 2, 36.0, 2.0, 0.2, 1000.0, 0.35, 1.5, [])  # geometry only: fast
            for pid in ("0x0488", "0x0508", "0x0588", "0x0688", "0x0708", "0x0788")]
    stored = 0
    with open_catalog(db, write=True) as cat:
        pages = cat.conn.execute("PRAGMA page_count").fetchone()[0]
        cat.conn.execute(f"PRAGMA max_page_count = {pages + 2}")
        with pytest.raises(CatalogError, match="disk is full") as err:
            for r in rows:
                cat.write_rows(r)
                stored += 1
    assert 0 < stored < len(rows)
    assert "every row committed before is kept" in str(err.value)
    with sqlite3.connect(db) as c:
        assert c.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
        assert c.execute("SELECT COUNT(*) FROM patterns").fetchone()[0] == stored
    c.close()


@needs_unshare
def test_disk_full_mid_sweep(tmp_path: Path) -> None:
    """A real full disk (a 96 KiB tmpfs): one line, the committed patterns survive, integrity ok."""
    disk = tmp_path / "disk"
    # No progress line: on a loaded machine the 5 s interval passes before the disk fills, and a progress line
    # above the error would hide whether the error itself is one line.
    res = in_small_tmpfs(disk, "FABPAT_PROGRESS_INTERVAL=86400 $FAB sweep --sample 30 --h 8 --workers 1 "
                               "--db disk/c.sqlite; echo rc=$?; "
                               "cp disk/c.sqlite c.sqlite; ls -A disk", size="96k")
    lines = res.stdout.split()
    assert lines[0] == "rc=2", (res.stdout, res.stderr)
    assert lines[1:] == ["c.sqlite"]  # no -wal, -shm or temporary file left on the full disk
    one_line_error(subprocess.CompletedProcess([], 2, "", res.stderr), "disk is full")
    with sqlite3.connect(tmp_path / "c.sqlite") as c:
        assert c.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
        n = c.execute("SELECT COUNT(*) FROM patterns").fetchone()[0]
        assert 0 < n < 30
        assert c.execute("SELECT COUNT(*) FROM results").fetchone()[0] == 3 * n  # whole patterns only
    c.close()
    with open_catalog(tmp_path / "c.sqlite") as cat:  # still a sound catalog
        assert len(cat.pattern_rows()) == n


@needs_unshare
def test_new_catalog_on_a_full_disk_leaves_no_file(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "dd if=/dev/zero of=disk/fill bs=1k count=200 2>/dev/null; "
                               f"$FAB {' '.join(SWEEP)} --db disk/c.sqlite; echo rc=$?; ls -A disk")
    assert res.stdout.split() == ["rc=2", "fill"], (res.stdout, res.stderr)
    one_line_error(subprocess.CompletedProcess([], 2, "", res.stderr), "cannot create catalog", "disk is full")


def test_new_catalog_appears_only_complete(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A failure while the new catalog is built (here: its tables) leaves neither it nor a temporary file."""
    monkeypatch.setattr(catalog_file, "_create_sql", lambda: ["CREATE TABLE meta (key TEXT)", "NOT SQL"])
    with pytest.raises(CatalogError, match="cannot create catalog"):
        open_catalog(tmp_path / "c.sqlite", write=True)
    assert list(tmp_path.iterdir()) == []


def test_readers_never_write(small_catalog: Path, tmp_path: Path) -> None:
    db = copy_of(small_catalog, tmp_path)
    before = digest(db)
    for args in (("catalog", "--db", str(db), "--format", "csv"), ("browse", "--db", str(db), "--out",
                                                                    str(tmp_path / "b.html"))):
        res = invoke(*args)
        assert res.exit_code == 0, res.stderr
    assert digest(db) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.html", "c.sqlite"]  # no -wal, -shm, journal


@needs_unshare
def test_full_disk_mid_sweep_says_so_and_leaves_one_file(small_catalog: Path, tmp_path: Path) -> None:
    """The catalog on a tmpfs with 16 KiB free: WAL's -shm index cannot grow. One line, no -wal/-shm."""
    shutil.copy(small_catalog, tmp_path / "c0.db")
    size = small_catalog.stat().st_size // 1024 + 4 + 16
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "cp c0.db disk/c.db && $FAB sweep --sample 12 --h 8 --workers 1 --db disk/c.db; "
                               "echo rc=$?; cp disk/c.db c.db; ls -A disk", size=f"{size}k")
    assert res.stdout.split() == ["rc=2", "c.db"], (res.stdout, res.stderr)
    one_line_error(tmpfs_error(res), "cannot store results in catalog disk/c.db: the disk is full")
    with sqlite3.connect(tmp_path / "c.db") as c:
        assert c.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
        assert c.execute("PRAGMA journal_mode").fetchone()[0] == "delete"  # one file, opens read-only anywhere
        assert c.execute("SELECT COUNT(*) FROM patterns").fetchone()[0] >= 2
    c.close()


@needs_unshare
def test_new_catalog_without_rows_is_not_left_on_a_full_disk(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "$FAB sweep --sample 2 --h 6 --workers 1 --db disk/new.db; echo rc=$?; ls -A disk")
    assert res.stdout.split() == ["rc=2"], (res.stdout, res.stderr)
    one_line_error(tmpfs_error(res), "catalog disk/new.db", "the disk is full")


def test_a_new_catalog_is_removed_when_its_sweep_fails_before_a_row(tmp_path: Path) -> None:
    new, empty = tmp_path / "new.db", tmp_path / "empty.db"
    empty.write_bytes(b"")
    for db in (new, empty):
        with pytest.raises(RuntimeError), open_catalog(db, write=True):
            raise RuntimeError("the first pattern failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.db"]  # the user's empty file stays as it was
    assert empty.stat().st_size == 0


def test_a_catalog_in_use_elsewhere_keeps_its_wal(small_catalog: Path, tmp_path: Path) -> None:
    """The -wal/-shm clean-up happens only under SQLite's exclusive lock: never under another reader."""
    db = tmp_path / "c.db"
    shutil.copy(small_catalog, db)
    other = sqlite3.connect(db)
    other.execute("PRAGMA journal_mode=WAL")
    other.execute("SELECT COUNT(*) FROM patterns").fetchone()
    with pytest.raises(RuntimeError), open_catalog(db, write=True):
        raise RuntimeError("boom")
    assert (tmp_path / "c.db-wal").exists() and (tmp_path / "c.db-shm").exists()
    assert other.execute("SELECT COUNT(*) FROM patterns").fetchone()[0] == 2  # the reader is unharmed
    other.close()
    assert db.exists()


def test_an_empty_db_is_an_empty_file_everywhere(tmp_path: Path) -> None:
    """Readers: "empty file" (not "damaged", no .recover); sweep makes the catalog in it, as in a missing file."""
    db = tmp_path / "e.db"
    db.write_bytes(b"")
    for args in (("catalog",), ("browse", "--out", str(tmp_path / "b.html")), ("plot", "--out", str(tmp_path / "f"))):
        res = invoke(*args, "--db", str(db))
        one_line_error(res, "is an empty file", "fabpat sweep --db")
        assert "recover" not in res.stderr and "damaged" not in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.db"] and db.stat().st_size == 0
    with open_catalog(db, write=True) as cat:
        assert cat.pattern_rows() == []
    with open_catalog(db) as cat:  # now a catalog
        assert cat.scenarios() == []
    (tmp_path / "e2.db").write_bytes(b"")
    with pytest.raises(CatalogError, match="empty file"):
        open_catalog(tmp_path / "e2.db")


def test_a_new_catalog_open_elsewhere_is_not_removed(tmp_path: Path) -> None:
    """The failed sweep's new catalog is removed only under SQLite's exclusive lock."""
    db = tmp_path / "new.db"
    with pytest.raises(RuntimeError), open_catalog(db, write=True) as cat:
        cat.finish()  # back in rollback-journal mode, as after a sweep's end
        other = sqlite3.connect(db)
        other.execute("BEGIN")
        other.execute("SELECT COUNT(*) FROM patterns").fetchone()  # a reader holds its shared lock
        raise RuntimeError("boom")
    assert db.exists()
    other.close()
