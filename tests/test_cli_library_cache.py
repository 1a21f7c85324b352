"""The library cache is a convenience: what is read back is checked, and a cache that cannot be read or
written never changes the listing or the exit code (at most one warning)."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest
from click.testing import CliRunner

from fabpat.cli import library_cache
from fabpat.cli.library_cache import cache_path, read_cache

# Depth 1 has two patterns: the whole listing takes a fraction of a second.
JOBS = [("0x2", 6, 1, 36.0, 0.2), ("0xa", 6, 1, 36.0, 0.2)]


def listing(env: dict[str, str]) -> tuple[int, str, str]:
    from fabpat.cli import cli

    r = CliRunner(env=env).invoke(cli, ["library", "--depth", "1", "--format", "json"])
    return r.exit_code, r.stdout, r.stderr


@pytest.fixture
def reference() -> str:
    """The listing computed with no cache at all."""
    code, out, err = listing({"FABPAT_CACHE": "off"})
    assert code == 0 and err == ""
    assert [row["id"] for row in json.loads(out)] == ["0x2", "0xa"]
    return out


@pytest.fixture(autouse=True)
def _fresh_warning(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(library_cache, "_warned", [])


def _good_rows() -> list[dict[str, object]]:
    row = {"filleted_area": 1.0, "filleted_perimeter": 2.0, "filleted_ratio": 0.5, "filleted_polar_moment": 3.0,
           "min_width": 0.5}
    return [{"id": pid, **row} for pid, *_ in JOBS]


def test_a_well_formed_cache_is_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FABPAT_CACHE", str(tmp_path))
    path = cache_path(JOBS)
    assert path is not None and path.parent == tmp_path
    path.write_text(json.dumps(_good_rows()))
    got = read_cache(path, JOBS)
    assert got is not None and [r["min_width"] for r in got] == [0.5, 0.5] and "id" not in got[0]


def _poison(kind: str) -> str:
    rows = _good_rows()
    if kind == "list of numbers":
        return "[1, 2]"
    if kind == "NaN":
        rows[1]["min_width"] = float("nan")
    elif kind == "Infinity":
        rows[0]["filleted_area"] = float("inf")
    elif kind == "negative":
        rows[0]["filleted_perimeter"] = -2.0
    elif kind == "text":
        rows[0]["filleted_area"] = "1.0"
    elif kind == "bool":
        rows[0]["min_width"] = True
    elif kind == "ratio over 1":
        rows[0]["filleted_ratio"] = 1.5
    elif kind == "another id":
        rows[1]["id"] = "0x8"
    elif kind == "swapped ids":
        rows.reverse()
    elif kind == "missing key":
        del rows[0]["min_width"]
    elif kind == "extra key":
        rows[0]["energy"] = 1.0
    elif kind == "one row short":
        rows = rows[:1]
    elif kind == "a dict":
        return json.dumps({"0x2": rows[0]})
    elif kind == "not JSON":
        return "[{"
    elif kind == "nested 100 000 deep":
        return "[" * 100_000 + "]" * 100_000
    return json.dumps(rows)


KINDS = ["list of numbers", "NaN", "Infinity", "negative", "text", "bool", "ratio over 1", "another id",
         "swapped ids", "missing key", "extra key", "one row short", "a dict", "not JSON", "nested 100 000 deep"]


@pytest.mark.parametrize("kind", KINDS)
def test_a_poisoned_cache_is_not_trusted(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str) -> None:
    monkeypatch.setenv("FABPAT_CACHE", str(tmp_path))
    path = cache_path(JOBS)
    assert path is not None
    path.write_text(_poison(kind))
    assert read_cache(path, JOBS) is None


@pytest.mark.parametrize("kind", ["list of numbers", "NaN", "another id", "not JSON"])
def test_the_listing_recomputes_over_a_poisoned_cache(tmp_path: Path, reference: str, kind: str) -> None:
    env = {"FABPAT_CACHE": str(tmp_path)}
    assert listing(env)[0] == 0  # writes the cache
    (written,) = tmp_path.glob("library-*.json")
    assert [r["id"] for r in json.loads(written.read_text())] == ["0x2", "0xa"]
    written.write_text(_poison(kind))
    code, out, err = listing(env)
    assert (code, out, err) == (0, reference, "")
    assert read_cache(written, JOBS) is not None  # recomputed and stored again


def test_a_cache_that_is_a_fifo_or_dev_zero_is_never_read(tmp_path: Path, reference: str) -> None:
    env = {"FABPAT_CACHE": str(tmp_path)}
    listing(env)
    (path,) = tmp_path.glob("library-*.json")
    path.unlink()
    os.mkfifo(path)
    code, out, err = listing(env)  # a read would block here for ever
    assert code == 0 and out == reference
    assert err.startswith("fabpat: warning: the library cache was not saved") and err.count("\n") == 1
    assert "FIFO" in err and stat.S_ISFIFO(os.lstat(path).st_mode)
    path.unlink()
    path.symlink_to("/dev/zero")
    library_cache._warned.clear()
    code, out, err = listing(env)  # a read would fill the memory
    assert code == 0 and out == reference and "character device" in err and err.count("\n") == 1
    assert stat.S_ISCHR(os.stat("/dev/zero").st_mode)


def test_a_cache_that_cannot_be_written_warns_once(tmp_path: Path, reference: str) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the cache folder would go")
    env = {"FABPAT_CACHE": str(blocker / "cache")}
    code, out, err = listing(env)
    assert code == 0 and out == reference
    assert err.count("\n") == 1 and "the library cache was not saved" in err and str(blocker) in err
    code, out, err = listing(env)  # the same process: no second warning
    assert (code, out, err) == (0, reference, "")


def test_a_full_disk_leaves_no_empty_cache_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import errno
    import io as stdio

    import fabpat.io

    def full(*paths: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(fabpat.io, "atomic_outputs", full)  # the disk fills as the cache is written
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "other.json").write_text("someone else's")
    for root in (tmp_path / "new" / "deeper" / "fabpat", kept / "fabpat"):
        warnings = stdio.StringIO()
        library_cache.write_cache(root / "library-x.json", JOBS, _good_rows(), warnings.write)
        assert "No space left on device" in warnings.getvalue() or library_cache._warned
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept"]  # new/deeper/fabpat made and removed again
    assert sorted(p.name for p in kept.iterdir()) == ["other.json"]  # an existing folder stays as it was
