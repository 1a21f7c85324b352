"""fabpat vs Kratos Multiphysics (optional test dependency) on the same mesh, supports and loads.

Kratos' shear-deformable corotational triangle ``ShellThickElementCorotational3D3N``, geometrically
nonlinear (4 equal load steps; energy = work of the loads, Simpson), all three scenarios on the dense
library pattern 0x2d88 at h = 2 mm. Measured (N·mm, Kratos / fabpat): cantilever 14.179 / 14.186,
cylinder 12.197 / 12.206, dome 132.37 / 133.20 — within 0.7 %; 20 load steps change Kratos' numbers
by < 1e-4. Asserted: energies within 5 % (the issue's bar) and displacement fields within 3 %.

Not asserted, measured: on the lacy pattern 0x0488 the nonlinear *dome* differs (Kratos 302.6 vs
fabpat 394.4 at h = 2; 354.7 vs 406.9 at h = 1) although the linear dome agrees to 0.2 % (below)
and cantilever/cylinder to < 1 %. There a third of the energy is in-plane bending of 3 mm bars that
are two or three triangles wide; Kratos' membrane part is much stiffer than the OPT membrane in
in-plane bending at that resolution and approaches fabpat only slowly with refinement.

Install: ``pip install KratosMultiphysics KratosStructuralMechanicsApplication
KratosLinearSolversApplication`` (≈ 150 MB).
"""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.scenarios import SCENARIOS, build_problem, run_scenario
from fabpat.shell import ShellProblem, solve_linear
from fabpat.shell.kratos import available, solve_kratos

pytestmark = pytest.mark.skipif(
    not available(), reason="Kratos not installed (optional: pip install KratosMultiphysics "
    "KratosStructuralMechanicsApplication KratosLinearSolversApplication)")


def _mesh(pid: str, h: float = 2.0):
    from fabpat.fillet import fillet_pattern
    from fabpat.library import get_pattern
    from fabpat.mesh import mesh_outline

    return mesh_outline(fillet_pattern(get_pattern(pid)).outline, h, 6, 36.0)


@pytest.fixture(scope="module")
def dense():
    return _mesh("0x2d88")


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_nonlinear_scenarios_match_kratos_thick_shells(dense, scenario: str) -> None:
    ours = run_scenario(dense, scenario, sides=6, nonlinear=True)
    theirs = solve_kratos(ours.problem, steps=4)
    assert theirs.energy == pytest.approx(ours.energy, rel=0.05)
    u, uk = ours.result.displacement, theirs.displacement
    assert np.linalg.norm(uk - u, axis=1).max() < 0.03 * np.linalg.norm(u, axis=1).max()


def test_linear_dome_of_a_lacy_pattern_matches_kratos() -> None:
    """Small load (λ = 1e-4, energy scaled by λ⁻²): the same loads and supports give the same linear
    response on the thin bars where the nonlinear dome differs (see module docstring)."""
    p = build_problem(_mesh("0x0488"), "dome", sides=6)
    s = 1e-4
    small = ShellProblem(p.X, p.F, p.material, p.fixed, s * p.loads)
    assert solve_kratos(small, steps=2).energy / s**2 == pytest.approx(solve_linear(p).energy, rel=0.01)
