"""Small helpers shared by several test modules."""

from __future__ import annotations

import functools
import hashlib
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from click.testing import Result

ROOT = Path(__file__).resolve().parents[1]
FLAT_SPHERE = ROOT / "assemblies" / "truncated-icosahedron.toml"
#: mm: the mesh of the shared sphere closure. A closure costs about the same from h = 7.5 to 3 (6–7 s idle:
#: the interfaces' refinement dominates the mesh), so the saving is in closing it once, not coarser.
SPHERE_H = 6.0
#: report steps of the sphere closures whose final state alone is read: one increment reaches the same
#: equilibrium as the default 4 (radius, sphericity_rms and energy agree to 1e-11 relative, measured) with
#: 10 factorizations instead of 19. Not for a best-fit placement (GP(1, 1) needs the path: 94 against 44).
SPHERE_STEPS = 1


def default_sigint() -> None:
    """``preexec_fn`` of a child that a test sends Ctrl-C: SIGINT's default action, so Python installs its
    KeyboardInterrupt handler. A shell starts a background job (``pytest -n 2 tests &``) with SIGINT ignored,
    its children inherit that, and Python leaves an ignored SIGINT ignored: the Ctrl-C would do nothing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.fixture
def sigint_raises() -> Any:
    """This test process raises KeyboardInterrupt on SIGINT for the test's duration (see
    :func:`default_sigint`: in a background job SIGINT starts out ignored), the earlier handling restored."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


@functools.cache
def flat_sphere() -> Any:
    """The shipped sphere (``assemblies/truncated-icosahedron.toml``: the paper's pair, straight sleeves)
    closed by ``simulate_assembly`` at :data:`SPHERE_H` in :data:`SPHERE_STEPS`, once per test process: the
    sphere-closure, warm-start and prediction tests read this one closure. Callers must not modify it."""
    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.assembly.spec.load import load_spec

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


SPECS = ROOT / "assemblies"
SMALL_SPEC = SPECS / "test-small.toml"
#: a real sweep of 2 patterns × 3 scenarios at a coarse mesh (1.5 s): the small catalogs the tests refuse,
#: damage and fill up
SWEEP = ("sweep", "--sample", "2", "--h", "8", "--workers", "1")


def invoke_result(*args: str) -> Result:
    """``fabpat ARGS`` in this process (click's runner), click's own Result (``exit_code``, ``stdout``,
    ``stderr``; an exception is caught in it): for the tests that read the Result itself."""
    from click.testing import CliRunner

    from fabpat.cli import cli

    return CliRunner().invoke(cli, list(args))


def one_line_error(res: Result | subprocess.CompletedProcess[str], *words: str) -> None:
    """``res`` (a Result or a CompletedProcess) failed with exit code 2 and one stderr line naming ``words``."""
    code = res.exit_code if isinstance(res, Result) else res.returncode
    assert code == 2, res.stderr
    assert res.stderr.startswith("fabpat: error:") and res.stderr.count("\n") == 1, res.stderr
    for w in words:
        assert w in res.stderr, res.stderr


def run_in(tmp_path: Path, *args: str) -> tuple[int, str, str]:
    """Run a command in-process with ``tmp_path`` as the current folder: (exit code, stdout, stderr)."""
    import os

    from click.testing import CliRunner

    from fabpat.cli import cli

    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        r = CliRunner(env={"FABPAT_CACHE": "off"}).invoke(cli, list(args), prog_name="fabpat")
    finally:
        os.chdir(old)
    return r.exit_code, r.stdout, r.stderr


def refusal_in(tmp_path: Path, *args: str) -> str:
    """Assert the command fails with exit 2 and one stderr line, writes nothing; return that line."""
    before = sorted(tmp_path.iterdir())
    code, out, err = run_in(tmp_path, *args)
    lines = err.strip().splitlines()
    assert code == 2, (out, err)
    assert len(lines) == 1 and lines[0].startswith("fabpat: error: "), err
    assert sorted(tmp_path.iterdir()) == before
    return lines[0]


def parts(folder: Path) -> list[str]:
    """The names of the temporary files (``….part…``) in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if ".part" in p.name) if folder.exists() else []


def digest(path: Path) -> str:
    """SHA-256 of the file's bytes: a file refused or read must be byte-identical afterwards."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


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
    import os

    from tests.conftest import FABPAT

    folder.mkdir(exist_ok=True)
    env = dict(os.environ, FABPAT_CACHE="off", COLUMNS="160", FAB=" ".join(FABPAT))
    return subprocess.run(["unshare", "-rm", "sh", "-c", f"mount -t tmpfs -o size={size} tmpfs {folder} && {script}"],
                          capture_output=True, text=True, env=env, timeout=300, cwd=folder.parent)


def tmpfs_error(res: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    """The stderr of an :func:`in_small_tmpfs` run as a failed command's, for :func:`one_line_error`."""
    return subprocess.CompletedProcess([], 2, "", res.stderr)


def edited(src: Path, dst: Path, **changes: str | None) -> Path:
    """``src`` with ``key = value`` lines replaced (the first line of that key in the file; None: removed)."""
    lines = src.read_text(encoding="utf-8").splitlines()
    for key, value in changes.items():
        k = next(i for i, ln in enumerate(lines) if ln.split("=")[0].strip() == key)
        if value is None:
            del lines[k]
        else:
            lines[k] = f"{key} = {value}"
    dst.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return dst


def strip(**patterns: object) -> dict:
    """A 1 × 3 honeycomb-strip spec (as parsed TOML) with these ``[patterns]`` keys."""
    return {"tiling": {"kind": "honeycomb-strip", "edge": 36.0, "rows": 1, "columns": 3},
            "patterns": patterns, "sheet": {"width": 600.0, "height": 400.0}}


def solid_count(shape: object) -> int:
    """How many solids an OCCT shape holds (``TopExp_Explorer`` over ``TopAbs_SOLID``)."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    n, ex = 0, TopExp_Explorer(shape, TopAbs_SOLID)
    while ex.More():
        n += 1
        ex.Next()
    return n


def open_sphere(folder: Path) -> Path:
    """The shipped truncated icosahedron with its [patterns] left open (no pattern named), written to folder."""
    text = FLAT_SPHERE.read_text(encoding="utf-8")
    head, _, rest = text.partition("[patterns]")
    path = folder / "open.toml"
    path.write_text(head + "[patterns]\nvariations = false\n\n" + rest[rest.index("[plates]"):], encoding="utf-8")
    return path
