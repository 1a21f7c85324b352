"""Long work shows progress: plain lines on a piped stderr every FABPAT_PROGRESS_INTERVAL seconds, nothing
on stdout (its data are unchanged), nothing with --no-progress, and nothing for work shorter than the
interval (a quick refusal stays one line, also for `assemble`)."""

from __future__ import annotations

import io
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fabpat.errors import RangeError
from fabpat.progress import INTERVAL_VARIABLE, Progress, progress_interval
from tests.helpers import SPECS
from tests.helpers import run_in as fabpat

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "assemblies" / "test-small.toml"


def run(*args: str, interval: str | None = "0.2", cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, FABPAT_CACHE="off")
    env.pop(INTERVAL_VARIABLE, None)
    if interval is not None:
        env[INTERVAL_VARIABLE] = interval
    return subprocess.run([sys.executable, "-m", "fabpat", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=600)


def progress_lines(stderr: str, command: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith(f"fabpat: {command}: ")]


def without_times(fields: dict) -> dict:  # type: ignore[type-arg]
    return {k: v for k, v in fields.items() if k != "seconds"}


@pytest.mark.slow
def test_simulate_assembly_in_a_pipe_prints_progress_lines_and_the_same_json() -> None:
    shown = run("simulate-assembly", str(SMALL), "--json")
    assert shown.returncode == 0, shown.stderr
    lines = progress_lines(shown.stderr, "simulate-assembly")
    # the solver's news follows the step: "; increment 2, λ = 0.001 → 1.000, iteration 12, 9 factorizations"
    # (the strip leaps from its knee to the end in one increment, so its report points, "40 % of the end
    # shortening", all come at the end: the leap's iterations are what a pipe sees)
    line = re.compile(r"fabpat: simulate-assembly: (\d+ % of the end shortening|meshing and joining the plates)"
                      r"; increment \d+, λ = \d\.\d{3}( → \d\.\d{3}, iteration \d+)?, \d+ factorizations"
                      r"(, \d+ step cuts)?, \d+ s")
    assert any(line.fullmatch(ln) for ln in lines), lines
    assert lines[-1].startswith("fabpat: simulate-assembly: done, ")
    quiet = run("simulate-assembly", str(SMALL), "--json", "--no-progress")
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr
    assert without_times(json.loads(shown.stdout)) == without_times(json.loads(quiet.stdout))


@pytest.mark.slow
def test_assemble_in_a_pipe_prints_its_steps(tmp_path: Path) -> None:
    # the small strip with its bill of materials only: the prediction step (the long one, whose lines are
    # checked) still runs, the files written after it (STEP, STL, GLB, …) are not what this test is about
    spec = tmp_path / "test-small.toml"
    spec.write_text(SMALL.read_text() + '\n[output]\nformats = ["bom"]\n')
    shown = run("assemble", str(spec), "--out", "a", cwd=tmp_path)
    assert shown.returncode == 0, shown.stderr
    lines = progress_lines(shown.stderr, "assemble")
    assert any(re.match(r"fabpat: assemble: step \d+ of \d+: prediction", ln) for ln in lines), lines
    assert lines[-1].startswith("fabpat: assemble: done, ")
    quiet = run("assemble", str(spec), "--out", "b", "--no-progress", cwd=tmp_path)
    assert quiet.returncode == 0 and not progress_lines(quiet.stderr, "assemble")
    assert [ln.replace("a/", "", 1) for ln in shown.stdout.splitlines()] == \
        [ln.replace("b/", "", 1) for ln in quiet.stdout.splitlines()]


def test_simulate_prints_a_line_per_scenario() -> None:
    shown = run("simulate", "0x0488", "--scenario", "all", "--h", "3.5", "--json", interval="0")
    assert shown.returncode == 0, shown.stderr
    done = [ln for ln in progress_lines(shown.stderr, "simulate") if " finished " in ln]
    assert [ln.split(":")[2].split()[0] for ln in done] == ["cantilever", "cylinder", "dome"], shown.stderr
    quiet = run("simulate", "0x0488", "--scenario", "all", "--h", "3.5", "--json", "--no-progress", interval="0")
    assert quiet.stderr == "" and [without_times(r) for r in json.loads(shown.stdout)] == \
        [without_times(r) for r in json.loads(quiet.stdout)]


def test_a_quick_refusal_prints_no_progress() -> None:
    r = run("simulate-assembly", str(SMALL), "--h", "9", interval=None)  # the default interval, 5 s
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("fabpat: error: "), r.stderr


def test_work_shorter_than_the_interval_prints_nothing() -> None:
    out = io.StringIO()
    with Progress("x", stream=out, terminal=False, interval=5.0) as bar:
        bar.update("working")
        bar.item("a finished")
    assert out.getvalue() == ""


def test_lines_come_every_interval_with_the_latest_state() -> None:
    out = io.StringIO()
    with Progress("x", total=2, stream=out, terminal=False, interval=0.2) as bar:
        bar.update("first half", 0)
        time.sleep(0.5)
        bar.update("second half", 1)
        time.sleep(0.5)
    lines = out.getvalue().splitlines()
    assert 3 <= len(lines) <= 8, lines  # ≈ 0.2, 0.4, 0.6, 0.8 s and the end: far fewer than the polls
    assert lines[0].startswith("fabpat: x: first half, ")
    assert any(ln.startswith("fabpat: x: second half, ") for ln in lines)
    assert lines[-1].startswith("fabpat: x: done, ")


def test_disabled_progress_prints_nothing_even_at_interval_zero() -> None:
    out = io.StringIO()
    with Progress("x", stream=out, terminal=False, interval=0.0, enabled=False) as bar:
        bar.update("working")
        bar.item("finished")
    assert out.getvalue() == ""


def test_an_error_ends_without_a_done_line() -> None:
    out = io.StringIO()
    with pytest.raises(KeyError), Progress("x", stream=out, terminal=False, interval=0.0) as bar:
        bar.update("working")
        raise KeyError("boom")
    assert out.getvalue() == "fabpat: x: working, 0 s\n"


def test_a_terminal_gets_a_bar_not_lines() -> None:
    out = io.StringIO()
    with Progress("x", total=1, stream=out, terminal=True, interval=0.0) as bar:
        bar.update("working", 0.5)
    assert "fabpat: x:" not in out.getvalue()


@pytest.mark.parametrize("value", ["x", "-1", "nan", "1e9"])
def test_a_bad_interval_is_refused(value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(INTERVAL_VARIABLE, value)
    with pytest.raises(RangeError, match=INTERVAL_VARIABLE):
        progress_interval()
    monkeypatch.setenv(INTERVAL_VARIABLE, "0.5")
    assert progress_interval() == 0.5


def test_kit_refusal_is_one_line_without_a_progress_bar(tmp_path: Path) -> None:
    # the progress bar drew an empty line on a piped stderr before the refusal
    spec = tmp_path / "s.toml"
    spec.write_text((SPECS / "test-small.toml").read_text().replace("kerf = 0.15", "kerf = 10"))
    code, _, err = fabpat(tmp_path, "assemble", str(spec), "--out", str(tmp_path / "kit"))
    assert code == 2 and err.startswith("fabpat: error: ") and err.count("\n") == 1, repr(err)
    assert "kerf" in err and not (tmp_path / "kit").exists()
