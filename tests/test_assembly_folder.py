"""`fabpat assemble --out`: an earlier kit is replaced only when fabpat demonstrably wrote all of it, and a
failed swap leaves the earlier kit and no temporary folder; a folder holding the spec is refused, and a full
disk is named with the kit's folder."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.conftest import run_cli
from tests.helpers import SMALL_SPEC, in_small_tmpfs, invoke, needs_unshare, one_line_error, tmpfs_error

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "assemblies" / "test-small.toml"
SPEC = {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 2},
        "patterns": {"pattern": "0x0488"}, "plates": {"thickness": 0.8}, "sheet": {"width": 170.0, "height": 90.0},
        "output": {"formats": ["bom", "svg"]}}


def small():  # type: ignore[no-untyped-def]
    from fabpat.assembly.spec.load import parse_spec

    return parse_spec(SPEC, "two.toml")


def build(out: Path):  # type: ignore[no-untyped-def]
    from fabpat.assembly.kit.build import assemble

    return assemble(small(), out, predict=False)


def listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_rerun_replaces_an_unchanged_earlier_kit(tmp_path: Path) -> None:
    out = tmp_path / "again"
    first = build(out)
    manifest = json.loads((out / "manifest.json").read_text())
    assert sorted(manifest["sha256"]) == sorted(f for f in first.files if f != "manifest.json")
    for name, digest in manifest["sha256"].items():  # the digests are the files' own
        import hashlib

        assert hashlib.sha256((out / name).read_bytes()).hexdigest() == digest
    second = build(out)
    assert sorted(second.files) == sorted(first.files) and sorted(os.listdir(tmp_path)) == ["again"]


@pytest.mark.parametrize("case", ["user-file", "changed-file", "user-folder", "link"])
def test_a_folder_holding_anything_fabpat_did_not_write_is_refused(tmp_path: Path, case: str) -> None:
    from fabpat.errors import ExportError

    out = tmp_path / "kit"
    build(out)
    if case == "user-file":
        (out / "notes.txt").write_text("keep me")
        words = "holds notes.txt, which fabpat did not write"
    elif case == "changed-file":
        (out / "bom.md").write_text("my own bill of materials")
        words = "bom.md has changed since fabpat wrote it"
    elif case == "user-folder":
        (out / "mine").mkdir()
        (out / "mine" / "a.txt").write_text("keep me")
        words = "holds mine/a.txt, which fabpat did not write"
    else:
        (out / "link").symlink_to(tmp_path)
        words = "holds link, which is not a regular file fabpat wrote"
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and not p.is_symlink()}
    with pytest.raises(ExportError, match=words):
        build(out)
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file() and not p.is_symlink()} == before
    assert sorted(os.listdir(tmp_path)) == ["kit"]  # no temporary folder


def test_a_manifest_that_merely_names_the_generator_is_not_enough(tmp_path: Path) -> None:
    """The hostile case: a folder whose manifest.json says "generator": "fabpat assemble" and a user's file."""
    out = tmp_path / "kit"
    out.mkdir()
    (out / "manifest.json").write_text(json.dumps({"generator": "fabpat assemble"}))
    (out / "thesis.tex").write_text("three years of work")
    r = run_cli("assemble", str(SMALL), "--out", str(out), "--no-progress")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("fabpat: error: "), r.stderr
    assert "lists no file digests" in r.stderr
    assert (out / "thesis.tex").read_text() == "three years of work"


@pytest.mark.parametrize("text", ["[1, 2]", "\"fabpat assemble\"", "{", "[" * 3000 + "]" * 3000])
def test_a_manifest_that_is_not_a_json_object_is_one_line(tmp_path: Path, text: str) -> None:
    out = tmp_path / "kit"
    out.mkdir()
    (out / "manifest.json").write_text(text)
    from click.testing import CliRunner

    from fabpat.cli import cli

    # in-process: the refusal's logic, four times (the real process's exit code is the test above's)
    r = CliRunner().invoke(cli, ["assemble", str(SMALL), "--out", str(out), "--no-progress"])
    assert r.exit_code == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert "manifest.json" in r.stderr and (out / "manifest.json").read_text() == text


def test_out_dot_is_refused_without_a_part_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.assembly.kit.build import assemble
    from fabpat.errors import ExportError

    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    for out in (".", str(work), ".."):
        with pytest.raises(ExportError, match="current folder or one above it"):
            assemble(small(), out, predict=False)
    assert listing(tmp_path) == ["work"]


def test_a_failed_swap_keeps_the_earlier_kit_and_leaves_no_part_folder(tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    from fabpat.assembly.kit import folder as kit_folder
    from fabpat.errors import ExportError

    out = tmp_path / "kit"
    build(out)
    before = {str(p.relative_to(out)): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    real = os.replace
    calls: list[str] = []

    def failing(src: object, dst: object) -> None:
        calls.append(str(dst))
        if len(calls) == 2:  # the earlier kit is aside; the new one cannot take its place
            raise PermissionError(1, "Operation not permitted", str(dst))
        real(src, dst)  # type: ignore[arg-type]

    monkeypatch.setattr(kit_folder.os, "replace", failing)
    with pytest.raises(ExportError, match="cannot write"):
        build(out)
    assert {str(p.relative_to(out)): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert sorted(os.listdir(tmp_path)) == ["kit"]


def _chattr(flag: str, path: Path) -> bool:
    tool = shutil.which("chattr")
    return tool is not None and subprocess.run([tool, flag, str(path)], capture_output=True).returncode == 0


@pytest.mark.parametrize("where", ["parent", "kit"])
def test_an_immutable_folder_leaves_no_part_folder(tmp_path: Path, where: str) -> None:
    parent = tmp_path / "imm"
    parent.mkdir()
    out = parent / "kit"
    build(out)
    target = parent if where == "parent" else out
    if not _chattr("+i", target):
        pytest.skip("chattr +i needs root on a file system with attributes")
    try:
        # --no-predict: the swap into the immutable folder is the point, not the strip's prediction
        r = invoke("assemble", str(SMALL), "--out", str(out), "--no-progress", "--no-predict")
        names = sorted(os.listdir(parent))
    finally:
        _chattr("-i", target)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and f"cannot write {out}" in r.stderr, r.stderr
    assert names == ["kit"] and (out / "manifest.json").is_file()


def test_assemble_out_folder_holding_the_spec_is_refused(tmp_path: Path) -> None:
    """assemble replaces its --out folder whole: a spec inside it would be deleted."""
    kit = tmp_path / "kit"
    kit.mkdir()
    spec = kit / "s.toml"
    shutil.copy(SMALL_SPEC, spec)
    res = invoke("assemble", str(spec), "--out", str(kit), "--no-progress")
    one_line_error(res, "holds the input SPEC")
    assert spec.read_bytes() == SMALL_SPEC.read_bytes()


@needs_unshare
def test_assemble_on_a_full_disk_names_the_kit(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    shutil.copy(SMALL_SPEC, tmp_path / "s.toml")
    res = in_small_tmpfs(disk, "$FAB assemble s.toml --out disk/kit --no-progress; echo rc=$?; ls -A disk")
    assert res.stdout.split() == ["rc=2"], (res.stdout, res.stderr)
    one_line_error(tmpfs_error(res), "cannot write disk/kit: the disk is full")
    assert ".part" not in res.stderr
