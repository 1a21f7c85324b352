"""``fabpat.io``: two outputs never name one file and an output is never one of the command's inputs
(``check_distinct``, ``input_scope``, also through links), stale temporary files of dead writers are removed,
and a writer's failure (``writer_failed``) names the target and a full disk as such."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from fabpat.errors import ExportError
from fabpat.io import atomic_outputs, check_distinct, input_scope, remove_stale_temps, writer_failed
from tests.helpers import ROOT, SMALL_SPEC, one_line_error
from tests.helpers import invoke_result as invoke

STRIP_SPEC = ROOT / "assemblies" / "graded-strip.toml"


def test_simulate_strip_png_equal_to_spec_is_refused(tmp_path: Path) -> None:
    spec = tmp_path / "gs.toml"
    shutil.copy(STRIP_SPEC, spec)
    res = invoke("simulate-assembly", str(spec), "--h", "6", "--png", str(spec))
    one_line_error(res, "is the input SPEC")
    assert spec.read_bytes() == STRIP_SPEC.read_bytes()


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


def test_occt_failure_says_disk_full_only_when_it_is(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    e = writer_failed(tmp_path / ".a.1.abcd1234.part.step", "OCCT could not write the STEP file")
    assert e.errno == errno.EIO and e.strerror == "OCCT could not write the STEP file"  # tmp_path has room

    class Full:
        f_bavail, f_frsize = 3, 4096

    monkeypatch.setattr(os, "statvfs", lambda _p: Full)
    e = writer_failed(tmp_path / ".a.1.abcd1234.part.step", "OCCT could not write the STEP file")
    assert e.errno == errno.ENOSPC and e.filename == str(tmp_path / ".a.1.abcd1234.part.step")


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


def test_simulate_same_path_twice_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "x.vtu"
    res = invoke("simulate", "0x2d88", "--scenario", "dome", "--vtu", str(out), "--png", str(out))
    one_line_error(res, "same file")
    assert list(tmp_path.iterdir()) == []


def test_same_file_through_a_link_is_refused(tmp_path: Path) -> None:
    (tmp_path / "a.vtu").write_text("old")
    (tmp_path / "b.png").symlink_to(tmp_path / "a.vtu")
    res = invoke("simulate", "0x2d88", "--scenario", "dome", "--vtu", str(tmp_path / "a.vtu"),
                 "--png", str(tmp_path / "b.png"))
    one_line_error(res, "same file")
    assert (tmp_path / "a.vtu").read_text() == "old"


def test_simulate_strip_same_path_twice_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "s.vtu"
    res = invoke("simulate-assembly", str(SMALL_SPEC), "--vtu", str(out), "--png", str(out))
    one_line_error(res, "same file")
    assert list(tmp_path.iterdir()) == []


def test_the_check_is_shared() -> None:
    check_distinct(["a.svg", "b.svg"])
    with pytest.raises(ExportError, match="same file"):
        check_distinct(["a.svg", "./a.svg"])
    with pytest.raises(ExportError, match="same file"), atomic_outputs("a.svg", "./a.svg"):
        pass  # pragma: no cover - refused before the block


def test_remove_stale_temps_only_touches_dead_writers(tmp_path: Path) -> None:
    dead = tmp_path / ".a.999999999.abcdefgh.part.svg"  # above any pid_max: no such process
    dead_dir = tmp_path / ".kit.999999999.ABCdef12.part"
    dead_dir.mkdir()
    (dead_dir / "x.stl").write_text("")
    alive = tmp_path / f".a.{os.getppid()}.abcdefgh.part.svg"
    mine = tmp_path / ".a.999999999.abc.part.svg"  # not fabpat's pattern (3 random characters)
    for p in (dead, alive, mine):
        p.write_text("")
    removed = remove_stale_temps(tmp_path)
    assert sorted(p.name for p in removed) == sorted([dead.name, dead_dir.name])
    assert alive.exists() and mine.exists() and not dead.exists() and not dead_dir.exists()


# -- no room for the output: the file size limit (`ulimit -f`) and a full device name what they cut -----------

def _limited(args: list[str], stdout: object, limit: int) -> subprocess.CompletedProcess[str]:
    """``fabpat ARGS`` in a subprocess whose files may hold ``limit`` bytes (RLIMIT_FSIZE, as `ulimit -f`),
    SIGXFSZ ignored so that a write past it fails with EFBIG instead of killing the process."""
    import resource
    import signal
    import sys

    def limited() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = dict(os.environ, FABPAT_CACHE="off")
    return subprocess.run([sys.executable, "-m", "fabpat", *args], stdout=stdout, stderr=subprocess.PIPE, text=True,
                          preexec_fn=limited, env=env, timeout=120)


def test_a_file_past_the_size_limit_is_named(tmp_path: Path) -> None:
    svg = tmp_path / "p.svg"
    r = _limited(["show", "0x0488", "--svg", str(svg)], subprocess.DEVNULL, 1024)  # the SVG is ~2.6 kB
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith(f"fabpat: error: cannot write {svg}: File too large: it reached the file size "
                               "limit of 1024 bytes (ulimit -f)"), r.stderr  # was "[Errno 27] File too large"
    assert list(tmp_path.iterdir()) == []  # no partial file, no temporary


def test_printed_output_cut_by_the_size_limit_is_an_error(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    with out.open("wb") as f:
        r = _limited(["catalog", "--format", "csv"], f, 4096)  # the CSV is ~190 kB
    # Python's text layer dropped the rest of the short write: the command exited 0 with 4 kB of 190
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith(f"fabpat: error: cannot write standard output ({out}): File too large"), r.stderr
    assert "file size limit of 4096 bytes" in r.stderr


def test_a_full_standard_output_is_named() -> None:
    with open("/dev/full", "wb") as full:
        r = _limited(["show", "0x0488"], full, 2**40)
    assert r.returncode == 2 and r.stderr == ("fabpat: error: cannot write standard output (/dev/full): No space left "
                                              "on device\n"), r.stderr  # was "[Errno 28] No space left on device"
