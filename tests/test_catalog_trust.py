"""What a catalog file may not do to fabpat: poisoned values are refused (never printed, drawn or used by
a rule), a FIFO, device or symbolic link to one is never replaced, and two writers creating one catalog
at the same moment lose no committed row."""

from __future__ import annotations

import multiprocessing
import os
import sqlite3
import stat
import threading
from pathlib import Path

import pytest

import fabpat
from fabpat.catalog import CatalogError, energies, open_catalog
from fabpat.catalog import sqlite_file as catalog_file  # the file-level helpers a test replaces
from fabpat.catalog.sweep import run_sweep
from tests.helpers import invoke_result as invoke
from tests.test_catalog import fake_catalog, fake_rows
from tests.test_sweep import IDS, fake_task

HEX = {"0x0488": {"dome": 400.0}, "0x0508": {"dome": 200.0}, "0x0588": {"dome": 100.0}}


def one_line_error(args: tuple[str, ...], *words: str) -> str:
    res = invoke(*args)
    assert res.exit_code == 2 and res.stderr.startswith("fabpat: error:") and res.stderr.count("\n") == 1, res.output
    assert "Traceback" not in res.output and all(w in res.stderr for w in words), res.stderr
    return res.stderr


def readers(db: Path, tmp: Path) -> dict[str, tuple[str, ...]]:
    return {"catalog": ("catalog", "--db", str(db)), "long": ("catalog", "--db", str(db), "--long"),
            "json": ("catalog", "--db", str(db), "--format", "json"),
            "browse": ("browse", "--db", str(db), "--out", str(tmp / "b.html")),
            "plot": ("plot", "--db", str(db), "--out", str(tmp / "figs"))}


# -- poisoned values ------------------------------------------------------------------------------------

@pytest.mark.parametrize("column, bad, shown", [
    ("energy", float("inf"), "energy = inf"), ("energy", -5.0, "energy = -5.0"), ("energy", "abc", "energy = 'abc'"),
    ("energy", 0.0, "energy = 0.0"), ("energy", None, "energy = NULL in a converged row"),
    ("max_displacement", float("-inf"), "max_displacement = -inf"), ("converged", "yes", "converged = 'yes'"),
    # plausibility: finite, positive and still no result (listed as one before)
    ("energy", 1e308, "energy = 1e+308 (implausible: the scenarios' fixed loads store at most 1e+06 N·mm"),
    ("max_displacement", 1e300, "max_displacement = 1e+300 (implausible: a solve moves a plate at most 2 × its "
                                "diameter, 144 mm)"),
])
def test_a_poisoned_result_is_one_line_everywhere(tmp_path: Path, column: str, bad: object, shown: str) -> None:
    db = fake_catalog(tmp_path / "c.sqlite", {6: HEX})
    with sqlite3.connect(db) as c:
        c.execute(f"UPDATE results SET {column} = ? WHERE id = '0x0508'", (bad,))
    c.close()
    for name, args in readers(db, tmp_path).items():
        msg = one_line_error(args, f"catalog {db}", "pattern 0x0508, scenario dome", shown)
        assert name and "0x0488" not in msg
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.sqlite"]  # no page, no figure
    for call in (lambda: fabpat.catalog(db), lambda: energies(db, "dome"), lambda: fabpat.catalog(db, sides=None)):
        with pytest.raises(CatalogError, match="pattern 0x0508, scenario dome"):
            call()


@pytest.mark.parametrize("column, bad", [("filleted_area", float("inf")), ("area", -1.0), ("min_width", "wide"),
                                         ("polar_moment", 0.0)])
def test_a_poisoned_metric_is_one_line_everywhere(tmp_path: Path, column: str, bad: object) -> None:
    db = fake_catalog(tmp_path / "c.sqlite", {6: HEX})
    with sqlite3.connect(db) as c:
        c.execute(f"UPDATE patterns SET {column} = ? WHERE id = '0x0588'", (bad,))
    c.close()
    for name, args in readers(db, tmp_path).items():
        if name != "long":  # the long form lists results, not metrics
            one_line_error(args, f"catalog {db}", "pattern 0x0588", f"{column} = {bad!r}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.sqlite"]


def test_a_poisoned_set_up_is_one_line(tmp_path: Path) -> None:
    db = fake_catalog(tmp_path / "c.sqlite", {6: HEX})
    with sqlite3.connect(db) as c:
        c.execute("UPDATE patterns SET edge = 'long' WHERE id = '0x0588'")
    c.close()
    for name in ("catalog", "browse", "plot"):
        one_line_error(readers(db, tmp_path)[name], f"catalog {db}", "edge = 'long'")


def test_a_sweep_recomputes_a_poisoned_row_instead_of_trusting_its_hash(tmp_path: Path) -> None:
    db = tmp_path / "c.sqlite"
    assert run_sweep(db, IDS[:3], workers=1, task=fake_task).computed == 9
    with sqlite3.connect(db) as c:
        c.execute("UPDATE results SET energy = 'abc' WHERE id = ? AND scenario = 'dome'", (IDS[1],))
        c.execute("UPDATE patterns SET area = -1 WHERE id = ?", (IDS[2],))
    c.close()
    with pytest.raises(CatalogError):
        fabpat.catalog(db)
    r = run_sweep(db, IDS[:3], workers=1, task=fake_task)
    assert (r.computed, r.skipped) == (1, 8)  # the poisoned result; the poisoned pattern row is rewritten too
    rows = {q["id"]: q for q in fabpat.catalog(db)}
    # fake_task's numbers: energy E/1000 × (1 + the scenario's index among those asked: dome alone → 1), area 1
    assert rows[IDS[1]]["energy_dome"] == 1.0 and rows[IDS[2]]["area"] == 1.0


# -- outputs that are not regular files -----------------------------------------------------------------

def test_a_fifo_as_db_is_refused_and_left_a_fifo(tmp_path: Path) -> None:
    fifo = tmp_path / "c.sqlite"
    os.mkfifo(fifo)
    one_line_error(("sweep", "--sample", "1", "--workers", "1", "--db", str(fifo)), "FIFO", "not a regular file")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    for name, args in readers(fifo, tmp_path).items():  # readers refuse it too, without blocking on it
        assert name and "FIFO" in one_line_error(args)
    with pytest.raises(CatalogError, match="FIFO"):
        open_catalog(fifo, write=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.sqlite"] and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_link_to_dev_null_is_refused_and_left_a_link(tmp_path: Path) -> None:
    link = tmp_path / "c.sqlite"
    link.symlink_to(os.devnull)
    one_line_error(("sweep", "--sample", "1", "--workers", "1", "--db", str(link)), "symbolic link to /dev/null",
                   "character device", "not a regular file")
    assert link.is_symlink() and os.readlink(link) == os.devnull and stat.S_ISCHR(os.stat(os.devnull).st_mode)
    one_line_error(("catalog", "--db", str(link)), "character device")
    with pytest.raises(CatalogError, match="character device"):
        open_catalog(link, write=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.sqlite"] and link.is_symlink()


def test_a_link_to_a_catalog_is_written_through(tmp_path: Path) -> None:
    real, link = tmp_path / "real.sqlite", tmp_path / "link.sqlite"
    link.symlink_to(real.name)  # dangling: the catalog is made where it points
    with open_catalog(link, write=True) as cat:
        cat.write_rows(fake_rows("0x0488", 6, {"dome": 1.0}))
    with open_catalog(link, write=True) as cat:  # now an existing catalog, through the link
        cat.write_rows(fake_rows("0x0508", 6, {"dome": 2.0}))
    assert link.is_symlink() and real.is_file() and not real.is_symlink()
    assert energies(real, "dome") == {"0x0488": 1.0, "0x0508": 2.0}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.sqlite", "real.sqlite"]  # no -wal/-shm left


# -- two writers creating one catalog -------------------------------------------------------------------

@pytest.mark.parametrize("start", ["missing", "empty"])
def test_two_writers_creating_one_catalog_keep_every_row(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         start: str) -> None:
    """Both find no catalog and build one; the first links (or fills) its catalog and commits a row before
    the second finishes building: the second must open the first's catalog, not replace it."""
    db = tmp_path / "c.sqlite"
    if start == "empty":
        db.write_bytes(b"")
    real = catalog_file._create_sql
    both_building = threading.Barrier(2, timeout=30)
    first_done = threading.Event()
    arrived: list[int] = []
    lock = threading.Lock()

    def create_sql() -> list[str]:
        both_building.wait()
        with lock:
            arrived.append(threading.get_ident())
            second = len(arrived) == 2
        if second:
            assert first_done.wait(30)
        return real()

    monkeypatch.setattr(catalog_file, "_create_sql", create_sql)
    errors: list[BaseException] = []

    def writer(pid: str) -> None:
        try:
            with open_catalog(db, write=True) as cat:
                cat.write_rows(fake_rows(pid, 6, {"dome": 1.0}))
        except BaseException as e:  # noqa: BLE001 - reported below
            errors.append(e)
        finally:
            first_done.set()

    threads = [threading.Thread(target=writer, args=(pid,)) for pid in ("0x0488", "0x0508")]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert not errors, errors
    assert sorted(energies(db, "dome")) == ["0x0488", "0x0508"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.sqlite"]


def _race_writer(db: str, pid: str, go: multiprocessing.synchronize.Event) -> None:  # type: ignore[name-defined]
    go.wait(30)
    with open_catalog(db, write=True) as cat:
        cat.write_rows(fake_rows(pid, 6, {"dome": 1.0}))


def test_processes_racing_to_create_one_catalog_keep_every_row(tmp_path: Path) -> None:
    ctx = multiprocessing.get_context("fork")
    for round_ in range(4):
        db = tmp_path / f"c{round_}.sqlite"
        go = ctx.Event()
        ids = [f"0x{0x0488 + 0x80 * k:04x}" for k in range(4)]
        procs = [ctx.Process(target=_race_writer, args=(str(db), pid, go)) for pid in ids]
        for p in procs:
            p.start()
        go.set()
        for p in procs:
            p.join(60)
        assert [p.exitcode for p in procs] == [0] * len(procs)
        assert sorted(energies(db, "dome")) == sorted(ids)


def test_a_refused_foreign_wal_database_gets_no_side_files(tmp_path: Path) -> None:
    db = tmp_path / "foreign.sqlite"
    conn = sqlite3.connect(db)
    conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("CREATE TABLE t(x)")
    conn.commit()
    conn.close()  # the last connection: SQLite removes -wal and -shm, the file stays in WAL mode
    before = db.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foreign.sqlite"]
    for write in (False, True):
        with pytest.raises(CatalogError, match="is not a fabpat catalog"):
            open_catalog(db, write=write)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["foreign.sqlite"]  # no -shm, no -wal
    assert db.read_bytes() == before
