"""The README's ten-line Python example (``examples/readme_example.py``, pasted verbatim into the
README and docs/python-api.md) runs and prints the numbers the paper and the shipped catalog give."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from fabpat.catalog import builtin_path

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "readme_example.py"


def test_readme_example(tmp_path: Path) -> None:
    code = SCRIPT.read_text(encoding="utf-8").rstrip("\n").splitlines()
    assert len(code) == 10  # the README promises a ten-line example
    env = dict(os.environ, MPLBACKEND="Agg", FABPAT_CACHE="off")
    r = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, cwd=tmp_path, env=env,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    first, second, third = (line.split() for line in r.stdout.splitlines())
    with sqlite3.connect(f"file:{builtin_path()}?mode=ro", uri=True) as db:
        area = db.execute("SELECT filleted_area FROM patterns WHERE id = '0x0488' AND sides = 6 AND depth = 2 "
                          "AND edge = 36.0 AND weight = 0.2").fetchone()[0]
        energy, displacement = db.execute(
            "SELECT energy, max_displacement FROM results WHERE id = '0x0488' AND scenario = 'cantilever' AND "
            "sides = 6 AND depth = 2 AND edge = 36.0 AND weight = 0.2").fetchone()
        stiff = db.execute("SELECT id, energy FROM results WHERE scenario = 'dome' AND converged = 1 AND sides = 6 "
                           "ORDER BY energy LIMIT 1").fetchone()  # fabpat.catalog() is the hexagons' rows
    assert first == ["430", "0x0488", f"{area:.2f}"]  # 430: the paper's library count (§3.2)
    assert float(second[0]) == pytest.approx(energy, abs=5e-5)  # a fresh simulation = the shipped catalog
    assert float(second[1]) == pytest.approx(displacement, abs=5e-3)
    assert third == [stiff[0], f"{stiff[1]:.2f}"]
    step = (tmp_path / "0x0488.step").read_text()
    assert "RATIONAL_B_SPLINE_CURVE" in step and "0x0488" in step  # the exact fillet, with its weights
    assert (tmp_path / "0x0488-cantilever.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the README and docs/python-api.md show the same snippet (and the page the output it prints)
    readme = (SCRIPT.parents[1] / "README.md").read_text(encoding="utf-8")
    assert "```python\n" + "\n".join(code) + "\n```" in readme
    page = (SCRIPT.parents[1] / "docs" / "python-api.md").read_text(encoding="utf-8")
    assert "```python\n" + "\n".join(code) + "\n```" in page
    assert "```text\n" + r.stdout + "```" in page
