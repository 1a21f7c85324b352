"""The paper's three scenarios on a solid hexagon vs the notes' CalculiX S6 reference numbers; non-finite or
implausibly large results are solver errors, not converged answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabpat.errors import SolverError
from fabpat.patterns.lattice import polygon_vertices
from fabpat.simulation.mesh import interface_segments, mesh_polygons, solid_polygon_mesh
from fabpat.simulation.scenarios import build_problem, edge_tangents, opposite, run_scenario


@pytest.fixture(scope="module")
def hexagon():
    return solid_polygon_mesh(6, 36.0, 2.0)  # 1044 nodes; h = 1.5 is within 0.4 % of h = 1 (see docs)


# notes.md: CalculiX S6, converged < 0.5 %: cantilever 2.62 linear / 2.60 nonlinear; shear-deformable
# shells (Kratos thick ≈ CalculiX): cylinder 2.153, dome 18.06 (nonlinear). Measured here at h = 2:
# 2.618 / 2.603, 2.147, 17.68 (h = 1.5: 2.624 / 2.609, 2.153, 17.89). Asserted within 3 %.
@pytest.mark.parametrize(("scenario", "nonlinear", "ref"), [
    ("cantilever", False, 2.62), ("cantilever", True, 2.60), ("cylinder", True, 2.153), ("dome", True, 18.06)])
def test_solid_hexagon_energy_vs_calculix(hexagon, scenario: str, nonlinear: bool, ref: float) -> None:
    r = run_scenario(hexagon, scenario, sides=6, nonlinear=nonlinear)
    assert r.converged
    assert r.energy == pytest.approx(ref, rel=0.03)
    assert r.nodes == hexagon.n_nodes and r.elements == hexagon.n_elements
    res = r.result
    assert res.energy == pytest.approx(res.element_energy.sum())
    if scenario == "cantilever":
        assert r.max_displacement == pytest.approx(3.5, rel=0.03)  # notes: tip ≈ 3.5 mm
        assert res.reactions[:, 2].sum() == pytest.approx(-1.5, rel=1e-6)  # the clamp carries the load
    else:  # self-equilibrated moments: the supports carry no net force
        assert np.abs(res.reactions[:, :3].sum(axis=0)).max() < 1e-6


def test_loads_are_self_equilibrated_and_distributed_by_length(hexagon) -> None:
    for sc, M in (("cylinder", -50.0), ("dome", -100.0)):
        p = build_problem(hexagon, sc, sides=6)
        assert np.abs(p.loads.sum(axis=0)).max() < 1e-9  # Σ forces = 0, Σ moments = 0
        if sc == "cylinder":  # (dome: the whole-edge hexagon's corners belong to two interfaces)
            I0 = hexagon.interfaces[0]
            assert p.loads[I0, 3].sum() == pytest.approx(M)  # Mx = −50 at the pinned edge (paper)
            w = p.loads[I0, 3] / M
            assert w[0] == pytest.approx(0.5 * w[1])  # end nodes get half a gap
    pc = build_problem(hexagon, "cantilever", sides=6)
    assert pc.loads[:, 2].sum() == pytest.approx(1.5)
    assert pc.fixed[hexagon.interfaces[0]].all() and pc.loads[hexagon.interfaces[3], 2].min() > 0


def test_linear_dome_moment_energy_positive_and_mirror_sign_free(hexagon) -> None:
    lin = run_scenario(hexagon, "dome", sides=6, nonlinear=False)
    assert lin.energy == pytest.approx(18.39, rel=0.02)  # shear-deformable linear (h = 2)
    assert lin.result.energy == pytest.approx(lin.result.external_work, rel=1e-9)


def test_pentagon_pattern_interfaces_any_n() -> None:
    """Odd n: the opposite interface of 0 is n//2 = 2; a pentagon with a hole runs all scenarios."""
    assert opposite(0, 5) == 2 and opposite(3, 5) == 0
    assert np.allclose(edge_tangents(5).sum(axis=0), 0.0)
    a = np.radians(np.arange(5) * 72.0 + 90.0)
    hole = np.c_[12 * np.cos(a), 12 * np.sin(a)][::-1]
    mesh = mesh_polygons([polygon_vertices(5, 36.0), hole], 2.5, interfaces=interface_segments(5, 36.0))
    assert all(len(i) >= 2 for i in mesh.interfaces)
    for sc in ("cantilever", "cylinder", "dome"):
        r = run_scenario(mesh, sc, sides=5, nonlinear=True)
        assert r.energy > 0 and np.isfinite(r.max_displacement)


def test_missing_interface_raises(hexagon) -> None:
    from dataclasses import replace

    bad = replace(hexagon, interfaces=(hexagon.interfaces[0][:1], *hexagon.interfaces[1:]))
    with pytest.raises(SolverError, match="interface 0"):
        run_scenario(bad, "cantilever", sides=6)
    with pytest.raises(SolverError, match="twist"):
        build_problem(hexagon, "twist", sides=6)


def test_non_finite_or_huge_results_are_solver_errors() -> None:
    from fabpat.simulation.mesh import solid_polygon_mesh
    from fabpat.simulation.scenarios import check_plausible, plate_size, run_scenario

    assert plate_size(6, 36.0) == pytest.approx(72.0)
    with pytest.raises(SolverError, match="not finite"):
        check_plausible(math.nan, math.inf, 72.0, False, "dome")
    with pytest.raises(SolverError, match="beyond what the model allows"):
        check_plausible(1.0, 150.0, 72.0, True, "dome")
    check_plausible(1.0, 140.0, 72.0, True, "dome")  # within 2 D: accepted
    # a 0.01 mm plate under the paper's 1.5 N: linear theory gives metres of deflection
    mesh = solid_polygon_mesh(6, 36.0, h=9.0)
    with pytest.raises(SolverError, match="drop --linear"):
        run_scenario(mesh, "cantilever", sides=6, thickness=0.01, nonlinear=False)
