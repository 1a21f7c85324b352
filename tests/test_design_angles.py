"""Sleeve angles by exact sensitivities (fabpat.design.angles): the adjoint gradient of the design error.

References outside the code under test: central differences of *full solves* (the closure solved again at
perturbed angles) for the adjoint gradient, and central differences of the refitted target for the fit's
distance gradients (the envelope theorem). The assembly is a cube of six 36 mm squares typed in by hand
(12 joints at 90°), meshed coarsely (h = 6 mm), its sleeves printed a few degrees open.
"""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.assembly.spec.load import parse_spec
from fabpat.design.angles import AngleSearch, angle_gradient, angle_model, design_error, optimise_angles, solve_angles
from fabpat.design.target import read_target

CUBE_V = [(0, 0, 0), (36, 0, 0), (36, 36, 0), (0, 36, 0), (0, 0, 36), (36, 0, 36), (36, 36, 36), (0, 36, 36)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
AXIS = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def cube(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201 - an AngleModel
    d = tmp_path_factory.mktemp("cube")
    (d / "m.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in CUBE_V)
                             + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in CUBE_F))
    spec = parse_spec({"tiling": {"kind": "mesh", "file": "m.obj"}, "patterns": {"square": "0x0488"},
                       "sleeve": {"margin": 2.8}}, str(d / "spec.toml"))
    return angle_model(spec, ["0x0488"] * 6, 6.0)


def test_adjoint_gradient_matches_full_solves_on_random_directions(cube) -> None:
    # a sphere: the cube's best ellipsoid of any other ratios turns freely (its rotation runs off to 1e6 rad),
    # so its error is no smooth function of the angles; the design run checks its own tiling on its own target
    tgt = read_target("sphere")
    rng = np.random.default_rng(1)
    assert np.allclose(cube.angle0, np.pi / 2)  # printed at the cube's dihedral: nothing moves
    a = cube.angle0 + np.radians(rng.uniform(3.0, 8.0, len(cube.labels)))
    run = solve_angles(cube, a)
    J, fit = design_error(run, tgt, AXIS)
    assert J > 0.0
    g = angle_gradient(cube, a, run, fit)
    step, worst = 1e-3, 0.0
    for _ in range(3):
        v = rng.normal(size=len(a))
        v /= np.linalg.norm(v)
        Jp, Jm = (design_error(solve_angles(cube, a + s * step * v, run), tgt, AXIS)[0] for s in (1.0, -1.0))
        fd = (Jp - Jm) / (2.0 * step)
        assert abs(fd) > 1e-3 * np.linalg.norm(g)  # a direction the error depends on
        worst = max(worst, abs(g @ v - fd) / abs(fd))
    assert worst < 1e-3, worst


def test_the_converged_state_is_an_equilibrium_of_its_own_link_parameters(cube) -> None:
    from fabpat.design.angles import _support

    run = solve_angles(cube, cube.angle0 + np.radians(5.0))
    state = _support(run)
    r = state.residual()
    free = state.free
    links = np.abs(run.result.final.link_forces).max()
    assert np.abs(r[free]).max() < 1e-6 * links
    moved = state.residual(state.p.link_spin * 1.01)  # other angles: out of balance
    assert np.abs(moved[free]).max() > 1e-3 * links


@pytest.mark.parametrize("target", ["sphere", "ellipsoid:1,1.1,1.3"])
def test_fit_gradient_is_the_derivative_of_the_refitted_squared_distances(target: str) -> None:
    rng = np.random.default_rng(2)
    u = rng.normal(size=(600, 3))
    P = 50.0 * u / np.linalg.norm(u, axis=1)[:, None] * np.array([1.0, 1.05, 1.25]) + rng.normal(0.0, 0.5, (600, 3))
    tgt = read_target(target)
    fit = tgt.fit(P, AXIS)
    assert fit.gradient is not None and fit.gradient.shape == P.shape
    V = rng.normal(size=P.shape)
    step = 1e-4
    Jp, Jm = (float(np.sum(tgt.fit(P + s * step * V, AXIS).signed ** 2)) for s in (1.0, -1.0))
    assert np.isclose(float(np.sum(2.0 * fit.signed[:, None] * fit.gradient * V)), (Jp - Jm) / (2.0 * step),
                      rtol=1e-3)


def _mesh_target(path, stretch: tuple[float, float, float] = (1.0, 1.05, 1.25), norm: float = 2.0):  # noqa: ANN001, ANN202
    """A watertight icosphere (162 vertices) made a ball of the ``norm``-norm (2: round, larger: a rounded cube)
    and stretched by ``stretch``, written as an OBJ and read as a target."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=2)
    V = np.asarray(ico.vertices)
    ico.vertices = V / (np.abs(V) ** norm).sum(axis=1)[:, None] ** (1.0 / norm) * np.asarray(stretch)
    ico.export(path)
    return read_target(str(path))


def test_mesh_target_distances_are_smooth_in_the_nodes(tmp_path) -> None:  # noqa: ANN001
    """A mesh target's refitted squared distances: their derivative along a random direction of 600 nodes is the
    fit's 2 d ∇d to 1e-4 (the nearest point of the facets, refitted by ICP, missed it by orders of magnitude), and
    nodes on the surface the mesh was made from are at a distance small against the nodes' spread."""
    tgt = _mesh_target(tmp_path / "egg.obj")
    assert tgt.implicit is not None
    rng = np.random.default_rng(2)
    u = rng.normal(size=(600, 3))
    on = 50.0 * u / np.linalg.norm(u, axis=1)[:, None] * np.array([1.0, 1.05, 1.25])
    assert tgt.fit(on, AXIS).relative_rms < 2e-3  # the icosphere's facets sag ≲ 1 % of its size
    P = on + rng.normal(0.0, 0.5, (600, 3))
    fit = tgt.fit(P, AXIS)
    assert fit.gradient is not None and fit.gradient.shape == P.shape
    assert np.allclose(np.linalg.norm(fit.gradient, axis=1), 1.0, atol=0.05)  # a distance to first order
    V = rng.normal(size=P.shape)
    step = 1e-4
    Jp, Jm = (float(np.sum(tgt.fit(P + s * step * V, AXIS).signed ** 2)) for s in (1.0, -1.0))
    fd = (Jp - Jm) / (2.0 * step)
    assert abs(float(np.sum(2.0 * fit.signed[:, None] * fit.gradient * V)) - fd) <= 1e-4 * abs(fd)


@pytest.mark.slow
def test_adjoint_gradient_on_a_mesh_target_matches_full_solves(cube, tmp_path) -> None:  # noqa: ANN001
    """The cube's angle gradient with a mesh target (a rounded cube, which the cube's closed shape fits in one
    orientation): within 1e-3 of central differences of full solves on a random direction, as design.json's
    gradient_check measures it (one direction: the suite's time)."""
    from fabpat.design.angles import gradient_check

    tgt = _mesh_target(tmp_path / "rounded.obj", (1.0, 1.0, 1.0), norm=4.0)
    a = cube.angle0 + np.radians(np.random.default_rng(4).uniform(3.0, 8.0, len(cube.labels)))
    run = solve_angles(cube, a)
    J, fit = design_error(run, tgt, AXIS)
    assert J > 0.0
    check = gradient_check(cube, a, run, tgt, AXIS, angle_gradient(cube, a, run, fit), directions=1)
    assert all(abs(r["differences"]) > 0.0 for r in check["directions"])
    assert check["max_relative_error"] <= 1e-3, check


def test_bounded_quasi_newton_lowers_the_error_within_the_range(cube) -> None:
    tgt = read_target("sphere")
    search = AngleSearch(cube, tgt, AXIS)
    lo, hi = np.radians(91.0), np.radians(100.0)
    optimise_angles(search, np.full(len(cube.labels), np.radians(92.0)), (lo, hi), 4)
    assert 2 <= len(search.history) <= 4
    assert search.best is not None
    assert np.all((search.best[0] >= lo) & (search.best[0] <= hi))
    assert search.best[1] < search.history[0]["J"]  # (a cube closes into a sphere only so far)


@pytest.mark.slow
def test_thickness_gradient_matches_full_solves(cube) -> None:
    """The adjoint gradient of J in each plate's thickness (fabpat.design.thickness) against central differences of
    full solves along a random direction of the six thicknesses: within 1e-3 (one direction: the suite's time)."""
    import dataclasses

    from fabpat.design.thickness import solve_thickness, thickness_gradient

    rng = np.random.default_rng(6)
    model = dataclasses.replace(cube, angle0=cube.angle0 + np.radians(rng.uniform(3.0, 8.0, len(cube.labels))))
    t = cube.material.t * rng.uniform(0.8, 1.2, len(cube.plates))
    tgt = read_target("sphere")
    run = solve_thickness(model, t)
    J, fit = design_error(run, tgt, AXIS)
    g = thickness_gradient(model, t, run, fit)
    assert J > 0.0 and g.shape == (6,)
    step = 1e-3 * cube.material.t
    v = rng.normal(size=len(t))
    v /= np.linalg.norm(v)
    Jp, Jm = (design_error(solve_thickness(model, t + s * step * v, run), tgt, AXIS)[0] for s in (1.0, -1.0))
    fd = (Jp - Jm) / (2.0 * step)
    assert abs(fd) > 1e-3 * np.linalg.norm(g)  # a direction the error depends on
    assert abs(g @ v - fd) < 1e-3 * abs(fd), (g @ v, fd)


def test_a_models_closures_share_one_pattern_and_one_analysis(cube, monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    from fabpat.shell.linalg import Pardiso, mkl
    from fabpat.shell.rigid_links import SolverSetup

    assert mkl() is not None  # PARDISO ships with the test dependencies on Linux x86-64
    monkeypatch.delenv("FABPAT_LINEAR_SOLVER", raising=False)
    model = dataclasses.replace(cube, solver=SolverSetup())
    first = solve_angles(model, cube.angle0 + np.radians(4.0))
    second = solve_angles(model, cube.angle0 + np.radians(6.0), first)
    fz = model.solver.factorizer()
    assert isinstance(fz, Pardiso)
    assert first.result.factorizations + second.result.factorizations >= 2
    assert fz.analyses == 1 and model.solver.assemblers == 1
    # the adjoints share them too (their transposed tangents one analysis), and a state whose factorisation
    # another state's replaced in the shared factoriser factors its own again: the same answers as unshared
    from fabpat.design.angles import _support

    a, b = _support(first, model.solver), _support(second, model.solver)
    rhs = np.random.default_rng(3).normal(size=a.free.shape)
    lam_a, lam_b, lam_a2 = a.adjoint(rhs), b.adjoint(rhs), a.adjoint(rhs)
    fzT = model.solver.factorizer(transposed=True)
    assert isinstance(fzT, Pardiso)
    assert fzT.analyses == 1 and model.solver.assemblers == 1
    for got, run in ((lam_a, first), (lam_b, second), (lam_a2, first)):
        alone = _support(run).adjoint(rhs)
        assert np.abs(got - alone).max() <= 1e-9 * np.abs(alone).max()
    assert np.abs(lam_a - lam_b).max() > 1e-6 * np.abs(lam_a).max()  # two states, two answers
