"""Shared fixtures: tiny, named inputs used across the test modules."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fabpat.library import Library, enumerate_library

FABPAT = [sys.executable, "-m", "fabpat"]


@pytest.fixture(scope="session")
def hex_library() -> Library:
    return enumerate_library(6, 2)


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the real ``fabpat`` entry point in a subprocess (as a user would)."""
    env = dict(os.environ, COLUMNS="160", FABPAT_CACHE="off")
    return subprocess.run([*FABPAT, *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=600)
