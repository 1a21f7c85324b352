"""Solves of one mesh share the reduced system's assembler and PARDISO's symbolic analysis
(:class:`fabpat.shell.rigid_links.SolverSetup`): the second solve builds no pattern and analyses nothing,
and its answer is the unshared solve's."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from fabpat.shell import Material
from fabpat.shell.linalg import Pardiso, mkl
from fabpat.shell.linked import solve_path
from fabpat.shell.rigid_links import LinkedProblem, SolverSetup
from tests.shell_fixtures import edge_weights, rect_mesh

MAT = Material(1.2e6, 0.0, 0.1)


def _cantilever(n: int, tip_load: float) -> LinkedProblem:
    V, F = rect_mesh(10.0, 1.0, n, 1)
    fixed = np.zeros((len(V), 6), bool)
    fixed[V[:, 0] < 1e-9] = True
    tip = np.flatnonzero(V[:, 0] > 10.0 - 1e-9)
    loads = np.zeros((len(V), 6))
    loads[tip, 2] = tip_load * edge_weights(V, tip)
    X3 = np.column_stack([V, np.zeros(len(V))])
    return LinkedProblem(X3, F, MAT, np.zeros((0, 3)), [], [], np.zeros((0, 3)), fixed, np.zeros_like(loads), loads)


@pytest.fixture(autouse=True)
def _pardiso(monkeypatch: pytest.MonkeyPatch) -> None:
    if mkl() is None:  # pragma: no cover - MKL ships with the test dependencies on Linux x86-64
        pytest.fail("these tests count PARDISO's analyses and need MKL")
    monkeypatch.delenv("FABPAT_LINEAR_SOLVER", raising=False)


def test_two_solves_of_one_mesh_analyse_once() -> None:
    setup = SolverSetup()
    a = solve_path(_cantilever(8, 2.0), steps=1, setup=setup)
    b = solve_path(_cantilever(8, 4.0), steps=1, setup=setup)  # other loads, the same mesh and supports
    fz = setup.factorizer()
    assert isinstance(fz, Pardiso)
    assert fz.analyses == 1 and setup.assemblers == 1
    assert a.factorizations + b.factorizations > 2  # both solves factored, with the one analysis
    alone = solve_path(_cantilever(8, 4.0), steps=1)
    scale = np.abs(alone.final.displacement).max()
    assert np.abs(b.final.displacement - alone.final.displacement).max() <= 1e-12 * scale


def test_another_mesh_is_set_up_and_analysed_again() -> None:
    setup = SolverSetup()
    solve_path(_cantilever(8, 2.0), steps=1, setup=setup)
    solve_path(_cantilever(10, 2.0), steps=1, setup=setup)
    fz = setup.factorizer()
    assert isinstance(fz, Pardiso)
    assert fz.analyses == 2 and setup.assemblers == 2


def test_a_pickled_setup_arrives_empty() -> None:
    setup = SolverSetup()
    solve_path(_cantilever(6, 2.0), steps=1, setup=setup)
    copy = pickle.loads(pickle.dumps(setup))
    assert copy.assemblers == 0
    solve_path(_cantilever(6, 2.0), steps=1, setup=copy)
    assert copy.assemblers == 1
