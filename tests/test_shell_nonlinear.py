"""Corotational kinematics and the geometrically nonlinear benchmarks of Sze, Liu & Lo (2004)."""

from __future__ import annotations

import numpy as np
import pytest

from fabpat.errors import SolverError
from fabpat.shell import Material, ShellProblem, solve_nonlinear
from fabpat.shell.corotational import CorotationalTriangles
from fabpat.shell.rotations import dexp_inv, expmap, logmap
from tests.shell_fixtures import edge_weights, rect_mesh


def test_rotation_maps() -> None:
    rng = np.random.default_rng(0)
    th = rng.normal(size=(20, 3))
    th *= (2.5 * rng.random(20) / np.linalg.norm(th, axis=1))[:, None]
    R = expmap(th)
    assert np.allclose(logmap(R), th, atol=1e-12)
    assert np.allclose(R @ R.transpose(0, 2, 1), np.eye(3), atol=1e-14)
    e = 1e-6  # δθ = H⁻¹ δψ for a spatial spin δψ
    for k in range(3):
        w = np.zeros(3)
        w[k] = e
        fd = (logmap(expmap(w) @ R) - logmap(expmap(-w) @ R)) / (2 * e)
        assert np.allclose(fd, dexp_inv(th)[:, :, k], atol=1e-8)


@pytest.fixture
def two_triangles() -> tuple[CorotationalTriangles, np.ndarray, np.ndarray]:
    X = np.array([[0, 0, 0], [2.0, 0.1, 0], [0.4, 1.7, 0], [2.2, 2.0, 0.0]])
    model = CorotationalTriangles(X, np.array([[0, 1, 2], [1, 3, 2]]), Material(1000.0, 0.3, 0.5))
    rng = np.random.default_rng(1)
    Q = expmap(np.array([0.7, -1.2, 0.4]))
    x = X @ Q.T + [1.0, 2.0, 3.0] + rng.normal(size=X.shape) * 0.05
    R = Q @ expmap(rng.normal(size=(4, 3)) * 0.1)
    return model, *model.gather(x, R)


def _perturbed(model, xe, Re, j, s):
    a, k = divmod(j, 6)
    xp, Rp = xe.copy(), Re.copy()
    if k < 3:
        xp[:, a, k] += s
    else:
        w = np.zeros(3)
        w[k - 3] = s
        Rp[:, a] = expmap(w) @ Re[:, a]
    return model.element_forces(xp, Rp)


def test_force_is_energy_gradient_and_tangent_is_force_derivative(two_triangles) -> None:
    model, xe, Re = two_triangles
    fe, U, d = model.element_forces(xe, Re)
    Kt = model.element_tangents(xe, Re, d)
    e = 1e-6
    for j in range(18):
        fp, Up, _ = _perturbed(model, xe, Re, j, e)
        fm, Um, _ = _perturbed(model, xe, Re, j, -e)
        assert np.allclose((Up - Um) / (2 * e), fe[:, j], rtol=1e-7, atol=1e-7)
        assert np.allclose((fp - fm) / (2 * e), Kt[:, :, j], rtol=1e-5, atol=1e-5 * np.abs(Kt).max())


def test_rigid_motion_is_strain_free(two_triangles) -> None:
    model, _, _ = two_triangles
    Q = expmap(np.array([2.0, 0.5, -1.0]))  # a 130° rotation
    x = model.X @ Q.T + 7.0
    fe, U, _ = model.element_forces(*model.gather(x, np.broadcast_to(Q, (4, 3, 3)).copy()))
    assert np.abs(U).max() < 1e-25 and np.abs(fe).max() < 1e-10


def _strip(L: float, b: float, nx: int, ny: int):
    V, F = rect_mesh(L, b, nx, ny)
    n = len(V)
    fixed = np.zeros((n, 6), bool)
    fixed[V[:, 0] < 1e-9] = True
    tip = np.flatnonzero(V[:, 0] > L - 1e-9)
    return V, F, fixed, tip, edge_weights(V, tip)


def test_sze_cantilever_end_shear() -> None:
    """Sze, Liu & Lo 2004 §3.1: L 10, b 1, t 0.1, E 1.2e6, ν 0, P 4 → tip W 6.698, −U 3.286.
    A 16 × 1 (×2 triangles) mesh reaches 0.1 %; asserted within 1 %."""
    V, F, fixed, tip, w = _strip(10.0, 1.0, 16, 1)
    loads = np.zeros((len(V), 6))
    loads[tip, 2] = 4.0 * w
    r = solve_nonlinear(ShellProblem(V, F, Material(1.2e6, 0.0, 0.1), fixed, loads))
    assert r.displacement[tip, 2].mean() == pytest.approx(6.698, rel=0.01)
    assert -r.displacement[tip, 0].mean() == pytest.approx(3.286, rel=0.01)
    assert r.converged and r.iterations < 200


def test_sze_cantilever_rolled_into_a_circle() -> None:
    """End moment M = 2πEI/L rolls the strip into a full circle: the tip returns to the root
    (Sze et al. 2004 §3.2: L 12, b 1, t 0.1, E 1.2e6, EI 100). Energy M²L/(2EI) exact for a circle."""
    L, t, E = 12.0, 0.1, 1.2e6
    EI = E * t**3 / 12
    V, F, fixed, tip, w = _strip(L, 1.0, 24, 1)
    loads = np.zeros((len(V), 6))
    M = 2 * np.pi * EI / L
    loads[tip, 4] = -M * w
    r = solve_nonlinear(ShellProblem(V, F, Material(E, 0.0, t), fixed, loads))
    tip_pos = V[tip] + r.displacement[tip, :2]
    assert np.abs(tip_pos[:, 0]).max() < 0.01 * L  # back at the root (measured 2e-5 L)
    assert np.abs(r.displacement[tip, 2]).max() < 0.01 * L
    assert r.energy == pytest.approx(M**2 * L / (2 * EI), rel=1e-3)


def test_nonconvergence_raises() -> None:
    """A load far past what load control can follow (snap of a strip rolled 20 times) raises."""
    V, F, fixed, tip, w = _strip(12.0, 1.0, 6, 1)
    loads = np.zeros((len(V), 6))
    loads[tip, 4] = -40 * np.pi * 100.0 / 12.0 * w
    with pytest.raises(SolverError, match="did not converge"):
        solve_nonlinear(ShellProblem(V, F, Material(1.2e6, 0.0, 0.1), fixed, loads), min_step=1 / 16, max_iter=8)
