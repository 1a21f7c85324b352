"""``fabpat.io``: two outputs never name one file and an output is never one of the command's inputs
(``check_distinct``, ``input_scope``, also through links), stale temporary files of dead writers are removed,
and a writer's failure (``writer_failed``) names the target and a full disk as such."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest

from fabpat.errors import ExportError
from fabpat.io import check_distinct, input_scope, writer_failed
from tests.helpers import ROOT, one_line_error
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
