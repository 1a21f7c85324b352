"""The user-set tolerances of ``fabpat export`` reach the files: coarser = fewer pieces, within bound; a
tolerance or thickness out of range, or work above --max-elements, is one line before any work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.helpers import refusal_in as one_line_error
from tests.test_exchange_dxf import bulge_area, cut_loops, read


def _outline():  # noqa: ANN202
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    return fillet_pattern(get_pattern("0x2d88")).outline


@pytest.mark.parametrize("tol", [0.002, 0.05])
def test_dxf_curve_tolerance(tmp_path: Path, tol: float) -> None:
    out = tmp_path / "p.dxf"
    r = run_cli("export", "0x2d88", "--dxf", str(out), "--curves", "lines", "--curve-tolerance", str(tol))
    assert r.returncode == 0, r.stderr
    loops = cut_loops(read(out))
    outline = _outline()
    area = sum(bulge_area(lp) for lp in loops)
    # every chord stays within tol of the exact outline, so the area differs by at most perimeter × tol
    assert abs(area - outline.area) <= outline.perimeter * tol
    vertices = sum(len(lp) for lp in loops)
    exact = sum(len(p) for p in outline.flatten(tol))
    assert vertices == pytest.approx(exact, rel=0.2)


def test_stl_mesh_tolerance(tmp_path: Path) -> None:
    trimesh = pytest.importorskip("trimesh")
    counts, errors = [], []
    outline = _outline()
    for tol in (0.002, 0.05):
        out = tmp_path / f"p{tol}.stl"
        r = run_cli("export", "0x2d88", "--stl", str(out), "--mesh-tolerance", str(tol))
        assert r.returncode == 0, r.stderr
        m = trimesh.load(out, file_type="stl")
        assert m.is_watertight
        counts.append(len(m.faces))
        errors.append(abs(m.volume - 2.0 * outline.area) / (2.0 * outline.perimeter))  # mean chord offset, mm
        assert errors[-1] <= tol
    assert counts[0] > 2 * counts[1]
    assert np.all(np.isfinite(errors))


def test_default_stl_of_the_curviest_pattern_is_within_0_1_percent_volume(tmp_path: Path) -> None:
    # 0x2508 has the largest STL volume error of the library (benchmarks/study_stl_volume.py: +0.107 %
    # at a 0.01 mm chord, +0.051 % at the 0.005 mm default); the issue asks for 0.1 % at the default
    trimesh = pytest.importorskip("trimesh")
    from fabpat.geometry.fillet import fillet_pattern
    from fabpat.patterns.library import get_pattern

    out = tmp_path / "p.stl"
    r = run_cli("export", "0x2508", "--stl", str(out))
    assert r.returncode == 0, r.stderr
    m = trimesh.load(out, file_type="stl")
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(2.0 * fillet_pattern(get_pattern("0x2508")).outline.area, rel=1e-3)


def test_export_tolerances(tmp_path: Path) -> None:
    assert "[1e-06, 10] mm" in one_line_error(tmp_path, "export", "0x2d88", "--curve-tolerance", "1e-12",
                                               "--dxf", "a.dxf")
    line = one_line_error(tmp_path, "export", "0x2d88", "--curves", "lines", "--curve-tolerance", "1e-5",
                          "--max-elements", "1000", "--dxf", "a.dxf")
    assert "curve segments" in line and "--max-elements" in line and "--curve-tolerance" in line
    line = one_line_error(tmp_path, "export", "0x2d88", "--mesh-tolerance", "1e-5", "--max-elements", "1000",
                          "--stl", "a.stl")
    assert "mesh triangles" in line
    # a 1000 mm hexagon is 2000 mm across: floating point (1e-9 relative) resolves 2e-6 mm, not 1e-6
    line = one_line_error(tmp_path, "export", "0x2d88", "--edge", "1000", "--mesh-tolerance", "1e-6",
                          "--stl", "a.stl")
    assert "below what floating point resolves" in line


def test_export_thickness_and_tolerance_are_one_line(tmp_path: Path) -> None:
    assert "--thickness" in one_line_error(tmp_path, "export", "0x2d88", "--thickness", "1e-9", "--step", "a.step")
    assert "--mesh-tolerance" in one_line_error(tmp_path, "export", "0x2d88", "--mesh-tolerance", "1e-9",
                                                "--stl", "a.stl")
