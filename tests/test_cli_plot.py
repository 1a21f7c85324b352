"""``fabpat plot``: an empty --highlight list is an error, a full disk leaves no folder, and a figure is never
written over the command's own --db."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.helpers import digest, in_small_tmpfs, needs_unshare, one_line_error
from tests.helpers import invoke_result as invoke


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


def test_plot_with_an_empty_highlight_list_is_an_error(tmp_path: Path) -> None:
    for empty in ("", " , "):
        one_line_error(invoke("plot", "--out", str(tmp_path / "f"), "--highlight", empty), "--highlight", "0x0488")
    assert list(tmp_path.iterdir()) == []


def test_plot_on_a_full_disk_leaves_no_folder_monkeypatched(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Full disk simulated in-process: matplotlib's savefig raises ENOSPC as the real write would."""
    from matplotlib.figure import Figure

    def full(self: Figure, fname: object, *args: object, **kwargs: object) -> None:
        Path(str(fname)).write_bytes(b"\x89PNG")  # a few bytes reach the disk, then it is full
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Figure, "savefig", full)
    out = tmp_path / "figures"
    res = invoke("plot", "--out", str(out))
    one_line_error(res, "disk is full")
    assert list(tmp_path.iterdir()) == []


@needs_unshare
def test_plot_on_a_full_disk_leaves_no_folder_tmpfs(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "$FAB plot --out disk/figures; echo rc=$?; ls -A disk")
    assert "rc=2" in res.stdout and res.stdout.split("rc=2")[1].strip() == "", res.stdout
    one_line_error(subprocess.CompletedProcess([], 2, "", res.stderr), "disk is full")
