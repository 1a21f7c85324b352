"""One pattern's scenario energies (fabpat.simulation.energies): the pipeline the sweep and `fabpat simulate`
share agrees with the notebook's fabpat.simulate to the last bit, records or raises its failures as asked,
and says what it is doing."""

from __future__ import annotations

import dataclasses
import math

import pytest

import fabpat
from fabpat.catalog.sweep import FAMILY_SAMPLES, SweepReport, SweepSetup
from fabpat.catalog.sweep_members import member_setups, merge_reports
from fabpat.errors import GeometryError, SolverError
from fabpat.patterns.variation import Variation
from fabpat.simulation.energies import scenario_energies


def test_one_mesh_energies_are_the_notebook_apis() -> None:
    """Two scenarios on one 4 mm mesh (linear: fast) equal fabpat.simulate's, computed by its own code path
    (fabpat.simulation.scenarios.simulate), bit for bit, with the same mesh."""
    p = fabpat.pattern("0x7f88")
    got = scenario_energies(p, ("cantilever", "Dome"), h=4.0, nonlinear=False)
    fp = p.fillet(0.2)
    for sc in ("cantilever", "dome"):
        ref = fabpat.simulate(fp, sc, h=4.0, linear=True)
        run = got.run(sc)
        assert run.energy == ref.energy and run.converged
        assert run.result is not None and run.result.fine.max_displacement == ref.max_displacement
        assert got.mesh is not None and got.mesh.n_nodes == ref.nodes
    assert [h for h, _ in got.meshes] == [4.0]
    assert got.error is None and got.filleted is not None
    assert got.min_width == pytest.approx(fp.min_width(), rel=1e-12)
    assert got.columns["filleted_area"] == pytest.approx(fp.metrics.area, rel=1e-12)


def test_default_energies_are_extrapolated_from_nested_meshes_as_the_api() -> None:
    """Without h: a mesh and its nested refinement (half its h), the energy extrapolated — the same number
    as fabpat.simulate's default, here for a family member (0x0488 has non-manifold vertices)."""
    p = fabpat.pattern("0x0488")
    got = scenario_energies(p, ("cylinder",), variation=Variation(bridge_weight=0.5), nonlinear=False)
    ref = fabpat.simulate(p.fillet(bridge_weight=0.5), "cylinder", linear=True)
    (h1, coarse), (h2, fine) = got.meshes
    assert (h1, h2) == ref.h and h2 == h1 / 2 and fine.n_elements == 4 * coarse.n_elements
    assert got.run("cylinder").energy == ref.energy
    assert got.energies == {"cylinder": ref.energy}
    assert got.filleted is not None and got.filleted.variation.bridge_weight == 0.5


def test_a_given_h_is_refused_or_lowered_as_asked() -> None:
    """0x0488's necks are 1.95 mm wide: 4.5 mm cannot resolve them. The command's h is refused, naming
    the h that works; the sweep's is an upper bound lowered to 1.1 × min_width (2.14 mm) with no solve
    needed to see it (no scenario asked)."""
    p = fabpat.pattern("0x0488")
    with pytest.raises(GeometryError, match=r"h = 4\.5 mm is too coarse for pattern 0x0488.*use h ≤ 3\.89"):
        scenario_energies(p, ("dome",), h=4.5, extrapolate=True)
    lowered = scenario_energies(p, (), h=4.5, extrapolate=True, h_is_bound=True)
    assert [h for h, _ in lowered.meshes] == [2.14, 1.07]
    assert lowered.runs == ()


def test_kept_errors_name_the_failure_on_every_run() -> None:
    got = scenario_energies(fabpat.pattern("0x0488"), ("cantilever", "dome"), h=4.5, extrapolate=False,
                            keep_errors=True)
    assert got.error is not None and got.error.startswith("GeometryError: h = 4.5 mm is too coarse")
    assert [r.error for r in got.runs] == [got.error, got.error]
    assert got.meshes == () and got.mesh is None and got.energies == {}
    assert all(math.isnan(r.energy) and not r.converged for r in got.runs)
    assert got.min_width == pytest.approx(1.95, abs=0.01)  # measured before meshing: the row still has it


def test_a_failing_solve_is_named_or_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    """A SolverError of one scenario: raised with the scenario and the pattern's name, or with keep_errors
    recorded on that scenario's run while the others are solved."""
    import fabpat.simulation.energies as energies

    real = energies.run_converged

    def fails_on_dome(meshes, scenario, **kw):  # noqa: ANN001, ANN003, ANN202 - a stand-in
        if scenario == "dome":
            raise SolverError("Newton–Raphson did not converge")
        return real(meshes, scenario, **kw)

    monkeypatch.setattr(energies, "run_converged", fails_on_dome)
    p = fabpat.pattern("0x0488")
    with pytest.raises(SolverError, match="^dome scenario of 0x0488 b0.5: Newton–Raphson did not converge$"):
        scenario_energies(p, ("cantilever", "dome"), h=3.5, nonlinear=False, variation=Variation(bridge_weight=0.5))
    kept = scenario_energies(p, ("dome", "cantilever"), h=3.5, nonlinear=False, keep_errors=True)
    assert kept.run("dome").error == "SolverError: Newton–Raphson did not converge"
    assert kept.run("cantilever").error is None and kept.run("cantilever").energy > 0
    assert kept.error is None


def test_progress_hears_meshing_and_each_scenario() -> None:
    heard: list[tuple[str, str, float | None]] = []

    class Ears:
        def update(self, text: str, done: float | None = None) -> None:
            heard.append(("update", text, done))

        def item(self, text: str) -> None:
            heard.append(("item", text, None))

    got = scenario_energies(fabpat.pattern("0x7f88"), ("cantilever", "cylinder"), h=4.0, nonlinear=False,
                            progress=Ears())
    assert got.mesh is not None
    n = got.mesh.n_elements
    assert [(k, t.split(",")[0], d) for k, t, d in heard] == [
        ("update", "meshing", 0),
        ("update", f"cantilever (1 of 2) on {n} elements", 0),
        ("item", "cantilever finished (1 of 2)", None),
        ("update", f"cylinder (2 of 2) on {n} elements", 1),
        ("item", "cylinder finished (2 of 2)", None)]
    assert heard[2][1].endswith(" N·mm") and ", energy " in heard[2][1]


def test_bad_requests_are_refused() -> None:
    p = fabpat.pattern("0x7f88")
    with pytest.raises(SolverError, match="unknown scenario 'twist'"):
        scenario_energies(p, ("twist",))
    with pytest.raises(GeometryError, match="give the Pattern"):
        scenario_energies(p.fillet(), ("dome",), weight=0.3)
    got = scenario_energies(p, (), h=4.0, extrapolate=False)
    with pytest.raises(SolverError, match="'dome' was not run"):
        got.run("dome")


def test_a_family_sweep_is_the_papers_member_then_each_sample() -> None:
    setups = member_setups(SweepSetup(extrapolate=False), family=True)
    assert [s.bridge_weight for s in setups] == [1.0, 0.25, 0.4, 0.63, 1.6, 2.5] == [1.0, *FAMILY_SAMPLES]
    assert {s.h for s in setups} == {1.5}
    one = SweepSetup(bridge_weight=0.5)
    assert member_setups(one, family=False) == [one]
    with pytest.raises(GeometryError, match="fixed for sweeps"):  # a mesh that could exhaust a worker's memory
        member_setups(SweepSetup(h=0.05, extrapolate=False), family=False)


def test_merged_reports_add_up() -> None:
    a = SweepReport(10, 30, 5, 25, 1, ["0x1: boom"], 2.0)
    b = SweepReport(10, 30, 30, 0, 0, [], 0.5)
    c = SweepReport(3, 9, 0, 9, 2, ["0x2: bang"], 1.0)
    m = merge_reports([a, b, c])
    assert (m.patterns, m.rows, m.skipped, m.computed, m.failed_rows, m.seconds) == (10, 30, 35, 34, 3, 3.5)
    assert m.crashed == ["0x1: boom", "0x2: bang"]
    assert a == SweepReport(10, 30, 5, 25, 1, ["0x1: boom"], 2.0)  # the parts are left as they were
    assert dataclasses.replace(merge_reports([b])) == b
    with pytest.raises(ValueError, match="at least one"):
        merge_reports([])
