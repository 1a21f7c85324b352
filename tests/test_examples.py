"""Every script in examples/ runs and prints numbers that are checked here by other means: closed
forms, files read back with other libraries, and the shipped catalog queried with plain sqlite3."""

from __future__ import annotations

import math
import os
import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FAN = math.sqrt(3) / 4 * 36.0**2  # mm²: a fan triangle of the 36 mm hexagon is equilateral


def run_example(name: str, cwd: Path, *args: str) -> list[dict[str, str]]:
    """Run ``examples/<name>`` in ``cwd``; each stdout line of key=value tokens as a dict."""
    env = dict(os.environ, MPLBACKEND="Agg", FABPAT_CACHE="off")
    r = subprocess.run([sys.executable, str(EXAMPLES / name), *args], capture_output=True, text=True, cwd=cwd,
                       env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    return [dict(tok.split("=", 1) for tok in line.split() if "=" in tok) for line in r.stdout.splitlines()]


def popcount(pattern_id: str) -> int:
    return bin(int(pattern_id, 16)).count("1")


def builtin_db() -> sqlite3.Connection:
    from fabpat.catalog import builtin_path

    return sqlite3.connect(f"file:{builtin_path()}?mode=ro", uri=True)


def catalog_results(pattern_id: str) -> dict[str, tuple[float, float]]:
    """{scenario: (energy, max_displacement)} of the default set-up, straight from the SQLite file."""
    with builtin_db() as db:
        q = db.execute("SELECT scenario, energy, max_displacement FROM results WHERE id = ? AND sides = 6 AND "
                       "depth = 2 AND edge = 36.0 AND thickness = 2.0 AND weight = 0.2", (pattern_id,))
        return {s: (e, d) for s, e, d in q}


def shoelace(P: np.ndarray) -> float:
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_laser_cut(tmp_path: Path) -> None:
    import ezdxf

    row = run_example("laser_cut.py", tmp_path)[0]
    pid, kerf = row["id"], float(row["kerf"])
    # the chosen pattern covers exactly half the hexagon: 48 of its 96 sub-triangles (closed form)
    assert float(row["lattice_area"]) == pytest.approx(3 * FAN, abs=1e-4)
    assert 6 * popcount(pid) * FAN / 16 == pytest.approx(3 * FAN, rel=1e-12)
    assert float(row["min_width"]) >= 2 * kerf
    # the DXF's CUT loops, read back with ezdxf, enclose the exact area grown by the kerf offset
    # (ΔA = perimeter · kerf/2 to first order; the chords within 0.01 mm cost < 0.01 mm × perimeter)
    doc = ezdxf.readfile(tmp_path / f"{pid}.dxf")
    loops = [np.array(e.get_points("xy")) for e in doc.modelspace() if e.dxf.layer == "CUT"
             and e.dxftype() == "LWPOLYLINE"]
    areas = sorted((abs(shoelace(P)) for P in loops), reverse=True)
    area, perimeter = float(row["filleted_area"]), float(row["perimeter"])
    assert areas[0] - sum(areas[1:]) == pytest.approx(area + perimeter * kerf / 2, abs=0.01 * perimeter)
    texts = [e.dxf.text for e in doc.modelspace() if e.dxftype() in ("TEXT", "MTEXT")]
    assert any(pid in t for t in texts)
    assert (tmp_path / f"{pid}.svg").read_text().startswith("<?xml")


def test_simulate_scenarios(tmp_path: Path) -> None:
    import meshio

    rows = run_example("simulate_scenarios.py", tmp_path)[:3]
    stored = catalog_results("0x0488")
    assert [r["scenario"] for r in rows] == ["cantilever", "cylinder", "dome"]
    for r in rows:  # a fresh simulation reproduces the shipped catalog (computed by `fabpat sweep`)
        energy, displacement = stored[r["scenario"]]
        assert float(r["energy"]) == pytest.approx(energy, rel=1e-6)
        assert float(r["max_displacement"]) == pytest.approx(displacement, rel=1e-3)
    dome = meshio.read(tmp_path / "0x0488-dome.vtu")
    assert len(dome.points) == int(rows[2]["nodes"])
    fine = float(rows[2]["mesh_energies"].split(",")[-1])  # the .vtu is the finer mesh's
    assert float(np.sum(dome.cell_data["strain_energy"][0])) == pytest.approx(fine, rel=1e-5)
    assert fine < float(rows[2]["energy"])  # the extrapolation raises it towards the converged value
    for s in ("cantilever", "cylinder", "dome", "energies"):
        assert (tmp_path / f"0x0488-{s}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _polar_moment_by_quadrature(pattern_id: str) -> float:
    """∫∫ r² dA over the solid triangles by the edge-midpoint rule (exact for quadratics)."""
    import fabpat

    p = fabpat.pattern(pattern_id)
    T = p.V[p.solid_faces]  # (k, 3, 2)
    u, v = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    mids = (T + np.roll(T, -1, axis=1)) / 2
    return float(np.sum(area * (mids**2).sum(axis=2).mean(axis=1)))


def test_rank_depth3(tmp_path: Path) -> None:
    out = run_example("rank_depth3.py", tmp_path)
    assert out[0] == {"sampled": "40", "depth": "3"}
    ranked = out[1:]
    assert [r["rank"] for r in ranked] == ["1", "2", "3", "4", "5"]
    moments = [float(r["polar_moment"]) for r in ranked]
    assert moments == sorted(moments, reverse=True)
    for r in ranked:
        pid = r["id"]
        assert re.fullmatch(r"0x[0-9a-f]{16}", pid)
        assert float(r["area"]) == pytest.approx(6 * popcount(pid) * FAN / 64, abs=1e-4)  # depth-3 sub-triangles
        assert float(r["perimeter"]) / 4.5 == pytest.approx(round(float(r["perimeter"]) / 4.5), abs=1e-6)
        assert float(r["polar_moment"]) == pytest.approx(_polar_moment_by_quadrature(pid), abs=0.01)


def test_build_kit(tmp_path: Path) -> None:
    import fabpat
    from fabpat.assembly.kit.sheets import read_sheet

    out = run_example("build_kit.py", tmp_path)
    head, parts = out[0], out[1:4]
    assert head["plates"] == "3" and head["sleeves"] == "2"  # a 1 × 3 strip: three plates, two shared edges
    fps = {i: fabpat.pattern(i).fillet() for i in ("0x0488", "0x0508", "0x0588")}
    assert [p["part"] for p in parts] == list(fps)
    for p in parts:
        assert float(p["area"]) == pytest.approx(fps[p["part"]].metrics.area, abs=1e-3)
        assert p["file"].startswith("sheets/") and (tmp_path / "kit" / p["file"]).is_file()
    assert float(head["cut_length"]) == pytest.approx(sum(f.metrics.perimeter for f in fps.values()), abs=1e-2)
    sheets = sorted((tmp_path / "kit" / "sheets").glob("*.dxf"))
    assert len(sheets) == int(head["sheets"])
    loops = sum(len(read_sheet(s)[0]) for s in sheets)
    assert loops == sum(1 + len(f.outline.holes) for f in fps.values())


def test_pick_by_stiffness(tmp_path: Path) -> None:
    out = run_example("pick_by_stiffness.py", tmp_path)
    with builtin_db() as db:
        rows = db.execute(
            "SELECT p.id, r.energy FROM patterns p JOIN results r USING (id, sides, depth, edge, thickness, weight) "
            "WHERE r.scenario = 'dome' AND r.converged = 1 AND p.min_width >= 2.0 AND sides = 6 "
            "ORDER BY r.energy").fetchall()
    assert int(out[0]["printable"]) == len(rows)
    assert out[1]["stiffest"] == rows[0][0] and float(out[1]["energy_dome"]) == pytest.approx(rows[0][1], abs=1e-6)
    assert out[2]["softest"] == rows[-1][0] and float(out[2]["energy_dome"]) == pytest.approx(rows[-1][1], abs=1e-6)
    near = sorted(rows, key=lambda r: abs(r[1] - 200.0))[:5]
    assert [r["near_target"] for r in out[3:8]] == [i for i, _ in near]
