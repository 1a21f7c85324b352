"""The ``fabpat`` command group itself: called without a command, it prints its help."""

from __future__ import annotations

from pathlib import Path

from tests.helpers import run_in as fabpat


def test_no_command_prints_the_help(tmp_path: Path) -> None:
    code, out, err = fabpat(tmp_path)
    assert code == 0 and out.startswith("Usage: fabpat") and "simulate" in out and err == ""
