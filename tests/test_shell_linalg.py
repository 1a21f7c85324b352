"""The sparse LU back-ends of the Newton iterations (fabpat.shell.linalg): PARDISO and SuperLU agree."""

from __future__ import annotations

import platform
import sys

import numpy as np
import pytest
import scipy.sparse as sp

from fabpat.errors import SolverError
from fabpat.shell.element import Material
from fabpat.shell.linalg import Pardiso, SuperLUFactorizer, factorizer, mkl
from fabpat.shell.solve import ShellProblem, _setup, solve_nonlinear
from tests.shell_fixtures import edge_weights, rect_mesh

ON_MKL_PLATFORM = sys.platform == "linux" and platform.machine() == "x86_64"


def _plate(nx: int = 12, ny: int = 4) -> ShellProblem:
    """A 60 × 20 mm plate clamped at x = 0 with a tip force and twisting moment at x = 60."""
    V, F = rect_mesh(60.0, 20.0, nx, ny, skew=0.2)
    fixed = np.zeros((len(V), 6), bool)
    fixed[V[:, 0] < 1e-9] = True
    tip = np.flatnonzero(V[:, 0] > 60 - 1e-9)
    loads = np.zeros((len(V), 6))
    loads[tip, 2] = 2.0 * edge_weights(V, tip)
    loads[tip, 3] = 150.0 * edge_weights(V, tip)
    return ShellProblem(V, F, Material(1000.0, 0.35, 2.0), fixed, loads)


def test_mkl_is_installed_where_fabpat_requires_it() -> None:
    """pyproject installs the mkl wheel on Linux x86-64: there the fast back-end must load."""
    if ON_MKL_PLATFORM:
        assert mkl() is not None
        assert isinstance(factorizer(), Pardiso)
    assert isinstance(factorizer("superlu"), SuperLUFactorizer)


@pytest.mark.skipif(not ON_MKL_PLATFORM, reason="MKL is installed on Linux x86-64 only")
def test_pardiso_refactorisations_solve_like_superlu() -> None:
    """Several matrices of one pattern (the analysis is reused), then one of another pattern."""
    p = _plate()
    model, asm, _ = _setup(p)
    K0 = asm.matrix(model.linear_element_matrices())
    rng = np.random.default_rng(3)
    fz = factorizer("pardiso")
    for scale in (0.0, 0.5, 2.0):
        K = K0.copy()
        K.data = K.data * (1.0 + scale * rng.uniform(-0.1, 0.1, K.nnz))  # nonsymmetric, same pattern
        b = rng.normal(size=K.shape[0])
        x = fz.factor(K).solve(b)
        xs = SuperLUFactorizer().factor(K).solve(b)
        assert np.linalg.norm(K @ x - b) <= 1e-9 * np.linalg.norm(b)
        assert np.linalg.norm(x - xs) <= 1e-8 * np.linalg.norm(xs)
    K2 = sp.csc_matrix(K0[:100, :100])  # a different pattern: analysed afresh
    b2 = rng.normal(size=100)
    assert np.linalg.norm(K2 @ fz.factor(K2).solve(b2) - b2) <= 1e-9 * np.linalg.norm(b2)


@pytest.mark.skipif(not ON_MKL_PLATFORM, reason="MKL is installed on Linux x86-64 only")
def test_large_matrices_take_the_two_level_factorisation_and_small_ones_keep_the_classic(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Above TWO_LEVEL_ROWS rows PARDISO factors with iparm(24) = 1 (the assembly closures' large tangents);
    below it, as every catalog scenario, the classic factorisation and its numbers stay. The bound is lowered
    here so that a small plate's tangent crosses it."""
    import fabpat.shell.linalg as linalg

    p = _plate()
    model, asm, _ = _setup(p)
    K = asm.matrix(model.linear_element_matrices())
    K.data = K.data * (1.0 + 0.05 * np.random.default_rng(4).uniform(-1.0, 1.0, K.nnz))  # nonsymmetric
    b = np.random.default_rng(5).normal(size=K.shape[0])
    classic = factorizer("pardiso")
    x0 = classic.factor(K).solve(b)
    assert isinstance(classic, Pardiso) and classic._iparm[23] == 0
    monkeypatch.setattr(linalg, "TWO_LEVEL_ROWS", K.shape[0])
    two = factorizer("pardiso")
    x = two.factor(K).solve(b)
    assert isinstance(two, Pardiso) and two._iparm[23] == 1
    assert np.linalg.norm(K @ x - b) <= 1e-9 * np.linalg.norm(b)
    assert np.linalg.norm(x - x0) <= 1e-8 * np.linalg.norm(x0)
    again = factorizer("pardiso")  # reproducible: the same bits from a fresh analysis
    assert np.array_equal(again.factor(K).solve(b), x)


@pytest.mark.parametrize("backend", ["superlu", "pardiso"] if ON_MKL_PLATFORM else ["superlu"])
def test_singular_matrix_is_reported(backend: str) -> None:
    """An exactly singular matrix: PARDISO's perturbed pivots hand it to SuperLU, which names it."""
    K = sp.csc_matrix(np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 2.0]]))
    with pytest.raises(SolverError, match="singular stiffness matrix"):
        factorizer(backend).factor(K)


@pytest.mark.parametrize("backend", ["superlu", "pardiso"] if ON_MKL_PLATFORM else ["superlu"])
def test_unsupported_plate_does_not_converge(backend: str) -> None:
    """No supports: round-off keeps the stiffness factorable, and Newton then fails (SolverError)."""
    p = _plate()
    free = ShellProblem(p.X, p.F, p.material, np.zeros_like(p.fixed), p.loads)
    with pytest.raises(SolverError, match="did not converge"):
        solve_nonlinear(free, linear_solver=backend)


@pytest.mark.skipif(not ON_MKL_PLATFORM, reason="MKL is installed on Linux x86-64 only")
def test_nonlinear_results_do_not_depend_on_the_back_end() -> None:
    """Large rotations (tip ≈ 0.4 rad): same energy and displacements to the Newton tolerance."""
    p = _plate()
    a = solve_nonlinear(p, linear_solver="pardiso")
    b = solve_nonlinear(p, linear_solver="superlu")
    assert float(np.abs(a.rotation).max()) > 0.2
    assert a.energy == pytest.approx(b.energy, rel=1e-8)
    assert np.abs(a.displacement - b.displacement).max() <= 1e-7 * np.abs(b.displacement).max()


def test_unknown_back_end_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(SolverError, match="expected one of auto, pardiso, superlu"):
        factorizer("umfpack")
    monkeypatch.setenv("FABPAT_LINEAR_SOLVER", " SuperLU ")  # the variable names "auto"'s choice, any case
    assert isinstance(factorizer(), SuperLUFactorizer)
    monkeypatch.setenv("FABPAT_LINEAR_SOLVER", "bogus")
    with pytest.raises(SolverError, match="FABPAT_LINEAR_SOLVER='bogus' is not a linear solver; expected one of"):
        factorizer()
