"""Issue 15 §6, outputs and files: one line and no stray file for every way an output can go wrong."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from fabpat.errors import ExportError
from fabpat.io import atomic_outputs, check_distinct, remove_stale_temps, temp_prefix
from tests.conftest import FABPAT

ROOT = Path(__file__).resolve().parents[1]
SMALL_SPEC = ROOT / "assemblies" / "test-small.toml"


def invoke(*args: str) -> Result:
    from fabpat.cli import cli

    return CliRunner().invoke(cli, list(args))


def one_line_error(res: Result | subprocess.CompletedProcess[str], *words: str) -> None:
    code = res.exit_code if isinstance(res, Result) else res.returncode
    assert code == 2, res.stderr
    assert res.stderr.startswith("fabpat: error:") and res.stderr.count("\n") == 1, res.stderr
    for w in words:
        assert w in res.stderr, res.stderr


def parts(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".part" in p.name) if folder.exists() else []


# -- two outputs, one file --------------------------------------------------------------------------


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


# -- empty lists ------------------------------------------------------------------------------------


def test_export_all_with_no_formats_is_an_error(tmp_path: Path) -> None:
    res = invoke("export", "--all", "--out", str(tmp_path / "o"), "--formats", "")
    one_line_error(res, "no format", "step, stl, 3mf, dxf, svg")
    res = invoke("export", "--all", "--out", str(tmp_path / "o"), "--formats", " , ")
    one_line_error(res, "no format")
    assert not (tmp_path / "o").exists()


def test_plot_with_an_empty_highlight_list_is_an_error(tmp_path: Path) -> None:
    for empty in ("", " , "):
        one_line_error(invoke("plot", "--out", str(tmp_path / "f"), "--highlight", empty), "--highlight", "0x0488")
    assert list(tmp_path.iterdir()) == []


# -- temporary files: interrupted runs and stale leftovers ----------------------------------------


def _export_all(out: Path) -> subprocess.Popen[str]:
    env = dict(os.environ, FABPAT_CACHE="off")
    return subprocess.Popen([*FABPAT, "export", "--all", "--out", str(out), "--formats", "svg,dxf"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def _wait_for_parts(proc: subprocess.Popen[str], out: Path) -> None:
    t0 = time.monotonic()
    while not parts(out):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < 120, "export --all wrote no temporary file"
        time.sleep(0.05)
    time.sleep(0.3)  # well inside the writing of 860 files


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_interrupted_export_all_leaves_no_part_files(tmp_path: Path, sig: signal.Signals) -> None:
    out = tmp_path / "parts"
    proc = _export_all(out)
    _wait_for_parts(proc, out)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err  # 143 for SIGTERM, 130 for Ctrl-C
    assert parts(out) == []
    assert not out.exists()  # the folder this run created is removed again


def test_ctrl_c_during_the_last_part_stops_before_the_commit(tmp_path: Path) -> None:
    """An interrupt held while a part is written (deferred_interrupts, one part at a time) is raised when
    that part is done, still inside the atomic block: even during the last part no file is committed."""
    import fabpat
    from fabpat.cli import deferred_interrupts
    from fabpat.exchange.registry import export_parts, filleted_part

    part = filleted_part(fabpat.pattern("0x0488").fillet())
    jobs = [(part, {"svg": tmp_path / f"p{i}.svg"}) for i in range(3)]
    done: list[int] = []

    def on_part(_part: object, _formats: list[str]) -> None:
        done.append(1)
        if len(done) == len(jobs):  # the last part: the signal arrives while it is being finished
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        export_parts(jobs, on_part=on_part, part_guard=deferred_interrupts)
    assert len(done) == 3 and list(tmp_path.iterdir()) == []


def test_deferred_interrupts_keep_an_ignored_sigint_and_surface_a_held_one() -> None:
    from fabpat.cli import deferred_interrupts

    before = signal.getsignal(signal.SIGINT)
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a background job's SIGINT
        with deferred_interrupts():
            os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, before)
    with pytest.raises(KeyboardInterrupt) as info, deferred_interrupts():  # held, then another error
        os.kill(os.getpid(), signal.SIGINT)
        raise ValueError("a writer failed")
    assert isinstance(info.value.__context__, ValueError)
    assert signal.getsignal(signal.SIGINT) is before


def test_stale_part_files_are_removed_by_the_next_run(tmp_path: Path) -> None:
    out = tmp_path / "parts"
    proc = _export_all(out)
    _wait_for_parts(proc, out)
    proc.kill()  # SIGKILL: no cleanup can run
    proc.wait()
    stale = parts(out)
    assert stale
    live = out / f"{temp_prefix('keep')}abcdefgh.part.svg"  # this process is alive: its file stays
    live.write_text("")
    res = invoke("export", "0x0488", "--svg", str(out / "p.svg"))
    assert res.exit_code == 0, res.stderr
    assert parts(out) == [live.name]
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["p.svg"]


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


# -- a full disk ------------------------------------------------------------------------------------


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


def _unshare_works() -> bool:
    try:
        return subprocess.run(["unshare", "-rm", "true"], capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


needs_unshare = pytest.mark.skipif(sys.platform != "linux" or not _unshare_works(),
                                   reason="needs unshare (util-linux) with user and mount namespaces")


def in_small_tmpfs(folder: Path, script: str, size: str = "64k") -> subprocess.CompletedProcess[str]:
    """Run ``script`` (sh) with a ``size`` tmpfs mounted on ``folder`` (a private mount namespace):
    a real full disk, no root needed on the host."""
    folder.mkdir(exist_ok=True)
    env = dict(os.environ, FABPAT_CACHE="off", COLUMNS="160", FAB=" ".join(FABPAT))
    return subprocess.run(["unshare", "-rm", "sh", "-c", f"mount -t tmpfs -o size={size} tmpfs {folder} && {script}"],
                          capture_output=True, text=True, env=env, timeout=300, cwd=folder.parent)


@needs_unshare
def test_plot_on_a_full_disk_leaves_no_folder_tmpfs(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    res = in_small_tmpfs(disk, "$FAB plot --out disk/figures; echo rc=$?; ls -A disk")
    assert "rc=2" in res.stdout and res.stdout.split("rc=2")[1].strip() == "", res.stdout
    one_line_error(subprocess.CompletedProcess([], 2, "", res.stderr), "disk is full")


# -- STEP time stamp ----------------------------------------------------------------------------------


def test_timestamp_must_be_iso8601(tmp_path: Path) -> None:
    from fabpat.exchange.registry import ExportSettings
    from fabpat.exchange.step import check_timestamp

    res = invoke("assemble", str(SMALL_SPEC), "--out", str(tmp_path / "kit"), "--timestamp", "garbage")
    one_line_error(res, "--timestamp", "ISO 8601")
    assert list(tmp_path.iterdir()) == []
    for bad in ("garbage", "2025-13-01", "", "2025-01-31T25:00", "2025-01-31 \u00e9"):
        with pytest.raises(ExportError, match="ISO 8601"):
            check_timestamp(bad)
        with pytest.raises(ExportError, match="ISO 8601"):
            ExportSettings(timestamp=bad).check()
    for good in ("2025-01-31T12:00:00", "2025-01-31T12:00:00Z", "2025-01-31T12:00:00+01:00"):
        assert check_timestamp(good) == good  # already normal: unchanged


def test_step_header_gets_a_valid_timestamp_only(tmp_path: Path) -> None:
    from fabpat.exchange.step import dump_step

    with pytest.raises(ExportError, match="ISO 8601"):
        dump_step(object(), tmp_path / "x.step", "x", "not a time")  # refused before OCCT sees the shape
    assert list(tmp_path.iterdir()) == []


# -- symbolic links -------------------------------------------------------------------------------------


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
