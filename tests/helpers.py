"""Small helpers shared by several test modules."""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
FLAT_SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
#: mm: the mesh of the shared sphere closure. A closure costs about the same from h = 7.5 to 3 (6–7 s idle:
#: the interfaces' refinement dominates the mesh), so the saving is in closing it once, not coarser.
SPHERE_H = 6.0
#: report steps of the sphere closures whose final state alone is read: one increment reaches the same
#: equilibrium as the default 4 (radius, sphericity_rms and energy agree to 1e-11 relative, measured) with
#: 10 factorizations instead of 19. Not for a best-fit placement (GP(1, 1) needs the path: 94 against 44).
SPHERE_STEPS = 1


@functools.cache
def flat_sphere() -> Any:
    """The shipped sphere (``assemblies/truncated-icosahedron.toml``: the paper's pair, straight sleeves)
    closed by ``simulate_assembly`` at :data:`SPHERE_H` in :data:`SPHERE_STEPS`, once per test process: the
    sphere-closure, warm-start and prediction tests read this one closure. Callers must not modify it."""
    from fabpat.assembly.simulation import simulate_assembly
    from fabpat.assembly.spec import load_spec

    return simulate_assembly(load_spec(FLAT_SPHERE), h=SPHERE_H, steps=SPHERE_STEPS)


def invoke(*args: str) -> subprocess.CompletedProcess[str]:
    """``fabpat ARGS`` in this process (click's runner), as a CompletedProcess like
    :func:`tests.conftest.run_cli`'s: for tests about what a command says and writes. A new interpreter
    costs seconds of imports (the CAD libraries), so run_cli stays for what only the real process shows
    (exit codes of the entry point, signals, stderr as written). An exception other than the command's
    own exit is raised, not turned into an exit code."""
    from click.testing import CliRunner

    from fabpat.cli import cli

    r = CliRunner().invoke(cli, list(args), env={"COLUMNS": "160", "FABPAT_CACHE": "off"})
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    return subprocess.CompletedProcess(["fabpat", *args], r.exit_code, r.stdout, r.stderr)
