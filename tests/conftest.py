"""Shared fixtures: tiny, named inputs used across the test modules."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

# One thread per BLAS/OpenMP/MKL pool, set before numpy is first imported: the README runs the suite with
# one xdist worker per core (-n 2 on 2 cores), and the pools' threads in every worker (and in the CLI
# subprocesses, which inherit this environment) only compete for the same cores — a sphere closure took
# 12.5 s of CPU with them and 7.7 s without. A variable already set (e.g. by a developer) is kept.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from fabpat.patterns.library import Library, enumerate_library  # noqa: E402 - after the thread settings

FABPAT = [sys.executable, "-m", "fabpat"]


@pytest.fixture(scope="session")
def hex_library() -> Library:
    return enumerate_library(6, 2)


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the real ``fabpat`` entry point in a subprocess (as a user would)."""
    env = dict(os.environ, COLUMNS="160", FABPAT_CACHE="off")
    return subprocess.run([*FABPAT, *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=600)


@pytest.fixture(scope="module")
def small_catalog(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real catalog of 2 patterns × 3 scenarios (1.5 s), in DELETE journal mode as a finished sweep leaves it."""
    from tests.helpers import SWEEP, invoke_result

    db = tmp_path_factory.mktemp("cat") / "c.sqlite"
    res = invoke_result(*SWEEP, "--db", str(db))
    assert res.exit_code == 0, res.stderr
    return db
