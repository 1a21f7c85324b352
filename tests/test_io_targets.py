"""Outputs and inputs that are not regular files: refused in one line, never renamed over, never read; an
output that is a symbolic link is written through, a dangling one refused.

Only FIFOs, directories and symbolic links made in tmp_path are used; a link to ``/dev/null`` is the
one device in play, and every test asserts it is still the character device it was.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from fabpat.errors import ExportError
from fabpat.io import atomic_outputs, check_suffix, read_input
from tests.conftest import run_cli
from tests.helpers import one_line_error, parts

ROOT = Path(__file__).resolve().parents[1]


def invoke(*args: str) -> Result:
    from fabpat.cli import cli

    return CliRunner(env={"FABPAT_CACHE": "off"}).invoke(cli, list(args))


def _dev_null_is_a_device() -> bool:
    return stat.S_ISCHR(os.stat("/dev/null").st_mode)


@pytest.fixture
def specials(tmp_path: Path) -> dict[str, Path]:
    """A FIFO, a directory and a symbolic link to /dev/null, each with an output suffix."""
    fifo = tmp_path / "pipe.svg"
    os.mkfifo(fifo)
    folder = tmp_path / "folder.svg"
    folder.mkdir()
    null = tmp_path / "null.svg"
    null.symlink_to("/dev/null")
    assert _dev_null_is_a_device()
    return {"FIFO": fifo, "directory": folder, "character device": null}


@pytest.mark.parametrize("kind", ["FIFO", "directory", "character device"])
def test_atomic_outputs_refuse_a_target_that_is_not_a_regular_file(specials: dict[str, Path], kind: str) -> None:
    target = specials[kind]
    with pytest.raises(ExportError, match=kind) as info, atomic_outputs(target) as (tmp,):
        tmp.write_text("never")
    assert str(target) in str(info.value) and "\n" not in str(info.value)
    assert not target.is_file() and _dev_null_is_a_device()
    assert sorted(p.name for p in target.parent.iterdir()) == ["folder.svg", "null.svg", "pipe.svg"]


def test_a_fifo_that_appears_while_writing_is_not_renamed_over(tmp_path: Path) -> None:
    target = tmp_path / "late.svg"
    with pytest.raises(ExportError, match="FIFO"), atomic_outputs(target) as (tmp,):
        tmp.write_text("data")
        os.mkfifo(target)  # made by someone else between the check and the rename
    assert stat.S_ISFIFO(os.lstat(target).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == ["late.svg"]


@pytest.mark.parametrize("kind", ["FIFO", "directory", "character device"])
def test_export_refuses_a_special_file_in_one_line(specials: dict[str, Path], kind: str) -> None:
    res = invoke("export", "0x0488", "--svg", str(specials[kind]))
    one_line_error(res, specials[kind].name, "directory" if kind == "directory" else kind)
    assert stat.S_ISFIFO(os.lstat(specials["FIFO"]).st_mode) and specials["directory"].is_dir()
    assert _dev_null_is_a_device()


@pytest.mark.parametrize("path", ["a.svg/", "a.svg/.", "sub/a.svg/.."])
def test_a_path_that_names_a_folder_is_refused(tmp_path: Path, path: str) -> None:
    (tmp_path / "sub").mkdir()
    res = invoke("export", "0x0488", "--svg", f"{tmp_path}/{path}")  # text: Path() would drop "/" and "."
    one_line_error(res, "names a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sub"] and list((tmp_path / "sub").iterdir()) == []


def test_check_suffix_refuses_a_trailing_slash() -> None:
    """``--vtu a.vtu/`` wrote ``a.vtu``: the suffix checker every file option calls refuses it."""
    with pytest.raises(ExportError, match="--vtu 'a.vtu/'.*names a folder"):
        check_suffix("a.vtu/", (".vtu",), "--vtu")
    assert check_suffix("a.vtu", (".vtu",), "--vtu") == Path("a.vtu")


def test_simulate_vtu_with_a_trailing_slash_is_refused(tmp_path: Path) -> None:
    res = invoke("simulate", "0x0488", "--scenario", "cantilever", "--vtu", f"{tmp_path}/a.vtu/")
    one_line_error(res, "--vtu", "names a folder")
    assert list(tmp_path.iterdir()) == []


# -- inputs ---------------------------------------------------------------------------------------------


def test_a_fifo_spec_is_refused_before_it_is_opened(tmp_path: Path) -> None:
    spec = tmp_path / "spec.toml"
    os.mkfifo(spec)
    for args in (["assemble", str(spec), "--out", str(tmp_path / "kit")], ["simulate-assembly", str(spec)]):
        res = run_cli(*args)  # a subprocess: a read of the FIFO would hang until the timeout
        one_line_error(res, "SPEC", "FIFO")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]


def test_a_device_as_spec_or_catalog_is_refused(tmp_path: Path) -> None:
    null = tmp_path / "null.toml"
    null.symlink_to("/dev/null")
    one_line_error(invoke("simulate-assembly", str(null)), "SPEC", "character device")
    db = tmp_path / "cat.sqlite"
    db.symlink_to("/dev/null")
    one_line_error(invoke("catalog", "--db", str(db)), "--db", "character device")
    assert _dev_null_is_a_device() and db.is_symlink()


def test_read_input_refuses_special_files_and_bounds_the_size(tmp_path: Path) -> None:
    fifo = tmp_path / "in.json"
    os.mkfifo(fifo)
    with pytest.raises(ExportError, match="cache .*in.json is a FIFO"):
        read_input(fifo, "cache")
    zero = tmp_path / "zero.json"
    zero.symlink_to("/dev/zero")
    with pytest.raises(ExportError, match="character device"):
        read_input(zero, "cache")
    big = tmp_path / "big.json"
    big.write_bytes(b"x" * 101)
    with pytest.raises(ExportError, match="larger than 100 bytes"):
        read_input(big, "cache", max_bytes=100)
    assert read_input(big, "cache", max_bytes=101) == b"x" * 101
    with pytest.raises(FileNotFoundError):
        read_input(tmp_path / "missing.json", "cache")


def test_a_symlinked_output_is_written_through(tmp_path: Path) -> None:
    real = tmp_path / "real"
    real.mkdir()
    (real / "p.svg").write_text("old")
    link = tmp_path / "p.svg"
    link.symlink_to(real / "p.svg")
    res = invoke("export", "0x0488", "--svg", str(link))
    assert res.exit_code == 0, res.stderr
    assert link.is_symlink() and os.readlink(link) == str(real / "p.svg")
    assert (real / "p.svg").read_text().startswith("<?xml")
    assert parts(real) == [] and parts(tmp_path) == []


def test_a_dangling_symlink_is_refused(tmp_path: Path) -> None:
    link = tmp_path / "p.svg"
    link.symlink_to(tmp_path / "missing" / "p.svg")
    one_line_error(invoke("export", "0x0488", "--svg", str(link)), "symbolic link")
    link2 = tmp_path / "q.svg"
    link2.symlink_to(tmp_path / "q-target.svg")
    one_line_error(invoke("export", "0x0488", "--svg", str(link2)), "dangling")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.svg", "q.svg"]
