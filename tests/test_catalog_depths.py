"""The built-in catalog's depth-3 patterns beside the paper's depth-2 library: what a default reading shows, what
``depth=3`` / ``--depth 3`` shows, the browsing page of each depth, and the Cylinder-energy range they widen."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import fabpat
from fabpat.catalog import default_depth, open_catalog
from fabpat.exchange.registry import PRINT_MIN_WIDTH
from fabpat.validate import as_float

HELD_OUT = Path(__file__).parents[1] / "benchmarks" / "data" / "depth3-hexagons-heldout.sqlite"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "fabpat", *args], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("sides", [5, 6])
def test_a_default_reading_is_the_papers_library_and_depth_3_the_shipped_deeper_patterns(sides: int) -> None:
    two = fabpat.catalog(sides=sides)
    assert len(two) == 430 and {r["depth"] for r in two} == {2}  # the paper's count, nothing added to it
    three = fabpat.catalog(sides=sides, depth=3)
    assert {r["depth"] for r in three} == {3} and len(three) >= 50
    assert not {r["id"] for r in two} & {r["id"] for r in three}
    # every shipped depth-3 pattern has its Cylinder energy (the strips' scenario); a Dome that snapped is stored as
    # not converged, without an energy, as a sweep stores it
    assert all(r["energy_cylinder"] is not None and r["converged_cylinder"] for r in three)
    assert all((r["energy_dome"] is None) == (not r["converged_dome"]) for r in three)


def test_the_cli_reads_depth_2_by_default_and_depth_3_when_asked() -> None:
    two = json.loads(_run("catalog", "--format", "json").stdout)
    three = json.loads(_run("catalog", "--format", "json", "--depth", "3", "--sides", "5").stdout)
    assert len(two) == 430 and {r["depth"] for r in two} == {2}
    assert {r["depth"] for r in three} == {3} and {r["sides"] for r in three} == {5}


def test_a_catalog_of_depth_3_rows_alone_is_read_whole_by_default(tmp_path: Path) -> None:
    db = tmp_path / "deep.sqlite"
    shutil.copy(HELD_OUT, db)
    with open_catalog(db) as cat:
        assert default_depth(cat, 6) is None  # no depth 2 held: every depth
    rows = fabpat.catalog(db)
    assert len(rows) >= 190 and {r["depth"] for r in rows} == {3}


def test_the_browsing_page_shows_the_depth_asked_for(tmp_path: Path) -> None:
    out = tmp_path / "deep.html"
    r = _run("browse", "--depth", "3", "--out", str(out))
    assert r.returncode == 0, r.stderr
    n = len(fabpat.catalog(depth=3))
    assert f"({n} patterns," in r.stdout
    assert f"fabpat library: {n} depth-3 hexagons" in out.read_text(encoding="utf-8")
    bad = _run("browse", "--depth", "4", "--out", str(tmp_path / "none.html"))
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "depth 2, 3" in bad.stderr and not (tmp_path / "none.html").exists()


def test_the_shipped_depth_3_hexagons_widen_the_printable_cylinder_range_by_half() -> None:
    # the range must-show as refined by measurement (docs/learned-response.md): max over min of the Cylinder
    # energy among patterns printable at the print limit, depth 2 and 3 together against depth 2 alone
    def span(rows: list[dict[str, object]]) -> float:
        e = [as_float(r["energy_cylinder"]) for r in rows
             if r["energy_cylinder"] is not None and as_float(r["min_width"]) >= PRINT_MIN_WIDTH]
        return max(e) / min(e)

    two, three = list(fabpat.catalog(sides=6)), list(fabpat.catalog(sides=6, depth=3))
    assert span(two + three) >= 1.5 * span(two)


def test_a_shipped_depth_3_hexagon_is_meshed_as_a_plate_of_its_own_depth() -> None:
    # a strip designed with [patterns] depth = 3 places depth-3 plates; the model once read every ID as depth 2
    from fabpat.assembly.solve.model import plate_mesh

    row = fabpat.catalog(depth=3, sort="energy_cylinder", top=1)[0]
    mesh = plate_mesh(str(row["id"]), 6, 36.0, 0.2, 3.0)
    e1, e2 = mesh.V[mesh.F[:, 1]] - mesh.V[mesh.F[:, 0]], mesh.V[mesh.F[:, 2]] - mesh.V[mesh.F[:, 0]]
    area = 0.5 * float(abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())
    assert abs(area / as_float(row["filleted_area"]) - 1.0) < 0.01  # the depth-3 outline, meshed
