"""Assemblies in one shell model: sleeve joints (rigid links), displacement control, path following."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fabpat.assembly.solve.model import ModelPlate, ModelSleeve, assembly_model, plate_mesh
from fabpat.assembly.surface.tiling import honeycomb_strip
from fabpat.shell.element import Material
from fabpat.shell.linked import solve_path
from fabpat.shell.rigid_links import LinkedProblem
from fabpat.simulation.scenarios import opposite, run_scenario, tributary_weights

PATTERN = "0x6808"
H = 4.0


def _two_plates(pattern: str = PATTERN, h: float = H):  # noqa: ANN202
    """Two tiles of a 1 × 2 honeycomb strip, their shared interface segments coincident, one sleeve."""
    t = honeycomb_strip(1, 2)
    mesh = plate_mesh(pattern, 6, 36.0, 0.2, h)
    plates = []
    for f in range(2):
        T = np.eye(4)
        T[:3, 3] = t.centroids[f]
        plates.append(ModelPlate(f"T{f}", mesh, T))
    (k,) = t.interior_edges
    (fa, ia), (fb, ib) = (tuple(int(v) for v in pair) for pair in t.edge_faces[k])
    a, b = t.V[t.edges[k]]
    frame = np.eye(4)
    frame[:3, 0] = (b - a) / np.linalg.norm(b - a)
    frame[:3, 1] = np.cross([0.0, 0.0, 1.0], frame[:3, 0])
    frame[:3, 3] = 0.5 * (a + b)
    model = assembly_model(plates, [ModelSleeve("E1", frame, ((fa, ia), (fb, ib)))], Material())
    return model, (fa, opposite(ia, 6)), (fb, opposite(ib, 6))


def _cantilever_loads(V: np.ndarray, N: int, clamp: np.ndarray, tip: np.ndarray):  # noqa: ANN202
    fixed = np.zeros((N, 6), dtype=bool)
    fixed[clamp] = True
    loads = np.zeros((N, 6))
    loads[tip, 2] = 1.5 * tributary_weights(V, tip)
    return fixed, loads


def _welded(model):  # noqa: ANN001, ANN202
    """The model's plate meshes (flat, z = 0) with coincident nodes merged: a weld over the shared
    interface segment, the joint a sleeve's full restraint approximates. (V (n, 2), F (m, 3))."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(model.X[:, :2]).query_pairs(1e-6, output_type="ndarray")  # mm: the same point
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(model.X),) * 2)
    _, label = connected_components(graph, directed=False)
    first = np.sort(np.unique(label, return_index=True)[1])
    new = np.empty(len(first), dtype=np.int64)
    new[label[first]] = np.arange(len(first))
    return model.X[first, :2], new[label][model.F]


def test_sleeve_joint_agrees_with_welding() -> None:
    from fabpat.shell import ShellProblem, solve_nonlinear

    model, (pa, ca), (pb, cb) = _two_plates()
    N = model.n_nodes
    fixed, loads = _cantilever_loads(model.X, N, model.nodes(pa, ca), model.nodes(pb, cb))
    sleeve = solve_path(model.problem(fixed, np.zeros((N, 6)), loads), steps=1)
    # the slaves follow the sleeve frame exactly: both slots' nodes keep their reference distances
    sl, *_ = model.links()
    x = model.X[sl] + sleeve.final.displacement[sl]
    d0 = np.linalg.norm(model.X[sl][:, None] - model.X[sl][None], axis=-1)
    assert np.abs(np.linalg.norm(x[:, None] - x[None], axis=-1) - d0).max() < 1e-9
    assert sleeve.final.displacement[:, 2].max() > 5.0  # a large-deflection check, mm

    # the same two meshes welded on the segment (their coincident nodes merged)
    V2, F2 = _welded(model)
    V3 = np.column_stack([V2, np.zeros(len(V2))])
    near = lambda P: np.unique(np.argmin(np.linalg.norm(V3[:, None] - P[None], axis=-1), axis=0))  # noqa: E731
    clamp, tip = near(model.X[model.nodes(pa, ca)]), near(model.X[model.nodes(pb, cb)])
    fixed_w, loads_w = _cantilever_loads(V2, len(V2), clamp, np.sort(tip))
    loads_w[:, 2] = 0.0
    loads_w[tip, 2] = loads[model.nodes(pb, cb), 2]  # same nodes, same shares
    welded = solve_nonlinear(ShellProblem(V2, F2, model.material, fixed_w, loads_w))
    linked_weld = solve_path(LinkedProblem(V3, F2, model.material, np.zeros((0, 3)), [], [], np.zeros((0, 3)),
                                           fixed_w, np.zeros_like(loads_w), loads_w), steps=1)
    slot_b = model.sleeves[0].slots[1]
    assert len(V2) == len(model.X) - model.nodes(*slot_b).size  # only the shared segment was merged
    assert linked_weld.final.energy == pytest.approx(welded.energy, rel=1e-6)  # two solvers, one weld
    assert sleeve.final.energy == pytest.approx(welded.energy, rel=0.01)


def test_displacement_control_reproduces_the_load_controlled_cantilever() -> None:
    mesh = plate_mesh(PATTERN, 6, 36.0, 0.2, 3.0)
    sr = run_scenario(mesh, "cantilever", sides=6)
    p, r = sr.problem, sr.result
    tip = mesh.interfaces[opposite(0, 6)]
    fixed = p.fixed.copy()
    fixed[tip, :3] = True
    pres = np.zeros((mesh.n_nodes, 6))
    pres[tip, :3] = r.displacement[tip]
    loads = p.loads.copy()
    loads[tip] = 0.0
    out = solve_path(LinkedProblem(p.X, p.F, p.material, np.zeros((0, 3)), [], [], np.zeros((0, 3)), fixed, pres,
                                   loads), steps=1)
    assert out.final.energy == pytest.approx(sr.energy, rel=1e-6)
    # the reactions at the prescribed tip are the loads the load-controlled run applied there
    assert np.abs(out.final.reactions[tip, :3] - p.loads[tip, :3]).max() < 1e-6 * 1.5
    # both runs stop at a residual of 1e-8 of their loads; on this soft cantilever (21 mm tip deflection)
    # that leaves the states ~1e-7 of the deflection apart (1.6e-6 mm measured)
    assert np.abs(out.final.displacement - r.displacement).max() < 2e-7 * np.abs(r.displacement).max()


def test_long_increments_interpolate_the_report_points_they_jump_over() -> None:
    """solve_path(max_step=…): the same λ = 1 equilibrium as one increment per report point, in fewer
    increments; the points between are flagged and lie between the equilibria around them."""
    mesh = plate_mesh(PATTERN, 6, 36.0, 0.2, 3.0)
    p = run_scenario(mesh, "cantilever", sides=6).problem
    prob = LinkedProblem(p.X, p.F, p.material, np.zeros((0, 3)), [], [], np.zeros((0, 3)), p.fixed,
                         np.zeros((mesh.n_nodes, 6)), p.loads)
    short = solve_path(prob, steps=4)
    long = solve_path(prob, steps=4, first_step=1.0, max_step=1.0)
    assert [q.exact for q in short.points] == [True] * 4
    assert long.increments < short.increments and long.factorizations < short.factorizations
    assert [q.lam for q in long.points] == pytest.approx([0.25, 0.5, 0.75, 1.0])
    assert long.points[-1].exact and not all(q.exact for q in long.points)
    assert long.final.energy == pytest.approx(short.final.energy, rel=1e-7)
    tip = np.abs(short.final.displacement).max()
    assert np.abs(long.final.displacement - short.final.displacement).max() < 1e-6 * tip
    for a, b, c in zip(long.points, long.points[1:], long.points[2:], strict=False):
        if not b.exact:  # the deflection grows along the path, so an interpolated point lies between
            za, zb, zc = (np.abs(q.displacement).max() for q in (a, b, c))
            assert za <= zb <= zc


@pytest.mark.slow
def test_cli_simulate_assembly_fields_files_and_bad_input(tmp_path) -> None:  # noqa: ANN001
    import json

    import meshio

    from tests.conftest import run_cli

    spec = str(Path(__file__).resolve().parents[1] / "assemblies" / "test-small.toml")
    vtu, png = tmp_path / "s.vtu", tmp_path / "s.png"
    r = run_cli("simulate-assembly", spec, "--h", "5", "--end-shortening", "0.005", "--steps", "2", "--json",
                "--vtu", str(vtu), "--png", str(png))
    assert r.returncode == 0, r.stderr
    row = json.loads(r.stdout)
    assert list(row) == ["converged", "plates", "sleeves", "nodes", "dofs", "iterations", "seconds", "energy",
                         "plate_energies", "sleeve_moments", "reaction", "max_deflection", "peak", "half_ratio",
                         "path", "radius", "sphericity_rms", "sphericity_max", "mesh_deviation_rms",
                         "mesh_deviation_max", "cylinder_radius", "cylindricity_rms", "peak_strain",
                         "peak_strain_plate", "strain_limit", "over_limit", "factorizations", "h", "warm_start"]
    assert row["radius"] is None and row["sphericity_rms"] is None  # a strip is not closed
    assert row["mesh_deviation_rms"] is None and row["cylinder_radius"] is None
    assert 0 < row["peak_strain"] < row["strain_limit"] and row["over_limit"] == []
    assert row["converged"] is True and row["plates"] == 3 and row["sleeves"] == 2
    assert list(row["plate_energies"]) == ["T1", "T2", "T3"] and list(row["sleeve_moments"]) == ["E1", "E2"]
    assert sum(row["plate_energies"].values()) == pytest.approx(row["energy"])
    assert [p["end_shortening"] for p in row["path"]] == pytest.approx([0.0025, 0.005])
    assert row["path"][-1]["reaction"] == row["reaction"] > 0  # compression
    assert row["path"][-1]["exact"] is True  # λ = 1 is an equilibrium, never interpolated
    assert row["path"][1]["reaction"] > row["path"][0]["reaction"] > 0
    mesh = meshio.read(vtu)
    assert len(mesh.points) == row["nodes"] - row["sleeves"]
    assert set(mesh.point_data) >= {"reference", "displacement", "rotation", "plate"}
    assert sorted(set(mesh.point_data["plate"].tolist())) == [0, 1, 2]
    assert set(mesh.cell_data) >= {"strain_energy", "membrane_energy", "bending_energy", "shear_energy"}
    assert png.read_bytes()[:4] == b"\x89PNG"

    # the refusals in-process (the same command's logic; the real process's exit code 2 and one stderr line
    # are test_sphere_closure's and test_assembly_hostile's)
    from click.testing import CliRunner

    from fabpat.cli import cli

    out = tmp_path / "x.png"
    for args, word in ((("--end-shortening", "0"), "--end-shortening"),
                       (("--end-shortening", "0.5"), "--end-shortening"), (("--h", "8"), "too coarse")):
        res = CliRunner().invoke(cli, ["simulate-assembly", spec, *args, "--png", str(out)])
        assert res.exit_code == 2 and res.stderr.count("\n") == 1 and word in res.stderr, res.stderr
    res = CliRunner().invoke(cli, ["simulate-assembly", spec.replace("test-small", "truncated-icosahedron"),
                                   "--imperfection", "0.1", "--png", str(out)])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "applies to strips" in res.stderr, res.stderr
    assert not out.exists() and not list(tmp_path.glob("*.tmp*"))


# The stiffest pattern of the built-in catalog in the Cylinder scenario (9.0 N·mm) and one about 4×
# softer (35.7 N·mm); strips of 1 × 4 tiles at a coarse mesh keep the paths quick.
STIFF, SOFT = "0xff88", "0x6808"
STRIP_H = 5.0


def _strip(patterns: list[str]):  # noqa: ANN202
    import dataclasses

    from fabpat.assembly.solve.strip import strip_setup
    from fabpat.assembly.spec.load import load_spec

    spec = load_spec(Path(__file__).resolve().parents[1] / "assemblies" / "test-small.toml")
    spec = dataclasses.replace(spec, tiling=dataclasses.replace(spec.tiling, rows=1, columns=len(patterns)))
    return strip_setup(spec, patterns, h=STRIP_H)


@pytest.fixture(scope="module")
def uniform_strip():  # noqa: ANN201
    from fabpat.assembly.solve.strip import run_strip

    return run_strip(_strip([SOFT] * 4), 0.1, steps=5)


def test_straight_strip_stays_flat_then_buckles_into_a_symmetric_arch(uniform_strip) -> None:  # noqa: ANN001
    from fabpat.assembly.solve.strip import run_strip

    # below the buckling load, without an imperfection, the strip only shortens in its plane
    flat = run_strip(_strip([SOFT] * 4), 0.004, steps=1, imperfection=0.0)
    assert np.abs(flat.result.final.displacement[:, 2]).max() < 1e-9
    k0 = flat.reaction / 0.004  # pre-buckling stiffness, N per unit end shortening
    r = uniform_strip
    reactions = [p["reaction"] for p in r.path]
    # the buckling plateau: past buckling the reaction barely grows, far below the flat strip's line
    assert reactions[-1] < 0.4 * k0 * 0.1
    assert (reactions[-1] - reactions[1]) / (0.1 - 0.04) < 0.1 * k0
    assert r.max_deflection > 0.15 * r.setup.length  # a real arch, upward (the imperfection's side)
    assert r.peak == pytest.approx(0.5, abs=0.01)
    assert r.half_ratio == pytest.approx(1.0, abs=0.02)


def test_the_strip_leaps_from_its_knee_to_the_end_of_its_path(uniform_strip) -> None:  # noqa: ANN001
    """After its first increment (the knee) a strip tries the rest of its path in one increment (strip.
    LEAP_ITERATIONS): this strip takes 2 increments and 16 factorizations (13 increments and 48 before); the
    report points in between are interpolated, λ = 1 is an equilibrium (the test below compares it with a
    path that doubles its increments)."""
    r = uniform_strip.result
    assert r.increments == 2 and r.cuts == 0, (r.increments, r.cuts)
    assert r.factorizations <= 24, r.factorizations
    assert [p.exact for p in r.points] == [False] * 4 + [True]


def test_a_dead_imperfection_reaches_the_equilibrium_of_a_ramped_one(uniform_strip) -> None:  # noqa: ANN001
    """The strip's imperfection load reaches its full size early on the path and is held (which rounds off
    the knee of the path); an elastic equilibrium does not depend on the path to it, so the same load
    ramped with the shortening over the whole path must reach the same state at λ = 1."""
    from fabpat.assembly.solve.strip import FIRST_STEP, MIN_STEP, STRIP_RTOL

    setup = uniform_strip.setup
    m = setup.model
    N, n = m.n_nodes, len(m.X)
    fixed = np.zeros((N, 6), dtype=bool)
    fixed[setup.left, :3] = fixed[setup.right, :3] = True
    pres = np.zeros((N, 6))
    pres[setup.right, 0] = -0.1 * setup.length
    loads = np.zeros((N, 6))
    area = m.lumped_area()
    loads[:n, 2] = 1e-2 * area / area.sum()
    ramped = solve_path(m.problem(fixed, pres, loads), steps=5, rtol=STRIP_RTOL, first_step=FIRST_STEP,
                        min_step=MIN_STEP, direction=loads).final
    dead = uniform_strip.result.final
    assert np.abs(dead.displacement - ramped.displacement).max() < 1e-4  # mm, of an arch ~40 mm high
    assert dead.energy == pytest.approx(ramped.energy, rel=1e-7)
    assert np.abs(dead.displacement[:n, 2]).max() > 0.15 * setup.length  # both on the buckled branch


@pytest.mark.slow
def test_graded_strip_peaks_towards_its_soft_end_and_mirrors(uniform_strip) -> None:  # noqa: ANN001
    from fabpat.assembly.solve.strip import run_strip

    graded = run_strip(_strip([STIFF] * 2 + [SOFT] * 2), 0.1, steps=5)
    mirrored = run_strip(_strip([SOFT] * 2 + [STIFF] * 2), 0.1, steps=5)
    assert graded.peak > 0.52 and graded.half_ratio < 0.9  # column 0 is the stiff end: flatter
    assert mirrored.peak == pytest.approx(1.0 - graded.peak, abs=0.01)
    assert uniform_strip.peak == pytest.approx(0.5, abs=0.01)


def test_a_ramped_sleeve_angle_turns_the_free_plate_rigidly() -> None:
    import dataclasses

    from fabpat.shell.rotations import expmap

    model, (pa, ca), _ = _two_plates(h=5.0)
    alpha = 0.4  # rad
    model = dataclasses.replace(model, sleeves=(dataclasses.replace(model.sleeves[0], angle=alpha),))
    N = model.n_nodes
    fixed = np.zeros((N, 6), dtype=bool)
    fixed[model.nodes(pa, ca)] = True  # plate A clamped at its far interface; plate B is free
    out = solve_path(model.problem(fixed, np.zeros((N, 6)), np.zeros((N, 6))), steps=2)
    s = model.sleeves[0]
    a, o = s.frame[:3, 0], s.frame[:3, 3]
    b = slice(model.offsets[1], model.offsets[2])  # plate B's nodes
    # no load, so nothing strains; slot A's half turn (−α/2) is held back by the clamped plate A, so
    # plate B turns by the whole +α about the sleeve axis (through the sleeve centre, which stays put)
    assert out.final.energy < 1e-8
    expected = o + (model.X[b] - o) @ expmap(alpha * a).T
    assert np.abs(model.X[b] + out.final.displacement[b] - expected).max() < 1e-6


def test_a_path_tells_its_increments_and_a_stalled_one_is_abandoned_with_its_reason() -> None:
    """Listeners hear every increment (its λ and the factorizations so far); a path whose factorizations
    stop moving λ is abandoned with a SolverError that says so, where without the limit it would go on."""
    from fabpat.errors import SolverError
    from fabpat.shell import news
    from fabpat.simulation.scenarios import build_problem

    mesh = plate_mesh(PATTERN, 6, 36.0, 0.2, 6.0)
    p = build_problem(mesh, "cantilever", sides=6)
    prob = LinkedProblem(p.X, p.F, p.material, np.zeros((0, 3)), [], [], np.zeros((0, 3)), p.fixed,
                         np.zeros((mesh.n_nodes, 6)), p.loads)
    heard: list[str] = []
    with news.listening(heard.append):
        out = solve_path(prob, steps=2, first_step=1.0 / 64)
    done = [h for h in heard if "iteration" not in h]  # one line per increment, and one per factorization
    assert len(done) == out.increments + out.cuts and done[-1].startswith(f"increment {len(done)}, λ = 1.000, ")
    assert done[-1].endswith(f" {out.factorizations} factorizations")
    assert sum("iteration" in h for h in heard) == out.factorizations
    assert heard[0].startswith("increment 1, λ = 0.000 → 0.016, iteration 1, 1 factorizations")
    # from a first step of 1/64 the increments double: 2 or 3 factorizations never move λ by half the path
    with pytest.raises(SolverError, match=r"stalled: abandoned at load fraction λ = 0\.0\d+, which [23] factoriz"):
        solve_path(prob, steps=2, first_step=1.0 / 64, stall=(2, 0.5))
    assert not news.listened()


def test_a_warm_start_too_far_off_costs_little_more_than_a_cold_start() -> None:
    """A warm start that does not converge is given up after a few factorizations (linked.WARM_FALL), so the
    path after it costs at most the cold path plus those: a guess of 3× the cantilever's deflection crept
    for 25 iterations and 23 factorizations before (34 against 11 cold, two report steps). A guess near the
    equilibrium (0.9× it) still converges as a warm start."""
    from fabpat.simulation.scenarios import build_problem

    mesh = plate_mesh(PATTERN, 6, 36.0, 0.2, 6.0)
    p = build_problem(mesh, "cantilever", sides=6)
    prob = LinkedProblem(p.X, p.F, p.material, np.zeros((0, 3)), [], [], np.zeros((0, 3)), p.fixed,
                         np.zeros((mesh.n_nodes, 6)), p.loads)
    cold = solve_path(prob, steps=1)
    far = solve_path(prob, steps=1, start=(3.0 * cold.final.displacement, 3.0 * cold.final.rotation))
    assert not far.warm
    assert far.factorizations <= cold.factorizations + 3, (far.factorizations, cold.factorizations)
    assert np.abs(far.final.displacement - cold.final.displacement).max() < 1e-9
    near = solve_path(prob, steps=1, start=(0.9 * cold.final.displacement, 0.9 * cold.final.rotation))
    assert near.warm
    assert np.abs(near.final.displacement - cold.final.displacement).max() < 1e-5


def test_curvature_fields_are_fitted_when_first_read_and_pickle_as_plain_fields() -> None:
    """A solve's curvature fields are the fit of its deformed mid-surface, made when a VTU, a picture or the
    caller first reads them (not by every solve), and a pickled simulation carries them as a plain dict."""
    import pickle

    from fabpat.assembly.solve.result import LazyFields
    from fabpat.assembly.solve.simulation import simulate_assembly
    from fabpat.shell.curvature import curvature_fields

    sim = simulate_assembly(Path(__file__).resolve().parents[1] / "assemblies" / "test-small.toml", h=6.0)
    assert isinstance(sim.curvature, LazyFields) and sim.curvature._make is not None  # not fitted yet
    m, n = sim.model, len(sim.model.X)
    x = m.X + sim.run.result.final.displacement[:n]
    want = curvature_fields(x, m.F, m.plate_of_node[:n], center=m.X.mean(axis=0) - np.array([0.0, 0.0, 1e6]))
    assert sorted(sim.curvature) == sorted(want)
    assert all(np.array_equal(sim.curvature[k], want[k]) for k in want)
    back = pickle.loads(pickle.dumps(sim.curvature))
    assert isinstance(back, dict) and all(np.array_equal(back[k], want[k]) for k in want)
