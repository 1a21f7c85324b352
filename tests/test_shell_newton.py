"""The shell engine's one Newton iteration (fabpat.shell.newton): closed forms, and both drivers on it."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fabpat.errors import SolverError
from fabpat.shell import Material, ShellProblem, solve_nonlinear
from fabpat.shell.linalg import Factor, SuperLUFactorizer
from fabpat.shell.linked import solve_path
from fabpat.shell.newton import Convergence, Residual, Rules, iterate
from fabpat.shell.rigid_links import LinkedProblem
from fabpat.shell.rotations import logmap
from tests.shell_fixtures import edge_weights, rect_mesh


class _Springs:
    """A linear system K u = f on n nodes of 6 dofs, u = (x − X, log R): a NewtonSystem whose exact
    solution is K⁻¹ f (one correction from any start, rotations about fixed axes adding up exactly)."""

    def __init__(self, K: sp.csc_matrix, f: np.ndarray, X: np.ndarray) -> None:
        self.K, self.f, self.X = K, f, X
        self.dofs = np.arange(f.size)
        self.n_dofs = f.size
        self.r = np.zeros(f.size)
        self.tangents = self.factorizations = 0

    def evaluate(self, x: np.ndarray, R: np.ndarray) -> Residual:
        u = np.concatenate([x - self.X, logmap(R)], axis=1).ravel()
        self.r = self.f - self.K @ u
        return Residual(float(np.linalg.norm(self.r)), float(np.linalg.norm(self.f)))

    def tangent(self, x: np.ndarray, R: np.ndarray, iteration: int) -> sp.csc_matrix:
        self.tangents += 1
        return self.K

    def rhs(self) -> np.ndarray:
        return self.r

    def factored(self, iteration: int) -> None:
        self.factorizations += 1

    def place(self, x: np.ndarray, R: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x, R


def _springs(n: int = 5, seed: int = 3) -> _Springs:
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(6 * n, 6 * n))
    K = sp.csc_matrix(A @ A.T + 6 * n * np.eye(6 * n))  # symmetric positive definite
    f = rng.normal(size=6 * n)
    return _Springs(K, f, rng.normal(size=(n, 3)))


def _start(s: _Springs) -> tuple[np.ndarray, np.ndarray]:
    return s.X.copy(), np.broadcast_to(np.eye(3), (len(s.X), 3, 3)).copy()


def test_a_linear_system_converges_after_one_correction_to_its_solution() -> None:
    s = _springs()
    exact = np.linalg.solve(s.K.toarray(), s.f).reshape(-1, 6)
    assert np.abs(exact[:, 3:]).max() < 0.5  # no rotation cap involved
    run = iterate(s, *_start(s), Convergence(1e-10, 0.0), Rules(25, 0.1, 0.5), SuperLUFactorizer())
    assert run.converged and run.iterations == 2  # one correction, then the test passes
    assert s.factorizations == s.tangents == 1
    assert np.abs(run.x - s.X - exact[:, :3]).max() < 1e-12
    assert np.abs(logmap(run.R) - exact[:, 3:]).max() < 1e-12
    assert run.residual == pytest.approx(np.linalg.norm(s.f))  # the residual the correction was taken from


def test_a_large_rotation_correction_is_capped_and_the_factorization_reused() -> None:
    """Loads needing 1.2 rad at one node with a 0.5 rad cap: the first corrections are scaled to 0.5 rad
    (the linear residual then falls by 1 − 0.5/1.2, too slowly to keep the LU: a new one each time),
    and the answer is still the exact one."""
    s = _springs(seed=4)
    exact = np.linalg.solve(s.K.toarray(), s.f).reshape(-1, 6)
    s.f = s.f * (1.2 / np.abs(exact[:, 3:]).max())
    exact = np.linalg.solve(s.K.toarray(), s.f).reshape(-1, 6)
    run = iterate(s, *_start(s), Convergence(1e-10, 0.0), Rules(25, 0.1, 0.5), SuperLUFactorizer())
    assert run.converged and run.iterations > 2
    assert np.abs(logmap(run.R) - exact[:, 3:]).max() < 1e-10
    # with reuse_ratio 1 every fall of the residual keeps the first factorization
    s2 = _springs(seed=4)
    s2.f = s.f
    run2 = iterate(s2, *_start(s2), Convergence(1e-10, 0.0), Rules(25, 1.0, 0.5), SuperLUFactorizer())
    assert run2.converged and s2.factorizations == 1 < s.factorizations


class _Scripted(_Springs):
    """A system whose residual norms follow a script (the corrections themselves are those of _Springs)."""

    def __init__(self, norms: list[float]) -> None:
        base = _springs()
        super().__init__(base.K, base.f, base.X)
        self.norms = norms
        self.calls = 0

    def evaluate(self, x: np.ndarray, R: np.ndarray) -> Residual:
        super().evaluate(x, R)
        self.calls += 1
        return Residual(self.norms[min(self.calls, len(self.norms)) - 1], 1.0)


def test_an_increment_is_given_up_after_its_allowed_rises_in_a_row() -> None:
    """Residuals 1, 1.1, 1.2, 1.3, then converged: three rises in a row end the run unconverged by default
    (the increment is halved by the path), a driver that allows four (the closure's) gets to convergence."""
    script = [1.0, 1.1, 1.2, 1.3, 1e-12]
    s = _Scripted(script)
    run = iterate(s, *_start(s), Convergence(1e-10, 0.0), Rules(25, 0.0, 0.5), SuperLUFactorizer())
    assert not run.converged and run.iterations == 4
    s4 = _Scripted(script)
    run4 = iterate(s4, *_start(s4), Convergence(1e-10, 0.0), Rules(25, 0.0, 0.5, rises=4), SuperLUFactorizer())
    assert run4.converged and run4.iterations == 5
    s1 = _Scripted([1.0, 0.9, 1.1, 0.8, 1.2, 0.7, 1e-12])  # rises that do not follow each other are no sign
    assert iterate(s1, *_start(s1), Convergence(1e-10, 0.0), Rules(25, 0.0, 0.5), SuperLUFactorizer()).converged


def test_the_factorization_is_kept_only_after_corrections_within_the_reuse_rotation() -> None:
    """A residual that falls 1000-fold keeps the factorization for the next correction, unless the correction
    that took it there turned a node by more than ``reuse_rotation``: then the tangent is formed again."""
    script = [1.0, 1e-3, 1e-12]
    kept = _Scripted(script)
    assert iterate(kept, *_start(kept), Convergence(1e-10, 0.0), Rules(25, 0.1, 0.5), SuperLUFactorizer()).converged
    assert kept.factorizations == 1
    fresh = _Scripted(script)
    run = iterate(fresh, *_start(fresh), Convergence(1e-10, 0.0), Rules(25, 0.1, 0.5, reuse_rotation=1e-9),
                  SuperLUFactorizer())
    assert run.converged and fresh.factorizations == 2


def test_the_convergence_test_has_a_floor_and_a_singular_tangent_ends_the_run_unconverged() -> None:
    test = Convergence.at_roundoff(1e-8, 4.0)  # floor: ROUNDOFF_FACTOR (0.5) × 4 N
    assert test.tolerance(1.0) == 2.0 and test.met(2.0, 1.0) and not test.met(2.01, 1.0)
    assert test.tolerance(1e9) == pytest.approx(10.0) and not test.met(11.0, 1e9)

    class Singular:
        def factor(self, K: sp.csc_matrix) -> Factor:
            raise SolverError("singular")

    s = _springs()
    run = iterate(s, *_start(s), Convergence(1e-10, 0.0), Rules(25, 0.1, 0.5), Singular())
    assert not run.converged and run.iterations == 1 and run.factor is None
    assert np.array_equal(run.x, s.X)  # not moved


def test_load_control_and_path_following_run_the_same_iteration_to_the_same_equilibrium(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A cantilever strip under an end shear (Sze et al. 2004 §3.1, 6.698 tip deflection) solved by
    solve_nonlinear (load steps) and solve_path (no links, one report interval): both ask the one
    convergence test, end on a test it passed, and agree on the state to the Newton tolerance."""
    seen: list[tuple[float, float, bool]] = []
    met = Convergence.met

    def spy(self: Convergence, residual: float, reference: float) -> bool:
        seen.append((residual, reference, met(self, residual, reference)))
        return seen[-1][2]

    monkeypatch.setattr(Convergence, "met", spy)
    V, F = rect_mesh(10.0, 1.0, 16, 1)
    fixed = np.zeros((len(V), 6), bool)
    fixed[V[:, 0] < 1e-9] = True
    tip = np.flatnonzero(V[:, 0] > 10.0 - 1e-9)
    loads = np.zeros((len(V), 6))
    loads[tip, 2] = 4.0 * edge_weights(V, tip)
    mat = Material(1.2e6, 0.0, 0.1)
    a = solve_nonlinear(ShellProblem(V, F, mat, fixed, loads))
    calls_a = len(seen)
    assert calls_a == a.iterations and seen[-1][2]  # one test per iteration, the last one passed
    X3 = np.column_stack([V, np.zeros(len(V))])
    b = solve_path(LinkedProblem(X3, F, mat, np.zeros((0, 3)), [], [], np.zeros((0, 3)), fixed,
                                 np.zeros_like(loads), loads), steps=1)
    assert len(seen) - calls_a == b.iterations and seen[-1][2]
    assert a.displacement[tip, 2].mean() == pytest.approx(6.698, rel=0.01)  # the published deflection
    scale = np.abs(a.displacement).max()
    assert np.abs(b.final.displacement - a.displacement).max() < 1e-6 * scale
    assert b.final.energy == pytest.approx(a.energy, rel=1e-7)
