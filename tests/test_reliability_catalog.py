"""Issue 15 §8, catalogs: one opening path that changes no file it refuses and names the real cause."""

from __future__ import annotations

import hashlib
import os
import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from fabpat.catalog import CatalogError, open_catalog
from fabpat.catalog import sqlite_file as catalog_file  # the file-level helpers a test replaces
from tests.test_reliability_files import in_small_tmpfs, needs_unshare, one_line_error

SWEEP = ("sweep", "--sample", "2", "--h", "8", "--workers", "1")


def invoke(*args: str) -> Result:
    from fabpat.cli import cli

    return CliRunner().invoke(cli, list(args))


def commands(db: Path, tmp: Path) -> dict[str, tuple[str, ...]]:
    """The four commands that open a catalog, each as one CLI call on ``db``."""
    return {"sweep": (*SWEEP, "--db", str(db)), "catalog": ("catalog", "--db", str(db)),
            "browse": ("browse", "--db", str(db), "--out", str(tmp / "b.html")),
            "plot": ("plot", "--db", str(db), "--out", str(tmp / "figures"))}


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def small_catalog(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real catalog of 2 patterns × 3 scenarios (1.5 s), in DELETE journal mode as a finished sweep leaves it."""
    db = tmp_path_factory.mktemp("cat") / "c.sqlite"
    res = invoke(*SWEEP, "--db", str(db))
    assert res.exit_code == 0, res.stderr
    return db


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
    from fabpat.sweep import simulate_pattern

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
