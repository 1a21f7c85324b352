"""Result files (VTU, PNG) and the Abaqus/CalculiX deck, checked against CalculiX when installed."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from fabpat.exchange.inp import deck_text, read_ccx_energy, write_inp
from fabpat.exchange.png_result import write_png
from fabpat.exchange.vtu import write_vtu
from fabpat.mesh import solid_polygon_mesh
from fabpat.scenarios import run_scenario


@pytest.fixture(scope="module")
def coarse():
    return solid_polygon_mesh(6, 36.0, 3.0)


@pytest.fixture(scope="module")
def dome_result(coarse):
    return run_scenario(coarse, "dome", sides=6, nonlinear=True)


def test_vtu_round_trip(tmp_path, coarse, dome_result) -> None:
    import meshio

    p = write_vtu(tmp_path / "r.vtu", coarse.V, coarse.F, dome_result.result)
    m = meshio.read(p)
    u = dome_result.result.displacement
    assert np.allclose(m.points[:, :2], coarse.V + u[:, :2])
    assert np.allclose(m.point_data["displacement"], u)
    assert m.point_data["rotation"].shape == (coarse.n_nodes, 3)
    assert m.cell_data["strain_energy"][0].sum() == pytest.approx(dome_result.energy)
    assert m.cells_dict["triangle"].shape == (coarse.n_elements, 3)


def test_png_written(tmp_path, coarse, dome_result) -> None:
    p = write_png(tmp_path / "r.png", coarse.V, coarse.F, dome_result.result)
    data = p.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_deck_format_and_consistent_weights(coarse) -> None:
    txt = deck_text(coarse, "cylinder", sides=6, nonlinear=True)
    n_edges = len({tuple(sorted(e)) for t in coarse.F for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))})
    node_block = txt.split("*NODE, NSET=NALL\n")[1].split("*ELEMENT")[0].strip().splitlines()
    assert len(node_block) == coarse.n_nodes + n_edges  # S6: one mid-side node per side
    for line in txt.splitlines():
        if line and line[0].isdigit():
            assert all(len(f.strip()) <= 20 for f in line.split(","))  # CalculiX cuts at 20 chars
    cl = txt.split("*CLOAD\n")[1].split("*NODE PRINT")[0].strip().splitlines()
    vals = {}
    for line in cl:
        k, d, v = line.split(",")
        vals.setdefault(int(d), []).append(float(v))
    assert sum(vals[4]) == pytest.approx(0.0, abs=1e-9)  # ±50 N·mm about x at the two edges
    m0 = sorted(v for v in vals[4] if v < 0)
    assert sum(m0) == pytest.approx(-50.0)
    # consistent S6 weights along a straight edge of equal sides: ends 1/6, mid-sides 4/6, shared 2/6
    assert m0[0] == pytest.approx(4 * m0[-1])
    assert "*STEP, NLGEOM" in txt and re.search(r"\*ELEMENT, TYPE=S6", txt)
    assert "TYPE=S3" in deck_text(coarse, "dome", sides=6, nonlinear=False, element="S3")


def _ccx(tmp_path, mesh, scenario: str, nonlinear: bool) -> float:
    write_inp(tmp_path / f"{scenario}.inp", mesh, scenario, sides=6, nonlinear=nonlinear, increment=0.25)
    subprocess.run(["ccx", "-i", scenario], cwd=tmp_path, capture_output=True, timeout=600, check=True)
    return read_ccx_energy(tmp_path / f"{scenario}.dat")


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx, Debian calculix-ccx) not installed")
@pytest.mark.parametrize(("scenario", "nonlinear"), [("dome", False), ("cantilever", True)])
def test_exported_deck_in_calculix_matches(tmp_path, coarse, scenario: str, nonlinear: bool) -> None:
    """Dome linear only (CalculiX 2.20 applies oblique moments wrongly with NLGEOM); cantilever NLGEOM.
    Measured at h = 2: dome 18.69 (ccx) vs 18.39, cantilever 2.593 vs 2.603 N·mm."""
    ours = run_scenario(coarse, scenario, sides=6, nonlinear=nonlinear).energy
    assert _ccx(tmp_path, coarse, scenario, nonlinear) == pytest.approx(ours, rel=0.05)
