"""A design run stopped early keeps what it finished: Ctrl-C, SIGTERM and the time budget write the best
design so far (``"interrupted": true``), an abandoned solve is recorded with its reason, and the solves'
own progress reaches the caller, from worker processes too. The solves are stand-ins (instant, a shape
per call): these tests are about the bookkeeping, not the physics."""

from __future__ import annotations

import functools
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fabpat.design import api
from fabpat.design.search import Runner
from fabpat.design.stop import BUDGET, OutOfTime, until_stopped
from fabpat.errors import SolverError
from tests.helpers import invoke
from tests.test_design import _base

#: what the stand-in solve does at its n-th call (0-based): raise this exception, or nothing
SCRIPT: dict[int, BaseException] = {}
CALLS: list[tuple[str, ...]] = []


def fake_solve(spec: Any, patterns: tuple[str, ...], h: float, travel: float, start: Any = None) -> dict[str, Any]:
    """A strip 'solve': an arch that gets closer to the target with every call (so each is the best so far)."""
    from fabpat.shell import news

    n = len(CALLS)
    CALLS.append(patterns)
    news.tell(f"increment 3, λ = 0.500, {7 + n} factorizations")  # as a path tells its listeners
    if n in SCRIPT:
        raise SCRIPT[n]
    x = np.linspace(0.0, 400.0, 81)
    return {"x": x, "z": (20.0 + 2.0 * n) * np.sin(np.pi * x / 400.0), "end_shortening": 0.1, "length": 400.0,
            "seconds": 0.0, "peak_strain": 0.001, "state": None, "factorizations": 1, "warm": False}


@pytest.fixture
def strip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, Path]:
    """A 1 × 4 strip base, an arch target (scaled to the strip) and the stand-in solve."""
    CALLS.clear()
    SCRIPT.clear()
    monkeypatch.setattr(api, "Runner", functools.partial(Runner, solve=fake_solve))
    monkeypatch.setattr(api, "space_mapping", lambda *a: None)  # the elastica's fits of stand-in shapes: seconds
    x = np.linspace(0.0, 200.0, 41)
    target = tmp_path / "arch.csv"
    target.write_text("x,z\n" + "".join(f"{a:.6f},{40.0 * np.sin(np.pi * a / 200.0):.6f}\n" for a in x))
    return {"spec": _base(tmp_path, "variations = false"), "target": target, "out": tmp_path / "d"}


def _design(strip: dict[str, Path], *more: str) -> Any:
    return invoke("design", str(strip["target"]), "--spec", str(strip["spec"]), "--out", str(strip["out"]),
                  "--h", "6", "--scale-target", "--no-progress", *more)


def test_ctrl_c_in_a_solve_writes_the_best_design_so_far_and_exits_130(strip: dict[str, Path]) -> None:
    SCRIPT[2] = KeyboardInterrupt()  # Ctrl-C while the third solve runs
    r = _design(strip)
    assert r.returncode == 130 and r.stderr.endswith("fabpat: interrupted\n"), r.stderr
    assert "stopped by Ctrl-C (SIGINT) after 2 solves: the best design so far is written" in r.stderr
    rec = json.loads((strip["out"] / "design.json").read_text())
    assert rec["interrupted"] is True and rec["stopped_by"] == "SIGINT" and rec["solves"] == 2
    assert sorted(p.name for p in strip["out"].iterdir()) == ["design.json", "design.png", "design.toml"]
    assert r.stdout.splitlines() == [f"{strip['out']}/{f}" for f in ("design.toml", "design.json", "design.png")]


def test_ctrl_c_before_any_solve_finished_writes_nothing(strip: dict[str, Path]) -> None:
    SCRIPT[0] = KeyboardInterrupt()
    r = _design(strip)
    assert (r.returncode, r.stderr) == (130, "fabpat: interrupted\n")
    assert not strip["out"].exists()


def test_the_budget_and_an_abandoned_solve_are_recorded(strip: dict[str, Path]) -> None:
    """The budget ringing in the fourth solve keeps the three before it, one of which was abandoned: a
    finished run with a warning line (exit 0), the solver's reason in design.json."""
    SCRIPT[1] = SolverError("path following stalled: abandoned at load fraction λ = 0.3125")
    SCRIPT[3] = OutOfTime()
    r = _design(strip, "--max-minutes", "30")
    assert r.returncode == 0, r.stderr
    assert "fabpat: warning: stopped when its time budget of 30 minutes ran out after 3 solves" in r.stderr
    rec = json.loads((strip["out"] / "design.json").read_text())
    assert rec["interrupted"] is True and rec["stopped_by"] == BUDGET and rec["solves"] == 3
    assert [a["reason"] for a in rec["abandoned"]] == ["path following stalled: abandoned at load fraction λ = 0.3125"]
    assert len(CALLS) == 4


def test_a_finished_run_says_it_was_not_interrupted(strip: dict[str, Path]) -> None:
    r = _design(strip, "--max-solves", "1")
    assert r.returncode == 0, r.stderr
    rec = json.loads((strip["out"] / "design.json").read_text())
    assert rec["interrupted"] is False and "stopped_by" not in rec and rec["abandoned"] == []


def test_the_progress_line_shows_the_solve_in_progress(strip: dict[str, Path],
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FABPAT_PROGRESS_INTERVAL", "0")  # a plain line for every update
    r = invoke("design", str(strip["target"]), "--spec", str(strip["spec"]), "--out", str(strip["out"]),
               "--h", "6", "--scale-target", "--max-solves", "1")
    assert r.returncode == 0, r.stderr
    assert "fabpat: design: 0 solves done; solve 1: increment 3, λ = 0.500, 7 factorizations, " in r.stderr
    assert "fabpat: design: 1 solves done; solve 2: increment 3, λ = 0.500, 8 factorizations, " in r.stderr


def test_a_spent_budget_before_the_first_solve_is_one_line_and_writes_nothing(strip: dict[str, Path],
                                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(api, "Runner", lambda *a, **k: Runner(*a, **{**k, "deadline": 0.0}, solve=fake_solve))
    r = _design(strip)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith("fabpat: error: the time budget ran out before any design was solved (0 solves")
    assert not strip["out"].exists()


def test_the_budget_cuts_a_solve_short() -> None:
    """The timer rings inside a long blocking call (a solve), well before that call would end."""
    t0 = time.perf_counter()
    assert until_stopped(lambda: time.sleep(30.0), t0 + 0.2) == BUDGET
    assert time.perf_counter() - t0 < 5.0
    assert until_stopped(lambda: None, t0 + 0.2) is None
    time.sleep(0.3)  # the timer was disarmed: nothing rings after the work


def tell_and_solve(spec: Any, patterns: tuple[str, ...], h: float) -> dict[str, Any]:
    """A solve in a worker process that tells its progress as the path does."""
    from fabpat.shell import news

    news.tell(f"increment 7, λ = 0.625, 19 factorizations ({patterns[0]})")
    time.sleep(0.5)  # the parent's reader polls every 0.2 s
    return {"pid": os.getpid()}


def test_worker_processes_progress_reaches_the_parent() -> None:
    heard: list[str] = []
    runner = Runner(None, 6.0, (), workers=2, solve=tell_and_solve, status=heard.append)
    out = runner.run([("a",), ("b",)])
    pids = {str(res["pid"]) for res in out}  # type: ignore[index]
    assert pids and os.getpid() not in pids
    said = [h for h in heard if "increment 7, λ = 0.625, 19 factorizations" in h]
    assert said and all(h.startswith("solves 1–2: worker ") for h in said), heard
    assert {h.split("worker ")[1].split(":")[0] for h in said} <= pids


def test_from_python_a_ctrl_c_returns_the_best_design_so_far(strip: dict[str, Path]) -> None:
    from fabpat.design import design

    SCRIPT[1] = KeyboardInterrupt()
    heard: list[str] = []
    res = design(strip["target"], strip["spec"], h=6.0, scale_target=True, status=heard.append)
    assert res.record["interrupted"] is True and res.record["stopped_by"] == "SIGINT" and res.record["solves"] == 1
    assert res.warning is not None and res.warning.startswith("stopped by Ctrl-C (SIGINT) after 1 solves")
    assert "solve 1: increment 3, λ = 0.500, 7 factorizations" in heard
