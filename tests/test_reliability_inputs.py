"""Issue 15 §6 and §8, second pass: outputs never replace inputs, a full disk is named as one (OCCT
writers, catalogs), and the smaller spec/catalog/time-stamp inconsistencies a hostile tester found."""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from fabpat.assembly.spec import parse_spec
from fabpat.catalog import CatalogError, open_catalog
from fabpat.errors import ExportError, SpecError
from fabpat.io import check_distinct, input_scope, writer_failed
from tests.test_reliability_files import SMALL_SPEC, in_small_tmpfs, needs_unshare, one_line_error

ROOT = Path(__file__).resolve().parents[1]
STRIP_SPEC = ROOT / "assemblies" / "graded-strip.toml"
SWEEP = ("sweep", "--sample", "2", "--h", "8", "--workers", "1")


def invoke(*args: str) -> Result:
    from fabpat.cli import cli

    return CliRunner().invoke(cli, list(args))


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def tmpfs_error(res: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.CompletedProcess([], 2, "", res.stderr)


@pytest.fixture(scope="module")
def small_catalog(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real catalog of 2 patterns × 3 scenarios."""
    db = tmp_path_factory.mktemp("cat") / "c.db"
    res = invoke(*SWEEP, "--db", str(db))
    assert res.exit_code == 0, res.stderr
    return db


# -- 1. an output is never one of the command's inputs ------------------------------------------------


def test_browse_out_equal_to_db_is_refused(small_catalog: Path, tmp_path: Path) -> None:
    db = tmp_path / "g.db"
    shutil.copy(small_catalog, db)
    (tmp_path / "hard.db").hardlink_to(db)
    (tmp_path / "sym.db").symlink_to(db)
    before = digest(db)
    for db_arg, out in ((db, db), (db, tmp_path / "hard.db"), (tmp_path / "sym.db", db)):
        res = invoke("browse", "--db", str(db_arg), "--out", str(out))
        one_line_error(res, "is the input --db", str(out))
        assert digest(db) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.db", "hard.db", "sym.db"]


def test_plot_never_writes_over_its_catalog_inside_the_folder(small_catalog: Path, tmp_path: Path) -> None:
    """A catalog that happens to sit in --out under a figure's name is an input, not a figure."""
    out = tmp_path / "figures"
    out.mkdir()
    db = out / "overview.png"
    shutil.copy(small_catalog, db)
    before = digest(db)
    res = invoke("plot", "--db", str(db), "--out", str(out))
    one_line_error(res, "is the input --db", "overview.png")
    assert digest(db) == before


def test_simulate_strip_png_equal_to_spec_is_refused(tmp_path: Path) -> None:
    spec = tmp_path / "gs.toml"
    shutil.copy(STRIP_SPEC, spec)
    res = invoke("simulate-strip", str(spec), "--h", "6", "--png", str(spec))
    one_line_error(res, "is the input SPEC")
    assert spec.read_bytes() == STRIP_SPEC.read_bytes()


def test_assemble_out_folder_holding_the_spec_is_refused(tmp_path: Path) -> None:
    """assemble replaces its --out folder whole: a spec inside it would be deleted."""
    kit = tmp_path / "kit"
    kit.mkdir()
    spec = kit / "s.toml"
    shutil.copy(SMALL_SPEC, spec)
    res = invoke("assemble", str(spec), "--out", str(kit), "--no-progress")
    one_line_error(res, "holds the input SPEC")
    assert spec.read_bytes() == SMALL_SPEC.read_bytes()


def test_check_distinct_refuses_declared_inputs_through_links(tmp_path: Path) -> None:
    src = tmp_path / "in.db"
    src.write_text("x")
    (tmp_path / "hard").hardlink_to(src)
    with input_scope():
        check_distinct([tmp_path / "other"], inputs={"--db": src})  # another file: fine
        for out in (src, tmp_path / "hard", tmp_path / "sub" / ".." / "in.db"):
            with pytest.raises(ExportError, match="is the input --db"):
                check_distinct([out])  # remembered for the rest of the scope
    check_distinct([src])  # the scope is over: an API caller may write where it likes


# -- 4. a full disk during export and assemble names the target and the cause ----------------------------


@needs_unshare
def test_export_on_a_full_disk_names_the_target(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "for f in a.step a.stl; do $FAB export 0x0488 --${f#a.} disk/$f; echo rc=$?; done; "
                               "dd if=/dev/zero of=disk/fill bs=1k count=56 2>/dev/null; "
                               "$FAB export 0x0488 --dxf disk/a.dxf; echo rc=$?; ls -A disk")
    assert res.stdout.split() == ["rc=2", "rc=2", "rc=2", "fill"], (res.stdout, res.stderr)
    lines = res.stderr.splitlines()
    assert len(lines) == 3, res.stderr
    for line, name in zip(lines, ("a.step", "a.stl", "a.dxf"), strict=True):
        assert line.startswith(f"fabpat: error: cannot write disk/{name}: the disk is full"), line
        assert ".part" not in line


@needs_unshare
def test_assemble_on_a_full_disk_names_the_kit(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    shutil.copy(SMALL_SPEC, tmp_path / "s.toml")
    res = in_small_tmpfs(disk, "$FAB assemble s.toml --out disk/kit --no-progress; echo rc=$?; ls -A disk")
    assert res.stdout.split() == ["rc=2"], (res.stdout, res.stderr)
    one_line_error(tmpfs_error(res), "cannot write disk/kit: the disk is full")
    assert ".part" not in res.stderr


def test_occt_failure_says_disk_full_only_when_it_is(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    e = writer_failed(tmp_path / ".a.1.abcd1234.part.step", "OCCT could not write the STEP file")
    assert e.errno == errno.EIO and e.strerror == "OCCT could not write the STEP file"  # tmp_path has room

    class Full:
        f_bavail, f_frsize = 3, 4096

    monkeypatch.setattr(os, "statvfs", lambda _p: Full)
    e = writer_failed(tmp_path / ".a.1.abcd1234.part.step", "OCCT could not write the STEP file")
    assert e.errno == errno.ENOSPC and e.filename == str(tmp_path / ".a.1.abcd1234.part.step")


# -- 5. catalogs on a full disk -----------------------------------------------------------------------


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


# -- 7. smaller inconsistencies -------------------------------------------------------------------------


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


@pytest.mark.parametrize("given, header", [
    ("2025-01-31 12:00", "2025-01-31T12:00:00"),
    ("20250131", "2025-01-31T00:00:00"),
    ("2025-01-31", "2025-01-31T00:00:00"),
    ("2025-01-31T12:00:00.75+00:00", "2025-01-31T12:00:00Z"),
    ("2025-01-31T12:00-05:30", "2025-01-31T12:00:00-05:30"),
])
def test_step_timestamp_is_normalised(tmp_path: Path, given: str, header: str) -> None:
    from fabpat import cad
    from fabpat.exchange.step import check_timestamp, write_step
    from tests.test_cad import bowtie

    assert check_timestamp(given) == header
    path = write_step(cad.make_solid(bowtie()), tmp_path / "t.step", "t", timestamp=given)
    text = path.read_text(encoding="utf-8")
    assert f"'{header}'" in text and (given == header or f"'{given}'" not in text)


def test_simulate_output_on_a_full_disk_names_the_target(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """meshio's own ENOSPC on the temporary .vtu: the line names r.vtu and the full disk."""
    import meshio

    def full(path: object, *args: object, **kwargs: object) -> None:
        Path(str(path)).write_bytes(b"<?xml")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(meshio, "write", full)
    res = invoke("simulate", "0x2d88", "--scenario", "dome", "--linear", "--h", "4", "--vtu", str(tmp_path / "r.vtu"))
    one_line_error(res, f"cannot write {tmp_path / 'r.vtu'}: the disk is full")
    assert ".part" not in res.stderr and list(tmp_path.iterdir()) == []


def test_write_failed_is_an_export_error_and_an_os_error(tmp_path: Path) -> None:
    e = writer_failed(tmp_path / "a.dxf", "cannot write the DXF file", OSError(errno.EACCES, "Permission denied"))
    assert isinstance(e, ExportError) and isinstance(e, OSError) and e.errno == errno.EACCES
    assert str(e) == f"cannot write {tmp_path / 'a.dxf'}: Permission denied"


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
